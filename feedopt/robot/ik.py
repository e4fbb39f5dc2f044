"""Numerical inverse kinematics along a sampled tool path (thesis 3.4).

Every sample is solved by Newton / damped-least-squares steps on pinocchio's TCP Jacobian,
warm-started from the previous sample's solution, so the solution closest to the previous one
(and ultimately to the user's start configuration) is tracked. Five-axis tasks (tool axis
given, rotation about it free) take the minimum-norm joint step, which keeps the redundant
rotation as close as possible to the previous sample.

The warm-started sweep is sequential by nature (each seed is the previous solutions), so on
paths sampled finer than :attr:`IKOptions.sweep_spacing` with a fixed tool axis (or a 6-DoF
task) it visits every k-th sample only; the samples between start from a cubic spline
through the swept ones and are solved by the batched refinement with everything else (numpy
over samples, pinocchio once per configuration and pass, only on the samples still above the
tolerance). A refined sample that moves more than a branch flip from its seed sends the whole
path back to the sample-by-sample sweep.

After the sweep the joint path is checked; the earliest offending sample is reported with its
index and pose: unreachable (no convergence), joint-limit violation, joint jump (branch flip)
and near-singular pose (condition number of the scaled TCP Jacobian).

:func:`solve_path_ik` runs the phases in order: :func:`_validate_task` (targets per sample),
:func:`_sweep` (per swept sample: :func:`_seed`, then :func:`_damped_newton_step` to a coarse
tolerance), :func:`_seeds_between` (spline seeds of the samples the sweep skipped),
:func:`_refine` (batched Newton to the final tolerance, by chunks of samples),
:func:`_check_converged` and :func:`_check_path` (limits, jumps, singularities). Its tunables
are :class:`IKOptions`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel, jacobian_condition_number
from feedopt.units import MM


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
    jacobian : (n, 6, dof) array or None
        TCP Jacobians at ``q`` (LOCAL_WORLD_ALIGNED, as :func:`feedopt.robot.model.tcp_jacobians`
        computes them), only when :func:`solve_path_ik` is asked for them.
    """

    q: np.ndarray
    condition_number: np.ndarray
    position_error: np.ndarray
    axis_error: np.ndarray
    jacobian: np.ndarray | None = None


