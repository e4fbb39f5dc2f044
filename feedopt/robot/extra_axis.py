"""The extra axis of a 7-axis robot, held where the arm is stiffest for the cut (issue 29).

A 7-axis robot on the 5-DoF milling task (an arm on a linear track, a 7-joint arm such as
the KUKA LBR iiwa) has two degrees of freedom left over: the rotation about the tool axis,
which the nearest IK's minimum-norm steps keep where they start, and the extra axis. The
nearest IK (``robot.redundancy: nearest``) moves every joint a little (a prismatic joint
weighs like 10 mm per radian, :data:`feedopt.robot.ik.PRISMATIC_WEIGHT`).

``robot.redundancy: optimise`` holds the extra axis at one value for the whole path
(:class:`feedopt.robot.ik.IKOptions` ``held_joint``): a track, a slow and heavy axis, does
not move during the cut at all, and an LBR keeps its redundancy parameter (KUKA's E1, the
angle of its third joint) like its own controller does. The value is the one that
minimises T* = integral ds / v_max(s) (or the largest deflection at the nominal feed): the
stiffness of the arm in the posture the held axis gives it, over the whole cut, the
posture optimisation of Lin, Zhao and Ding 2017 (RCIM 48) with the time the feed bound
allows as criterion (as :mod:`feedopt.robot.redundancy` does for the tool rotation).

Search: :data:`SCAN_POINTS` values evenly over the joint's range (inside ``limit_margin``,
:data:`PRISMATIC_MARGIN` for a prismatic joint), then Brent's bounded search (Brent 1973;
:func:`scipy.optimize.minimize_scalar` ``"bounded"``) between the neighbours of the best
scanned value, on the coarse search samples; confirmed at full resolution, else values
moved towards the nearest solution's (``backtrack``), else the nearest IK is kept and the
reason given. A value is refused where the IK refuses it, where a joint comes within the
margin of its limit on the search samples, or where the worst-case joint accelerations
take more than their share (:func:`feedopt.robot.redundancy.allowed_shares`), exactly as a
psi profile is. The first configuration is reached from the nearest IK's by moving the held
joint in steps (:data:`START_STEP_RAD`, :data:`START_STEP_M`), each solved from the
previous one, so the arm stays on the nearest solution's branch.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import RobotModel
from feedopt.robot.redundancy import (
    RedundancyOptions,
    RedundancyStatus,
    RedundancyTask,
    acceleration_shares,
    allowed_shares,
    max_deflection_at_nominal,
)
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes
from feedopt.schedule.stage import ScheduleInputs
from feedopt.units import MM

#: Values of the held joint evaluated evenly over its range before the bounded search.
SCAN_POINTS = 13
#: Evaluations of Brent's bounded search after the scan.
REFINE_EVALUATIONS = 12
#: Margin to a prismatic joint's travel limits [m] (a revolute joint's is the options').
PRISMATIC_MARGIN = 5e-3
#: Steps of the held joint from the nearest IK's first configuration [rad] and [m].
START_STEP_RAD = float(np.deg2rad(2.0))
START_STEP_M = 0.02


@dataclass(frozen=True)
class HeldEvaluation:
    """The robot stage and the bound with the extra axis held at ``value`` [rad or m]."""

    value: float
    q_start: np.ndarray
    along: RobotAlongPath
    schedule: ScheduleInputs
    objective: float
    shares: np.ndarray  # acceleration shares per sample (acceleration_shares)


@dataclass(frozen=True)
class ExtraAxisResult:
    """What ``robot.redundancy: optimise`` chose for a 7-axis robot (SI, radians or metres).

    ``value`` is None where the nearest IK is kept (``status`` and ``reason`` say why);
    ``scanned`` and ``scanned_objective`` are the search's evaluations in the order made
    (objective NaN where refused); ``ik_options`` and ``q_start`` re-solve the chosen
    posture (compensation), None with the nearest IK.
    """

    joint: int
    joint_name: str
    prismatic: bool
    status: RedundancyStatus
    reason: str
    objective: str
    value: float | None
    value_nearest: np.ndarray  # the held joint along the path with the nearest IK
    scanned: np.ndarray
    scanned_objective: np.ndarray
    s: np.ndarray
    along: RobotAlongPath
    schedule: ScheduleInputs
    q_start: np.ndarray | None
    ik_options: IKOptions | None
    t_star_nearest: float
    t_star: float
    evaluations: int
    infeasible: int
    seconds: float

    @property
    def gain(self) -> float:
        """Relative reduction of T*, ``1 - t_star / t_star_nearest``."""
        return 1.0 - self.t_star / self.t_star_nearest

    def display(self, value: float | np.ndarray) -> float | np.ndarray:
        """A joint value in the report's unit (mm or deg)."""
        return np.asarray(value) / MM if self.prismatic else np.degrees(value)

    @property
    def unit(self) -> str:
        return "mm" if self.prismatic else "deg"

    def describe(self) -> str:
        """One progress line."""
        held = ("the nearest IK kept" if self.value is None
                else f"{self.joint_name} held at {float(self.display(self.value)):.2f} "
                f"{self.unit}")
        return (f"{self.status.value}: {held}; T* {self.t_star_nearest:.2f} s nearest -> "
                f"{self.t_star:.2f} s ({self.gain:.2%}), {self.evaluations} evaluations "
                f"({self.seconds:.2f} s)" + (f"; {self.reason}" if self.reason else ""))

    def summary(self) -> dict:
        """summary.json ``scenario.redundancy``."""
        return {"status": self.status.value, "reason": self.reason,
                "objective": self.objective, "extra_axis": self.joint_name,
                "unit": self.unit,
                "held_value": None if self.value is None else float(self.display(self.value)),
                "t_star_nearest_s": self.t_star_nearest, "t_star_s": self.t_star,
                "gain": self.gain, "evaluations": self.evaluations,
                "infeasible": self.infeasible, "seconds": self.seconds,
                "scanned": [float(v) for v in self.display(self.scanned)],
                "scanned_objective": [None if not np.isfinite(v) else float(v)
                                      for v in self.scanned_objective]}


