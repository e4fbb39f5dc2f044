"""The free rotation about the tool axis: a smooth profile psi(s) that makes the robot stiff
where the force is (issue 14, "Redundancy").

Milling is a 5-DoF task: the rotation of the spindle about its own axis does not change the
cut, and a 6-axis robot has one degree of freedom left over (thesis 1.1, ref. [13]). The robot
stage takes the nearest IK solution (:func:`feedopt.robot.ik.solve_path_ik`, minimum-norm
steps). Here the TCP x axis is turned about the tool axis by psi(s) relative to that
solution's x axes, so ``psi = 0`` is today's result, and psi(s) is chosen to minimise

* ``"time"``: T* = integral ds / v_max(s) (:meth:`ScheduleProblem.lower_bound_time`), the
  lower bound on the cycle time of every law under the feed bound; or
* ``"deflection"``: the largest deflection along the path at the nominal feed (the
  program's feeds for a G-code path), :meth:`DeflectionModel.deflection`,

over a natural cubic spline psi(s) through a few equally spaced knots (6-12: one or two per
path feature such as a line of the thesis's triangle wave, where the force direction turns;
each knot costs one line search of the optimiser, 10-20 IK + bound evaluations, so 12 knots
keep a search at a few hundred evaluations).

This is the stiffness-oriented posture optimisation of robotic machining (Lin, Zhao and
Ding 2017, *Posture optimization methodology of 6R industrial robots for machining using
performance evaluation indexes*, RCIM 48; Xiong, Ding and Zhu 2019, *Stiffness-based pose
optimization of an industrial robot for five-axis milling*, RCIM 55), with two differences:
the criterion is the time the feed bound allows (or the deflection), not a stiffness index
per cutter location, and the redundancy is one smooth spline over the whole path rather
than a pose per point, so the joints stay smooth and the timing laws see a C2 joint path.
The search is derivative-free (T* is a minimum of piecewise-smooth bounds, and refused
profiles are steps): a scan of constant offsets, then Powell's conjugate-direction method
(Powell 1964; :func:`scipy.optimize.minimize` ``method="Powell"``, initial directions of
``step`` along each knot, so its line searches start near the current profile; knots
clipped to +-psi_max) from the best of them, on a coarse resampling of the path (the
caller's ``search`` task, e.g. 1 mm), verified at full resolution at the end (the caller's
``final`` task). Profiles the IK refuses (unreachable, joint limits, branch flips,
near-singular poses: :class:`feedopt.robot.ik.IKOptions` ``max_condition``), that come
within ``limit_margin`` of a joint limit on the search samples, or whose joint
accelerations in the worst case exceed their share of the limits score a penalty; they
never stop the search. The result is never worse than the nearest IK: if the full
resolution does not confirm the gain, the nearest solution is kept and the reason given.

Where the tool axis is the last joint's axis through the TCP (a spindle coaxial with A6, as
on both bundled robots), turning about it turns that joint alone: q1..q5, the translational
compliance and the feed bound do not change, and there is nothing to choose
(:func:`turns_last_joint_only`, status ``LAST_JOINT``, today's robot stage returned as is).
The redundancy matters for a spindle mounted off the A6 axis (e.g. at 90 deg on a bracket).

The start configuration: a 6-DoF IK from the user's start configuration could land on another
branch (wrist or elbow flip) when psi(0) is far from 0, so the first sample is reached by
turning its x axis from psi = 0 to psi(0) in steps of 1 deg, each warm-started from the
previous one (:func:`start_configuration`): the branch is the nearest solution's by
continuity, and the IK's jump and singularity checks guard every step.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import RobotModel, forward_kinematics, tcp_jacobians
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.schedule.stage import ScheduleInputs
from feedopt.units import MM

OBJECTIVES = ("time", "deflection")
#: Step of the start-configuration sweep about the tool axis [rad].
_START_STEP = np.deg2rad(1.0)


@dataclass(frozen=True)
class RedundancyOptions:
    """Tunables of :func:`optimise_redundancy`.

    Attributes
    ----------
    objective : str
        ``"time"`` (T*) or ``"deflection"`` (max deflection at the nominal feed).
    knots : int or None
        Knots of the psi spline; ``None``: ``round(L / knot_spacing) + 1`` within
        [``min_knots``, ``max_knots``] (L the path length).
    knot_spacing : float
        Path length per knot [m] when ``knots`` is None.
    min_knots, max_knots : int
        Range of the automatic knot count.
    psi_max : float
        Bound on every knot value, |psi| <= psi_max [rad] (pi: any rotation).
    scan_step : float
        Constant offsets tried before the local search, every ``scan_step`` [rad] over
        (-pi, pi] (0: no scan, start from psi = 0).
    max_evaluations : int
        Objective evaluations (IK + bound on the search samples) allowed in the search.
    xtol : float
        Powell's tolerance on the knot values [rad].
    ftol : float
        Powell's relative tolerance on the objective.
    joint_acceleration_share : float
        Share of each joint's acceleration limit that the worst case of
        ``qdd = q''(s) v^2 + q'(s) a`` may take, with v = v_max(s) and |a| = the tangential
        acceleration limit (:func:`acceleration_shares`): within it every law, also those
        that do not bound joint accelerations themselves (``thesis``, ``constant``), keeps
        the joints within their limits. Where the nearest solution already takes more (a
        program's rapids, whose v_max is only a cap), about as much as it
        (``acceleration_margin``).
    path_acceleration : bool
        Count the path acceleration term ``|q'| a`` (default). False bounds only the
        velocity term: profiles may then turn faster, and the laws that bound joint
        accelerations (``topp``, ``convex``, ``jerk``) ramp more gently where they do,
        while ``thesis`` and ``constant`` may break the joint limits (their replay says so).
    penalty : float
        Objective of a profile the IK refuses, in units of the nearest solution's objective.
    min_gain : float
        Smallest relative improvement of the objective that counts (below it, rounding).
    step : float
        Powell's initial step along each knot [rad] (its line searches bracket from there).
    limit_margin : float
        On the search samples the joints must stay this far inside their position limits
        [rad]: the optimum often presses a joint against its limit, and the samples between
        the search samples must not cross it.
    acceleration_margin : float
        Likewise, on the search samples the acceleration share must stay below
        ``(1 - acceleration_margin)`` of ``joint_acceleration_share`` (q' and q'' of the
        joint spline through the coarse samples differ a little from the full resolution's).
        Where the nearest solution already takes more (the laws slow down there anyway:
        a program's rapids and air moves), a profile may take ``(1 + acceleration_margin)``
        of its share on the search samples, ``(1 + 2 acceleration_margin)`` at full
        resolution (a slow-down at most ~5 % deeper on those samples).
    backtrack : tuple of float
        Scales of the best knots tried at full resolution, in order, until one is accepted
        (samples the search did not see can refuse the profile; a smaller rotation is
        closer to the nearest solution, which they accept).
    """

    objective: str = "time"
    knots: int | None = None
    knot_spacing: float = 0.05
    min_knots: int = 6
    max_knots: int = 12
    psi_max: float = float(np.pi)
    scan_step: float = float(np.deg2rad(30.0))
    max_evaluations: int = 400
    xtol: float = 1e-2
    ftol: float = 1e-4
    joint_acceleration_share: float = 1.0
    path_acceleration: bool = True
    penalty: float = 10.0
    min_gain: float = 1e-4
    step: float = 0.2
    limit_margin: float = float(np.deg2rad(0.5))
    acceleration_margin: float = 0.05
    backtrack: tuple[float, ...] = (1.0, 0.75, 0.5, 0.25)

    def __post_init__(self) -> None:
        where = "robot.redundancy_options."

        def refuse(name: str, what: str) -> None:
            raise InputError(f"{where}{name} must be {what}, got {getattr(self, name)!r}")

        if self.objective not in OBJECTIVES:
            refuse("objective", f"one of {', '.join(OBJECTIVES)}")
        if self.knots is not None and self.knots < 2:
            refuse("knots", ">= 2")
        if not 2 <= self.min_knots <= self.max_knots:
            refuse("min_knots", f">= 2 and <= max_knots ({self.max_knots})")
        for name in ("knot_spacing", "psi_max", "xtol", "ftol", "penalty", "min_gain",
                     "step"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                refuse(name, "a finite number > 0")
        for name in ("limit_margin", "scan_step"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                refuse(name, "a finite number >= 0")
        if not 0 <= self.acceleration_margin < 1:
            refuse("acceleration_margin", "in [0, 1)")
        if not 0 < self.joint_acceleration_share <= 1:
            refuse("joint_acceleration_share", "in (0, 1]")
        if not self.backtrack or not all(0 < b <= 1 for b in self.backtrack):
            refuse("backtrack", "scales in (0, 1]")
        if self.max_evaluations < 1:
            refuse("max_evaluations", ">= 1")

    def knot_count(self, length: float) -> int:
        """Knots of the psi spline on a path of ``length`` [m]."""
        if self.knots is not None:
            return int(self.knots)
        return int(np.clip(round(length / self.knot_spacing) + 1, self.min_knots,
                           self.max_knots))


@dataclass(frozen=True, eq=False)
class RedundancyTask:
    """One sampling of the path, with what the objective needs on it.

    Attributes
    ----------
    s : (n,) array
        Arc length of the samples [m].
    positions, tool_axes : (n, 3) arrays
        TCP positions [m] and tool axes in the base frame.
    bound_of : callable
        ``bound_of(along) -> ScheduleInputs``: the feed bound and problem on these samples for
        the robot stage ``along`` (the runner's ``schedule_problem`` with the rest fixed).
    nearest : RobotAlongPath
        Today's robot stage on these samples (5-DoF nearest IK): psi = 0, and the reference.
    """

    s: np.ndarray
    positions: np.ndarray
    tool_axes: np.ndarray
    bound_of: Callable[[RobotAlongPath], ScheduleInputs]
    nearest: RobotAlongPath


class RedundancyStatus(Enum):
    """What :func:`optimise_redundancy` did."""

    IMPROVED = "improved"  # the profile lowers the objective at full resolution
    LAST_JOINT = "last_joint"  # the tool axis is the last joint's axis: nothing to choose
    NO_GAIN = "no_gain"  # the search found nothing better than the nearest IK
    NOT_CONFIRMED = "not_confirmed"  # better on the search samples, not at full resolution


@dataclass(frozen=True)
class ProfileEvaluation:
    """The robot stage and the bound for one redundancy profile on one sampling.

    Attributes
    ----------
    psi : (n,) array
        Rotation about the tool axis relative to the nearest IK [rad].
    x_axes : (n, 3) array
        TCP x axes handed to :func:`robot_along_path` (6-DoF task).
    q_start : (dof,) array
        Start configuration of that call (:func:`start_configuration`).
    along : RobotAlongPath
    schedule : ScheduleInputs
    t_star : float
        T* [s] of ``schedule.problem``.
    max_deflection : float
        Largest deflection at the nominal feed [m] (only for the ``"deflection"`` objective,
        else nan).
    acceleration_shares : (n,) array
        Share of the most loaded joint's acceleration limit the worst case takes, per
        sample (:func:`acceleration_shares`).
    """

    psi: np.ndarray
    x_axes: np.ndarray
    q_start: np.ndarray
    along: RobotAlongPath
    schedule: ScheduleInputs
    t_star: float
    max_deflection: float
    acceleration_shares: np.ndarray

    @property
    def acceleration_share(self) -> float:
        """The largest of :attr:`acceleration_shares`."""
        return float(np.max(self.acceleration_shares))


@dataclass(frozen=True)
class RedundancyResult:
    """A redundancy profile psi(s) and what it gains (SI units, radians).

    Attributes
    ----------
    status : RedundancyStatus
    reason : str
        Why the nearest IK was kept, or why larger scales of the best profile were refused
        (empty when the best profile itself was accepted).
    objective : str
        ``"time"`` or ``"deflection"``.
    knot_s, knot_psi : (k,) arrays
        Spline knots [m] and values [rad] (zeros unless improved).
    s, psi : (n,) arrays
        Full-resolution samples [m] and psi(s) there [rad].
    x_axes : (n, 3) array or None
        TCP x axes for :func:`robot_along_path` (None: keep the nearest IK, 5-DoF).
    q_start : (dof,) array or None
        Its start configuration (None with ``x_axes``).
    along : RobotAlongPath
        The robot stage to plan with (the nearest one itself unless improved).
    schedule : ScheduleInputs
        The bound and problem on it.
    t_star_nearest, t_star : float
        T* [s] at full resolution with the nearest IK and with ``along``.
    objective_nearest, objective_value : float
        The objective at full resolution [s or m], nearest and chosen.
    search_nearest, search_best : float
        The objective on the search samples, nearest and best found.
    acceleration_share_nearest, acceleration_share : float
        The largest of :func:`acceleration_shares` at full resolution, nearest and chosen.
    iterations, evaluations, infeasible : int
        Powell iterations, objective evaluations (scan included) and those refused (by
        the IK, the joint-limit margin or the acceleration share).
    seconds : float
        Wall time of the whole optimisation [s].
    scale : float
        The scale of the search's best knots accepted at full resolution
        (:attr:`RedundancyOptions.backtrack`; 0 when the nearest IK is kept).
    """

    status: RedundancyStatus
    reason: str
    objective: str
    knot_s: np.ndarray
    knot_psi: np.ndarray
    s: np.ndarray
    psi: np.ndarray
    x_axes: np.ndarray | None
    q_start: np.ndarray | None
    along: RobotAlongPath
    schedule: ScheduleInputs
    t_star_nearest: float
    t_star: float
    objective_nearest: float
    objective_value: float
    search_nearest: float
    search_best: float
    acceleration_share_nearest: float
    acceleration_share: float
    iterations: int
    evaluations: int
    infeasible: int
    seconds: float
    scale: float = 0.0

    @property
    def gain(self) -> float:
        """Relative reduction of T*, ``1 - t_star / t_star_nearest``."""
        return 1.0 - self.t_star / self.t_star_nearest

    def describe(self) -> str:
        """One progress line."""
        return (f"{self.status.value}: T* {self.t_star_nearest:.2f} s nearest -> "
                f"{self.t_star:.2f} s ({self.gain:.2%}), psi {np.degrees(self.psi.min()):.1f}.."
                f"{np.degrees(self.psi.max()):.1f} deg, {self.evaluations} evaluations "
                f"({self.seconds:.2f} s)" + (f"; {self.reason}" if self.reason else ""))


# --------------------------------------------------------------------------- geometry


def x_axes_of(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """TCP x axes (n, 3) in the base frame of configurations ``q`` (n, dof) (forward
    kinematics): the psi = 0 reference of a joint path."""
    return forward_kinematics(robot, q)[:, :3, 0]


def rotate_about_axes(x_axes: np.ndarray, tool_axes: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """``x`` turned by ``psi`` (n,) [rad] about the unit tool axes ``z`` (right hand):
    ``cos psi x + sin psi (z x x)`` (Rodrigues' formula for x normal to z; the component of x
    along z, at most the IK's tolerance, is removed first)."""
    z = np.asarray(tool_axes, dtype=float)
    x = np.asarray(x_axes, dtype=float)
    x = x - np.einsum("ij,ij->i", x, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    psi = np.asarray(psi, dtype=float)[:, None]
    return np.cos(psi) * x + np.sin(psi) * np.cross(z, x)


def knot_positions(length: float, count: int) -> np.ndarray:
    """``count`` equally spaced knots over [0, length] [m]."""
    return np.linspace(0.0, length, count)


def psi_profile(knot_s: np.ndarray, knot_psi: np.ndarray) -> CubicSpline:
    """psi(s) [rad]: the natural cubic spline through the knots (C2, so the joint path and
    its q'(s), q''(s) stay smooth)."""
    return CubicSpline(knot_s, knot_psi, bc_type="natural")


def start_configuration(
    robot: RobotModel,
    position: np.ndarray,
    tool_axis: np.ndarray,
    x_axis: np.ndarray,
    q_nearest: np.ndarray,
    psi: float,
    ik_options: IKOptions | None = None,
) -> np.ndarray:
    """Configuration (dof,) at the first sample with the TCP x axis turned by ``psi`` from
    ``x_axis`` (the nearest solution's, at ``q_nearest``), reached by turning in steps of
    1 deg (each IK warm-started from the previous step), so that it is on the nearest
    solution's branch. InputError from the IK if a step is refused (limit, flip, singular)."""
    steps = max(1, int(np.ceil(abs(psi) / _START_STEP))) + 1
    angles = np.linspace(0.0, psi, steps)
    x = rotate_about_axes(np.broadcast_to(x_axis, (steps, 3)),
                          np.broadcast_to(tool_axis, (steps, 3)), angles)
    ik = solve_path_ik(robot, np.broadcast_to(position, (steps, 3)).copy(),
                       np.broadcast_to(tool_axis, (steps, 3)).copy(), q_nearest, x_axes=x,
                       options=ik_options)
    return ik.q[-1]


def acceleration_shares(schedule: ScheduleInputs, path_acceleration: bool = True) -> np.ndarray:
    """Per sample (n,), the largest share of a joint's acceleration limit taken by the worst
    case of ``qdd = q''(s) v^2 + q'(s) a`` at the bound feed v = v_max(s) and |a| = the
    tangential acceleration limit: ``max_j (|q''_j| v_max^2 + |q'_j| a_max) / qdd_max_j``
    (1: the whole limit). ``path_acceleration=False``: the velocity term only; so is an
    infinite tangential limit. Samples with an infinite bound (uncapped rapids) count as 0."""
    problem = schedule.problem
    v = np.where(np.isfinite(problem.v_max), problem.v_max, 0.0)
    qdd = np.abs(problem.d2q_ds2) * (v * v)[:, None]
    if path_acceleration and np.isfinite(problem.accel_max):
        qdd = qdd + np.abs(problem.dq_ds) * problem.accel_max
    return np.max(qdd / problem.joint_acceleration_max, axis=1)


def allowed_shares(nearest: np.ndarray, share: float, margin: float,
                   search: bool) -> np.ndarray:
    """Per sample, the acceleration share a profile may take (:class:`RedundancyOptions`
    ``joint_acceleration_share``, ``acceleration_margin``): ``share`` (less the margin on the
    search samples) or, where the nearest solution takes more (``nearest``, per sample), a
    little more than that (one margin on the search samples, two at full resolution)."""
    if search:
        return np.maximum((1.0 - margin) * share, (1.0 + margin) * nearest)
    return np.maximum(share, (1.0 + 2.0 * margin) * nearest)


def max_deflection_at_nominal(schedule: ScheduleInputs) -> float:
    """Largest deflection [m] along the path at the nominal feed (a program's own feed per
    move; none on rapids), by the replay's model (:meth:`DeflectionModel.deflection`)."""
    problem = schedule.problem
    if problem.programmed_feed is not None:
        feed = np.where(np.isfinite(problem.programmed_feed), problem.programmed_feed, 0.0)
    else:
        feed = np.full(problem.n, problem.nominal_feed)
    return float(np.max(schedule.model.deflection(feed)))


def evaluate_profile(
    robot: RobotModel,
    task: RedundancyTask,
    psi: np.ndarray,
    stiffness_set: str | np.ndarray,
    ik_options: IKOptions | None = None,
    deflection: bool = False,
    x_nearest: np.ndarray | None = None,
    path_acceleration: bool = True,
) -> ProfileEvaluation:
    """The robot stage and bound on ``task``'s samples with the redundancy ``psi`` (n,) [rad].

    ``deflection``: also the max deflection at the nominal feed; ``x_nearest`` (n, 3): the
    nearest solution's x axes (computed when None); ``path_acceleration``: see
    :func:`acceleration_share`. Raises InputError when the IK refuses the profile.
    """
    x0 = x_axes_of(robot, task.nearest.q) if x_nearest is None else x_nearest
    psi = np.asarray(psi, dtype=float)
    x = rotate_about_axes(x0, task.tool_axes, psi)
    q0 = start_configuration(robot, task.positions[0], task.tool_axes[0], x0[0],
                             task.nearest.q[0], float(psi[0]), ik_options)
    along = robot_along_path(robot, TcpPath(task.s, task.positions, task.tool_axes, x_axes=x),
                             q0, stiffness_set, ik_options=ik_options)
    schedule = task.bound_of(along)
    return ProfileEvaluation(
        psi=psi, x_axes=x, q_start=q0, along=along, schedule=schedule,
        t_star=schedule.problem.lower_bound_time(),
        max_deflection=max_deflection_at_nominal(schedule) if deflection else float("nan"),
        acceleration_shares=acceleration_shares(schedule, path_acceleration),
    )


def turns_last_joint_only(robot: RobotModel, q: np.ndarray, tool_axes: np.ndarray,
                          tol: float = 1e-9) -> bool:
    """True when, at every configuration of ``q`` (n, dof), the last joint's axis is the tool
    axis through the TCP (its Jacobian column is ``[0; +-z]``): turning about the tool axis
    then moves that joint only, and the translational compliance (Eq. 3.19/3.20, whose last
    term ``J_6 J_6^T / k_6`` has no translational part) and the feed bound do not change.
    The bundled robots carry their spindles this way (coaxial with A6)."""
    last = tcp_jacobians(robot, q)[:, :, -1]
    off_axis = np.cross(last[:, 3:], tool_axes)
    return bool(np.all(np.linalg.norm(last[:, :3], axis=1) <= tol)
                and np.all(np.linalg.norm(off_axis, axis=1) <= tol)
                and np.all(np.linalg.norm(last[:, 3:], axis=1) > 0.5))


# --------------------------------------------------------------------------- search


@dataclass
class _Search:
    """The objective on the search samples, counting and remembering what it saw."""

    robot: RobotModel
    task: RedundancyTask
    knot_s: np.ndarray
    x_nearest: np.ndarray
    stiffness_set: str | np.ndarray
    ik_options: IKOptions | None
    options: RedundancyOptions
    reference: float = np.nan  # nearest objective
    share_allowed: np.ndarray = field(default_factory=lambda: np.zeros(0))
    evaluations: int = 0
    infeasible: int = 0
    best_value: float = np.inf
    best_knots: np.ndarray = field(default_factory=lambda: np.zeros(0))
    progress: Callable[[int, int], None] | None = None

    def objective_of(self, ev: ProfileEvaluation) -> float:
        return ev.t_star if self.options.objective == "time" else ev.max_deflection

    def __call__(self, knots: np.ndarray) -> float:
        """The objective of the profile through ``knots`` (penalised when infeasible); the
        best feasible profile is remembered."""
        knots = np.clip(np.asarray(knots, dtype=float), -self.options.psi_max,
                        self.options.psi_max)
        self.evaluations += 1
        psi = psi_profile(self.knot_s, knots)(self.task.s)
        feasible = False
        try:
            ev = evaluate_profile(self.robot, self.task, psi, self.stiffness_set,
                                  self.ik_options, self.options.objective == "deflection",
                                  self.x_nearest, self.options.path_acceleration)
        except InputError:
            value = self.options.penalty * self.reference
        else:
            value = self.objective_of(ev)
            excess = float(np.max(ev.acceleration_shares / self.share_allowed)) - 1.0
            margin = self.options.limit_margin
            q = ev.along.q
            if np.any(q < self.robot.q_lower + margin) or np.any(q > self.robot.q_upper - margin):
                value = self.options.penalty * self.reference
            elif excess > 0:  # exact penalty: continuous at the boundary (margin included)
                value += self.options.penalty * self.reference * excess
            else:
                feasible = True
        if not feasible:
            self.infeasible += 1
        elif value < self.best_value:
            self.best_value, self.best_knots = value, knots.copy()
        if self.progress is not None:
            self.progress(self.evaluations, self.options.max_evaluations)
        return value


def _scan(search: _Search, k: int, step: float, psi_max: float) -> None:
    """Evaluate constant offsets every ``step`` over (-pi, pi] within +-psi_max."""
    if step <= 0:
        return
    offsets = np.arange(step, np.pi + 1e-9, step)
    for c in np.concatenate([offsets, -offsets[offsets < np.pi - 1e-9]]):
        if abs(c) <= psi_max + 1e-12 and search.evaluations < search.options.max_evaluations:
            search(np.full(k, c))


@dataclass(frozen=True)
class _SearchStats:
    search_nearest: float = float("nan")
    search_best: float = float("nan")
    iterations: int = 0
    evaluations: int = 0
    infeasible: int = 0


def _nearest_result(
    final: RedundancyTask, options: RedundancyOptions, knot_s: np.ndarray,
    status: RedundancyStatus, reason: str, t_start: float, stats: _SearchStats,
    nearest: tuple[ScheduleInputs, float, np.ndarray] | None = None,
) -> RedundancyResult:
    """The result that keeps the nearest IK (``nearest``: its schedule, objective and
    acceleration shares at full resolution, computed when None)."""
    if nearest is None:
        nearest = _full_nearest(final, options)
    schedule, objective, shares = nearest
    share = float(np.max(shares))
    t_star = schedule.problem.lower_bound_time()
    return RedundancyResult(
        status=status, reason=reason, objective=options.objective, knot_s=knot_s,
        knot_psi=np.zeros(knot_s.size), s=final.s, psi=np.zeros(final.s.size), x_axes=None,
        q_start=None, along=final.nearest, schedule=schedule, t_star_nearest=t_star,
        t_star=t_star, objective_nearest=objective, objective_value=objective,
        search_nearest=stats.search_nearest, search_best=stats.search_best,
        acceleration_share_nearest=share, acceleration_share=share,
        iterations=stats.iterations, evaluations=stats.evaluations,
        infeasible=stats.infeasible, seconds=time.perf_counter() - t_start)


def _full_nearest(final: RedundancyTask,
                  options: RedundancyOptions) -> tuple[ScheduleInputs, float, np.ndarray]:
    """The nearest IK's schedule, objective and acceleration shares on ``final``."""
    schedule = final.bound_of(final.nearest)
    objective = (schedule.problem.lower_bound_time() if options.objective == "time"
                 else max_deflection_at_nominal(schedule))
    return schedule, objective, acceleration_shares(schedule, options.path_acceleration)


def optimise_redundancy(
    robot: RobotModel,
    search: RedundancyTask,
    final: RedundancyTask,
    stiffness_set: str | np.ndarray,
    options: RedundancyOptions | None = None,
    ik_options: IKOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> RedundancyResult:
    """Choose the rotation about the tool axis psi(s) along the path (module docstring).

    Parameters
    ----------
    robot : RobotModel
    search : RedundancyTask
        The coarse sampling the optimiser evaluates (e.g. 1 mm).
    final : RedundancyTask
        The run's own sampling, on which the result is verified and returned.
    stiffness_set : str or (dof,) array
        Joint stiffness set of the run (:func:`feedopt.robot.stiffness.joint_stiffness`).
    options : RedundancyOptions or None
    ik_options : IKOptions or None
        The run's IK tunables (joint-jump and singularity limits apply to every profile).
    progress : callable or None
        ``progress(evaluations, max_evaluations)`` after every objective evaluation.

    Returns
    -------
    RedundancyResult
        Never worse than the nearest IK at full resolution (by ``options.min_gain``).

    Raises
    ------
    InputError
        Only from the nearest solution itself (its 6-DoF re-solve or bound), i.e. input the
        run would refuse anyway.
    """
    t_start = time.perf_counter()
    options = RedundancyOptions() if options is None else options
    length = float(final.s[-1] - final.s[0])
    knot_s = final.s[0] + knot_positions(length, options.knot_count(length))

    if turns_last_joint_only(robot, search.nearest.q, search.tool_axes):
        return _nearest_result(final, options, knot_s, RedundancyStatus.LAST_JOINT, (
            "the tool axis is the axis of the last joint through the TCP: turning about it "
            "turns that joint only and leaves the compliance and the feed bound unchanged"),
            t_start, _SearchStats())

    srch = _Search(robot=robot, task=search, knot_s=knot_s,
                   x_nearest=x_axes_of(robot, search.nearest.q), stiffness_set=stiffness_set,
                   ik_options=ik_options, options=options, progress=progress)
    stats = _run_search(srch)
    return _confirm(srch, final, stats, t_start)


def _run_search(srch: _Search) -> _SearchStats:
    """The search on ``srch``'s samples: the nearest solution as the reference (and the
    feasible start), the scan of constant offsets, then Powell from the best of them."""
    options, task = srch.options, srch.task
    k = srch.knot_s.size
    ref = evaluate_profile(srch.robot, task, np.zeros(task.s.size), srch.stiffness_set,
                           srch.ik_options, options.objective == "deflection", srch.x_nearest,
                           options.path_acceleration)
    srch.reference = srch.objective_of(ref)
    srch.share_allowed = allowed_shares(ref.acceleration_shares,
                                        options.joint_acceleration_share,
                                        options.acceleration_margin, search=True)
    srch.best_value, srch.best_knots = srch.reference, np.zeros(k)
    srch.evaluations = 1

    _scan(srch, k, options.scan_step, options.psi_max)
    iterations = 0
    remaining = options.max_evaluations - srch.evaluations
    if remaining > 0:
        res = minimize(srch, srch.best_knots.copy(), method="Powell",
                       options={"xtol": options.xtol, "ftol": options.ftol,
                                "maxfev": remaining, "direc": np.eye(k) * options.step})
        iterations = int(res.nit)
    return _SearchStats(srch.reference, srch.best_value, iterations, srch.evaluations,
                        srch.infeasible)


def _confirm(srch: _Search, final: RedundancyTask, stats: _SearchStats,
             t_start: float) -> RedundancyResult:
    """Full resolution: the nearest solution (the reference) and the search's best profile,
    scaled towards psi = 0 until one is accepted; else the nearest IK, with the reasons."""
    options, knot_s = srch.options, srch.knot_s
    nearest = _full_nearest(final, options)
    _, nearest_obj, nearest_share = nearest

    def keep_nearest(status: RedundancyStatus, reason: str) -> RedundancyResult:
        return _nearest_result(final, options, knot_s, status, reason, t_start, stats, nearest)

    if not srch.best_value < srch.reference * (1.0 - options.min_gain):
        return keep_nearest(RedundancyStatus.NO_GAIN, "no profile found on the search samples "
                            "does better than the nearest IK")
    allowed = allowed_shares(nearest_share, options.joint_acceleration_share,
                             options.acceleration_margin, search=False)
    reasons = []
    for scale in options.backtrack:  # the best profile, then scaled towards psi = 0
        knots = scale * srch.best_knots
        psi = psi_profile(knot_s, knots)(final.s)
        why = _refusal(srch.robot, final, psi, srch.stiffness_set, srch.ik_options, options,
                       allowed, nearest_obj)
        if isinstance(why, str):
            reasons.append(f"x {scale:g}: {why}")
            continue
        ev, value = why
        return RedundancyResult(
            status=RedundancyStatus.IMPROVED, reason="; ".join(reasons),
            objective=options.objective, knot_s=knot_s, knot_psi=knots, s=final.s, psi=psi,
            x_axes=ev.x_axes, q_start=ev.q_start, along=ev.along, schedule=ev.schedule,
            t_star_nearest=nearest[0].problem.lower_bound_time(), t_star=ev.t_star,
            objective_nearest=nearest_obj, objective_value=value,
            search_nearest=stats.search_nearest, search_best=stats.search_best,
            acceleration_share_nearest=float(np.max(nearest_share)),
            acceleration_share=ev.acceleration_share, scale=scale,
            iterations=stats.iterations, evaluations=stats.evaluations,
            infeasible=stats.infeasible, seconds=time.perf_counter() - t_start)
    return keep_nearest(RedundancyStatus.NOT_CONFIRMED,
                        "the best profile (and its scaled copies) at full resolution: "
                        + "; ".join(reasons))


def _refusal(robot: RobotModel, final: RedundancyTask, psi: np.ndarray,
             stiffness_set: str | np.ndarray, ik_options: IKOptions | None,
             options: RedundancyOptions, allowed: np.ndarray,
             nearest_obj: float) -> str | tuple[ProfileEvaluation, float]:
    """Why ``psi`` is refused at full resolution (IK, joint accelerations above ``allowed``,
    no gain over ``nearest_obj``), or its evaluation and objective."""
    try:
        ev = evaluate_profile(robot, final, psi, stiffness_set, ik_options,
                              options.objective == "deflection",
                              path_acceleration=options.path_acceleration)
    except InputError as exc:
        return f"the IK refuses it: {exc}"
    over = np.flatnonzero(ev.acceleration_shares > allowed)
    if over.size:
        i = int(over[np.argmax(ev.acceleration_shares[over] / allowed[over])])
        return (f"its joint accelerations in the worst case use {ev.acceleration_shares[i]:.3g}"
                f" of a joint's limit at s = {final.s[i] / MM:.1f} mm (> {allowed[i]:.3g} "
                "allowed there)")
    value = ev.t_star if options.objective == "time" else ev.max_deflection
    if not value < nearest_obj * (1.0 - options.min_gain):
        return f"no gain ({value:.6g} vs {nearest_obj:.6g} with the nearest IK)"
    return ev, value


# --------------------------------------------------------------------------- report


@dataclass(frozen=True)
class StiffnessEllipses:
    """The translational stiffness ellipse in the plane normal to the tool axis, per sample.

    Attributes
    ----------
    stiffness : (n, 2) array
        Principal stiffnesses [N/m], stiffest first: the inverse eigenvalues of the in-plane
        block ``P^T C P`` of the 3x3 compliance (force in the plane -> displacement in it;
        ``P`` an orthonormal basis of the plane).
    directions : (n, 2, 3) array
        Their unit directions in the base frame (in the plane, sign arbitrary).
    """

    stiffness: np.ndarray
    directions: np.ndarray

    def angle_to(self, reference: np.ndarray, tool_axes: np.ndarray) -> np.ndarray:
        """Angle [rad] in (-pi/2, pi/2] of the stiffest direction from ``reference`` (n, 3)
        (e.g. the feed direction), about the tool axes (an ellipse has no sign)."""
        d = self.directions[:, 0]
        ang = np.arctan2(np.einsum("ij,ij->i", np.cross(reference, d), tool_axes),
                         np.einsum("ij,ij->i", reference, d))
        return np.where(ang > np.pi / 2, ang - np.pi, np.where(ang <= -np.pi / 2, ang + np.pi,
                                                               ang))


def stiffness_ellipses(compliance: np.ndarray, tool_axes: np.ndarray) -> StiffnessEllipses:
    """Stiffness ellipses (:class:`StiffnessEllipses`) of translational compliances (n, 3, 3)
    [m/N] (thesis Eq. 3.19/3.20, :attr:`RobotAlongPath.compliance`) in the planes normal to
    the unit ``tool_axes`` (n, 3)."""
    z = np.asarray(tool_axes, dtype=float)
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    helper = np.where((np.abs(z[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(z, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(z, e1)
    p = np.stack([e1, e2], axis=2)  # (n, 3, 2)
    c2 = np.swapaxes(p, 1, 2) @ np.asarray(compliance, dtype=float) @ p
    c2 = 0.5 * (c2 + np.swapaxes(c2, 1, 2))
    w, v = np.linalg.eigh(c2)  # ascending compliance = descending stiffness
    return StiffnessEllipses(stiffness=1.0 / w, directions=np.swapaxes(p @ v, 1, 2))
