"""KUKA A, B, C <-> rotation (intrinsic Z-Y'-X'')."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from feedopt.robot.kuka import abc_from_rotation, rotation_from_abc


def _rz_ry_rx(a, b, c):
    """KUKA's Rz(A) Ry(B) Rx(C) written out by hand (angles in rad)."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    return rz @ ry @ rx


def test_rotation_is_rz_ry_rx():
    rng = np.random.default_rng(3)
    abc = rng.uniform([-180, -89, -180], [180, 89, 180], size=(50, 3))
    r = rotation_from_abc(abc)
    for a, m in zip(abc, r, strict=True):
        np.testing.assert_allclose(m, _rz_ry_rx(*np.deg2rad(a)), rtol=0, atol=1e-15)
        # pinocchio's rpyToMatrix(r, p, y) = Rz(y) Ry(p) Rx(r): roll = C, pitch = B, yaw = A
        np.testing.assert_array_equal(m, pin.rpy.rpyToMatrix(*np.deg2rad(a[::-1])))
    np.testing.assert_allclose(abc_from_rotation(r), abc, atol=1e-9)
    assert rotation_from_abc(abc.reshape(5, 10, 3)).shape == (5, 10, 3, 3)
    np.testing.assert_array_equal(rotation_from_abc(abc[0]), r[0])


def test_gimbal_lock_keeps_the_rotation():
    abc = np.array([[30.0, 90.0, 20.0], [-40.0, -90.0, 10.0]])
    back = abc_from_rotation(rotation_from_abc(abc))
    np.testing.assert_allclose(back[:, 2], 0.0)
    np.testing.assert_allclose(rotation_from_abc(back), rotation_from_abc(abc), atol=1e-9)