def start_with_held(robot: RobotModel, position: np.ndarray, tool_axis: np.ndarray,
                    q_nearest: np.ndarray, joint: int, value: float) -> np.ndarray:
    """The configuration (dof,) at the first sample with joint ``joint`` at ``value``,
    reached from the nearest IK's ``q_nearest`` in steps of the held joint, each IK warm
    started from the previous (InputError where a step is refused)."""
    step = START_STEP_M if robot.axis_convention.prismatic[joint] else START_STEP_RAD
    start = float(q_nearest[joint])
    count = max(1, math.ceil(abs(value - start) / step))
    options = IKOptions(held_joint=joint)
    q = np.array(q_nearest, dtype=float)
    for v in np.linspace(start, value, count + 1)[1:]:
        q[joint] = v
        q = solve_path_ik(robot, position[None], tool_axis[None], q, options=options).q[0]
    return q


@dataclass
class _Search:
    """The objective on the search samples, remembering every value tried."""

    robot: RobotModel
    task: RedundancyTask
    joint: int
    stiffness_set: str | np.ndarray
    options: RedundancyOptions
    reference: float
    share_allowed: np.ndarray
    tried: list
    infeasible: int = 0
    progress: Callable[[int, int], None] | None = None

    def __call__(self, value: float) -> float:
        """The objective with the joint held at ``value``, penalised where refused."""
        try:
            ev = evaluate_held(self.robot, self.task, self.joint, float(value),
                               self.stiffness_set, self.options)
        except InputError:
            ev = None
        margin = _margin(self.robot, self.joint, self.options)
        ok = ev is not None and not (
            np.any(ev.along.q < self.robot.q_lower + margin)
            or np.any(ev.along.q > self.robot.q_upper - margin)
            or np.any(ev.shares > self.share_allowed))
        self.tried.append((float(value), ev.objective if ok else np.nan))
        if self.progress is not None:
            self.progress(len(self.tried), SCAN_POINTS + REFINE_EVALUATIONS)
        if not ok:
            self.infeasible += 1
            return self.options.penalty * self.reference
        return ev.objective


def _margin(robot: RobotModel, joint: int, options: RedundancyOptions) -> np.ndarray:
    """Per joint, how far inside its limits the search keeps it [rad or m]."""
    margin = np.full(robot.dof, options.limit_margin)
    margin[robot.axis_convention.prismatic] = PRISMATIC_MARGIN
    return margin


def evaluate_held(robot: RobotModel, task: RedundancyTask, joint: int, value: float,
                  stiffness_set: str | np.ndarray,
                  options: RedundancyOptions) -> HeldEvaluation:
    """The robot stage, bound and objective on ``task`` with ``joint`` held at ``value``
    (InputError where the IK refuses it)."""
    q0 = start_with_held(robot, task.positions[0], task.tool_axes[0], task.nearest.q[0],
                         joint, value)
    x_axes = five_axis_x_axes(robot, q0, task.tool_axes)  # None unless the axis turns
    along = robot_along_path(robot, TcpPath(task.s, task.positions, task.tool_axes,
                                            x_axes=x_axes), q0,
                             stiffness_set, ik_options=IKOptions(held_joint=joint))
    schedule = task.bound_of(along)
    objective = (schedule.problem.lower_bound_time() if options.objective == "time"
                 else max_deflection_at_nominal(schedule))
    return HeldEvaluation(value, q0, along, schedule, objective,
                          acceleration_shares(schedule, options.path_acceleration))


