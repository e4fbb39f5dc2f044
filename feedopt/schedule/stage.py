"""The schedule stage of a run up to the timing laws: deflection model, feed bound, problem.

:func:`schedule_problem` is what the runner calls: it turns the process (forces), the robot
(compliance, joint path) and the scenario's limits into the deflection model, the feed bound
v_max(s) (:mod:`feedopt.schedule.bounds`) and the :class:`ScheduleProblem` every law gets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.tool_bending import compliance_matrices
from feedopt.schedule.bounds import BoundInputs, FeedBound, feed_bound
from feedopt.schedule.checks import check_boundary_feeds
from feedopt.schedule.deflection import DeflectionModel
from feedopt.schedule.problem import ScheduleProblem, StopSamples
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class ScheduleInputs:
    """The deflection model, the feed bound and the problem handed to every law."""

    model: DeflectionModel
    bound: FeedBound
    problem: ScheduleProblem
    limit: float  # deflection limit [m]
    wall_limit: float = np.inf  # part tolerances of deflection.mode surface [m]
    floor_limit: float = np.inf


def angle_grid(teeth: int, step_deg: float) -> np.ndarray:
    """Uniform cutter angles over one tooth pitch (the forces repeat every pitch) [rad]."""
    step = np.deg2rad(step_deg)
    pitch = 2.0 * np.pi / teeth
    return np.arange(0.0, pitch - 1e-12, step)


#: Largest force-model workload of a run: samples x angles per revolution pitch (grid plus
#: slice entry/exit angles) x axial slices x teeth, evaluated twice (bound and replay). The
#: default run is 8.7e7 (about 1.5 s of bound and replay on a 2-core machine, 6e7 per s);
#: 1e6 samples at the default step and slices 1.8e10; the cap is about half an hour.
MAX_FORCE_EVALUATIONS = 1e11


def check_workload(n_samples: int, n_angles: int, axial_slices: int, process) -> None:
    """InputError, with the estimate, when the force model would run for hours on
    ``process`` (its tool's teeth; an engagement found per slice in a tri-dexel stock has up
    to several intervals per slice, each with its entry and exit)."""
    table = process.engagement.by_slice
    intervals = 1 if table is None else table.lo.shape[2]
    teeth = process.tool.teeth
    slices = axial_slices * intervals
    work = 2.0 * n_samples * (n_angles + 2 * slices) * slices * teeth
    if work > MAX_FORCE_EVALUATIONS:
        per = f" ({intervals} intervals each)" if intervals > 1 else ""
        raise InputError(
            f"schedule.angle_step_deg and schedule.axial_slices ask for {n_angles} angles x "
            f"{axial_slices} slices{per} on {n_samples} samples: about {work:.2g} force "
            "evaluations, "
            f"more than the {MAX_FORCE_EVALUATIONS:.0e} a run may take "
            "(about half an hour of computing); "
            "use a coarser angle step (1 deg is the default and within 1e-6 of the exact "
            "maximum), fewer slices (20) or a larger path.spacing_mm")


def programmed_feed(moves, s: np.ndarray, feed) -> tuple[np.ndarray, np.ndarray]:
    """A program's own feed at arc lengths ``s`` [m/s] and which samples are rapids: the F
    of each sample's move; on rapids ``feed.rapid_mm_s`` or ``inf`` (then the robot's joint
    limits bound them)."""
    move = moves.index_at(s)
    rapid = moves.category[move] == "rapid"
    cap = np.inf if feed.rapid_mm_s is None else feed.rapid_mm_s * MM
    return np.where(rapid, cap, moves.feed[move]), rapid


def unmodelled_plunge_cap(max_feed: np.ndarray, programmed: np.ndarray,
                          plunge: np.ndarray | None, cap_mm_s: float | None) -> np.ndarray:
    """The feed cap on plunges the force model does not cover (no plunge coefficients in
    the material file): there the program's F, capped by ``feed.plunge_max_mm_s``, is all
    that limits the feed (never ``feed.max_mm_s``: nothing bounds their deflection; they
    are labelled, not deflection-limited)."""
    if plunge is None or not plunge.any():
        return max_feed
    cap = np.inf if cap_mm_s is None else cap_mm_s * MM
    return np.where(plunge, np.minimum(programmed, cap), max_feed)


def stop_samples(stops, s: np.ndarray) -> StopSamples | None:
    """The path's stops (:class:`feedopt.geometry.stops.StopTable`, None: none) as sample
    indices: the sampler puts a sample exactly at every stop."""
    if stops is None or len(stops) == 0:
        return None
    index = np.searchsorted(s, stops.s)
    index = np.clip(index, 0, s.size - 1)
    off = np.abs(s[index] - stops.s)
    if np.any(off > 1e-9 * max(1.0, float(s[-1]))):
        k = int(np.argmax(off))
        raise RuntimeError(f"stop {stops.label[k]} at s = {stops.s[k]:.9g} m is not a path "
                           f"sample (nearest {s[index[k]]:.9g} m): the sampler must place it")
    hold = np.asarray(stops.hold_s, dtype=float)
    interior = (index > 0) & (index < s.size - 1)
    if not np.any(interior | (hold > 0)):
        return None
    return StopSamples(index=index, hold_s=hold, kind=tuple(stops.kind),
                       label=tuple(stops.label))


def tip_compliance(robot_compliance: np.ndarray, tool, frames: np.ndarray) -> np.ndarray:
    """The translational compliance at the tool tip [m/N] (n, 3, 3): the robot's (thesis
    Eq. 3.19/3.20) and the tool's own bending in series (compliances add;
    :meth:`feedopt.process.tool.Tool.tip_compliance`, about the tool axis ``frames[:, :, 2]``);
    the robot's alone when the tool is rigid (no stickout, no measured tip stiffness)."""
    if not tool.bends:
        return robot_compliance
    lateral, axial = tool.tip_compliance()
    return robot_compliance + compliance_matrices(lateral, axial, frames[:, :, 2])


