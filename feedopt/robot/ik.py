"""Numerical inverse kinematics along a sampled tool path (thesis 3.4).

Every sample is solved by Newton / damped-least-squares steps on pinocchio's TCP Jacobian,
warm-started from the previous sample's solution, so the solution closest to the previous one
(and ultimately to the user's start configuration) is tracked. Five-axis tasks (tool axis
given, rotation about it free) take the minimum-norm joint step, which keeps the redundant
rotation as close as possible to the previous sample.

After the sweep the joint path is checked; the earliest offending sample is reported with its
index and pose: unreachable (no convergence), joint-limit violation, joint jump (branch flip)
and near-singular pose (condition number of the scaled TCP Jacobian).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel, jacobian_condition_number


@dataclass(frozen=True)
class PathIK:
    """Joint path solving a sampled TCP path.

    Attributes
    ----------
    q : (n, dof) array
        Joint configurations [rad].
    condition_number : (n,) array
        Condition number of the 6 x dof TCP Jacobian (angular rows scaled by a length).
    position_error : (n,) array
        Remaining TCP position error [m].
    axis_error : (n,) array
        Remaining orientation error [rad]: angle between the tool axes (5-DoF task) or of the
        full rotation error (6-DoF task).
    """

    q: np.ndarray
    condition_number: np.ndarray
    position_error: np.ndarray
    axis_error: np.ndarray


def _unit_rows(v: np.ndarray, name: str) -> np.ndarray:
    norms = np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(~(norms > 1e-12))
    if bad.size:
        raise InputError(f"{name}: sample {bad[0]} is a zero or non-finite vector ({v[bad[0]]})")
    return v / norms[:, None]


def _target_rotations(z: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Rotations (n, 3, 3) with columns [x, y, z]; x is made orthogonal to z."""
    x = x - np.sum(x * z, axis=1, keepdims=True) * z
    norms = np.linalg.norm(x, axis=1)
    bad = np.flatnonzero(norms < 1e-9)
    if bad.size:
        raise InputError(
            f"x_axes: sample {bad[0]} is parallel to the tool axis {z[bad[0]]}; give an x axis "
            "perpendicular to the tool axis"
        )
    x = x / norms[:, None]
    return np.stack([x, np.cross(z, x), z], axis=2)