@dataclass(frozen=True)
class IKOptions:
    """Tunables of :func:`solve_path_ik` (the defaults are what every run uses).

    Attributes
    ----------
    tol_position, tol_angle : float
        Newton stops when the position error [m] and orientation error [rad] are below these.
    coarse_position, coarse_angle : float
        The sequential sweep moves on to the next sample once the errors [m], [rad] are below
        these (Newton's quadratic region); the batched refinement then reaches the tolerances.
    max_iterations, max_iterations_first : int
        Newton steps per sample (first sample: from ``q_start``, may be far); the batched
        refinement takes at most ``max_iterations`` steps too.
    max_newton_step : float
        Newton steps are scaled down to at most this joint change [rad].
    damping : float
        Damped-least-squares regularisation lambda^2 (tiny: plain Newton when non-singular).
    fail_position, fail_angle : float
        Residuals [m], [rad] above which a sample counts as unreachable.
    max_joint_step : float
        Largest allowed joint change between consecutive samples [rad]; larger = branch flip.
    max_condition : float
        Largest allowed Jacobian condition number (angular rows scaled by
        ``condition_length`` [m]); above it the pose counts as near-singular.
    condition_length : float
        Length scale [m] of the angular Jacobian rows in the condition number.
    sweep_spacing : float
        The sequential sweep visits samples about this far apart [m]: every k-th sample,
        k = floor(sweep_spacing / median sample spacing) (every sample on paths sampled at
        this spacing or coarser). The samples between are seeded by a cubic spline through
        the swept ones, by chord length, and solved by the batched refinement. 1 mm: a
        large arm's joints move by ~1e-3 rad per mm of tool path, far inside one Newton
        basin, and a seed the refinement moves by more than a branch flip sends the path
        back to the sample-by-sample sweep (tests/robot/test_ik_batch.py agrees at 4 mm
        across sharp corners). At 0.1 mm sampling it sweeps every 10th sample.
    held_joint : int or None
        A joint the Newton steps do not move: it keeps its value in ``q_start`` along the
        whole path (the extra axis of a 7-axis robot held where the arm is stiffest,
        :mod:`feedopt.robot.extra_axis`); None: every joint moves.
    """

    tol_position: float = 1e-10
    tol_angle: float = 1e-10
    coarse_position: float = 1e-4
    coarse_angle: float = 1e-3
    max_iterations: int = 20
    max_iterations_first: int = 300
    max_newton_step: float = 0.2
    damping: float = 1e-12
    fail_position: float = 1e-7
    fail_angle: float = 1e-7
    max_joint_step: float = float(np.deg2rad(5.0))
    max_condition: float = 100.0
    condition_length: float = 1.0
    sweep_spacing: float = 1e-3
    held_joint: int | None = None

    def __post_init__(self) -> None:
        if self.held_joint is not None and (isinstance(self.held_joint, bool) or not isinstance(
                self.held_joint, int | np.integer) or self.held_joint < 0):
            raise ValueError(f"IKOptions.held_joint must be a joint index >= 0 or None, got "
                             f"{self.held_joint!r}")
        for name in ("max_iterations", "max_iterations_first"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"IKOptions.{name} must be an integer >= 1, got {value!r}")
        for f in fields(self):
            if f.name in ("max_iterations", "max_iterations_first", "held_joint"):
                continue
            value = getattr(self, f.name)
            low_ok = value >= 0 if f.name == "damping" else value > 0
            if not (np.isfinite(value) and low_ok):
                raise ValueError(f"IKOptions.{f.name} must be a finite number > 0 "
                                 f"(damping: >= 0), got {value!r}")


@dataclass(frozen=True)
class _Task:
    """A validated path task: targets per sample, in the base frame."""

    positions: np.ndarray  # (n, 3) [m]
    tool_axes: np.ndarray  # (n, 3) unit vectors
    rotations: np.ndarray | None  # (n, 3, 3) 6-DoF targets, or None (5-DoF)
    normals: np.ndarray | None  # (n, 3, 2) 5-DoF: two unit normals of each tool axis
    q_start: np.ndarray  # (dof,) [rad]

    @property
    def six_dof(self) -> bool:
        return self.rotations is not None

    @property
    def n(self) -> int:
        return self.positions.shape[0]

    @property
    def size(self) -> int:
        """Task dimension: 6 (full pose) or 5 (position + tool axis)."""
        return 6 if self.six_dof else 5


#: IK weight of a prismatic joint [1/m^2] against a revolute joint's [1/rad^2]: the Newton
#: steps minimise sum w_i dq_i^2, so 10 mm of a linear track cost as much as 1 rad of an arm
#: joint and the slow, heavy track moves only where the arm alone cannot follow the path.
PRISMATIC_WEIGHT = 1e4


def inverse_weights(robot: RobotModel) -> np.ndarray:
    """1 / the IK weight of each joint (:data:`PRISMATIC_WEIGHT` for prismatic joints)."""
    return np.where(robot.axis_convention.prismatic, 1.0 / PRISMATIC_WEIGHT, 1.0)


