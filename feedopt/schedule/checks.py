"""Kinematic checks of a trajectory against its problem (used by laws' tests and verify.py).

Everything is evaluated on the path samples (never only on a solver grid) and at the
polynomial breakpoints, where continuity is measured as left/right jumps; the joint velocities
and accelerations also between the samples (:func:`feedopt.schedule.joints.dense_joint_extrema`:
q(s(t)) replayed on every sample interval where they can exceed their values at the samples,
its maximum refined), since a corner shorter than a sample makes them peak there. Numbers are SI
inside; every problem string is in user units (mm, mm/s, mm/s^2, mm/s^3, deg/s) with the
unit written, limits included.

Start and stop ramps (:class:`Ramp`, :func:`find_ramps`) are defined on the trajectory
itself, not on the samples, so they do not depend on the sample spacing: the start ramp runs
from s = 0 to the first instant at which the feed stops increasing (sddot <= 0) or reaches the
feed bound v_max(s) (within :data:`BOUND_REACHED_RTOL`, the ramp then ends with the polynomial
piece in which that happens), whichever comes first; the stop ramp is the same seen backwards
from the end of the path. ``min_cutting_feed`` is the smallest feed between the two ramps.

What :func:`check_timing` finds violated is typed (:class:`Violation` flags beside the problem
strings). The input checks every law shares are here too: :func:`check_boundary_feeds` (the
start and end feeds against the bound) and :func:`check_positive_bound`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from feedopt.errors import InputError
from feedopt.schedule.joints import DenseJoints, dense_joint_extrema
from feedopt.schedule.orientation_limits import OrientationExtrema, dense_orientation_extrema
from feedopt.schedule.polynomial import horner, sample_piece_chunks, sample_pieces
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM

# Evaluation points per polynomial piece for the extrema of acceleration and jerk.
_POINTS_PER_PIECE = 9
#: A ramp "reaches the bound" where sdot >= (1 - BOUND_REACHED_RTOL) v_max(s).
BOUND_REACHED_RTOL = 1e-3
# Acceleration below this fraction of max |sddot| counts as zero (the feed is flat).
_FLAT_ACCEL_RTOL = 1e-9
# Events (breakpoints, acceleration roots) closer than this fraction of the duration merge.
_EVENT_TOL = 1e-12
# Points per event interval where a ramp is compared with the bound.
_BOUND_POINTS = 8
#: Relative slack with which a law accepts a boundary feed at the bound (rounding of inputs).
BOUNDARY_FEED_RTOL = 1e-12


class Violation(enum.Flag):
    """What a :class:`TimingCheck` found violated; one flag per kind of problem string.

    Code tests the flags (``Violation.REVERSAL in check.violations``), people read
    ``problems``; every problem string comes with its flag.
    """

    NONE = 0
    FEED_BOUND = enum.auto()  #: sdot > v_max on a sample
    ACCELERATION = enum.auto()  #: |sddot| > accel_max
    JERK = enum.auto()  #: |sdddot| > jerk_max (C2 laws)
    REVERSAL = enum.auto()  #: sdot < 0: the tool would move backwards
    C2 = enum.auto()  #: claims C2 but the acceleration jumps
    JOINT_VELOCITY = enum.auto()
    JOINT_ACCELERATION = enum.auto()
    ORIENTATION_RATE = enum.auto()  #: the tool vector turns faster than its limit
    ORIENTATION_ACCELERATION = enum.auto()
    START_FEED = enum.auto()  #: the feed at t = 0 is not v_start
    END_FEED = enum.auto()  #: the feed at the end is not v_end
    LENGTH = enum.auto()  #: s(t) does not cover the path
    NON_FINITE = enum.auto()  #: the trajectory has non-finite coefficients (nothing checked)


def check_boundary_feeds(
    law: str,
    problem: ScheduleProblem,
    start_bound: float | None = None,
    end_bound: float | None = None,
    rtol: float = BOUNDARY_FEED_RTOL,
    names: tuple[str, str] = ("v_start", "v_end"),
    who: str | None = None,
) -> None:
    """Refuse boundary feeds a law cannot start or end at: the check every law shares.

    The runner makes the same check once before planning, naming the scenario fields
    (``names``) and itself (``who``, default ``"<law> law"``).

    ``v_start`` and ``v_end`` must lie in ``[0, bound (1 + rtol)]``, where the bound at each
    end is ``v_max`` at the first / last sample unless the law passes a tighter one (toppra and
    the SOCP fold the joint velocity limits in, the jerk law its first / last section cap).

    Raises
    ------
    InputError
        Naming the law, the boundary feed, the bound and the sample, in mm/s.
    """
    bounds = (
        float(problem.v_max[0]) if start_bound is None else float(start_bound),
        float(problem.v_max[-1]) if end_bound is None else float(end_bound),
    )
    for name, where, k, v, bound in (
        (names[0], "start", 0, problem.v_start, bounds[0]),
        (names[1], "end", problem.n - 1, problem.v_end, bounds[1]),
    ):
        if v < 0 or v > bound * (1 + rtol):
            raise InputError(
                f"{who or law + ' law'}: {name} = {v / MM:.6g} mm/s is outside "
                f"[0, {bound / MM:.6g}] mm/s, "
                f"the feed bound at the path {where} (sample {k})"
            )


def check_positive_bound(law: str, problem: ScheduleProblem, bound: np.ndarray) -> None:
    """Refuse a per-sample feed bound that is not positive (or NaN) somewhere (InputError)."""
    bad = ~(np.asarray(bound) > 0)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise InputError(
            f"{law} law: the feed bound is {bound[k] / MM:.6g} mm/s at sample {k} "
            f"(s = {problem.s[k] / MM:.3f} mm); every sample needs a positive bound"
        )


@dataclass(frozen=True)
class Ramp:
    """A start or stop ramp of a trajectory (see the module docstring for the definition).

    ``s_from``..``s_to`` [m] and ``t_from``..``t_to`` [s] delimit it; ``feed`` [m/s] is the
    feed it reaches (start ramp: at ``t_to``) or leaves from (stop ramp: at ``t_from``);
    ``reason`` says why it ends there: ``"flat"`` (the feed stops increasing, or for a stop
    ramp starts decreasing), ``"bound"`` (the feed meets v_max) or ``"path"`` (the ramp is the
    whole path).
    """

    s_from: float
    s_to: float
    t_from: float
    t_to: float
    feed: float
    reason: str = "flat"

    @property
    def length(self) -> float:
        """Arc length of the ramp [m]."""
        return self.s_to - self.s_from

    @property
    def duration(self) -> float:
        """Duration of the ramp [s]."""
        return self.t_to - self.t_from

    @classmethod
    def nan(cls) -> Ramp:
        """A ramp of a trajectory that could not be evaluated."""
        return cls(np.nan, np.nan, np.nan, np.nan, np.nan, "none")


@dataclass(frozen=True)
class TimingCheck:
    """Numbers that say whether a timing law respects the bounds it was given.

    SI units. ``feed_ratio`` is max over samples of sdot / v_max (<= 1 + rtol to pass);
    ``joint_velocity_ratio`` and ``joint_acceleration_ratio`` are the largest |joint rate| /
    limit anywhere along the trajectory (the dense replay, not only the samples). Jumps
    are the largest left/right differences at interior breakpoints; ``c2`` says the
    acceleration jump is at numerical-noise level. ``min_cutting_feed`` is the smallest feed
    of the trajectory between ``start_ramp`` and ``stop_ramp`` (exact: taken at the
    breakpoints and the roots of sddot, not on the samples); if the ramps meet, the feed
    where they meet.
    """

    duration: float
    lower_bound: float
    feed_ratio: float
    worst_sample: int
    max_feed: float
    min_cutting_feed: float
    max_accel: float
    max_jerk: float
    velocity_jump: float
    accel_jump: float
    c2: bool
    joint_velocity_ratio: float
    joint_acceleration_ratio: float
    start_feed: float
    end_feed: float
    start_ramp: Ramp = field(default_factory=Ramp.nan)
    stop_ramp: Ramp = field(default_factory=Ramp.nan)
    problems: tuple[str, ...] = field(default_factory=tuple)
    violations: Violation = Violation.NONE
    #: five-axis paths: the replay's largest orientation rate and acceleration (None else)
    orientation: OrientationExtrema | None = None

    @property
    def ok(self) -> bool:
        """True when no bound is violated."""
        return not self.problems


def breakpoint_jumps(trajectory: Trajectory, order: int) -> np.ndarray:
    """|left - right| of the ``order``-th derivative of s(t) at each interior breakpoint."""
    pp = trajectory.timing
    if pp.x.size <= 2:
        return np.zeros(0)
    d = pp.derivative(order) if order > 0 else pp
    if d.c.shape[0] == 0:
        return np.zeros(pp.x.size - 2)
    h = np.diff(pp.x)[:-1]
    # left limit: end of piece i evaluated at h_i; right limit: constant term of piece i+1
    left = horner(d.c[:, :-1], h)
    right = d.c[-1, 1:]
    return np.abs(left - right)


def _events(trajectory: Trajectory) -> np.ndarray:
    """Breakpoints and roots of sddot, sorted, near-duplicates merged: between two
    consecutive events sddot has one sign."""
    pp = trajectory.timing
    x = pp.x
    if pp.c.shape[0] > 2:
        roots = pp.derivative(2).roots(discontinuity=False, extrapolate=False)
        roots = roots[np.isfinite(roots) & (roots > x[0]) & (roots < x[-1])]
    else:
        roots = np.zeros(0)
    ev = np.unique(np.concatenate([x, roots]))
    keep = np.concatenate([[True], np.diff(ev) > _EVENT_TOL * max(x[-1] - x[0], 1e-300)])
    keep[-1] = True
    ev = ev[keep]
    if ev.size >= 3 and ev[-1] - ev[-2] <= _EVENT_TOL * (x[-1] - x[0]):
        ev = np.delete(ev, -2)  # the end must stay, its near twin goes
    return ev


def _bound_reached(trajectory: Trajectory, problem: ScheduleProblem, ev: np.ndarray,
                   first: bool) -> float | None:
    """Where a ramp over the events ``ev`` meets the feed bound, or None if it does not.

    The feed is compared with ``(1 - BOUND_REACHED_RTOL) v_max(s)`` at :data:`_BOUND_POINTS`
    points per event interval. ``first``: the end of the first event interval in which it
    gets there (the feed rises to the bound until the interval ends); otherwise the start of
    the last such interval (for the stop ramp, seen backwards).
    """
    pp = trajectory.timing
    grid = sample_pieces(ev, _BOUND_POINTS, endpoint=False)
    s = np.clip(pp(grid), problem.s[0], problem.s[-1])
    gap = pp.derivative(1)(grid) - (1.0 - BOUND_REACHED_RTOL) * np.interp(
        s, problem.s, problem.v_max)
    at = np.flatnonzero(gap >= 0.0)
    if at.size == 0:
        return None
    if first:
        return float(ev[np.searchsorted(ev, grid[at[0]], side="left")])
    return float(ev[np.searchsorted(ev, grid[at[-1]], side="right") - 1])


def find_ramps(
    trajectory: Trajectory, problem: ScheduleProblem, follow_bound: bool = True
) -> tuple[Ramp, Ramp, float]:
    """Start ramp, stop ramp and the minimum feed between them (the cutting feed).

    Definition (independent of the sample spacing: only the polynomial s(t) and v_max(s),
    linear between samples, enter):

    - **start ramp**: from t = 0 to the first instant at which the feed stops increasing
      (sddot <= 0, i.e. a plateau or a maximum of the feed; found exactly at the roots of
      sddot and at breakpoints) or, if ``follow_bound``, reaches the feed bound
      (sdot >= (1 - :data:`BOUND_REACHED_RTOL`) v_max(s)), whichever comes first. In the
      second case the ramp ends with the event interval (polynomial piece, or stretch between
      roots of sddot) in which the feed gets there, so it reaches the bound itself rather
      than 0.1 % below it, and a law that then follows a rising bound (topp, convex) is not
      counted as ramping all along;
    - **stop ramp**: the same seen backwards from the end: from the last instant at which
      the feed stops decreasing towards the end or is at the bound, to the end;
    - **cutting feed**: the minimum of sdot(t) between the two ramps, exact (at breakpoints
      and roots of sddot, where the extrema of sdot lie); if the ramps meet, the feed there.

    ``follow_bound=False`` is for the constant baseline, which ignores the bound: its ramps
    end where its feed levels off.
    """
    pp = trajectory.timing
    ev = _events(trajectory)
    d1, d2 = pp.derivative(1), pp.derivative(2)
    acc = d2(0.5 * (ev[:-1] + ev[1:]))
    flat = _FLAT_ACCEL_RTOL * max(float(np.max(np.abs(acc), initial=0.0)), 1e-300)
    not_rising = np.flatnonzero(acc <= flat)
    not_falling = np.flatnonzero(acc >= -flat)
    i_up = int(not_rising[0]) if not_rising.size else ev.size - 1
    i_dn = int(not_falling[-1]) + 1 if not_falling.size else 0
    t_up, t_dn = float(ev[i_up]), float(ev[i_dn])
    why_up = "flat" if not_rising.size else "path"
    why_dn = "flat" if not_falling.size else "path"
    if follow_bound:
        hit = _bound_reached(trajectory, problem, ev[: i_up + 1], first=True)
        if hit is not None and hit < t_up:
            t_up, why_up = hit, "bound"
        hit = _bound_reached(trajectory, problem, ev[i_dn:], first=False)
        if hit is not None and hit > t_dn:
            t_dn, why_dn = hit, "bound"
    t0, t1 = float(pp.x[0]), float(pp.x[-1])
    lo, hi = min(t_up, t_dn), max(t_up, t_dn)
    inside = ev[(ev > lo) & (ev < hi)]
    cutting = float(np.min(d1(np.concatenate([[lo, hi], inside]))))
    s_up, s_dn = pp(np.array([t_up, t_dn]))
    s0, s1 = pp(np.array([t0, t1]))
    start = Ramp(float(s0), float(s_up), t0, t_up, float(d1(t_up)), why_up)
    stop = Ramp(float(s_dn), float(s1), t_dn, t1, float(d1(t_dn)), why_dn)
    return start, stop, cutting


@dataclass(frozen=True)
class Extreme:
    """An extreme value of the motion and where it is: time [s] and arc length [m]."""

    value: float
    t: float
    s: float


@dataclass(frozen=True)
class DenseExtrema:
    """Extremes over :data:`_POINTS_PER_PIECE` points in every polynomial piece: the largest
    |acceleration| and |jerk|, the smallest and largest feed (SI units)."""

    max_accel: Extreme
    max_jerk: Extreme
    min_feed: Extreme
    max_feed: float


def dense_extrema(trajectory: Trajectory, points: int = _POINTS_PER_PIECE) -> DenseExtrema:
    """:class:`DenseExtrema` of ``trajectory``, evaluated a chunk of pieces at a time
    (:func:`~feedopt.schedule.polynomial.sample_piece_chunks`): a law with a piece per path
    sample has 9e6 points at 1e6 samples, 0.5 GB if evaluated at once. The first point
    reaching an extreme is the one reported, as ``np.argmax`` over all points would, and a
    NaN is, as there, the extreme (the first NaN)."""
    best: dict[str, Extreme] = {}
    max_feed = -np.inf
    for m in trajectory.at_each(sample_piece_chunks(trajectory.timing.x, points)):
        for name, values, sign in (("max_accel", np.abs(m.sddot), 1.0),
                                   ("max_jerk", np.abs(m.sdddot), 1.0),
                                   ("min_feed", m.sdot, -1.0)):
            i = int(np.argmax(sign * values))  # the first NaN if there is one
            old = best.get(name)
            if old is None or (not np.isnan(old.value) and (
                    np.isnan(values[i]) or sign * values[i] > sign * old.value)):
                best[name] = Extreme(float(values[i]), float(m.t[i]), float(m.s[i]))
        max_feed = float(np.maximum(max_feed, np.max(m.sdot)))  # NaN stays NaN
    return DenseExtrema(best["max_accel"], best["max_jerk"], best["min_feed"], max_feed)


#: A check's finding: what kind of violation and the message naming where.
Finding = tuple[Violation, str]


def check_timing(
    trajectory: Trajectory,
    problem: ScheduleProblem,
    rtol: float = 1e-6,
    c2_tol: float | None = None,
    enforce_feed_bound: bool = True,
    sample_times: np.ndarray | None = None,
) -> TimingCheck:
    """Check feed bound, limits, boundary feeds and continuity of ``trajectory``.

    Parameters
    ----------
    rtol : float
        Relative tolerance on every bound (feed, acceleration, jerk, joint limits).
    enforce_feed_bound : bool
        False for the ``constant`` baseline, which by definition ignores v_max: its feed
        ratio is still measured but not counted as a problem, and its ramps end where its
        feed levels off (:func:`find_ramps` with ``follow_bound=False``).
    sample_times : array, optional
        ``trajectory.time_at(problem.s)`` when the caller has it already (the verifier).
    c2_tol : float, optional
        Largest acceleration jump [m/s^2] still counted as continuous; default
        ``1e-6 * max(1, max|sddot|)``, i.e. numerical noise.
    """
    # Feed at the path samples (exact inverse of s(t)).
    t_samples = trajectory.time_at(problem.s) if sample_times is None else sample_times
    feed = trajectory.at(t_samples).sdot
    ratio = feed / problem.v_max
    worst = int(np.argmax(ratio))
    findings = _feed_findings(problem, feed, ratio, worst, rtol) if enforce_feed_bound else []
    dense = dense_extrema(trajectory)  # per piece: acceleration / jerk extrema
    findings += _motion_findings(trajectory, problem, dense, rtol)
    vj, aj, c2, found = _continuity(trajectory, dense.max_accel.value, c2_tol)
    findings += found
    # joint velocity and acceleration of q(s(t)) between the samples too (dense replay)
    joints = dense_joint_extrema(trajectory, problem, t_samples)
    findings += _joint_findings(joints, problem, rtol)
    orientation = dense_orientation_extrema(trajectory, problem, t_samples)
    findings += _orientation_findings(orientation, rtol)
    start, end, found = _boundary_findings(trajectory, problem, rtol)
    findings += found
    start_ramp, stop_ramp, cutting = find_ramps(trajectory, problem,
                                                follow_bound=enforce_feed_bound)
    violations = Violation.NONE
    for kind, _ in findings:
        violations |= kind
    return TimingCheck(
        duration=trajectory.duration,
        lower_bound=problem.lower_bound_time(),
        feed_ratio=float(ratio[worst]),
        worst_sample=worst,
        max_feed=dense.max_feed,
        min_cutting_feed=cutting,
        max_accel=dense.max_accel.value,
        max_jerk=dense.max_jerk.value,
        velocity_jump=vj,
        accel_jump=aj,
        c2=c2,
        joint_velocity_ratio=joints.velocity.ratio,
        joint_acceleration_ratio=joints.acceleration.ratio,
        orientation=orientation,
        start_feed=start,
        end_feed=end,
        start_ramp=start_ramp,
        stop_ramp=stop_ramp,
        problems=tuple(message for _, message in findings),
        violations=violations,
    )


def _feed_findings(problem: ScheduleProblem, feed: np.ndarray, ratio: np.ndarray, worst: int,
                   rtol: float) -> list[Finding]:
    """The feed at the samples [m/s] over its bound v_max (``ratio`` = feed / v_max, largest
    at ``worst``)."""
    if ratio[worst] <= 1 + rtol:
        return []
    return [(Violation.FEED_BOUND,
             f"feed {feed[worst] / MM:.6g} mm/s exceeds its bound "
             f"{problem.v_max[worst] / MM:.6g} mm/s at s = {problem.s[worst] / MM:.3f} mm "
             f"(sample {worst}, ratio {ratio[worst]:.6f})")]


def _where(e: Extreme) -> str:
    return f"at t = {e.t:.4f} s, s = {e.s / MM:.3f} mm"


def _motion_findings(trajectory: Trajectory, problem: ScheduleProblem, dense: DenseExtrema,
                     rtol: float) -> list[Finding]:
    """Tangential acceleration and jerk over their limits, and a reversal, found densely."""
    out: list[Finding] = []
    if dense.max_accel.value > problem.accel_max * (1 + rtol):
        out.append((Violation.ACCELERATION,
                    f"tangential acceleration {dense.max_accel.value / MM:.6g} mm/s^2 exceeds "
                    f"its limit {problem.accel_max / MM:.6g} mm/s^2 {_where(dense.max_accel)}"))
    if (np.isfinite(problem.jerk_max) and trajectory.continuity >= 2
            and dense.max_jerk.value > problem.jerk_max * (1 + rtol)):
        out.append((Violation.JERK,
                    f"tangential jerk {dense.max_jerk.value / MM:.6g} mm/s^3 exceeds its limit "
                    f"{problem.jerk_max / MM:.6g} mm/s^3 {_where(dense.max_jerk)}"))
    if dense.min_feed.value < -1e-9 * max(1.0, dense.max_feed):
        out.append((Violation.REVERSAL,
                    f"the path velocity becomes negative ({dense.min_feed.value / MM:.4g} mm/s "
                    f"{_where(dense.min_feed)}): the tool would reverse"))
    return out


def _continuity(trajectory: Trajectory, max_accel: float, c2_tol: float | None
                ) -> tuple[float, float, bool, list[Finding]]:
    """The largest velocity and acceleration jumps at breakpoints, whether s(t) is C2, and
    a law that claims C2 without being it."""
    pp = trajectory.timing
    v_jump = breakpoint_jumps(trajectory, 1)
    a_jump = breakpoint_jumps(trajectory, 2)
    s_jump = breakpoint_jumps(trajectory, 0)
    vj = float(v_jump.max(initial=0.0))
    aj = float(a_jump.max(initial=0.0))
    tol = c2_tol if c2_tol is not None else 1e-6 * max(1.0, max_accel)
    c2 = bool(aj <= tol and vj <= 1e-9 and s_jump.max(initial=0.0) <= 1e-12)
    if trajectory.continuity < 2 or c2:
        return vj, aj, c2, []
    k = int(np.argmax(a_jump)) if a_jump.size else 0
    at = (f" at t = {pp.x[k + 1]:.4f} s, s = {float(pp(pp.x[k + 1])) / MM:.3f} mm"
          if a_jump.size else "")
    return vj, aj, c2, [(Violation.C2,
                         f"claims C2 but the acceleration jumps by {aj / MM:.3g} mm/s^2{at}")]


def _joint_findings(joints: DenseJoints, problem: ScheduleProblem, rtol: float
                    ) -> list[Finding]:
    """Joint velocities and accelerations over their limits (``joints``:
    :func:`dense_joint_extrema`)."""
    out: list[Finding] = []
    for kind, what, unit, e, limits in (
        (Violation.JOINT_VELOCITY, "velocity", "deg/s", joints.velocity,
         problem.joint_velocity_max),
        (Violation.JOINT_ACCELERATION, "acceleration", "deg/s^2", joints.acceleration,
         problem.joint_acceleration_max),
    ):
        if e.ratio > 1 + rtol:
            out.append((kind,
                        f"joint {e.joint + 1} {what} {np.rad2deg(abs(e.value)):.4g} {unit} "
                        f"exceeds its limit {np.rad2deg(limits[e.joint]):.4g} {unit} "
                        f"({e.ratio:.4f} x) at s = {e.s / MM:.3f} mm ({e.where})"))
    return out


def _orientation_findings(e: OrientationExtrema | None, rtol: float) -> list[Finding]:
    """The tool vector's rate and acceleration over their limits (five-axis paths)."""
    out: list[Finding] = []
    if e is None:
        return out
    for kind, what, unit, value, ratio, s in (
        (Violation.ORIENTATION_RATE, "rate", "deg/s", e.rate, e.rate_ratio, e.rate_s),
        (Violation.ORIENTATION_ACCELERATION, "acceleration", "deg/s^2", e.acceleration,
         e.acceleration_ratio, e.acceleration_s),
    ):
        if ratio > 1 + rtol:
            out.append((kind, f"tool orientation {what} {np.rad2deg(value):.4g} {unit} exceeds "
                              f"its limit {np.rad2deg(value / ratio):.4g} {unit} ({ratio:.4f} x)"
                              f" at s = {s / MM:.3f} mm"))
    return out


def _boundary_findings(trajectory: Trajectory, problem: ScheduleProblem, rtol: float
                       ) -> tuple[float, float, list[Finding]]:
    """The feeds at the first and last instant against the requested ones (inverting a
    flat s(t) at rest is ill-conditioned, so they are not taken from the samples), and the
    length covered."""
    pp = trajectory.timing
    ends = trajectory.at(np.array([pp.x[0], pp.x[-1]]))
    start, end = float(ends.sdot[0]), float(ends.sdot[1])
    out: list[Finding] = []
    for kind, name, got, want in ((Violation.START_FEED, "start", start, problem.v_start),
                                  (Violation.END_FEED, "end", end, problem.v_end)):
        if abs(got - want) > 1e-9 + rtol * abs(want):
            out.append((kind, f"{name} feed {got / MM:.6g} mm/s differs from the requested "
                              f"{want / MM:.6g} mm/s"))
    if abs(trajectory.length - problem.length) > 1e-9 + 1e-9 * problem.length:
        out.append((Violation.LENGTH, f"covers {trajectory.length / MM:.9g} mm of a "
                                      f"{problem.length / MM:.9g} mm path"))
    return start, end, out