def interior_stop_indices(stops, s: np.ndarray) -> np.ndarray | None:
    """Sample indices of the stops strictly inside the path (where the joint path is split
    into pieces, :func:`feedopt.robot.stage.joint_spline`); None without any."""
    found = stop_samples(stops, s)
    if found is None:
        return None
    inside = found.index[(found.index > 0) & (found.index < s.size - 1)]
    return np.unique(inside) if inside.size else None


def schedule_problem(scenario, process, robot, along, placement, samples,
                     path, progress=None) -> ScheduleInputs:
    """Build the deflection model, v_max(s) and the schedule problem of ``scenario``.

    ``process`` is a :class:`feedopt.process.stage.ProcessAlongPath`, ``robot`` a
    :class:`feedopt.robot.model.RobotModel`, ``along`` the robot along the path
    (:func:`feedopt.robot.stage.robot_along_path`), ``placement`` the
    :class:`feedopt.cell.Placement`, ``samples`` the sampled path, ``path`` the path;
    ``progress(samples_done, samples)`` follows the deflection bound (a progress bar).
    """
    limits, feed, sched = scenario.limits, scenario.feed, scenario.schedule
    defl = scenario.deflection
    angles = angle_grid(process.tool.teeth, sched.angle_step_deg)
    check_workload(samples.s.size, angles.size, sched.axial_slices, process)
    model = DeflectionModel(
        tool=process.tool,
        coefficients=process.coefficients,
        engagement=process.engagement,
        angles=angles,
        frames=placement.frames,
        compliance=tip_compliance(along.compliance, process.tool, placement.frames),
        rpm=scenario.cut.spindle_rpm,
        mode="norm" if defl.mode == "surface" else defl.mode,
        direction=np.asarray(defl.direction, dtype=float) if defl.direction is not None else None,
        axial_slices=sched.axial_slices,
    )
    limit = defl.limit_mm * MM
    wall_limit, floor_limit = (np.inf if x is None else x * MM
                               for x in (defl.wall_limit_mm, defl.floor_limit_mm))
    programmed = None
    if path.moves is None:
        max_feed = (feed.max_mm_s if feed.max_mm_s is not None else feed.nominal_mm_s) * MM
    else:  # a program: its F per move (feed.max_mm_s may replace it on feed moves)
        programmed, rapid = programmed_feed(path.moves, samples.s, feed)
        max_feed = programmed if feed.max_mm_s is None else np.where(
            rapid, programmed, feed.max_mm_s * MM)
        max_feed = unmodelled_plunge_cap(max_feed, programmed, process.unmodelled_plunge,
                                         feed.plunge_max_mm_s)
    qd_max = robot.joint_velocity_max * limits.joint_velocity_scale
    qdd_max = robot.joint_acceleration_max * limits.joint_acceleration_scale
    dq_ds = along.dq_ds  # q'(s) at the samples, from the robot stage
    bound = feed_bound(BoundInputs(
        model=model, limit=limit, max_feed=max_feed, dq_ds=dq_ds, joint_velocity_max=qd_max,
        torque_max=limits.spindle_torque_nm, power_max=limits.spindle_power_w,
        positions=placement.positions,
        compensation_cap=(np.inf if defl.compensation_cap_mm is None
                          else defl.compensation_cap_mm * MM),
        wall_limit=wall_limit, floor_limit=floor_limit,
        **orientation_inputs(path, samples, limits),
        progress=progress,
    ))
    problem = ScheduleProblem(
        s=samples.s,
        v_max=bound.v_max,
        q=along.ik.q,
        dq_ds=dq_ds,
        d2q_ds2=along.d2q_ds2,
        joint_velocity_max=qd_max,
        joint_acceleration_max=qdd_max,
        accel_max=limits.tangential_acceleration_mm_s2 * MM,
        jerk_max=limits.tangential_jerk_mm_s3 * MM,
        nominal_feed=feed.nominal_mm_s * MM,
        v_start=feed.start_mm_s * MM,
        v_end=feed.end_mm_s * MM,
        segment_start=path.segment_start,
        segment_kind=path.segment_kind,
        key_point_spacing=sched.key_point_spacing_mm * MM,
        programmed_feed=(None if programmed is None else np.minimum(np.minimum(
            programmed, bound.parts.get("joint_velocity", np.inf)),
            bound.parts.get("orientation", np.inf))),
        stops=stop_samples(path.stops, samples.s),
        orientation=path.orientation,
        orientation_rate_max=_rad(limits.orientation_rate_deg_s),
        orientation_acceleration_max=_rad(limits.orientation_acceleration_deg_s2),
    )
    # Once, before any law, naming the scenario's fields (every law repeats it for itself).
    check_boundary_feeds("run", problem, rtol=1e-9, names=("feed.start_mm_s", "feed.end_mm_s"),
                         who="feed")
    return ScheduleInputs(model=model, bound=bound, problem=problem, limit=limit,
                          wall_limit=wall_limit, floor_limit=floor_limit)


