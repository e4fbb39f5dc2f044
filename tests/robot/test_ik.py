"""Inverse kinematics along a path: round trips, continuity, and refusals."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.robot import ik as ik_module
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import forward_kinematics, load_robot
from tests.robot.helpers import KUKA_DIR, Q_START_DEG, WORKPIECE_ORIGIN_M, triangle_wave

# A comfortable region of the KR500-3 (away from wrist and elbow singularities).
Q_LO = np.deg2rad([-60, -80, 60, -60, 30, -90])
Q_HI = np.deg2rad([60, -30, 120, 60, 100, 90])


@settings(max_examples=25, deadline=None)
@given(u=st.lists(st.floats(0, 1), min_size=6, max_size=6),
       d=st.lists(st.floats(-1, 1), min_size=6, max_size=6))
def test_round_trip_6dof_and_5dof(kuka, u, d):
    q_true = Q_LO + np.asarray(u) * (Q_HI - Q_LO)
    seed = q_true + np.deg2rad(3.0) * np.asarray(d)
    pose = forward_kinematics(kuka, q_true)
    p, z, x = pose[None, :3, 3], pose[None, :3, 2], pose[None, :3, 0]
    for x_axes in (x, None):
        res = solve_path_ik(kuka, p, z, seed, x_axes=x_axes)
        back = forward_kinematics(kuka, res.q)[0]
        assert np.linalg.norm(back[:3, 3] - p[0]) < 1e-9  # 1e-6 mm
        assert np.arccos(np.clip(back[:3, 2] @ z[0], -1, 1)) < 1e-6
        if x_axes is not None:
            np.testing.assert_allclose(back[:3, :3], pose[:3, :3], atol=1e-6)
            np.testing.assert_allclose(res.q[0], q_true, atol=1e-6)  # closest solution
        assert res.position_error[0] < 1e-9 and res.axis_error[0] < 1e-6


def test_round_trip_second_robot(ur10):
    rng = np.random.default_rng(5)
    q_true = rng.uniform(-1.0, 1.0, size=(10, 6)) + np.array([0, -1.2, 1.2, -1.5, -1.5, 0])
    poses = forward_kinematics(ur10, q_true)
    for q, pose in zip(q_true, poses, strict=True):
        res = solve_path_ik(ur10, pose[None, :3, 3], pose[None, :3, 2], q + 0.02,
                            x_axes=pose[None, :3, 0],
                            options=IKOptions(max_condition=1e4))
        np.testing.assert_allclose(forward_kinematics(ur10, res.q)[0], pose, atol=1e-9)


def _triangle_task(n):
    p = triangle_wave(n) + WORKPIECE_ORIGIN_M
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    return p, z


def test_triangle_wave_gives_continuous_joint_path(kuka):
    p, z = _triangle_task(3001)
    res = solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG))
    assert res.q.shape == (3001, 6)
    steps = np.abs(np.diff(res.q, axis=0))
    # path step 0.33 mm -> joint steps well below 0.05 deg; no jumps anywhere
    assert np.rad2deg(steps.max()) < 0.05
    assert np.rad2deg(steps.max()) < 5 * np.rad2deg(np.median(steps.max(axis=1))) + 0.01
    back = forward_kinematics(kuka, res.q)
    assert np.abs(back[:, :3, 3] - p).max() < 1e-9
    assert np.abs(back[:, :3, 2] - z).max() < 1e-9
    assert res.condition_number.max() < 10.0  # far from singular in the recommended placement
    np.testing.assert_allclose(res.q[0], np.deg2rad(Q_START_DEG), atol=np.deg2rad(0.01))


def test_5dof_keeps_redundant_rotation_close_to_previous(kuka):
    """The free rotation about the tool axis must not drift.

    The coaxial tool turns with A6 about the tool axis; starting with A6 = -15 deg, the
    minimum-norm steps must keep it there (and A4 at the value the first sample settles on).
    """
    p, z = _triangle_task(1001)
    q0 = np.deg2rad(Q_START_DEG) + np.deg2rad([0, 0, 0, 10, 0, -15])
    res = solve_path_ik(kuka, p, z, q0)
    total = np.abs(np.diff(res.q, axis=0)).sum(axis=0)
    x_path = forward_kinematics(kuka, res.q)[:, :3, 0]
    # with 6-DoF targets built from the 5-DoF solution the joint path is reproduced
    res6 = solve_path_ik(kuka, p, z, res.q[0], x_axes=x_path)
    np.testing.assert_allclose(res6.q, res.q, atol=1e-7)
    assert np.rad2deg(total[3]) < 0.01 and np.rad2deg(total[5]) < 0.01
    assert abs(np.rad2deg(res.q[0, 5]) + 15.0) < 1.0


def test_unreachable_sample_is_named(kuka):
    p, z = _triangle_task(50)
    p[30] = [4.0, 0.0, 0.8]
    with pytest.raises(InputError, match=r"sample 30 .*unreachable"):
        solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG))


def test_near_singular_pose_reports_condition_number(kuka):
    q_s = np.deg2rad([0, -90, 90, 0, 0.5, 0])  # wrist almost stretched (A5 = 0.5 deg)
    pose = forward_kinematics(kuka, q_s)
    p = pose[:3, 3] + np.linspace(0, 0.01, 5)[:, None] * np.array([0, 0, 1.0])
    z = np.tile(pose[:3, 2], (5, 1))
    with pytest.raises(InputError, match=r"sample 0 .*condition number"):
        solve_path_ik(kuka, p, z, q_s)


def test_joint_jump_is_refused(kuka):
    p, z = _triangle_task(7)  # 50 mm between samples: big joint steps
    with pytest.raises(InputError, match=r"sample 1 .*jumps by"):
        solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG),
                      options=IKOptions(max_joint_step=np.deg2rad(0.5)))


def test_joint_limit_violation_is_named(tmp_path):
    d = tmp_path / "robot"
    shutil.copytree(KUKA_DIR, d)
    urdf = (d / "kr500_3.urdf").read_text()
    # narrow A1 to +-1 deg: the path (y from -38 to +38 mm at x ~ 1.9 m) needs about +-1.2 deg
    urdf = urdf.replace('lower="-3.2288591161895095" upper="3.2288591161895095"',
                        'lower="-0.017453292519943295" upper="0.017453292519943295"')
    (d / "kr500_3.urdf").write_text(urdf)
    robot = load_robot(d)
    p, z = _triangle_task(301)
    q0 = np.deg2rad(Q_START_DEG)
    q0[0] = 0.0
    with pytest.raises(InputError, match=r"joint 1 = .* outside its limits"):
        solve_path_ik(robot, p, z, q0)


def test_bad_inputs(kuka):
    p, z = _triangle_task(5)
    q0 = np.deg2rad(Q_START_DEG)
    with pytest.raises(InputError, match="tool_axes: sample 2"):
        solve_path_ik(kuka, p, np.where(np.arange(5)[:, None] == 2, 0.0, z), q0)
    with pytest.raises(InputError, match="x_axes: sample 0 is parallel"):
        solve_path_ik(kuka, p, z, q0, x_axes=z)
    with pytest.raises(InputError, match="q_start: joint 2"):
        solve_path_ik(kuka, p, z, np.deg2rad([0, 40, 90, 0, 45, 0]))
    with pytest.raises(InputError, match="shape"):
        solve_path_ik(kuka, p[:, :2], z, q0)


def test_ik_options_defaults_and_validation():
    o = IKOptions()
    assert (o.tol_position, o.tol_angle, o.coarse_position, o.coarse_angle) == (
        1e-10, 1e-10, 1e-4, 1e-3)
    assert (o.max_iterations, o.max_iterations_first, o.max_newton_step, o.damping) == (
        20, 300, 0.2, 1e-12)
    assert (o.fail_position, o.fail_angle, o.max_condition, o.condition_length) == (
        1e-7, 1e-7, 100.0, 1.0)
    assert o.max_joint_step == np.deg2rad(5.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.max_condition = 1e3
    assert IKOptions(damping=0.0).damping == 0.0
    for bad in ({"max_iterations": 0}, {"max_iterations_first": 2.5}, {"tol_position": 0.0},
                {"max_condition": float("inf")}, {"damping": -1.0}, {"max_joint_step": np.nan}):
        with pytest.raises(ValueError, match=f"IKOptions.{next(iter(bad))}"):
            IKOptions(**bad)


def test_default_options_are_the_options_none(kuka):
    p, z = _triangle_task(101)
    q0 = np.deg2rad(Q_START_DEG)
    a = solve_path_ik(kuka, p, z, q0)
    b = solve_path_ik(kuka, p, z, q0, None, IKOptions())
    for name in ("q", "condition_number", "position_error", "axis_error"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_tight_options_take_effect(kuka):
    p, z = _triangle_task(101)
    q0 = np.deg2rad(Q_START_DEG)
    with pytest.raises(InputError, match=r"condition number .* > 2"):
        solve_path_ik(kuka, p, z, q0, options=IKOptions(max_condition=2.0))
    # one Newton step per sample and none in refinement cannot reach 1e-10 m from q_start
    with pytest.raises(InputError, match="sample 0 .*unreachable"):
        solve_path_ik(kuka, p, z, q0 + 0.1,
                      options=IKOptions(max_iterations_first=1, max_iterations=1))


def test_damped_newton_step_is_minimum_norm_and_clamped():
    rng = np.random.default_rng(4)
    jt = rng.normal(size=(5, 6))
    e = rng.normal(size=5) * 1e-3
    eye = np.eye(5) * 1e-12
    ones = np.ones(6)
    dq = ik_module._damped_newton_step(jt, e, eye, max_step=10.0, winv=ones)
    np.testing.assert_allclose(jt @ dq, e, atol=1e-12)
    np.testing.assert_allclose(dq, np.linalg.pinv(jt) @ e, atol=1e-12)  # minimum norm
    big = ik_module._damped_newton_step(jt, e * 1e4, eye, max_step=0.2, winv=ones)
    assert np.isclose(np.abs(big).max(), 0.2)
    np.testing.assert_allclose(big / np.linalg.norm(big), dq / np.linalg.norm(dq), atol=1e-9)


def test_weighted_step_is_the_weighted_minimum_norm_solution():
    """With weights w the step solves J dq = e with the least sum w_i dq_i^2: by brute
    force, the minimum-norm solution in the scaled joints u = sqrt(w) q."""
    rng = np.random.default_rng(5)
    jt = rng.normal(size=(5, 7))
    e = rng.normal(size=5) * 1e-3
    w = np.array([1e4, 1, 1, 1, 1, 1, 1.0])  # a track and six arm joints
    dq = ik_module._damped_newton_step(jt, e, np.eye(5) * 1e-14, max_step=10.0, winv=1 / w)
    np.testing.assert_allclose(jt @ dq, e, atol=1e-12)
    s = 1 / np.sqrt(w)
    reference = s * (np.linalg.pinv(jt * s) @ e)
    np.testing.assert_allclose(dq, reference, atol=1e-12)
    plain = ik_module._damped_newton_step(jt, e, np.eye(5) * 1e-14, 10.0, np.ones(7))
    assert abs(dq[0]) < 0.05 * abs(plain[0])  # the heavy joint moves far less


def test_seed_is_a_first_order_predictor():
    q = np.array([[0.0, 1.0], [0.1, 1.2], [9.0, 9.0]])
    q_start = np.array([-1.0, -2.0])
    np.testing.assert_array_equal(ik_module._seed(q, 0, q_start), q_start)
    np.testing.assert_array_equal(ik_module._seed(q, 1, q_start), q[0])
    np.testing.assert_allclose(ik_module._seed(q, 2, q_start), [0.2, 1.4])
    assert ik_module._seed(q, 1, q_start) is not q[0]


def test_path_check_phases(kuka):
    q = np.deg2rad(np.array([Q_START_DEG, Q_START_DEG, Q_START_DEG]))
    q[1, 2] += np.deg2rad(6.0)
    steps = ik_module._joint_steps(q)
    np.testing.assert_array_equal(steps[0], 0.0)
    np.testing.assert_allclose(np.rad2deg(steps[1:, 2]), [6.0, 6.0])
    q[2, 1] = kuka.q_upper[1] + 1e-6
    below, above = ik_module._outside_limits(kuka, q)
    assert not below.any() and np.array_equal(np.argwhere(above), [[2, 1]])
