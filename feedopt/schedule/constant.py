"""The ``constant`` timing law: the nominal feed everywhere (the thesis baseline).

The tool is brought from ``v_start`` to the nominal feed and back to ``v_end`` by C2 ramps
inside the tangential acceleration and jerk limits: either the quintic of Eq. 3.21-3.22 with
zero end accelerations (default) or a jerk-limited S-curve. The feed bound ``v_max`` is
ignored on purpose (the thesis ran at the nominal feed and measured the deflection it gave);
the law measures how far it exceeds the bound and says so in ``notes``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from feedopt.errors import InputError, LawNotApplicable
from feedopt.schedule.joints import interval_peaks
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.quintic import (
    QuinticPieces,
    fit_length,
    ppoly_from_jerk_phases,
    quintic_ramp_duration,
    scurve_distance,
    scurve_times,
)
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM

# Bisection steps when the cruise feed is lowered so that both ramps fit (exact to rounding).
_CRUISE_BISECTION_STEPS = 100


class ConstantOptions(BaseModel):
    """Tunables of the ``constant`` law."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    ramp: Literal["quintic", "jerk"] = Field(
        "quintic",
        description="start/stop ramp: quintic (Eq. 3.22 with zero end accelerations, the "
        "shortest smoothstep meeting the limits) or jerk (bang-zero-bang jerk S-curve, needs "
        "finite tangential acceleration and jerk limits)",
    )


@dataclass(frozen=True)
class ConstantStats(LawStats):
    """What the ``constant`` law reports (``as_dict()``: its summary.json entry)."""

    cruise_feed_mm_s: float
    ramp: str
    ramp_lengths_mm: tuple[float, float]
    max_feed_ratio: float
    #: the path was too short for the nominal feed: the cruise feed was lowered
    cruise_lowered: bool = outcome(False)
    #: sample where the feed is highest relative to v_max
    worst_sample: int = outcome(0)

    @property
    def exceeds_bound(self) -> bool:
        """The feed goes above v_max (expected: the baseline ignores the bound)."""
        return self.max_feed_ratio > 1.0 + 1e-9


def _ramp_lengths(v0: float, v: float, v1: float, problem: ScheduleProblem, ramp: str):
    if ramp == "quintic":
        t_up = float(quintic_ramp_duration(v0, v, problem.accel_max, problem.jerk_max))
        t_dn = float(quintic_ramp_duration(v, v1, problem.accel_max, problem.jerk_max))
        return 0.5 * (v0 + v) * t_up, 0.5 * (v + v1) * t_dn
    return (
        scurve_distance(v0, v, problem.accel_max, problem.jerk_max),
        scurve_distance(v, v1, problem.accel_max, problem.jerk_max),
    )


def _check_inputs(problem: ScheduleProblem, ramp: str) -> None:
    """Refuse limits the ramps cannot be planned with (InputError)."""
    limited = np.isfinite(problem.accel_max) or np.isfinite(problem.jerk_max)
    if ramp == "jerk" and not (np.isfinite(problem.accel_max) and np.isfinite(problem.jerk_max)):
        raise InputError("constant law: ramp='jerk' needs finite accel_max and jerk_max")
    no_ramp = problem.v_start == problem.nominal_feed == problem.v_end
    if not limited and not no_ramp:
        raise InputError("constant law: ramps need a finite accel_max or jerk_max")
    if problem.nominal_feed <= 0:
        raise InputError(f"constant law: nominal_feed must be > 0, got {problem.nominal_feed}")


