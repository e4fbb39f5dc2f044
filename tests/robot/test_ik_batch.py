"""The path IK's strided sweep + batched refinement against an independent per-sample IK.

The reference below is written from scratch: for every sample, full Newton iterations with
numpy's minimum-norm least squares on pinocchio's frame Jacobian, warm-started from the
previous sample's solution only (no predictor, no coarse tolerance, no batching).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from feedopt.robot import ik as ik_module
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import forward_kinematics, tcp_jacobians
from tests.robot.helpers import Q_START_DEG, WORKPIECE_ORIGIN_M, triangle_wave

# Tolerance of the default IKOptions (1e-10 m, 1e-10 rad): two solutions that each meet it
# differ by about that much in the joints (arm lengths ~1-2 m).
JOINT_TOL = 3e-10


def _reference_ik(robot, p, z, q_first, x_axes=None):
    """Per-sample Newton to 1e-13 (5-DoF: position and the tool axis's two normal rotation
    components; 6-DoF: the full rotation error), minimum-norm steps by lstsq."""
    model, data, fid = robot.model, robot.model.createData(), robot.tcp_frame_id
    q, out = np.array(q_first, dtype=float), []
    for k in range(p.shape[0]):
        for _ in range(30):
            jac = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
            pose = data.oMf[fid]
            ep = p[k] - pose.translation
            if x_axes is None:
                zc = pose.rotation[:, 2]
                c = np.cross(zc, z[k])
                sn = np.linalg.norm(c)
                ew = c * (np.arctan2(sn, zc @ z[k]) / sn) if sn > 0 else np.zeros(3)
                proj = np.eye(3) - np.outer(z[k], z[k])
                a, e = np.vstack([jac[:3], proj @ jac[3:]]), np.concatenate([ep, proj @ ew])
            else:
                x = x_axes[k] - (x_axes[k] @ z[k]) * z[k]
                x /= np.linalg.norm(x)
                target = np.column_stack([x, np.cross(z[k], x), z[k]])
                ew = pin.log3(target @ pose.rotation.T)
                a, e = jac, np.concatenate([ep, ew])
            if np.abs(e).max() < 1e-13:
                break
            q = q + np.linalg.lstsq(a, e, rcond=None)[0]
        out.append(q.copy())
    return np.array(out)


def _wave(n):
    p = triangle_wave(n) + WORKPIECE_ORIGIN_M
    return p, np.tile([0.0, 0.0, 1.0], (n, 1))


@pytest.mark.parametrize("six_dof", [False, True])
def test_batched_ik_equals_the_per_sample_reference(kuka, six_dof):
    # 0.7 mm spacing with a 4 mm sweep spacing: the sweep visits every 5th sample, the
    # spline seeds the others (also across the wave's sharp corners, where q(s) has kinks)
    p, z = _wave(801)
    q0 = np.deg2rad(Q_START_DEG)
    options = IKOptions(sweep_spacing=4e-3)
    x = None
    if six_dof:
        x = forward_kinematics(kuka, solve_path_ik(kuka, p, z, q0).q)[:, :3, 0]
    task = ik_module._validate_task(kuka, p, z, q0, x)
    assert ik_module._sweep_stride(task, options) == 5
    got = solve_path_ik(kuka, p, z, q0, x_axes=x, options=options)
    ref = _reference_ik(kuka, p, z, got.q[0], x_axes=x)
    np.testing.assert_allclose(got.q, ref, rtol=0, atol=JOINT_TOL)
    back = forward_kinematics(kuka, got.q)
    assert np.abs(back[:, :3, 3] - p).max() <= 1e-10
    assert np.abs(back[:, :3, 2] - z).max() <= 1e-10
    assert got.position_error.max() <= 1e-10 and got.axis_error.max() <= 1e-10


def test_strided_and_sample_by_sample_sweeps_agree_on_a_fine_path(kuka):
    # ~0.04 mm spacing: the default sweep (1 mm) visits every 25th sample
    n = 2001
    p = WORKPIECE_ORIGIN_M + np.stack([np.linspace(0, 0.04, n), 0.01 * np.sin(
        np.linspace(0, 3 * np.pi, n)), np.zeros(n)], axis=1)
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    q0 = np.deg2rad(Q_START_DEG)
    strided = solve_path_ik(kuka, p, z, q0)
    every = solve_path_ik(kuka, p, z, q0, options=IKOptions(sweep_spacing=1e-9))
    np.testing.assert_allclose(strided.q, every.q, rtol=0, atol=JOINT_TOL)
    task = ik_module._validate_task(kuka, p, z, q0, None)
    assert ik_module._sweep_stride(task, IKOptions()) == 25


def test_a_turning_tool_axis_is_swept_sample_by_sample(kuka):
    n = 401
    p, _ = _wave(n)
    tilt = np.deg2rad(10) * np.sin(np.linspace(0, np.pi, n))
    z = np.stack([np.sin(tilt), np.zeros(n), np.cos(tilt)], axis=1)
    task = ik_module._validate_task(kuka, p, z, np.deg2rad(Q_START_DEG), None)
    assert ik_module._sweep_stride(task, IKOptions(sweep_spacing=4e-3)) == 1
    # a 6-DoF task has no free rotation: it may be strided
    task6 = ik_module._validate_task(kuka, p, z, np.deg2rad(Q_START_DEG),
                                     np.tile([1.0, 0.0, 0.0], (n, 1)))
    assert ik_module._sweep_stride(task6, IKOptions(sweep_spacing=4e-3)) > 1


def test_jacobians_are_those_of_the_solution(kuka):
    p, z = _wave(301)
    got = solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG), jacobians=True)
    np.testing.assert_array_equal(got.jacobian, tcp_jacobians(kuka, got.q))
    assert solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG)).jacobian is None


def test_a_seed_off_the_branch_falls_back_to_the_sample_by_sample_sweep(kuka, monkeypatch):
    p, z = _wave(801)
    q0 = np.deg2rad(Q_START_DEG)
    options = IKOptions(sweep_spacing=4e-3)
    want = solve_path_ik(kuka, p, z, q0, options=IKOptions(sweep_spacing=1e-9))
    real = ik_module._seeds_between

    def far_seeds(task, visit, q_swept):
        seeds = real(task, visit, q_swept)
        seeds[403] += [0.3, -0.3, 0.3, 0.0, 0.3, 0.0]  # Newton from here wanders off
        return seeds

    monkeypatch.setattr(ik_module, "_seeds_between", far_seeds)
    got = solve_path_ik(kuka, p, z, q0, options=options)
    np.testing.assert_array_equal(got.q, want.q)


def test_progress_reaches_the_total(kuka):
    p, z = _wave(801)
    calls = []
    solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG), options=IKOptions(sweep_spacing=4e-3),
                  progress=lambda done, total: calls.append((done, total)))
    done = [d for d, _ in calls]
    assert calls and done == sorted(done) and calls[-1][0] == calls[-1][1]
    assert calls[-1][1] == 801 + 161  # refined samples + swept samples (every 5th)
