"""The robot stage along a sampled path: joint path, compliance and q(s), in one call.

What the runner needs from the robot for a path sampled at arc lengths ``s``: the joint path
(:func:`feedopt.robot.ik.solve_path_ik`), the translational TCP compliance at every sample
(thesis Eq. 3.19, DPP Eq. 3.20; the complementary stiffness of Eq. 3.18 is neglected, thesis
3.4) and the joints as a cubic spline in ``s`` with its first two derivatives at the samples
(for the joint-velocity bound and the joint limits of the timing laws).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions, PathIK, solve_path_ik
from feedopt.robot.model import RobotModel
from feedopt.robot.stiffness import compliance_from_jacobians, joint_stiffness

# Samples per block when the compliance is formed from the IK's Jacobians (bounds the
# (block, 6, 6) intermediate of Eq. 3.19).
_BLOCK = 1 << 16


@dataclass(frozen=True)
class RobotAlongPath:
    """The robot along a sampled path (SI units, base frame).

    Attributes
    ----------
    ik : PathIK
        Joint path ``ik.q`` (n, dof) [rad] with condition numbers and residuals per sample.
    compliance : (n, 3, 3) array
        Translational TCP compliance [m/N]: deflection per force on the tool at the TCP,
        ``C = (J K^-1 J^T)[:3, :3]`` (Eq. 3.19; Eq. 3.20 with the DPP set).
    q_of_s : CubicSpline or PPoly
        ``q(s)`` through the samples (axis 0; not-a-knot ends; one spline per piece between
        stops, :func:`joint_spline`) [rad] of arc length [m].
    dq_ds, d2q_ds2 : (n, dof) arrays
        ``q'(s)`` [rad/m] and ``q''(s)`` [rad/m^2] of ``q_of_s`` at the samples.
    warnings : tuple of str
        The robot's data warnings (``robot.yaml`` ``warnings:``), each prefixed with
        ``robot <name>: `` as the run reports them.
    """

    ik: PathIK
    compliance: np.ndarray
    q_of_s: PPoly
    dq_ds: np.ndarray
    d2q_ds2: np.ndarray
    warnings: tuple[str, ...] = ()

    @property
    def q(self) -> np.ndarray:
        """Joint configurations (n, dof) [rad] (``ik.q``)."""
        return self.ik.q

    @property
    def max_condition_number(self) -> float:
        """Largest Jacobian condition number along the path (1 m length scale)."""
        return float(np.max(self.ik.condition_number))


def _arc_lengths(s: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """``s`` as strictly increasing finite arc lengths, one per position, or InputError."""
    s = np.asarray(s, dtype=float)
    n = np.shape(positions)[0] if np.ndim(positions) == 2 else s.size  # else: IK refuses
    if s.shape != (n,):
        raise InputError(f"s must have shape ({n},) like positions, got {s.shape}")
    if n < 2:
        raise InputError(f"the path needs at least 2 samples for q(s), got {n}")
    if not np.all(np.isfinite(s)) or np.any(np.diff(s) <= 0):
        bad = np.flatnonzero(~np.isfinite(s))
        k = int(bad[0]) if bad.size else int(np.flatnonzero(np.diff(s) <= 0)[0]) + 1
        raise InputError(f"s must be finite and strictly increasing; sample {k} is not "
                         f"(s = {s[k]!r})")
    return s


def _translational_compliance(jacobians: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The (n, 3, 3) translational block of ``J K^-1 J^T`` (Eq. 3.19; Eq. 3.20 with the DPP
    set), block by block: bit for bit
    :func:`feedopt.robot.stiffness.translational_compliance` of the same configurations,
    without a second Jacobian pass or a kept (n, 6, 6) array."""
    n = jacobians.shape[0]
    out = np.empty((n, 3, 3))
    for start in range(0, n, _BLOCK):
        block = slice(start, start + _BLOCK)
        out[block] = compliance_from_jacobians(jacobians[block], k)[:, :3, :3]
    return out


def joint_spline(s: np.ndarray, q: np.ndarray, breaks: np.ndarray | None = None) -> PPoly:
    """``q(s)`` as a cubic spline through the samples (not-a-knot ends), one per piece
    between the ``breaks`` (interior sample indices where the path may have a corner: a stop),
    joined into one piecewise polynomial: continuous there, its derivatives one-sided (the
    following piece's at the break itself). Without breaks: one :class:`CubicSpline`."""
    if breaks is None or len(breaks) == 0:
        return CubicSpline(s, q, axis=0)
    edges = np.unique(np.concatenate([[0], np.asarray(breaks, dtype=int), [s.size - 1]]))
    parts = [CubicSpline(s[a:b + 1], q[a:b + 1], axis=0) for a, b in zip(edges[:-1], edges[1:],
                                                                         strict=True)]
    return PPoly(np.concatenate([p.c for p in parts], axis=1), s, extrapolate=True)


@dataclass(frozen=True)
class TcpPath:
    """What the TCP must do along a sampled path (SI units, base frame).

    Attributes
    ----------
    s : (n,) array
        Arc length of the samples [m], strictly increasing.
    positions : (n, 3) array
        TCP positions [m].
    tool_axes : (n, 3) array
        Tool axes (TCP +z, from the tool tip into the spindle).
    x_axes : (n, 3) array or None
        TCP +x directions (6-DoF task); ``None``: rotation about the tool axis free (5-DoF).
    breaks : (k,) int array or None
        Interior sample indices where the path stops and may turn (a corner, a reversal):
        ``q(s)`` is one cubic spline per piece between them (:func:`joint_spline`).
    """

    s: np.ndarray
    positions: np.ndarray
    tool_axes: np.ndarray
    x_axes: np.ndarray | None = None
    breaks: np.ndarray | None = None


def robot_along_path(
    robot: RobotModel,
    path: TcpPath,
    q_start: np.ndarray,
    stiffness_set: str | np.ndarray,
    ik_options: IKOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> RobotAlongPath:
    """Solve the robot stage along a sampled path.

    Parameters
    ----------
    robot : RobotModel
    path : TcpPath
        The samples, TCP positions, tool axes (and x axes, stops) to follow.
    q_start : (dof,) array
        Start configuration [rad]; seeds the IK of the first sample.
    stiffness_set : str or (dof,) array
        Joint stiffness set name (``"cp"``, ``"dpp"``) or values [N m/rad].
    ik_options : IKOptions or None
        IK tunables; ``None``: the defaults.
    progress : callable or None
        ``progress(done, total)`` during the IK (:func:`~feedopt.robot.ik.solve_path_ik`).

    Returns
    -------
    RobotAlongPath

    Raises
    ------
    InputError
        Bad shapes or arc lengths, an unknown stiffness set, or a path sample the IK refuses
        (unreachable, joint limit, branch flip, near-singular; named by index and pose).
    """
    s = _arc_lengths(path.s, path.positions)
    k = joint_stiffness(robot, stiffness_set)
    ik = solve_path_ik(robot, path.positions, path.tool_axes, q_start, x_axes=path.x_axes,
                       options=ik_options, jacobians=True, progress=progress)
    compliance = _translational_compliance(ik.jacobian, k)
    ik = replace(ik, jacobian=None)  # (n, 6, dof): not kept
    q_of_s = joint_spline(s, ik.q, path.breaks)
    return RobotAlongPath(
        ik=ik,
        compliance=compliance,
        q_of_s=q_of_s,
        dq_ds=q_of_s(s, 1),
        d2q_ds2=q_of_s(s, 2),
        warnings=tuple(f"robot {robot.name}: {w}" for w in robot.data_warnings),
    )