class _TcpKinematics:
    """Pinocchio TCP placement and Jacobian of one robot, with its own work data."""

    def __init__(self, robot: RobotModel, held_joint: int | None = None) -> None:
        self.model, self.data, self.fid = robot.model, robot.model.createData(), robot.tcp_frame_id
        self.winv = inverse_weights(robot)
        if held_joint is not None:
            if held_joint >= robot.dof:
                raise InputError(f"IK: held joint index {held_joint} is not a joint of "
                                 f"{robot.name} (0..{robot.dof - 1})")
            self.winv[held_joint] = 0.0  # W^-1 = 0: the Newton steps never move it

    def evaluate(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """TCP rotation (3, 3), position (3,) and Jacobian (6, dof) (LOCAL_WORLD_ALIGNED)."""
        pin.computeJointJacobians(self.model, self.data, q)
        placement = pin.updateFramePlacement(self.model, self.data, self.fid)
        jac = pin.getFrameJacobian(self.model, self.data, self.fid, pin.LOCAL_WORLD_ALIGNED)
        return placement.rotation, placement.translation, jac

    def evaluate_rows(
        self, q: np.ndarray, rows: np.ndarray, pose: np.ndarray, jac: np.ndarray
    ) -> None:
        """TCP poses (4, 4) and Jacobians (6, dof) of the configurations ``q[rows]``, written
        to ``pose[rows]`` and ``jac[rows]`` (one pinocchio call per configuration: the frame
        Jacobian, which places the frame too; the Jacobian is bit for bit
        :func:`feedopt.robot.model.tcp_jacobians`'s)."""
        model, data, fid = self.model, self.data, self.fid
        frame_jacobian, world_aligned, placements = (pin.computeFrameJacobian,
                                                     pin.LOCAL_WORLD_ALIGNED, data.oMf)
        for k in rows.tolist():
            jac[k] = frame_jacobian(model, data, q[k], fid, world_aligned)
            pose[k] = placements[fid].homogeneous


# Samples per chunk of the batched refinement (bounds its (chunk, 6, dof) work arrays), and
# how often the sequential sweep reports progress.
_CHUNK = 1 << 15
_PROGRESS_EVERY = 1 << 12

# --------------------------------------------------------------------------- geometry helpers


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


# --------------------------------------------------------------------------- task and seed


def _validate_task(
    robot: RobotModel,
    positions: np.ndarray,
    tool_axes: np.ndarray,
    q_start: np.ndarray,
    x_axes: np.ndarray | None,
) -> _Task:
    """Check shapes, finiteness and the start configuration; build the per-sample targets."""
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
    rotations = normals = None
    if x_axes is not None:
        x_in = np.asarray(x_axes, dtype=float)
        if x_in.shape != (n, 3):
            raise InputError(f"x_axes must have shape ({n}, 3) like positions, got {x_in.shape}")
        rotations = _target_rotations(z_t, x_in)
    else:
        normals = _perpendicular_bases(z_t)
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
    return _Task(positions=p_t, tool_axes=z_t, rotations=rotations, normals=normals, q_start=q0)


def _seed(q_solved: np.ndarray, k: int, q_start: np.ndarray) -> np.ndarray:
    """Start of Newton at sample k: ``q_start``, then the previous solution plus the previous
    step (first-order predictor along the path)."""
    if k == 0:
        return q_start.copy()
    if k == 1:
        return q_solved[0].copy()
    return q_solved[k - 1] + (q_solved[k - 1] - q_solved[k - 2])


# --------------------------------------------------------------------------- one sample


def _axis_error(rot: np.ndarray, z_target: np.ndarray, normals: np.ndarray):
    """Rotation vector (3,) turning the TCP z axis (column 2 of ``rot``) onto ``z_target`` by
    the shortest rotation, and its angle [rad]; about a normal when the axis is reversed."""
    z0, z1, z2 = rot[0, 2], rot[1, 2], rot[2, 2]
    t0, t1, t2 = z_target
    ew = np.array([z1 * t2 - z2 * t1, z2 * t0 - z0 * t2, z0 * t1 - z1 * t0])
    sn = float(np.sqrt(ew @ ew))
    ea = float(np.arctan2(sn, z0 * t0 + z1 * t1 + z2 * t2))
    if sn > 1e-300:
        ew *= ea / sn
    if sn < 1e-9 and ea > 1.0:  # axis exactly reversed: rotate about any normal
        ew = normals[:, 0] * ea
    return ew, ea


def _rotation_error(rot: np.ndarray, r_target: np.ndarray):
    """Rotation vector (3,) from the TCP rotation ``rot`` to ``r_target`` (base axes), angle."""
    ew = pin.log3(r_target @ rot.T)
    return ew, float(np.sqrt(ew @ ew))


def _task_system(
    jac: np.ndarray,
    ep: np.ndarray,
    ew: np.ndarray,
    normals: np.ndarray | None,
    jt: np.ndarray,
    e: np.ndarray,
) -> None:
    """Fill the task Jacobian ``jt`` (m, dof) and error ``e`` (m,): 3 position rows, then 3
    rotation rows (6-DoF) or the 2 rotation components normal to the tool axis (5-DoF)."""
    jt[:3] = jac[:3]
    e[:3] = ep
    if normals is None:
        jt[3:] = jac[3:]
        e[3:] = ew
    else:
        jt[3:] = normals.T @ jac[3:]
        e[3:] = normals.T @ ew


def _damped_newton_step(
    jt: np.ndarray, e: np.ndarray, damping_eye: np.ndarray, max_step: float,
    winv: np.ndarray,
) -> np.ndarray:
    """Weighted minimum-norm damped least-squares step ``W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1
    e`` (dof,), ``winv`` = diag W^-1 (:func:`inverse_weights`; all ones: the plain step).

    Falls back to least squares when the damped normal matrix is not positive definite;
    scaled down so that no joint moves by more than ``max_step`` [rad].
    """
    _, x, info = lapack.dposv((jt * winv) @ jt.T + damping_eye, e)
    dq = (winv * (jt.T @ x) if info == 0  # else least squares; a held joint's column is 0
          else np.linalg.lstsq(jt * (winv > 0), e, rcond=None)[0])
    big = np.abs(dq).max()
    if big > max_step:
        dq *= max_step / big
    return dq


def _solve_sample(
    kin: _TcpKinematics,
    task: _Task,
    k: int,
    q: np.ndarray,
    iterations: int,
    options: IKOptions,
    work: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, bool, float, float]:
    """Newton from ``q`` on sample k until the coarse tolerance (or the final one).

    Returns the configuration, whether it converged, and the last position [m] and
    orientation [rad] errors. ``work`` is (task Jacobian, task error, damping matrix).
    """
    jt, e, damping_eye = work
    p_k = task.positions[k]
    normals = None if task.six_dof else task.normals[k]
    ep_norm = ea = np.inf
    for _ in range(iterations):
        rot, trans, jac = kin.evaluate(q)
        ep = p_k - trans
        if task.six_dof:
            ew, ea = _rotation_error(rot, task.rotations[k])
        else:
            ew, ea = _axis_error(rot, task.tool_axes[k], normals)
        ep_norm = float(np.sqrt(ep @ ep))
        if ep_norm <= options.tol_position and ea <= options.tol_angle:
            return q, True, ep_norm, ea
        _task_system(jac, ep, ew, normals, jt, e)
        q = q + _damped_newton_step(jt, e, damping_eye, options.max_newton_step, kin.winv)
        if ep_norm <= options.coarse_position and ea <= options.coarse_angle:
            return q, True, ep_norm, ea
    return q, False, ep_norm, ea


def _sweep(
    kin: _TcpKinematics, task: _Task, options: IKOptions, visit: np.ndarray | None = None,
    progress: Callable[[int], None] | None = None,
) -> np.ndarray:
    """Sequential sweep (m, dof) over the samples ``visit`` (default: all), in order: seed
    from the previously visited samples, Newton until the coarse tolerance (usually one
    step), so that every sample tracks the previous one's branch. ``progress(m_done)``."""
    visit = np.arange(task.n) if visit is None else visit
    dof = task.q_start.shape[0]
    q_out = np.empty((visit.size, dof))
    work = (np.empty((task.size, dof)), np.empty(task.size), np.eye(task.size) * options.damping)
    for j, k in enumerate(visit.tolist()):
        iterations = options.max_iterations_first if j == 0 else options.max_iterations
        q, converged, ep_norm, ea = _solve_sample(
            kin, task, k, _seed(q_out, j, task.q_start), iterations, options, work
        )
        q_out[j] = q
        if not converged or not np.all(np.isfinite(q)):
            raise _unreachable(task, k, ep_norm, ea)
        if progress is not None and (j + 1) % _PROGRESS_EVERY == 0:
            progress(j + 1)
    return q_out


def _sweep_stride(task: _Task, options: IKOptions) -> int:
    """Every how many samples the sweep visits one (1: all; see IKOptions.sweep_spacing).

    Always 1 for a 5-DoF task whose tool axis turns along the path: there the redundant
    rotation the warm-started minimum-norm steps settle on depends on the sweep's step (by
    O(step^2), 2e-5 rad at 0.1 mm on a helix whose axis tilts by 20 deg), so only the
    sample-by-sample sweep gives the same joints. With a fixed tool axis (every feedopt run)
    or a 6-DoF task the solution does not depend on it (agreement within the tolerances,
    tests/robot/test_ik_batch.py)."""
    if task.n < 3:
        return 1
    if not task.six_dof and np.ptp(task.tool_axes, axis=0).max() > 1e-12:
        return 1
    d = np.diff(task.positions, axis=0)
    chord = np.sqrt(np.einsum("ij,ij->i", d, d))
    h = float(np.median(chord))
    if not (h > 0 and np.all(chord > 0)):  # repeated positions: no chord-length parameter
        return 1
    return max(1, int(options.sweep_spacing / h * (1 + 1e-9)))


def _swept_samples(n: int, stride: int) -> np.ndarray:
    """Indices the sweep visits: every ``stride``-th sample and the last one."""
    visit = np.arange(0, n, stride)
    return visit if visit[-1] == n - 1 else np.append(visit, n - 1)


def _seeds_between(task: _Task, visit: np.ndarray, q_swept: np.ndarray) -> np.ndarray:
    """Seeds (n, dof) of every sample: the swept solutions at ``visit``, a not-a-knot cubic
    spline through them (chord-length parameter) in between."""
    from scipy.interpolate import CubicSpline

    d = np.diff(task.positions, axis=0)
    u = np.concatenate([[0.0], np.cumsum(np.sqrt(np.einsum("ij,ij->i", d, d)))])
    seeds = CubicSpline(u[visit], q_swept, axis=0)(u)
    seeds[visit] = q_swept
    return seeds


# --------------------------------------------------------------------------- whole path


def _path_errors(task: _Task, rot: np.ndarray, pos: np.ndarray):
    """Position errors (n, 3) [m] and rotation vectors (n, 3) [rad] of every sample."""
    ep = task.positions - pos
    if task.six_dof:
        ew = _log3_batch(task.rotations @ np.swapaxes(rot, 1, 2))
    else:
        ew = _axis_error_batch(rot[:, :, 2], task.tool_axes, task.normals)
    return ep, ew


def _batch_newton_steps(
    task: _Task,
    jac: np.ndarray,
    ep: np.ndarray,
    ew: np.ndarray,
    damping_eye: np.ndarray,
    max_step: float,
    winv: np.ndarray,
) -> np.ndarray:
    """Damped Newton steps (m, dof) of every sample of ``task`` (as :func:`_damped_newton_step`)
    from their Jacobians (m, 6, dof) and errors (m, 3)."""
    if task.six_dof:
        jt_b, e_b = jac, np.concatenate([ep, ew], axis=1)
    else:
        bt = np.swapaxes(task.normals, 1, 2)  # (m, 2, 3)
        jt_b = np.concatenate([jac[:, :3], bt @ jac[:, 3:]], axis=1)
        e_b = np.concatenate([ep, np.einsum("mij,mj->mi", bt, ew)], axis=1)
    a = (jt_b * winv) @ np.swapaxes(jt_b, 1, 2) + damping_eye
    dq = winv * np.einsum("mji,mj->mi", jt_b, np.linalg.solve(a, e_b[..., None])[..., 0])
    big = np.abs(dq).max(axis=1, keepdims=True)
    dq *= np.minimum(1.0, max_step / np.maximum(big, 1e-300))
    return dq


def _refine(
    kin: _TcpKinematics, task: _Task, q: np.ndarray, options: IKOptions,
    jacobian_out: np.ndarray | None = None, progress: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched refinement of ``q`` (n, dof) in place, by chunks of samples: pinocchio per
    configuration, errors and Newton steps vectorised, until every sample is within the
    tolerances; each pass evaluates only the samples still above them.

    With two chunks or more, the second half of the chunks is refined in a forked child
    process (:mod:`feedopt.background`; the pinocchio loop holds the GIL, so threads would
    not help) while this process refines the first: every sample is refined alone, so the
    result is the same bit for bit.

    Returns the position [m] and orientation [rad] errors (n,) and the Jacobian condition
    numbers (n,) of the last evaluation; fills ``jacobian_out`` (n, 6, dof) with its TCP
    Jacobians when given. ``progress(samples_done)`` after each chunk.
    """
    from feedopt import background

    n = q.shape[0]
    pos_err, ang_err, cond = np.empty(n), np.empty(n), np.empty(n)
    out = (q, pos_err, ang_err, cond, jacobian_out)
    starts = range(0, n, _CHUNK)
    if len(starts) < 2 or not background.fork_available():
        _refine_rows(kin, task, options, out, 0, n, progress)
        return pos_err, ang_err, cond
    split = starts[(len(starts) + 1) // 2]

    def second_half() -> tuple[np.ndarray | None, ...]:
        _refine_rows(kin, task, options, out, split, n, None)
        return tuple(None if a is None else a[split:] for a in out)

    child = background.start(second_half, "refining the path IK")
    try:
        _refine_rows(kin, task, options, out, 0, split, progress)
    except BaseException:
        child.join(cancel=True)
        raise
    for mine, theirs in zip(out, child.join(reraise=True), strict=True):
        if mine is not None:
            mine[split:] = theirs
    if progress is not None:
        progress(n)
    return pos_err, ang_err, cond


def _refine_rows(
    kin: _TcpKinematics, task: _Task, options: IKOptions,
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None],
    first: int, stop: int, progress: Callable[[int], None] | None,
) -> None:
    """:func:`_refine` of the samples ``first`` .. ``stop`` (chunk by chunk), into ``out`` =
    (q, position errors, orientation errors, condition numbers, Jacobians or None)."""
    q, pos_err, ang_err, cond, jacobian_out = out
    dof = q.shape[1]
    damping_eye = np.eye(task.size) * options.damping
    for start in range(first, stop, _CHUNK):
        rows = np.arange(start, min(start + _CHUNK, stop))
        sub = _sub_task(task, rows)
        qc = q[rows]  # a copy, written back below
        pose, jac = np.empty((rows.size, 4, 4)), np.empty((rows.size, 6, dof))
        todo = np.arange(rows.size)
        for _ in range(options.max_iterations + 1):
            kin.evaluate_rows(qc, todo, pose, jac)
            ep, ew = _path_errors(_sub_task(sub, todo), pose[todo, :3, :3], pose[todo, :3, 3])
            pos_err[rows[todo]] = np.linalg.norm(ep, axis=1)
            ang_err[rows[todo]] = np.linalg.norm(ew, axis=1)
            above = ((pos_err[rows[todo]] > options.tol_position)
                     | (ang_err[rows[todo]] > options.tol_angle))
            if not above.any():
                break
            todo, ep, ew = todo[above], ep[above], ew[above]
            qc[todo] += _batch_newton_steps(_sub_task(sub, todo), jac[todo], ep, ew,
                                            damping_eye, options.max_newton_step, kin.winv)
        q[rows] = qc
        cond[rows] = jacobian_condition_number(jac, options.condition_length)
        if jacobian_out is not None:
            jacobian_out[rows] = jac
        if progress is not None:
            progress(int(rows[-1]) + 1)


def _sub_task(task: _Task, rows: np.ndarray) -> _Task:
    """The targets of the samples ``rows`` only."""
    return _Task(
        positions=task.positions[rows], tool_axes=task.tool_axes[rows],
        rotations=None if task.rotations is None else task.rotations[rows],
        normals=None if task.normals is None else task.normals[rows], q_start=task.q_start,
    )


def solve_path_ik(
    robot: RobotModel,
    positions: np.ndarray,
    tool_axes: np.ndarray,
    q_start: np.ndarray,
    x_axes: np.ndarray | None = None,
    options: IKOptions | None = None,
    jacobians: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> PathIK:
    """Joint configurations placing the TCP on ``positions`` with its +z on ``tool_axes``.

    Phases: validate the task; sequential sweep (seed from the previous samples, damped
    Newton to a coarse tolerance) over every sample, or every k-th one on paths sampled finer
    than ``options.sweep_spacing`` (the others seeded by a spline through them); batched
    refinement to the final tolerance; convergence check; path checks (joint limits, joint
    jumps = branch flips, near-singular poses).

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
    options : IKOptions or None
        Tolerances, iteration counts and path-check limits; ``None``: ``IKOptions()``.
    jacobians : bool
        Also return the TCP Jacobians at the solution (``PathIK.jacobian``).
    progress : callable or None
        ``progress(done, total)`` now and then (units of work: swept plus refined samples).

    Raises
    ------
    InputError
        Naming the first sample (index and pose) that is unreachable, violates a joint limit,
        jumps (branch flip) or is near-singular.
    """
    options = IKOptions() if options is None else options
    task = _validate_task(robot, positions, tool_axes, q_start, x_axes)
    kin = _TcpKinematics(robot, options.held_joint)
    jac = np.empty((task.n, 6, robot.dof)) if jacobians else None
    stride = _sweep_stride(task, options)
    solved = None
    if stride > 1:
        try:
            solved = _solve_strided(kin, task, options, stride, jac, progress)
        except InputError:  # the strided sweep lost the path: sample by sample says where
            solved = None
    if solved is None:
        solved = _solve_strided(kin, task, options, 1, jac, progress)
    q, pos_err, ang_err, cond = solved
    _check_converged(task, q, pos_err, ang_err, options)
    _check_path(robot, task, q, cond, options)
    return PathIK(q=q, condition_number=cond, position_error=pos_err, axis_error=ang_err,
                  jacobian=jac)


def _solve_strided(
    kin: _TcpKinematics, task: _Task, options: IKOptions, stride: int,
    jac: np.ndarray | None, progress: Callable[[int, int], None] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Sweep every ``stride``-th sample, seed the others from the spline through them, refine
    all: ``(q, position errors, orientation errors, condition numbers)``, or None when the
    refinement moved a sample by more than a branch flip (``max_joint_step``) from its seed
    (it left the swept branch)."""
    visit = _swept_samples(task.n, stride)
    total = visit.size + task.n  # units of work: swept, then refined samples
    q_swept = _sweep(kin, task, options, visit, _offset(progress, 0, total))
    q = q_swept if stride == 1 else _seeds_between(task, visit, q_swept)
    if options.held_joint is not None:  # the spline through a constant, exactly
        q[:, options.held_joint] = task.q_start[options.held_joint]
    seeds = None if stride == 1 else q.copy()
    pos_err, ang_err, cond = _refine(kin, task, q, options, jac,
                                     _offset(progress, visit.size, total))
    if seeds is not None and not np.abs(q - seeds).max() <= options.max_joint_step:
        return None
    return q, pos_err, ang_err, cond


def _offset(
    progress: Callable[[int, int], None] | None, base: int, total: int
) -> Callable[[int], None] | None:
    """``done -> progress(base + done, total)`` (None without a progress callback)."""
    if progress is None:
        return None
    return lambda done: progress(base + done, total)


# --------------------------------------------------------------------------- checks


def _describe(k: int, position: np.ndarray, axis: np.ndarray) -> str:
    p = np.asarray(position) / MM
    return (
        f"sample {k} (TCP x={p[0]:.3f}, y={p[1]:.3f}, z={p[2]:.3f} mm, tool axis "
        f"[{axis[0]:.4f}, {axis[1]:.4f}, {axis[2]:.4f}])"
    )


class UnreachableError(InputError):
    """A path sample the IK cannot reach (Newton did not converge): bad input, exit 2; the
    runner may add a workpiece position that does reach the path."""


def _unreachable(task: _Task, k: int, position_error: float, angle_error: float
                 ) -> UnreachableError:
    return UnreachableError(
        f"IK: {_describe(k, task.positions[k], task.tool_axes[k])} is unreachable: Newton did "
        f"not converge (residual {position_error / MM:.3g} mm, {np.rad2deg(angle_error):.3g} "
        "deg); move the workpiece closer to the robot or change q_start"
    )


def _check_converged(
    task: _Task, q: np.ndarray, pos_err: np.ndarray, ang_err: np.ndarray, options: IKOptions
) -> None:
    """Raise for the first sample whose residual exceeds the failure limits (or q is NaN)."""
    bad = np.flatnonzero(
        (pos_err > options.fail_position) | (ang_err > options.fail_angle)
        | ~np.isfinite(q).all(axis=1)
    )
    if bad.size:
        k = int(bad[0])
        raise _unreachable(task, k, pos_err[k], ang_err[k])


def _outside_limits(robot: RobotModel, q: np.ndarray, tol: float = 1e-9):
    """Joints below (n, dof) and above (n, dof) their position limits (beyond ``tol`` rad)."""
    return q < robot.q_lower - tol, q > robot.q_upper + tol


def _joint_steps(q: np.ndarray) -> np.ndarray:
    """|q_k - q_(k-1)| (n, dof) per joint, zero for the first sample."""
    steps = np.zeros(q.shape)
    if q.shape[0] > 1:
        steps[1:] = np.abs(np.diff(q, axis=0))
    return steps


def _check_path(
    robot: RobotModel, task: _Task, q: np.ndarray, cond: np.ndarray, options: IKOptions
) -> None:
    """Raise InputError for the earliest sample with a limit, jump or singularity problem."""
    below, above = _outside_limits(robot, q)
    steps = _joint_steps(q)
    limit_bad = np.any(below | above, axis=1)
    jump = np.any(steps > options.max_joint_step, axis=1)
    singular = ~(cond <= options.max_condition)
    bad = np.flatnonzero(limit_bad | jump | singular)
    if not bad.size:
        return
    k = int(bad[0])
    problems = []
    if singular[k]:
        problems.append(f"near-singular pose (Jacobian condition number {cond[k]:.1f} > "
                        f"{options.max_condition:g})")
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
            f"(> {np.rad2deg(options.max_joint_step):.3f} deg: branch flip or path too coarse)"
        )
    q_deg = ", ".join(f"{v:.2f}" for v in np.rad2deg(q[k]))
    raise InputError(
        f"IK: {_describe(k, task.positions[k], task.tool_axes[k])}: " + "; ".join(problems)
        + f" at q = [{q_deg}] deg. Move the workpiece, change the start configuration or the "
        "tool axis so the path stays away from it"
    )
