"""The robot stage along a path: the same numbers as the direct calls, bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import forward_kinematics
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.stiffness import translational_compliance
from tests.robot.helpers import Q_START_DEG, WORKPIECE_ORIGIN_M, triangle_wave


def _task(n=801):
    p = triangle_wave(n) + WORKPIECE_ORIGIN_M
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    return s, p, z, np.deg2rad(Q_START_DEG)


def _direct(robot, s, p, z, q0, stiffness, x_axes=None, options=None):
    """What runner.prepare computed before the stage existed."""
    ik = solve_path_ik(robot, p, z, q0, x_axes=x_axes, options=options)
    q_of_s = CubicSpline(s, ik.q, axis=0)
    return ik, translational_compliance(robot, ik.q, stiffness), q_of_s


@pytest.mark.parametrize("six_dof", [False, True])
def test_stage_is_bit_identical_to_the_direct_calls(kuka, six_dof):
    s, p, z, q0 = _task()
    x = np.tile([1.0, 0.0, 0.0], (s.size, 1)) if six_dof else None
    if six_dof:  # an x axis the 5-DoF solution actually has, so the 6-DoF task is feasible
        x = forward_kinematics(kuka, solve_path_ik(kuka, p, z, q0).q)[:, :3, 0]
    got = robot_along_path(kuka, TcpPath(s, p, z, x), q0, "dpp")
    ik, comp, q_of_s = _direct(kuka, s, p, z, q0, "dpp", x_axes=x)
    for f in dataclasses.fields(ik):
        np.testing.assert_array_equal(getattr(got.ik, f.name), getattr(ik, f.name))
    np.testing.assert_array_equal(got.compliance, comp)
    np.testing.assert_array_equal(got.q, ik.q)
    np.testing.assert_array_equal(got.dq_ds, q_of_s(s, 1))
    np.testing.assert_array_equal(got.d2q_ds2, q_of_s(s, 2))
    fine = np.linspace(0.0, s[-1], 3001)
    for nu in (0, 1, 2, 3):
        np.testing.assert_array_equal(got.q_of_s(fine, nu), q_of_s(fine, nu))
    assert got.max_condition_number == float(np.max(ik.condition_number))


def test_stage_shapes_units_and_warnings(kuka):
    s, p, z, q0 = _task(201)
    got = robot_along_path(kuka, TcpPath(s, p, z), q0, "cp")
    assert isinstance(got, RobotAlongPath)
    assert got.compliance.shape == (201, 3, 3) and got.dq_ds.shape == (201, 6)
    np.testing.assert_array_equal(got.compliance, translational_compliance(kuka, got.q, "cp"))
    # [m/N]: the KR500-3 gives way by roughly 1e-6 m per N at the TCP (100-1000 N/mm)
    assert 1e-7 < np.linalg.eigvalsh(got.compliance).max() < 1e-5
    np.testing.assert_allclose(got.q_of_s(s), got.q, rtol=0, atol=1e-15)  # interpolating
    assert got.warnings == tuple(f"robot {kuka.name}: {w}" for w in kuka.data_warnings)
    assert got.warnings and "placeholder" in got.warnings[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        got.compliance = None


def test_explicit_stiffness_and_ik_options_pass_through(kuka):
    s, p, z, q0 = _task(201)
    k = np.full(6, 2e6)
    got = robot_along_path(kuka, TcpPath(s, p, z), q0, k,
                           ik_options=IKOptions(max_condition=50.0))
    np.testing.assert_array_equal(got.compliance, translational_compliance(kuka, got.q, k))
    with pytest.raises(InputError, match=r"jumps by .*> 0\.001 deg"):
        robot_along_path(kuka, TcpPath(s, p, z), q0, "dpp",
                         ik_options=IKOptions(max_joint_step=np.deg2rad(1e-3)))


def test_bad_inputs(kuka):
    s, p, z, q0 = _task(21)
    with pytest.raises(InputError, match=r"s must have shape \(21,\)"):
        robot_along_path(kuka, TcpPath(s[:-1], p, z), q0, "dpp")
    s_bad = s.copy()
    s_bad[7] = s_bad[6]
    with pytest.raises(InputError, match="strictly increasing; sample 7"):
        robot_along_path(kuka, TcpPath(s_bad, p, z), q0, "dpp")
    s_bad[7] = np.nan
    with pytest.raises(InputError, match="sample 7"):
        robot_along_path(kuka, TcpPath(s_bad, p, z), q0, "dpp")
    with pytest.raises(InputError, match="at least 2 samples"):
        robot_along_path(kuka, TcpPath(s[:1], p[:1], z[:1]), q0, "dpp")
    with pytest.raises(InputError, match="available: cp, dpp"):
        robot_along_path(kuka, TcpPath(s, p, z), q0, "xyz")
    with pytest.raises(InputError, match="positions must have shape"):
        robot_along_path(kuka, TcpPath(s, p[:, :2].ravel(), z), q0, "dpp")
