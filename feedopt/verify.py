"""Replay verification of a trajectory: what will the robot feel at the feed we command?

For every path sample the feed actually commanded by the trajectory (s(t) inverted exactly)
is turned into a feed per tooth, the milling force F = c Fc + Fe is recomputed over a cutter
revolution, rotated into the base frame and multiplied by the robot's compliance; the
largest deflection must stay within the limit (1e-6 relative). The kinematic part
(:func:`feedopt.schedule.checks.check_timing`) checks the feed bound, tangential
acceleration and jerk, joint limits (everywhere along the trajectory: q(s(t)) is replayed
between the samples too, where a corner shorter than a sample makes the joint accelerations
peak), boundary feeds and C2 continuity with numbers.

Two verdicts come out. ``verified``: the law kept every promise it makes (the constant
baseline does not promise the deflection limit; topp does not promise C2). ``exportable``:
the trajectory meets what every exported trajectory must meet (deflection within the limit,
C2, jerk within its limit); only exportable trajectories are written for the controller
unless the user explicitly asks for the others.

Every message (problems, warnings, export blockers) is in user units (mm, mm/s, mm/s^2,
mm/s^3) with the unit written, limits included.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from feedopt.schedule.checks import TimingCheck, Violation, check_timing
from feedopt.schedule.deflection import DeflectionModel
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.stops import stitched_ramps
from feedopt.schedule.surface import SurfaceErrors, part_samples, surface_errors
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM


def _spec(law: str):
    from feedopt.schedule.laws import LAWS

    return LAWS.get(law)


def is_baseline(law: str) -> bool:
    """True for a law that ignores the deflection bound by design (registry metadata): its
    exceedance is measured and reported, but it is the expected result, not a failure."""
    spec = _spec(law)
    return bool(spec is not None and spec.baseline)


class Verdict(Enum):
    """Outcome of replaying a trajectory."""

    EXPORTABLE = "verified, exportable"  # kept its promises and meets the export rules
    VERIFIED = "verified, not exportable"  # kept its promises (a baseline, a C1 law)
    FAILED = "FAILED VERIFICATION"  # broke a promise it makes


@dataclass(frozen=True)
class Verification:
    """Outcome of replaying one trajectory.

    ``verified`` is True when the law met every constraint it is responsible for;
    ``meets_limit`` says whether the predicted deflection stays within the limit.
    """

    law: str
    timing: TimingCheck
    feed: np.ndarray
    deflection: np.ndarray
    limit: float
    worst_sample: int
    meets_limit: bool
    verified: bool
    problems: tuple[str, ...]
    warnings: tuple[str, ...]
    export_blockers: tuple[str, ...] = ()
    surface: SurfaceErrors | None = None  # predicted wall/floor errors at this feed
    tolerances: tuple[float, float] = (np.inf, np.inf)  # (wall, floor) limits, mode surface

    @property
    def exportable(self) -> bool:
        """Deflection within the limit, C2 and jerk-bounded, and verified."""
        return self.verified and not self.export_blockers

    @property
    def verdict(self) -> Verdict:
        if not self.verified:
            return Verdict.FAILED
        return Verdict.EXPORTABLE if self.exportable else Verdict.VERIFIED

    @property
    def max_deflection(self) -> float:
        return float(self.deflection[self.worst_sample])

    @property
    def deflection_ratio(self) -> float:
        return self.max_deflection / self.limit


def verify_trajectory(
    trajectory: Trajectory,
    problem: ScheduleProblem,
    model: DeflectionModel,
    limit: float,
    rtol: float = 1e-6,
    deflection: np.ndarray | None = None,
    sample_times: np.ndarray | None = None,
) -> Verification:
    """Replay ``trajectory`` on the path samples of ``problem`` and check every constraint.

    ``deflection`` may carry ``model.deflection(trajectory.feed_at(problem.s))`` already
    computed (the runner replays all laws in one pass over the forces); otherwise it is
    computed here. ``sample_times`` may carry ``trajectory.time_at(problem.s)``. A trajectory
    planned between stops gets the start and stop ramps of its first and last piece and the
    smallest cutting feed of its pieces (:func:`feedopt.schedule.stops.stitched_ramps`).
    """
    baseline = is_baseline(trajectory.law)
    if not is_finite(trajectory):
        return _non_finite(trajectory, problem, limit)
    if sample_times is None:
        sample_times = trajectory.time_at(problem.s)
    timing = check_timing(trajectory, problem, rtol=rtol, enforce_feed_bound=not baseline,
                          sample_times=sample_times)
    ramps = stitched_ramps(trajectory, problem, follow_bound=not baseline)
    if ramps is not None:  # planned between stops: ramps and cutting feed of its pieces
        timing = replace(timing, start_ramp=ramps[0], stop_ramp=ramps[1],
                         min_cutting_feed=ramps[2])
    feed = trajectory.timing.derivative(1)(sample_times)  # feed_at(problem.s)
    if deflection is None:
        deflection = model.deflection(np.maximum(feed, 0.0))
    worst = int(np.argmax(deflection))
    meets = bool(deflection[worst] <= limit * (1 + rtol))
    problems = list(timing.problems)
    spec = _spec(trajectory.law)
    if spec is not None and trajectory.continuity < spec.continuity:
        problems.append(f"the {trajectory.law} law promises C{spec.continuity} but returned a "
                        f"C{trajectory.continuity} trajectory")
    warnings: list[str] = list(trajectory.notes)
    if not meets:
        msg = (
            f"predicted deflection {deflection[worst] / MM:.4f} mm exceeds the limit "
            f"{limit / MM:.4f} mm (ratio {deflection[worst] / limit:.4f}) at sample {worst}, "
            f"s = {problem.s[worst] / MM:.2f} mm"
        )
        if baseline:
            warnings.append(msg + " (expected: this baseline ignores the limit)")
        else:
            problems.append(msg)
    blockers = []
    if not meets:
        blockers.append(f"deflection reaches {deflection[worst] / MM:.4f} mm, "
                        f"{deflection[worst] / limit:.4f} x the limit {limit / MM:.4g} mm")
    if not timing.c2:
        blockers.append(
            f"not C2: the acceleration jumps by up to {timing.accel_jump / MM:.4g} mm/s^2, "
            "so the jerk is unbounded"
        )
    elif np.isfinite(problem.jerk_max) and timing.max_jerk > problem.jerk_max * (1 + rtol):
        blockers.append(f"jerk {timing.max_jerk / MM:.4g} mm/s^3 exceeds the limit "
                        f"{problem.jerk_max / MM:.4g} mm/s^3")
    return Verification(
        law=trajectory.law,
        timing=timing,
        feed=feed,
        deflection=deflection,
        limit=limit,
        worst_sample=worst,
        meets_limit=meets,
        verified=not problems,
        problems=tuple(problems),
        warnings=tuple(warnings),
        export_blockers=tuple(blockers),
    )


def is_finite(trajectory: Trajectory, max_duration: float = 1e7) -> bool:
    """True when s(t) has finite coefficients and a finite, sane duration."""
    return bool(
        np.all(np.isfinite(trajectory.timing.c))
        and np.all(np.isfinite(trajectory.timing.x))
        and 0 < trajectory.duration < max_duration
    )


def _non_finite(trajectory: Trajectory, problem: ScheduleProblem, limit: float) -> Verification:
    nan = np.full(problem.n, np.nan)
    msg = (f"the {trajectory.law} law produced a non-finite trajectory (duration "
           f"{trajectory.duration!r} s): nothing to replay")
    timing = TimingCheck(
        duration=trajectory.duration, lower_bound=problem.lower_bound_time(),
        feed_ratio=np.nan, worst_sample=0, max_feed=np.nan, min_cutting_feed=np.nan,
        max_accel=np.nan, max_jerk=np.nan, velocity_jump=np.nan, accel_jump=np.nan, c2=False,
        joint_velocity_ratio=np.nan, joint_acceleration_ratio=np.nan, start_feed=np.nan,
        end_feed=np.nan, problems=(msg,), violations=Violation.NON_FINITE,
    )
    return Verification(
        law=trajectory.law, timing=timing, feed=nan, deflection=nan, limit=limit,
        worst_sample=0, meets_limit=False, verified=False, problems=(msg,),
        warnings=tuple(trajectory.notes), export_blockers=(msg,),
    )


def check_surface(ver: Verification, surface: SurfaceErrors,
                  tolerances: tuple[float, float], rtol: float = 1e-6) -> Verification:
    """``ver`` with the replayed surface errors (:mod:`feedopt.schedule.surface`) and, for
    finite part tolerances (mode surface), their check: a law over a tolerance breaks its
    promise (a baseline is only warned about) and is not exported."""
    wall_limit, floor_limit = tolerances
    problems, warnings, blockers = list(ver.problems), list(ver.warnings), list(
        ver.export_blockers)
    broken = False
    worst = surface.worst_wall()
    for what, field, values, limit in (
            ("wall", "wall_limit_mm", worst, wall_limit),
            ("floor", "floor_limit_mm", np.abs(surface.floor), floor_limit)):
        if not np.isfinite(limit) or np.all(np.isnan(values)):
            continue
        i = int(np.nanargmax(values))
        if values[i] <= limit * (1 + rtol):
            continue
        msg = (f"predicted {what} error {values[i] / MM:.4f} mm exceeds "
               f"deflection.{field} {limit / MM:.4f} mm (ratio {values[i] / limit:.4f}) at "
               f"sample {i}")
        if is_baseline(ver.law):
            warnings.append(msg + " (expected: this baseline ignores the limit)")
        else:
            problems.append(msg)
            broken = True
        blockers.append(msg)
    return replace(ver, surface=surface, tolerances=tolerances, problems=tuple(problems),
                   warnings=tuple(warnings), export_blockers=tuple(blockers),
                   verified=ver.verified and not broken)


def replay_all(trajectories: dict[str, Trajectory], problem: ScheduleProblem,
               model: DeflectionModel, limit: float, progress=None,
               tolerances: tuple[float, float] = (np.inf, np.inf)
               ) -> dict[str, tuple[Verification, float]]:
    """Verify every trajectory, replaying the forces of all of them in one pass, and the
    surface errors of all of them in another (checked against ``tolerances`` (wall, floor)
    [m] where finite: :func:`check_surface`).

    Returns ``{law: (verification, seconds)}``; the shared force pass is split evenly among
    the laws that could be replayed. ``progress(samples_done, samples)`` follows the replay.
    """
    import time

    t0 = time.perf_counter()
    replayable = [law for law, traj in trajectories.items() if is_finite(traj)]
    replay, surfaces = {}, {}
    # the samples' times, found once per law (an inverse of s(t) at every sample)
    times = {law: trajectories[law].time_at(problem.s) for law in replayable}
    if replayable:
        feeds = np.stack([np.maximum(trajectories[law].timing.derivative(1)(times[law]), 0.0)
                          for law in replayable])
        replay = dict(zip(replayable, model.deflection(feeds, progress), strict=True))
        # every sample where a part tolerance is checked, else where the part is measured
        e = model.engagement
        index = (None if np.isfinite(tolerances).any()
                 else part_samples(problem.s, e.exit > e.entry))
        fixed_axis = np.ptp(model.frames[:, :, 2], axis=0).max() <= 1e-12
        # a flat end mill's wall/floor along its z, from one interval per sample (an
        # engagement found per slice in a tri-dexel stock has no such wall model)
        if model.tool.is_flat and fixed_axis and e.by_slice is None:
            surfaces = dict(zip(replayable, surface_errors(model, feeds, index), strict=True))
        elif np.isfinite(tolerances).any():  # refused upstream (process stage): a bug here
            raise ValueError(f"part tolerances need a flat end mill; the tool is a "
                             f"{model.tool.shape.value} cutter")
    shared = (time.perf_counter() - t0) / max(len(replayable), 1)
    out = {}
    for law, traj in trajectories.items():
        t1 = time.perf_counter()
        ver = verify_trajectory(traj, problem, model, limit, deflection=replay.get(law),
                                sample_times=times.get(law))
        if law in surfaces:
            ver = check_surface(ver, surfaces[law], tolerances)
        out[law] = (ver, shared + time.perf_counter() - t1)
    return out