def _search(srch: _Search, lo: float, hi: float) -> float | None:
    """Scan, then Brent's bounded search around the best scanned value; the best feasible
    value tried (None: none)."""
    for v in np.linspace(lo, hi, SCAN_POINTS):
        srch(v)
    values = np.array([v for v, _ in srch.tried])
    objective = np.array([f for _, f in srch.tried])
    if np.all(np.isnan(objective)):
        return None
    i = int(np.nanargmin(objective))
    grid = np.linspace(lo, hi, SCAN_POINTS)
    k = int(np.argmin(np.abs(grid - values[i])))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, SCAN_POINTS - 1)]
    if b > a:
        minimize_scalar(srch, bounds=(a, b), method="bounded",
                        options={"maxiter": REFINE_EVALUATIONS, "xatol": (hi - lo) * 1e-4})
    values = np.array([v for v, _ in srch.tried])
    objective = np.array([f for _, f in srch.tried])
    return float(values[int(np.nanargmin(objective))])


def choose_extra_axis(
    robot: RobotModel, joint: int, search: RedundancyTask, final: RedundancyTask,
    stiffness_set: str | np.ndarray, options: RedundancyOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ExtraAxisResult:
    """Hold the extra axis ``joint`` where T* (or the deflection) is lowest (module
    docstring); never worse than the nearest IK at full resolution (by ``min_gain``)."""
    t0 = time.perf_counter()
    options = RedundancyOptions() if options is None else options
    nearest_search = search.bound_of(search.nearest)
    reference = (nearest_search.problem.lower_bound_time() if options.objective == "time"
                 else max_deflection_at_nominal(nearest_search))
    share = allowed_shares(acceleration_shares(nearest_search, options.path_acceleration),
                           options.joint_acceleration_share, options.acceleration_margin, True)
    srch = _Search(robot, search, joint, stiffness_set, options, reference, share, [],
                   progress=progress)
    margin = _margin(robot, joint, options)[joint]
    best = _search(srch, robot.q_lower[joint] + margin, robot.q_upper[joint] - margin)
    nearest_full = final.bound_of(final.nearest)
    nearest_obj = (nearest_full.problem.lower_bound_time() if options.objective == "time"
                   else max_deflection_at_nominal(nearest_full))
    allowed = allowed_shares(acceleration_shares(nearest_full, options.path_acceleration),
                             options.joint_acceleration_share, options.acceleration_margin,
                             False)

    def result(status: RedundancyStatus, reason: str,
               ev: HeldEvaluation | None = None) -> ExtraAxisResult:
        chosen = nearest_full if ev is None else ev.schedule
        return ExtraAxisResult(
            joint=joint, joint_name=robot.joint_names[joint],
            prismatic=bool(robot.axis_convention.prismatic[joint]), status=status,
            reason=reason, objective=options.objective,
            value=None if ev is None else ev.value, value_nearest=final.nearest.q[:, joint],
            scanned=np.array([v for v, _ in srch.tried]),
            scanned_objective=np.array([f for _, f in srch.tried]), s=final.s,
            along=final.nearest if ev is None else ev.along, schedule=chosen,
            q_start=None if ev is None else ev.q_start,
            ik_options=None if ev is None else IKOptions(held_joint=joint),
            t_star_nearest=nearest_full.problem.lower_bound_time(),
            t_star=chosen.problem.lower_bound_time(), evaluations=len(srch.tried),
            infeasible=srch.infeasible, seconds=time.perf_counter() - t0)

    if best is None or not min(f for _, f in srch.tried if np.isfinite(f)) < reference * (
            1.0 - options.min_gain):
        return result(RedundancyStatus.NO_GAIN, "no held value does better than the "
                      "nearest IK on the search samples")
    reasons = []
    start = float(final.nearest.q[0, joint])
    for scale in options.backtrack:  # the best value, then moved towards the nearest's
        value = start + scale * (best - start)
        why = _confirm(robot, final, joint, value, stiffness_set, options, allowed,
                       nearest_obj)
        if isinstance(why, str):
            reasons.append(f"{float(_shown(robot, joint, value)):.3g}: {why}")
            continue
        return result(RedundancyStatus.IMPROVED, "; ".join(reasons), why)
    return result(RedundancyStatus.NOT_CONFIRMED,
                  "the best held value (and values closer to the nearest IK's) at full "
                  "resolution: " + "; ".join(reasons))


def _shown(robot: RobotModel, joint: int, value: float) -> float:
    """``value`` in the joint's display unit (deg, or mm for a prismatic joint)."""
    return value / robot.axis_convention.unit[joint]


def _confirm(robot: RobotModel, final: RedundancyTask, joint: int, value: float,
             stiffness_set: str | np.ndarray, options: RedundancyOptions,
             allowed: np.ndarray, nearest_obj: float) -> str | HeldEvaluation:
    """The evaluation at full resolution, or why it is refused (IK, joint accelerations, no
    gain)."""
    try:
        ev = evaluate_held(robot, final, joint, value, stiffness_set, options)
    except InputError as exc:
        return f"the IK refuses it: {exc}"
    over = np.flatnonzero(ev.shares > allowed)
    if over.size:
        return (f"its worst-case joint accelerations use {ev.shares[over].max():.3g} of a "
                "joint's limit")
    if not ev.objective < nearest_obj * (1.0 - options.min_gain):
        return (f"no gain at full resolution ({ev.objective:.6g} against the nearest IK's "
                f"{nearest_obj:.6g})")
    return ev