def _perpendicular_bases(z: np.ndarray) -> np.ndarray:
    """Two unit vectors (n, 3, 2) perpendicular to each unit vector z (n, 3)."""
    helper = np.where(np.abs(z[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(z, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(z, e1)
    return np.stack([e1, e2], axis=2)


def _axis_error_batch(z: np.ndarray, z_t: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) turning the axes z onto z_t by the shortest rotation."""
    c = np.cross(z, z_t)
    sn = np.linalg.norm(c, axis=1)
    ang = np.arctan2(sn, np.sum(z * z_t, axis=1))
    scale = np.divide(ang, sn, out=np.zeros_like(sn), where=sn > 1e-300)
    ew = c * scale[:, None]
    flip = (sn < 1e-9) & (ang > 1.0)
    ew[flip] = basis[flip][:, :, 0] * ang[flip, None]
    return ew


def _log3_batch(r: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) of rotation matrices (n, 3, 3)."""
    vee = 0.5 * np.stack(
        [r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]], axis=1
    )
    cos = np.clip((np.trace(r, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    sin = np.linalg.norm(vee, axis=1)
    ang = np.arctan2(sin, cos)
    scale = np.where(sin > 1e-12, ang / np.maximum(sin, 1e-300), 1.0 + ang**2 / 6.0)
    out = vee * scale[:, None]
    near_pi = cos < -0.99
    for k in np.flatnonzero(near_pi):
        out[k] = pin.log3(r[k])
    return out


def _describe(k: int, position: np.ndarray, axis: np.ndarray) -> str:
    p = np.asarray(position) * 1e3
    return (
        f"sample {k} (TCP x={p[0]:.3f}, y={p[1]:.3f}, z={p[2]:.3f} mm, tool axis "
        f"[{axis[0]:.4f}, {axis[1]:.4f}, {axis[2]:.4f}])"
    )


def solve_path_ik(
    robot: RobotModel,
    positions: np.ndarray,
    tool_axes: np.ndarray,
    q_start: np.ndarray,
    x_axes: np.ndarray | None = None,
    *,
    tol_position: float = 1e-10,
    tol_angle: float = 1e-10,
    max_iterations: int = 20,
    max_iterations_first: int = 300,
    max_joint_step: float = np.deg2rad(5.0),
    max_condition: float = 100.0,
    condition_length: float = 1.0,
    max_newton_step: float = 0.2,
    damping: float = 1e-12,
    fail_position: float = 1e-7,
    fail_angle: float = 1e-7,
) -> PathIK:
    """Joint configurations placing the TCP on ``positions`` with its +z on ``tool_axes``.

    Parameters
    ----------
    robot : RobotModel
    positions : (n, 3) array
        TCP positions in the base frame [m].
    tool_axes : (n, 3) array
        Tool axis directions (TCP +z, pointing from the tool tip into the spindle); normalised.
    q_start : (dof,) array
        User's start configuration [rad]; seeds the first sample.
    x_axes : (n, 3) array or None
        TCP +x directions for a 6-DoF task (made orthogonal to the tool axis); ``None`` for the
        5-DoF milling task where the rotation about the tool axis is free.
    tol_position, tol_angle : float
        Newton stops when the position error [m] and orientation error [rad] are below these.
    max_iterations, max_iterations_first : int
        Newton steps per sample (first sample: from ``q_start``, may be far).
    max_joint_step : float
        Largest allowed joint change between consecutive samples [rad]; larger = branch flip.
    max_condition : float
        Largest allowed Jacobian condition number (angular rows scaled by
        ``condition_length`` [m]); above it the pose counts as near-singular.
    max_newton_step : float
        Newton steps are scaled down to at most this joint change [rad].
    damping : float
        Damped-least-squares regularisation lambda^2 (tiny: plain Newton when non-singular).
    fail_position, fail_angle : float
        Residuals [m], [rad] above which a sample counts as unreachable.

    Raises
    ------
    InputError
        Naming the first sample (index and pose) that is unreachable, violates a joint limit,
        jumps (branch flip) or is near-singular.
    """
    dof = robot.dof
    p_t = np.asarray(positions, dtype=float)
    if p_t.ndim != 2 or p_t.shape[1] != 3 or p_t.shape[0] == 0:
        raise InputError(f"positions must have shape (n, 3) with n >= 1, got {p_t.shape}")
    n = p_t.shape[0]
    if not np.all(np.isfinite(p_t)):
        k = int(np.flatnonzero(~np.isfinite(p_t).all(axis=1))[0])
        raise InputError(f"positions: sample {k} is not finite ({p_t[k]})")
    z_t = np.asarray(tool_axes, dtype=float)
    if z_t.shape != (n, 3):
        raise InputError(f"tool_axes must have shape ({n}, 3) like positions, got {z_t.shape}")
    z_t = _unit_rows(z_t, "tool_axes")
    six_dof = x_axes is not None
    if six_dof:
        x_in = np.asarray(x_axes, dtype=float)
        if x_in.shape != (n, 3):
            raise InputError(f"x_axes must have shape ({n}, 3) like positions, got {x_in.shape}")
        r_t = _target_rotations(z_t, x_in)
        n_task = 6
    else:
        basis = _perpendicular_bases(z_t)  # (n, 3, 2)
        n_task = 5
    q0 = np.asarray(q_start, dtype=float)
    if q0.shape != (dof,) or not np.all(np.isfinite(q0)):
        raise InputError(f"q_start must have {dof} finite values, got {q_start!r}")
    out_of_range = np.flatnonzero((q0 < robot.q_lower) | (q0 > robot.q_upper))
    if out_of_range.size:
        j = out_of_range[0]
        raise InputError(
            f"q_start: joint {j + 1} = {np.rad2deg(q0[j]):.3f} deg is outside its limits "
            f"[{np.rad2deg(robot.q_lower[j]):.1f}, {np.rad2deg(robot.q_upper[j]):.1f}] deg"
        )

    model, data, fid = robot.model, robot.model.createData(), robot.tcp_frame_id
    lwa = pin.LOCAL_WORLD_ALIGNED
    posv = lapack.dposv
    q_out = np.empty((n, dof))
    eye = np.eye(n_task) * damping
    e = np.empty(n_task)
    jt = np.empty((n_task, dof))
    coarse_p, coarse_a = 1e-4, 1e-3  # in Newton's quadratic region: refine in batch later

    # Sequential sweep: warm start + first-order predictor, Newton until within the coarse
    # tolerance (usually one step), so every sample tracks the previous one's branch.
    q = q0.copy()
    for k in range(n):
        pk, zk = p_t[k], z_t[k]
        if k >= 2:
            q = q + (q_out[k - 1] - q_out[k - 2])
        limit = max_iterations_first if k == 0 else max_iterations
        done = False
        for _ in range(limit):
            pin.computeJointJacobians(model, data, q)
            placement = pin.updateFramePlacement(model, data, fid)
            jac = pin.getFrameJacobian(model, data, fid, lwa)
            rot = placement.rotation
            ep = pk - placement.translation
            if six_dof:
                ew = pin.log3(r_t[k] @ rot.T)
                ea = float(np.sqrt(ew @ ew))
            else:
                z0, z1, z2 = rot[0, 2], rot[1, 2], rot[2, 2]
                t0, t1, t2 = zk
                ew = np.array([z1 * t2 - z2 * t1, z2 * t0 - z0 * t2, z0 * t1 - z1 * t0])
                sn = float(np.sqrt(ew @ ew))
                ea = float(np.arctan2(sn, z0 * t0 + z1 * t1 + z2 * t2))
                if sn > 1e-300:
                    ew *= ea / sn
                if sn < 1e-9 and ea > 1.0:  # axis exactly reversed: rotate about any normal
                    ew = basis[k][:, 0] * ea
            ep_norm = float(np.sqrt(ep @ ep))
            if ep_norm <= tol_position and ea <= tol_angle:
                done = True
                break
            jt[:3] = jac[:3]
            e[:3] = ep
            if six_dof:
                jt[3:] = jac[3:]
                e[3:] = ew
            else:
                b = basis[k]
                jt[3:] = b.T @ jac[3:]
                e[3:] = b.T @ ew
            _, x, info = posv(jt @ jt.T + eye, e)
            dq = jt.T @ x if info == 0 else np.linalg.lstsq(jt, e, rcond=None)[0]
            big = np.abs(dq).max()
            if big > max_newton_step:
                dq *= max_newton_step / big
            q = q + dq
            if ep_norm <= coarse_p and ea <= coarse_a:
                done = True
                break
        q_out[k] = q
        if not done or not np.all(np.isfinite(q)):
            raise InputError(
                f"IK: {_describe(k, pk, zk)} is unreachable: Newton did not converge "
                f"(residual {ep_norm * 1e3:.3g} mm, {np.rad2deg(ea):.3g} deg); move the "
                "workpiece closer to the robot or change q_start"
            )

    # Batched refinement: pinocchio per sample, errors and Newton steps vectorised.
    rot = np.empty((n, 3, 3))
    pos = np.empty((n, 3))
    jac_out = np.empty((n, 6, dof))
    for _ in range(max_iterations + 1):
        for k in range(n):
            pin.computeJointJacobians(model, data, q_out[k])
            placement = pin.updateFramePlacement(model, data, fid)
            rot[k] = placement.rotation
            pos[k] = placement.translation
            jac_out[k] = pin.getFrameJacobian(model, data, fid, lwa)
        ep = p_t - pos
        if six_dof:
            ew = _log3_batch(r_t @ np.swapaxes(rot, 1, 2))
        else:
            ew = _axis_error_batch(rot[:, :, 2], z_t, basis)
        pos_err = np.linalg.norm(ep, axis=1)
        ang_err = np.linalg.norm(ew, axis=1)
        todo = np.flatnonzero((pos_err > tol_position) | (ang_err > tol_angle))
        if not todo.size:
            break
        jb = jac_out[todo]
        if six_dof:
            jt_b, e_b = jb, np.concatenate([ep[todo], ew[todo]], axis=1)
        else:
            bt = np.swapaxes(basis[todo], 1, 2)  # (m, 2, 3)
            jt_b = np.concatenate([jb[:, :3], bt @ jb[:, 3:]], axis=1)
            e_b = np.concatenate([ep[todo], np.einsum("mij,mj->mi", bt, ew[todo])], axis=1)
        a = jt_b @ np.swapaxes(jt_b, 1, 2) + eye
        dq = np.einsum("mji,mj->mi", jt_b, np.linalg.solve(a, e_b[..., None])[..., 0])
        big = np.abs(dq).max(axis=1, keepdims=True)
        dq *= np.minimum(1.0, max_newton_step / np.maximum(big, 1e-300))
        q_out[todo] += dq

    bad = np.flatnonzero(
        (pos_err > fail_position) | (ang_err > fail_angle) | ~np.isfinite(q_out).all(axis=1)
    )
    if bad.size:
        k = int(bad[0])
        raise InputError(
            f"IK: {_describe(k, p_t[k], z_t[k])} is unreachable: Newton did not converge "
            f"(residual {pos_err[k] * 1e3:.3g} mm, {np.rad2deg(ang_err[k]):.3g} deg); move the "
            "workpiece closer to the robot or change q_start"
        )

    cond = jacobian_condition_number(jac_out, condition_length)
    _check_path(robot, q_out, cond, p_t, z_t, max_joint_step, max_condition)
    return PathIK(q=q_out, condition_number=cond, position_error=pos_err, axis_error=ang_err)


def _check_path(
    robot: RobotModel,
    q: np.ndarray,
    cond: np.ndarray,
    p_t: np.ndarray,
    z_t: np.ndarray,
    max_joint_step: float,
    max_condition: float,
) -> None:
    """Raise InputError for the earliest sample with a limit, jump or singularity problem."""
    n = q.shape[0]
    tol = 1e-9
    below = q < robot.q_lower - tol
    above = q > robot.q_upper + tol
    limit_bad = np.any(below | above, axis=1)
    jump = np.zeros(n, dtype=bool)
    steps = np.zeros((n, q.shape[1]))
    if n > 1:
        steps[1:] = np.abs(np.diff(q, axis=0))
        jump[1:] = np.any(steps[1:] > max_joint_step, axis=1)
    singular = ~(cond <= max_condition)
    bad = np.flatnonzero(limit_bad | jump | singular)
    if not bad.size:
        return
    k = int(bad[0])
    where = _describe(k, p_t[k], z_t[k])
    problems = []
    if singular[k]:
        problems.append(
            f"near-singular pose (Jacobian condition number {cond[k]:.1f} > {max_condition:g})"
        )
    if limit_bad[k]:
        j = int(np.flatnonzero(below[k] | above[k])[0])
        problems.append(
            f"joint {j + 1} = {np.rad2deg(q[k, j]):.3f} deg outside its limits "
            f"[{np.rad2deg(robot.q_lower[j]):.1f}, {np.rad2deg(robot.q_upper[j]):.1f}] deg"
        )
    if jump[k]:
        j = int(np.argmax(steps[k]))
        problems.append(
            f"joint {j + 1} jumps by {np.rad2deg(steps[k, j]):.3f} deg from the previous sample "
            f"(> {np.rad2deg(max_joint_step):.3f} deg: branch flip or path too coarse)"
        )
    q_deg = ", ".join(f"{v:.2f}" for v in np.rad2deg(q[k]))
    raise InputError(
        f"IK: {where}: " + "; ".join(problems) + f" at q = [{q_deg}] deg. Move the workpiece, "
        "change the start configuration or the tool axis so the path stays away from it"
    )