def _rad(deg: float | None) -> float:
    return np.inf if deg is None else float(np.radians(deg))


def orientation_inputs(path, samples, limits) -> dict:
    """The feed bound's inputs of the orientation limits (``BoundInputs``): the tool
    vector's largest rates near each sample on a five-axis path, the limits in SI."""
    if path.orientation is None:
        return {}
    rate, curvature = path.orientation.peaks(samples.s)
    return {"axis_rate": rate, "axis_curvature": curvature,
            "orientation_rate_max": _rad(limits.orientation_rate_deg_s),
            "orientation_acceleration_max": _rad(limits.orientation_acceleration_deg_s2),
            "accel_max": limits.tangential_acceleration_mm_s2 * MM}


def bounds_line(schedule: ScheduleInputs, moves, s: np.ndarray, seconds: float) -> str:
    """The run's progress line of the bound: its range, T*, the share of each active
    constraint and, on a program (``moves``: the path's program tables, else None), the line
    where it is lowest."""
    v_max = schedule.bound.v_max
    share = ", ".join(f"{k} {v:.0%}" for k, v in schedule.bound.active_fraction().items()
                      if v > 0)
    if moves is not None:  # where a program's bound is lowest, by its line
        share += f"; lowest at {moves.label(moves.lowest_cut(s, v_max)[1])}"
    return (f"[4/5] bounds: v_max {v_max.min() / MM:.3f}-{v_max.max() / MM:.3f} "
            f"mm/s, T* = {schedule.problem.lower_bound_time():.2f} s; active: {share} "
            f"({seconds:.2f} s)")
