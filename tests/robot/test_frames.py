"""Frames from roll-pitch-yaw: pinocchio's rotation against the hand-written product."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.robot.frames import rotation_from_rpy, transform_from_xyz_rpy, workpiece_transform
from feedopt.units import MM


def _hand_transform(position_mm, rpy_deg):
    """The runner's former workpiece_transform: Rz(yaw) Ry(pitch) Rx(roll) written out."""
    r, p, y = np.deg2rad(rpy_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    t = np.eye(4)
    t[:3, :3] = rz @ ry @ rx
    t[:3, 3] = np.asarray(position_mm) * MM
    return t


def test_workpiece_transform_equals_the_hand_written_product():
    rng = np.random.default_rng(7)
    angles = np.vstack([rng.uniform(-180, 180, size=(300, 3)),
                        rng.choice([-180, -90, -45, 0, 30, 90, 180], size=(60, 3))])
    for rpy in angles:
        xyz = rng.uniform(-2000, 2000, 3)
        got = workpiece_transform(list(xyz), list(rpy))
        want = _hand_transform(xyz, rpy)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(got[:3, 3], want[:3, 3])  # same mm -> m scaling
        np.testing.assert_array_equal(got[3], [0, 0, 0, 1])


def test_bundled_placements_are_bit_identical():
    # every bundled scenario has rpy 0: the switch to pinocchio changes no number of them
    for pos in ([1750.0, -300.0, 800.0], [1798.4, -4.8, 800.0]):
        np.testing.assert_array_equal(workpiece_transform(pos, [0.0, 0.0, 0.0]),
                                      _hand_transform(pos, [0.0, 0.0, 0.0]))


@pytest.mark.parametrize(
    ("rpy", "x_to", "y_to", "z_to"),
    [
        ([0, 0, 90], [0, 1, 0], [-1, 0, 0], [0, 0, 1]),  # yaw: about z
        ([0, 90, 0], [0, 0, -1], [0, 1, 0], [1, 0, 0]),  # pitch: about y
        ([90, 0, 0], [1, 0, 0], [0, 0, 1], [0, -1, 0]),  # roll: about x
        ([180, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, -1]),  # tool flipped (UR10 TCP)
        ([0, -90, 0], [0, 0, 1], [0, 1, 0], [-1, 0, 0]),  # KR500-3 TCP: z = -flange x
    ],
)
def test_known_rotations(rpy, x_to, y_to, z_to):
    r = workpiece_transform([0, 0, 0], rpy)[:3, :3]
    np.testing.assert_allclose(r, np.column_stack([x_to, y_to, z_to]), atol=1e-15)


def test_extrinsic_xyz_order():
    # roll 90 then yaw 90 about the fixed axes: x -> x -> y, y -> z -> z, z -> -y -> x
    r = workpiece_transform([0, 0, 0], [90, 0, 90])[:3, :3]
    np.testing.assert_allclose(r, np.column_stack([[0, 1, 0], [0, 0, 1], [1, 0, 0]]),
                               atol=1e-15)
    rz = workpiece_transform([0, 0, 0], [0, 0, 90])[:3, :3]
    rx = workpiece_transform([0, 0, 0], [90, 0, 0])[:3, :3]
    np.testing.assert_allclose(r, rz @ rx, atol=1e-15)


def test_transform_maps_workpiece_points_to_base():
    t = workpiece_transform([1000.0, -200.0, 500.0], [0.0, 0.0, 90.0])
    p_w = np.array([0.1, 0.0, 0.02])  # 100 mm along workpiece x, 20 mm up
    np.testing.assert_allclose(t[:3, :3] @ p_w + t[:3, 3], [1.0, -0.1, 0.52], atol=1e-15)


def test_rotation_from_rpy_is_vectorised_and_orthonormal():
    rpy = np.random.default_rng(1).uniform(-180, 180, size=(4, 5, 3))
    r = rotation_from_rpy(rpy)
    assert r.shape == (4, 5, 3, 3)
    np.testing.assert_allclose(r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape),
                               atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-14)
    for idx in ((0, 0), (3, 4)):
        np.testing.assert_array_equal(r[idx], workpiece_transform([0, 0, 0], rpy[idx])[:3, :3])
    assert rotation_from_rpy([10.0, 20.0, 30.0]).shape == (3, 3)
    assert rotation_from_rpy(np.zeros((0, 3))).shape == (0, 3, 3)


def test_bad_inputs_are_named():
    with pytest.raises(InputError, match="workpiece.position_mm"):
        workpiece_transform([1.0, 2.0], [0, 0, 0])
    with pytest.raises(InputError, match="workpiece.rpy_deg"):
        workpiece_transform([0, 0, 0], [0, float("nan"), 0])
    with pytest.raises(InputError, match="frame origin"):
        transform_from_xyz_rpy(["a", 0, 0], [0, 0, 0])
    with pytest.raises(InputError, match=r"shape \(\.\.\., 3\)"):
        rotation_from_rpy(np.zeros((2, 2)))