def _cruise_feed(problem: ScheduleProblem, ramp: str) -> tuple[float, bool]:
    """The nominal feed, or the largest lower feed whose two ramps fit in the path.

    Returns ``(feed [m/s], lowered)``.
    """
    v0, v1, L = problem.v_start, problem.v_end, problem.length
    v = problem.nominal_feed
    if sum(_ramp_lengths(v0, v, v1, problem, ramp)) <= L:
        return v, False
    # Lower the cruise feed until both ramps fit (ramp length grows with the feed).
    lo, hi = max(v0, v1), v
    if sum(_ramp_lengths(v0, lo, v1, problem, ramp)) > L:
        raise InputError(
            f"constant law: the path ({L / MM:.3f} mm) is too short to change the feed "
            f"from v_start={v0 / MM:.4g} to v_end={v1 / MM:.4g} mm/s within the limits"
        )
    for _ in range(_CRUISE_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if sum(_ramp_lengths(v0, mid, v1, problem, ramp)) > L:
            hi = mid
        else:
            lo = mid
    return lo, True


def _timing(problem: ScheduleProblem, v: float, h_up: float, h_dn: float, ramp: str):
    """s(t): ramp up to ``v``, cruise, ramp down (quintic pieces or jerk phases)."""
    v0, v1, L = problem.v_start, problem.v_end, problem.length
    cruise = max(L - h_up - h_dn, 0.0)
    if cruise <= 1e-9 * L:  # no cruise left: drop it (fit_length absorbs the rest)
        cruise = 0.0
    if ramp == "quintic":
        t_up = float(quintic_ramp_duration(v0, v, problem.accel_max, problem.jerk_max))
        t_dn = float(quintic_ramp_duration(v, v1, problem.accel_max, problem.jerk_max))
        h = np.array([h_up, cruise, h_dn])
        T = np.array([t_up, cruise / v, t_dn])
        vs = np.array([v0, v, v])
        vf = np.array([v, v, v1])
        keep = h > 0
        s0 = np.concatenate([[0.0], np.cumsum(h)[:-1]])
        zeros = np.zeros(int(keep.sum()))
        pieces = QuinticPieces(
            s0=s0[keep], h=h[keep], v0=vs[keep], vf=vf[keep], a0=zeros, af=zeros, T=T[keep]
        )
        pp = pieces.ppoly()
    else:
        A, J = problem.accel_max, problem.jerk_max
        tj1, ta1 = scurve_times(v - v0, A, J)
        tj2, ta2 = scurve_times(v1 - v, A, J)
        g1 = 1.0 if v >= v0 else -1.0
        g2 = 1.0 if v1 >= v else -1.0
        durations = [tj1, ta1, tj1, cruise / v, tj2, ta2, tj2]
        jerks = [g1 * J, 0.0, -g1 * J, 0.0, g2 * J, 0.0, -g2 * J]
        pp = ppoly_from_jerk_phases(np.array(durations), np.array(jerks), v0=v0)
    return fit_length(pp, problem.length)


def _check_robot_can_cruise(problem: ScheduleProblem, v: float) -> None:
    """Decline when the robot's joints cannot run the path at the constant feed ``v``.

    The baseline ignores the deflection bound by design, not the robot: at constant feed the
    joint rates are |dq/ds| v and |d2q/ds2| v^2 (no tangential acceleration), which must stay
    within the joint velocity and acceleration limits. Checked with their bounds around each
    sample (:meth:`~feedopt.schedule.joints.IntervalPeaks.at_samples`: between the samples
    too), before any trajectory is built.
    """
    dq, d2q = interval_peaks(problem).at_samples(problem)
    qd = dq * v / problem.joint_velocity_max
    qdd = d2q * v * v / problem.joint_acceleration_max
    for what, ratio, limit, unit, power in (
        ("velocity", qd, problem.joint_velocity_max, "deg/s", 1),
        ("acceleration", qdd, problem.joint_acceleration_max, "deg/s^2", 2),
    ):
        k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        if ratio[k, j] > 1 + 1e-9:
            need = ratio[k, j] * limit[j]
            raise LawNotApplicable(
                f"constant law: at the nominal feed {v / MM:.4g} mm/s joint {j + 1} would need "
                f"{np.rad2deg(need):.4g} {unit}, {ratio[k, j]:.3g} x its {what} limit "
                f"{np.rad2deg(limit[j]):.4g} {unit}, at s = {problem.s[k] / MM:.3f} mm "
                f"(sample {k}). The baseline ignores the deflection limit by design, not the "
                f"robot's joint limits: a feed of at most "
                f"{v / ratio[k, j] ** (1.0 / power) / MM:.4g} mm/s runs (feed.nominal_mm_s)")
    _check_orientation_can_cruise(problem, v)


def _check_orientation_can_cruise(problem: ScheduleProblem, v: float) -> None:
    """Decline when the tool vector of a five-axis path would turn faster than its limits at
    the constant feed ``v`` (rate |u'| v; acceleration |u''| v^2 + |u'| a_max, the ramps'
    tangential acceleration included), with the peaks around each sample."""
    if problem.orientation is None:
        return
    rate, curvature = problem.orientation.peaks(problem.s)
    for what, need, limit, unit in (
        ("rate", rate * v, problem.orientation_rate_max, "deg/s"),
        ("acceleration", curvature * v * v + rate * problem.accel_max,
         problem.orientation_acceleration_max, "deg/s^2"),
    ):
        k = int(np.argmax(need))
        if need[k] > limit * (1 + 1e-9):
            raise LawNotApplicable(
                f"constant law: at the nominal feed {v / MM:.4g} mm/s the tool axis would turn "
                f"at {np.rad2deg(need[k]):.4g} {unit}, {need[k] / limit:.3g} x the orientation "
                f"{what} limit {np.rad2deg(limit):.4g} {unit} (limits.orientation_{what}_"
                f"{'deg_s' if what == 'rate' else 'deg_s2'}), at s = {problem.s[k] / MM:.3f} mm"
                f" (sample {k}); the baseline ignores the deflection limit, not the tool's")


def plan_constant(problem: ScheduleProblem, options: ConstantOptions | None = None) -> Trajectory:
    """Nominal feed with C2 start/stop ramps.

    Parameters
    ----------
    problem : ScheduleProblem
        Uses ``nominal_feed``, ``v_start``, ``v_end``, ``accel_max``, ``jerk_max``, ``length``.
    options : ConstantOptions, optional
        ``ramp``: ``quintic`` (Eq. 3.22 with zero end accelerations and the shortest duration
        meeting the limits, smoothstep velocity) or ``jerk`` (bang-zero-bang jerk S-curve,
        needs finite ``accel_max`` and ``jerk_max``). Default: :class:`ConstantOptions`.

    Returns
    -------
    Trajectory
        ``law="constant"``, ``continuity=2``, :class:`ConstantStats`. If the path is too
        short to reach the nominal feed, the cruise feed is lowered until the two ramps fit
        (``stats.cruise_lowered``, and said in ``notes``).
    """
    options = ConstantOptions() if options is None else options
    if problem.programmed_feed is not None:
        raise LawNotApplicable("a G-code program has a feed per move and rapids; the constant "
                               "law runs one feed: its baseline is the programmed law")
    ramp = options.ramp
    _check_inputs(problem, ramp)
    notes: list[str] = []
    v, lowered = _cruise_feed(problem, ramp)
    _check_robot_can_cruise(problem, v)
    if lowered:
        notes.append(
            f"path too short to reach the nominal feed {problem.nominal_feed / MM:.4g} mm/s: "
            f"cruise feed lowered to {v / MM:.4g} mm/s"
        )
    h_up, h_dn = _ramp_lengths(problem.v_start, v, problem.v_end, problem, ramp)
    pp = _timing(problem, v, h_up, h_dn, ramp)
    traj = Trajectory(law="constant", timing=pp, continuity=2, notes=tuple(notes))
    # feed on the samples: exactly v while cruising, the exact inverse of s(t) on the ramps
    feed = np.full(problem.n, v)
    ramps = (problem.s < h_up) | (problem.s > problem.length - h_dn)
    feed[ramps] = traj.feed_at(problem.s[ramps])
    ratio = feed / problem.v_max
    worst = int(np.argmax(ratio))
    stats = ConstantStats(
        cruise_feed_mm_s=v / MM,
        ramp=ramp,
        ramp_lengths_mm=(h_up / MM, h_dn / MM),
        max_feed_ratio=float(ratio[worst]),
        cruise_lowered=lowered,
        worst_sample=worst,
    )
    if stats.exceeds_bound:
        notes.append(
            f"ignores the feed bound by design: the feed reaches {ratio[worst]:.4f} x v_max "
            f"(at s = {problem.s[worst] / MM:.3f} mm, sample {worst}); the deflection limit "
            f"is violated there"
        )
    return Trajectory(law="constant", timing=pp, continuity=2, notes=tuple(notes), stats=stats)
