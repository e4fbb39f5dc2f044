"""Minimum-time, jerk-limited C2 timing law as one convex SOCP (cvxpy + Clarabel), ``convex``.

Formulation (Verscheure et al. 2009, IEEE TAC 54(10), with a node-based acceleration so the
result can be C2). On solver gridpoints s_0 < ... < s_N the variables are b_k = sdot^2 and
a_k = sddot. Between gridpoints sddot is linear in s, so b is quadratic in s and

    b_{k+1} - b_k = (a_k + a_{k+1}) (s_{k+1} - s_k)

(on a piece that starts or ends at rest: b = 1.5 ds a, the constant-jerk start). The
constraints, all linear in (a, b), are

* feed bound: b_k <= node bound (minimum of v_max and the joint velocity limits over both
  neighbouring intervals) and, inside each interval, the middle Bernstein coefficient
  b_k + a_k ds_k <= interval bound: a quadratic lies below the largest of its Bernstein
  coefficients, so the model b(s) stays under the bound on the fine samples too;
* |a_k| <= accel_max, and the joint accelerations |q'(s) sddot + q''(s) sdot^2| <= limit
  on every cell (a grid interval cut at the samples) where they can bind, not only at the
  gridpoints: on a cell they are a quartic in s whose Bernstein coefficients are linear in
  (a_k, a_k+1, b_k), and bounding those bounds the whole cell
  (:func:`feedopt.schedule.joint_rows.node_model_rows`). A corner shorter than a sample makes
  q'' spike at one sample; where the grid is coarser than the samples, both ends of every
  sample interval where a joint can bind are added to it (:func:`joint_refinement`), so the
  feed dips at the corner alone. The joint velocity limits enter the feed bound with |q'| over
  the sample intervals (:func:`feedopt.schedule.topp.sample_feed_bound`);
* jerk: sdddot = (da/ds) sdot and sdot <= w_k on interval k, so
  |a_{k+1} - a_k| <= jerk_max ds_k / w_k is a convex, conservative jerk limit (no sequential
  convexification). w_k is the interval's feed bound, and near a rest end the feed a
  jerk-limited start could reach there (plus a margin);
* a = 0 and b = v^2 at both ends.

The travel time sum 2 ds_k / (sqrt(b_k) + sqrt(b_{k+1})) is minimised through second-order
cones: c_k^2 <= b_k and d_k (c_k + c_{k+1}) >= 1, objective sum 2 ds_k d_k.

The output s(t) is a quintic Hermite piece in t per grid interval through (s, sdot, sddot) at
the gridpoints (C2), with a piece duration that is exact for constant-jerk motion. It is
verified on the fine samples (joint rates between them too); if the smoothing overshoots the
feed, jerk, acceleration or a joint acceleration limit (or reverses), those limits are shrunk
by the measured margin and the SOCP is solved
again: every attempt is a typed :class:`ConvexAttempt` whose :class:`Overshoot` flags decide
the re-solve (``stats.attempts``, ``stats.resolves`` and ``notes``). The solver grid is the
samples, or, on long paths, an adaptive subset (dense where v_max varies, coarse where it is
flat) capped at ``ConvexOptions.max_gridpoints``, plus graded points near a rest end (between
samples). The SOCP is solved in mm and s (``MM_PER_M``: b ~ 10 mm^2/s^2) for good
conditioning.
"""

from __future__ import annotations

import enum
import time
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.interpolate import PPoly

from feedopt.errors import InputError
from feedopt.schedule.checks import (
    Violation,
    check_boundary_feeds,
    check_positive_bound,
    check_timing,
)
from feedopt.schedule.joint_rows import JointRows, NodeGrid, node_model_rows
from feedopt.schedule.joints import IntervalPeaks, interval_peaks
from feedopt.schedule.polynomial import derivative_coefficients, horner, quintic_hermite_spline
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.topp import plan_topp, sample_feed_bound
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM, MM_PER_M

# Safety on the measured overshoot when a limit is shrunk for the next solve.
_FEED_SHRINK_SAFETY = 1.0 - 1e-6
_LIMIT_SHRINK_SAFETY = 0.999
# Relative overshoot of the final attempt reported as a VIOLATION.
_VIOLATION_RTOL = 1e-9
# Joint accelerations of the smoothed s(t) above their limit by more than this (relative)
# re-solve (and, on the last attempt, are a VIOLATION): the SOCP meets its rows to the
# solver's tolerance only; the verifier allows 1e-6.
_JOINT_RTOL = 1e-7


class ConvexOptions(BaseModel):
    """Tunables of the ``convex`` law (SOCP, Verscheure et al. 2009)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    max_gridpoints: int = Field(
        3000, ge=2,
        description="cap on the solver grid (adaptive: dense where v_max varies; every sample "
        "when the path has fewer)")
    rest_gridpoints: int = Field(
        61, ge=2,
        description="graded gridpoints (s ~ i^3) near an end at rest, where the node model "
        "cannot describe a jerk-limited start; reserved out of max_gridpoints")
    jerk_margin: float = Field(
        0.02, ge=0.0, lt=1.0, allow_inf_nan=False,
        description="relative margin on the jerk limit for the first solve (the quintic "
        "smoothing may exceed the discrete jerk slightly)")
    reach_margin: float = Field(
        0.05, ge=0.0, allow_inf_nan=False,
        description="relative margin on the jerk-limited reach feed from / to a rest end, used "
        "as the feed in the jerk constraint there")
    max_resolves: int = Field(
        3, ge=0,
        description="how many times to shrink the limits by the measured overshoot and solve "
        "again")
    reversal_jerk_scale: float = Field(
        0.9, gt=0.0, lt=1.0, allow_inf_nan=False,
        description="factor on the jerk limit of the next solve when the smoothed feed "
        "reverses")
    compare_topp: bool = Field(
        True,
        description="when no topp trajectory is given, run toppra after planning to report the "
        "gap to it (its time is not planning time)")
    solver_options: dict[str, float | int | bool | str] = Field(
        default_factory=dict,
        description="extra keyword arguments for cvxpy's Problem.solve with Clarabel (e.g. "
        "tol_gap_rel)")


class SocpStatus(enum.StrEnum):
    """cvxpy's status of one SOCP solve (its string values)."""

    OPTIMAL = "optimal"
    OPTIMAL_INACCURATE = "optimal_inaccurate"
    INFEASIBLE = "infeasible"
    INFEASIBLE_INACCURATE = "infeasible_inaccurate"
    UNBOUNDED = "unbounded"
    UNBOUNDED_INACCURATE = "unbounded_inaccurate"
    INFEASIBLE_OR_UNBOUNDED = "infeasible_or_unbounded"
    USER_LIMIT = "user_limit"
    SOLVER_ERROR = "solver_error"

    @property
    def solved(self) -> bool:
        """A solution is available (optimal, possibly inaccurate)."""
        return self in (SocpStatus.OPTIMAL, SocpStatus.OPTIMAL_INACCURATE)


class Overshoot(enum.Flag):
    """What the quintic smoothing of one SOCP solution overshot on the fine samples."""

    NONE = 0
    FEED = enum.auto()  #: sdot > scaled v_max on a sample
    JERK = enum.auto()  #: exact max |sdddot| > jerk_max
    ACCELERATION = enum.auto()  #: max |sddot| > accel_max
    REVERSAL = enum.auto()  #: sdot < 0 somewhere (check_timing's Violation.REVERSAL)
    #: a joint acceleration > its limit between gridpoints (the dense replay of check_timing)
    JOINT_ACCELERATION = enum.auto()


class _Scales(NamedTuple):
    """Factors on the feed bound, jerk limit, acceleration limit and joint acceleration
    limits of one solve."""

    feed: float
    jerk: float
    accel: float
    joint: float = 1.0


@dataclass(frozen=True)
class ConvexAttempt(LawStats):
    """One SOCP solve and the check of its quintic smoothing (a row of ``stats.attempts``)."""

    feed_ratio: float
    max_accel: float
    max_jerk: float
    status: SocpStatus
    feed_scale: float
    jerk_scale: float
    accel_scale: float
    #: the factor on the joint acceleration limits when not 1 (None: 1)
    joint_scale: float | None = None
    #: largest joint acceleration / limit of the smoothed s(t) (dense replay)
    joint_ratio: float = outcome(float("nan"))
    #: what this attempt overshot (empty: accepted)
    overshoot: Overshoot = outcome(Overshoot.NONE)


@dataclass(frozen=True)
class ConvexStats(LawStats):
    """What the ``convex`` law reports (``as_dict()``: its summary.json entry)."""

    gridpoints: int
    solver: str
    status: SocpStatus
    resolves: int
    attempts: tuple[ConvexAttempt, ...]
    solver_time_s: float
    socp_time_s: float
    feed_ratio: float
    max_jerk_m_s3: float
    max_accel_m_s2: float
    lower_bound_s: float
    planning_time_s: float
    topp_time_s: float | None = None
    topp_duration_s: float | None = None
    gap_to_topp: float | None = None
    #: samples added to the grid where a joint acceleration can bind (None: none)
    joint_refined_gridpoints: int | None = None
    #: limits the returned trajectory still violates after the last attempt
    violations: Overshoot = outcome(Overshoot.NONE)


def accel_reachable(s: np.ndarray, v: np.ndarray, accel: float, v_start: float,
                    v_end: float) -> np.ndarray:
    """The largest feed [m/s] at each sample that a motion from ``v_start`` to ``v_end`` under
    ``v`` can have with |sddot| <= ``accel`` (forward and backward pass, vectorised:
    v(s)^2 <= min over s' <= s of (v(s')^2 + 2 a (s - s')), and the same backwards)."""
    if not np.isfinite(accel):
        return np.asarray(v, dtype=float)
    b = np.square(np.asarray(v, dtype=float))
    b[0] = min(b[0], v_start * v_start)
    b[-1] = min(b[-1], v_end * v_end)
    two_a = 2.0 * accel
    fwd = np.minimum.accumulate(b - two_a * s) + two_a * s
    back = np.minimum.accumulate((b + two_a * s)[::-1])[::-1] - two_a * s
    return np.sqrt(np.maximum(np.minimum(fwd, back), 0.0))


def adaptive_grid(
    problem: ScheduleProblem, v_sample: np.ndarray, max_gridpoints: int,
    rest_gridpoints: int = 61,
) -> np.ndarray:
    """Arc lengths [m] of the solver grid (about ``max_gridpoints`` points or fewer).

    Every sample when there are few enough; otherwise points are placed at equal steps of a
    measure that is half arc length and half the variation of log(v_max), the latter spread
    over a braking distance so the grid is also dense where the tool slows down before a drop
    of the bound. Near a boundary at rest the grid is graded (s ~ i^3, the shape of a
    jerk-limited start) over the jerk-limited acceleration distance, with points between
    samples: the node model (sddot linear in s) cannot describe a start from rest, so the
    pieces there must be short (``rest_gridpoints`` points per rest end, reserved out of
    ``max_gridpoints``).
    """
    n = problem.n
    s = problem.s
    a_lim = problem.accel_max if np.isfinite(problem.accel_max) else np.inf
    j_lim = problem.jerk_max
    # the fastest feed the tool can reach (not a cap it never gets near, such as a rapid
    # limit on a short rapid): it sizes the braking zones below
    v_top = float(np.max(accel_reachable(s, v_sample, a_lim, problem.v_start, problem.v_end)))
    zone = 1.5 * v_top * (v_top / a_lim + 2.0 * np.sqrt(v_top / j_lim))
    zone = min(zone, 0.25 * s[-1])
    if n <= max_gridpoints:
        pts = [s]
    else:
        dlog = np.abs(np.diff(np.log(v_sample)))
        width = max(1, int(round(zone / (s[-1] / (n - 1)))))
        spread = np.convolve(dlog, np.ones(width) / width, mode="same")
        tv = np.concatenate([[0.0], np.cumsum(spread)])
        measure = s / s[-1]
        if tv[-1] > 0:
            measure = 0.5 * measure + 0.5 * tv / tv[-1]
        reserve = 2 * (rest_gridpoints - 1)
        idx = np.searchsorted(measure, np.linspace(0.0, 1.0, max(max_gridpoints - reserve, 2)))
        pts = [s[np.clip(idx, 0, n - 1)], s[[0, n - 1]]]
    graded = zone * np.linspace(0.0, 1.0, rest_gridpoints) ** 3
    if problem.v_start == 0:
        pts.append(graded)
    if problem.v_end == 0:
        pts.append(s[-1] - graded)
    return _without_near_twins(np.unique(np.clip(np.concatenate(pts), 0.0, s[-1])), s[-1])


def _without_near_twins(grid: np.ndarray, length: float) -> np.ndarray:
    """``grid`` (sorted) without points closer than 1e-9 of the length to a neighbour (the
    end points kept)."""
    keep = np.concatenate([[True], np.diff(grid) > 1e-9 * length])
    keep[-1] = True
    grid = grid[keep]
    if grid.size > 2 and grid[-1] - grid[-2] <= 1e-9 * length:
        grid = np.delete(grid, -2)
    return grid


def grid_bounds_at(
    s: np.ndarray, v_sample: np.ndarray, s_grid: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Interval and node bounds on sdot for a grid that need not lie on the samples.

    The bound is known at the samples only; between two samples the smaller of the two
    applies. A grid interval gets the minimum over every sample interval it overlaps, a
    gridpoint the minimum over its neighbouring grid intervals. On a grid of samples this is
    :func:`feedopt.schedule.topp.grid_bounds`.
    """
    v_pair = np.minimum(v_sample[:-1], v_sample[1:])  # per sample interval
    m = v_pair.size
    lo = np.clip(np.searchsorted(s, s_grid[:-1], side="right") - 1, 0, m - 1)
    hi = np.clip(np.searchsorted(s, s_grid[1:], side="left") - 1, 0, m - 1)
    hi = np.maximum(hi, lo)
    interval = np.minimum(np.minimum.reduceat(v_pair, lo), v_pair[hi])
    node = np.empty(s_grid.size)
    node[0], node[-1] = interval[0], interval[-1]
    node[1:-1] = np.minimum(interval[:-1], interval[1:])
    return interval, node


def jerk_limited_reach(distance: np.ndarray, a_max: float, j_max: float) -> np.ndarray:
    """Feed reached after ``distance`` from rest at full jerk, then full acceleration.

    Jerk phase: s = j t^3 / 6, v = j t^2 / 2 until a = a_max (s1 = a^3 / (6 j^2),
    v1 = a^2 / (2 j)); then v^2 = v1^2 + 2 a (s - s1). Used (with a margin) as the feed
    w in the jerk constraint near a rest end, where v_max would be far too conservative.
    """
    d = np.maximum(np.asarray(distance, dtype=float), 0.0)
    if not np.isfinite(a_max):
        return 0.5 * j_max * (6 * d / j_max) ** (2.0 / 3.0)
    s1 = a_max**3 / (6 * j_max**2)
    v1 = a_max**2 / (2 * j_max)
    jerk_phase = 0.5 * j_max * (6 * np.minimum(d, s1) / j_max) ** (2.0 / 3.0)
    accel_phase = np.sqrt(v1**2 + 2 * a_max * np.maximum(d - s1, 0.0))
    return np.where(d <= s1, jerk_phase, accel_phase)


def _rest_reach_feed(problem: ScheduleProblem, s_grid: np.ndarray) -> np.ndarray:
    """Per grid interval: the largest feed reachable from a rest start / towards a rest end
    (``inf`` where the boundary feed is not zero)."""
    w = np.full(s_grid.size - 1, np.inf)
    if problem.v_start == 0:
        w = np.minimum(w, jerk_limited_reach(s_grid[1:], problem.accel_max, problem.jerk_max))
    if problem.v_end == 0:
        w = np.minimum(
            w, jerk_limited_reach(problem.length - s_grid[:-1], problem.accel_max,
                                  problem.jerk_max)
        )
    return w


@dataclass(frozen=True)
class _SocpData:
    """The SOCP's numbers in mm / s units: gridpoints ``s_mm``, bounds on b = sdot^2 at the
    gridpoints and over each interval, the boundary b, the per-interval feed bound ``w`` of
    the jerk rows and the tangential acceleration and jerk limits."""

    s_mm: np.ndarray
    b_node: np.ndarray
    b_int: np.ndarray
    b_start: float
    b_end: float
    w: np.ndarray
    a_max: float
    j_max: float


def _solve_socp(data: _SocpData, joint_rows: JointRows, solver_options: dict):
    """Solve the SOCP in mm / s units; returns (b, a, status, solve time, setup time).

    ``status`` is a :class:`SocpStatus`; ``b`` and ``a`` are None when cvxpy has no values.
    """
    import cvxpy as cp

    t0 = time.perf_counter()
    s_mm, b_node, b_int, w = data.s_mm, data.b_node, data.b_int, data.w
    a_max, j_max, b_start, b_end = data.a_max, data.j_max, data.b_start, data.b_end
    n = s_mm.size
    ds = np.diff(s_mm)
    # sddot linear in s: b_{k+1} - b_k = ds (a_k + a_{k+1}). On a piece that starts (ends)
    # at rest, constant jerk gives sdot^2 = 1.5 ds sddot instead, so the quintic through the
    # gridpoint values is exactly that constant-jerk start (stop).
    left = np.ones(n - 1)
    right = np.ones(n - 1)
    if b_start == 0:
        right[0] = 1.5
    if b_end == 0:
        left[-1] = 1.5
    b = cp.Variable(n)
    a = cp.Variable(n)
    c = cp.Variable(n)
    d = cp.Variable(n - 1)
    cons = [
        b[0] == b_start,
        b[n - 1] == b_end,
        a[0] == 0,
        a[n - 1] == 0,
        b[1:] - b[:-1] == cp.multiply(ds * left, a[:-1]) + cp.multiply(ds * right, a[1:]),
        b <= b_node,
        b[:-1] + cp.multiply(ds, a[:-1]) <= b_int,
        cp.SOC(b + 1, cp.vstack([2 * c, b - 1]), axis=0),
        cp.SOC(c[:-1] + c[1:] + d, cp.vstack([2 * np.ones(n - 1), c[:-1] + c[1:] - d]), axis=0),
    ]
    if np.isfinite(a_max):
        cons += [a <= a_max, a >= -a_max]
    if np.isfinite(j_max):
        da = j_max * ds / w
        cons += [a[1:] - a[:-1] <= da, a[:-1] - a[1:] <= da]
    if len(joint_rows):  # joint accelerations over every cell where they can bind
        r = joint_rows
        qdd = (cp.multiply(r.ca, a[r.ia]) + cp.multiply(r.ca1, a[r.ia1])
               + cp.multiply(r.cb, b[r.ib]))
        cons += [qdd <= 1.0, qdd >= -1.0]
    prob = cp.Problem(cp.Minimize(2 * ds @ d), cons)
    # Clarabel's "insufficient progress" near the optimum (seen at duality gaps ~1e-4 with
    # the joint rows of rapids and cuts together) returns its iterate as optimal_inaccurate
    # instead of raising: the smoothed trajectory is checked against every limit anyway
    opts = {"solver": cp.CLARABEL, "accept_unknown": True}
    opts.update(solver_options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "inaccurate": reported via status
        prob.solve(**opts)
    total = time.perf_counter() - t0
    stats = prob.solver_stats
    solve_time = float(stats.solve_time) if stats and stats.solve_time else float("nan")
    status = SocpStatus._value2member_map_.get(prob.status, SocpStatus.SOLVER_ERROR)
    if b.value is None:
        return None, None, status, solve_time, total
    return np.asarray(b.value), np.asarray(a.value), status, solve_time, total


def quintic_timing(s: np.ndarray, v: np.ndarray, a: np.ndarray):
    """C2 s(t): quintic Hermite pieces in t through (s, sdot, sddot) at the gridpoints.

    The duration of each piece solves ds = (v0 + v1) dt / 2 + (a0 - a1) dt^2 / 12, which is
    exact when the motion between the gridpoints has constant jerk; where that quadratic has
    no positive root (e.g. starting from rest) the trapezoid 2 ds / (v0 + v1) is used.
    """
    ds = np.diff(s)
    m = 0.5 * (v[:-1] + v[1:])
    cq = (a[:-1] - a[1:]) / 12.0
    disc = m**2 + 4 * cq * ds
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        dt_sym = 2 * ds / (m + root)
        dt_trap = ds / m
    use_sym = (disc >= 0) & (m + root > 0) & np.isfinite(dt_sym) & (dt_sym > 0)
    dt = np.where(use_sym, dt_sym, dt_trap)
    if np.any(~np.isfinite(dt)) or np.any(dt <= 0):
        k = int(np.argmax(~np.isfinite(dt) | (dt <= 0)))
        raise InputError(
            f"the feed is zero on both ends of the grid interval at s = {s[k] / MM:.3f} mm "
            f"(gridpoint {k}): the bound or the limits stop the motion there"
        )
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return PPoly(quintic_hermite_spline(dt, s, v, a), t)


def _exact_jerk_max(pp: PPoly) -> float:
    """max |sdddot| over all quintic pieces (the jerk is quadratic in t: ends and vertex)."""
    jerk = derivative_coefficients(pp.c, 3)  # (3, m): quadratic per piece
    h = np.diff(pp.x)
    slope = derivative_coefficients(jerk)  # (2, m): its derivative
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = np.where(slope[0] != 0, -slope[1] / slope[0], -1.0)
    inside = (tv > 0) & (tv < h)
    jerkv = np.where(inside, horner(jerk, tv), 0.0)
    return float(np.max(np.abs(np.concatenate([jerk[-1], horner(jerk, h), jerkv]))))


@dataclass(frozen=True)
class _Grid:
    """The solver grid and everything on it that does not change between attempts."""

    s: np.ndarray  # gridpoints [m]
    v_int: np.ndarray  # feed bound per grid interval [m/s]
    v_node: np.ndarray  # feed bound per gridpoint [m/s]
    w_bound: np.ndarray  # feed w_k of each interval in the jerk constraint [m/s]
    peaks: IntervalPeaks  # bounds of |q'|, |q''| on every sample interval
    refined: int = 0  # gridpoints added where a joint acceleration can bind


def _check_inputs(problem: ScheduleProblem, peaks: IntervalPeaks) -> np.ndarray:
    """Refuse what the SOCP cannot solve; returns the per-sample feed bound [m/s]."""
    if not np.isfinite(problem.jerk_max) or problem.jerk_max <= 0:
        raise InputError(
            f"jerk_max = {problem.jerk_max} m/s^3: the convex law needs a finite positive jerk "
            "limit (use the topp law for an unlimited jerk)"
        )
    v_sample = sample_feed_bound(problem, peaks)
    check_positive_bound("convex", problem, v_sample)
    check_boundary_feeds("convex", problem, v_sample[0], v_sample[-1])
    return v_sample


def joint_refinement(problem: ScheduleProblem, v_sample: np.ndarray, peaks: IntervalPeaks,
                     s_grid: np.ndarray, budget: int) -> np.ndarray:
    """The samples to add to ``s_grid`` [m]: both ends of every sample interval on which a
    joint acceleration can reach its limit (max|q'| accel_max + max|q''| v^2 >= limit, v the
    smaller bound of its ends), where a corner shorter than a sample makes q'' spike; the
    ``budget`` intervals nearest to binding first. There the grid interval is the sample
    interval, so the feed can dip at the corner alone, not along a whole coarse interval."""
    v_pair = np.minimum(v_sample[:-1], v_sample[1:])
    # without a tangential acceleration limit every interval can bind through q' sddot: the
    # velocity term alone then says where the corners are
    a_cap = float(problem.accel_max) if np.isfinite(problem.accel_max) else 0.0
    limit = np.asarray(problem.joint_acceleration_max, dtype=float)
    ratio = np.max((peaks.dq_ds * a_cap + peaks.d2q_ds2 * v_pair[:, None] ** 2) / limit, axis=1)
    s = problem.s
    on_grid = np.isin(s, s_grid)
    todo = np.flatnonzero((ratio >= 1.0) & ~(on_grid[:-1] & on_grid[1:]))
    todo = todo[np.argsort(-ratio[todo], kind="stable")[:budget]]
    return np.unique(np.concatenate([s[todo], s[todo + 1]]))


def _grid(problem: ScheduleProblem, v_sample: np.ndarray, peaks: IntervalPeaks,
          options: ConvexOptions) -> _Grid:
    """Adaptive solver grid refined where joint accelerations can bind, its feed bounds and
    jerk feeds."""
    s_grid = adaptive_grid(problem, v_sample, options.max_gridpoints, options.rest_gridpoints)
    extra = joint_refinement(problem, v_sample, peaks, s_grid, options.max_gridpoints)
    if extra.size:
        s_grid = _without_near_twins(np.union1d(s_grid, extra), problem.length)
    v_int, v_node = grid_bounds_at(problem.s, v_sample, s_grid)
    # feed bound w_k of each interval in the jerk constraint: v_max, and near a rest end the
    # jerk-limited reach (v_max alone would make the start from rest very slow)
    w_bound = np.minimum(v_int, (1 + options.reach_margin) * _rest_reach_feed(problem, s_grid))
    return _Grid(s=s_grid, v_int=v_int, v_node=v_node, w_bound=w_bound, peaks=peaks,
                 refined=int(extra.size))


def _attempt(problem: ScheduleProblem, grid: _Grid, scales: _Scales, options: ConvexOptions):
    """Solve the SOCP with scaled limits, smooth it into quintics and check the result.

    Returns ``(timing, attempt, solver time [s], SOCP time incl. setup [s])``; raises
    InputError when the SOCP has no solution.
    """
    a_lim, j_lim = float(problem.accel_max), float(problem.jerk_max)
    b_node = (grid.v_node * scales.feed * MM_PER_M) ** 2
    b_int = (grid.v_int * scales.feed * MM_PER_M) ** 2
    b_start = min((problem.v_start * MM_PER_M) ** 2, b_node[0])
    b_end = min((problem.v_end * MM_PER_M) ** 2, b_node[-1])
    rows = node_model_rows(problem, NodeGrid(
        s=grid.s * MM_PER_M, b_int=b_int, a_cap=a_lim * scales.accel * MM_PER_M,
        qdd_max=np.asarray(problem.joint_acceleration_max, dtype=float) * scales.joint,
        rest_start=b_start == 0, rest_end=b_end == 0, scale=MM_PER_M), grid.peaks)
    b, a, status, solve_time, total = _solve_socp(_SocpData(
        s_mm=grid.s * MM_PER_M, b_node=b_node, b_int=b_int, b_start=b_start, b_end=b_end,
        w=grid.w_bound * scales.feed * MM_PER_M, a_max=a_lim * scales.accel * MM_PER_M,
        j_max=j_lim * scales.jerk * MM_PER_M), rows, options.solver_options)
    if b is None or not status.solved:
        raise InputError(
            f"the convex SOCP is {status}: the boundary feeds, the feed bound and the "
            "acceleration / jerk limits are inconsistent (try the topp law to see which)"
        )
    b = np.clip(b, 0.0, b_node)
    b[0], b[-1] = b_start, b_end
    v = np.sqrt(b) / MM_PER_M
    acc = a / MM_PER_M
    acc[0] = acc[-1] = 0.0
    timing = quintic_timing(grid.s, v, acc)
    chk = check_timing(Trajectory(law="convex", timing=timing, continuity=2), problem)
    jerk = _exact_jerk_max(timing)
    overshoot = Overshoot.NONE
    if chk.feed_ratio > 1.0:
        overshoot |= Overshoot.FEED
    if jerk > j_lim:
        overshoot |= Overshoot.JERK
    if chk.max_accel > a_lim:
        overshoot |= Overshoot.ACCELERATION
    if Violation.REVERSAL in chk.violations:
        overshoot |= Overshoot.REVERSAL
    if chk.joint_acceleration_ratio > 1.0 + _JOINT_RTOL:
        overshoot |= Overshoot.JOINT_ACCELERATION
    attempt = ConvexAttempt(
        feed_ratio=chk.feed_ratio, max_accel=chk.max_accel, max_jerk=jerk, status=status,
        feed_scale=scales.feed, jerk_scale=scales.jerk, accel_scale=scales.accel,
        joint_scale=None if scales.joint == 1.0 else scales.joint,
        joint_ratio=chk.joint_acceleration_ratio, overshoot=overshoot,
    )
    return timing, attempt, solve_time, total


def _shrunk(scales: _Scales, attempt: ConvexAttempt, problem: ScheduleProblem,
            options: ConvexOptions) -> _Scales:
    """The scales of the next solve: each overshot limit (joint accelerations included)
    shrunk by the measured overshoot (plus a little); a reversal shrinks the jerk limit by
    ``reversal_jerk_scale``."""
    feed, jerk, accel, joint = scales
    over = attempt.overshoot
    if Overshoot.FEED in over:
        feed *= _FEED_SHRINK_SAFETY / attempt.feed_ratio
    if Overshoot.JERK in over:
        jerk *= _LIMIT_SHRINK_SAFETY * float(problem.jerk_max) / attempt.max_jerk
    if Overshoot.ACCELERATION in over:
        accel *= _LIMIT_SHRINK_SAFETY * float(problem.accel_max) / attempt.max_accel
    if Overshoot.REVERSAL in over:
        jerk *= options.reversal_jerk_scale
    if Overshoot.JOINT_ACCELERATION in over:
        joint *= _LIMIT_SHRINK_SAFETY / attempt.joint_ratio
    return _Scales(feed, jerk, accel, joint)


def _solve_until_within_limits(problem: ScheduleProblem, grid: _Grid, options: ConvexOptions):
    """Solve, and re-solve with shrunk limits while the smoothing overshoots (at most
    ``max_resolves`` times). Returns ``(timing, attempts, solver time, SOCP time)``."""
    scales = _Scales(1.0, 1.0 - options.jerk_margin, 1.0)
    attempts: list[ConvexAttempt] = []
    solve_total = socp_total = 0.0
    while True:
        timing, attempt, solve_time, total = _attempt(problem, grid, scales, options)
        solve_total += solve_time
        socp_total += total
        attempts.append(attempt)
        if not attempt.overshoot or len(attempts) > options.max_resolves:
            return timing, tuple(attempts), solve_total, socp_total
        scales = _shrunk(scales, attempt, problem, options)


def _violations(last: ConvexAttempt, problem: ScheduleProblem) -> Overshoot:
    """Limits the final trajectory still overshoots (beyond :data:`_VIOLATION_RTOL`)."""
    out = Overshoot.NONE
    if last.feed_ratio > 1 + _VIOLATION_RTOL:
        out |= Overshoot.FEED
    if last.max_jerk > float(problem.jerk_max) * (1 + _VIOLATION_RTOL):
        out |= Overshoot.JERK
    if last.max_accel > float(problem.accel_max) * (1 + _VIOLATION_RTOL):
        out |= Overshoot.ACCELERATION
    if last.joint_ratio > 1 + _JOINT_RTOL:
        out |= Overshoot.JOINT_ACCELERATION
    return out | (last.overshoot & Overshoot.REVERSAL)


def _notes(gridpoints: int, attempts: tuple[ConvexAttempt, ...], violations: Overshoot,
           problem: ScheduleProblem) -> list[str]:
    """What the law tells the user: formulation, re-solves and remaining violations."""
    last = attempts[-1]
    resolves = len(attempts) - 1
    j_lim, a_lim = float(problem.jerk_max), float(problem.accel_max)
    notes = [
        f"SOCP (Verscheure et al. 2009) on {gridpoints} gridpoints, solved by Clarabel; s(t) is "
        "quintic Hermite in t through (s, sdot, sddot) at gridpoints: C2, jerk-limited."
    ]
    if resolves:
        notes.append(
            f"the quintic smoothing overshot a limit; re-solved {resolves} time(s) with the feed "
            f"bound x{last.feed_scale:.6f}, jerk limit x{last.jerk_scale:.4f}, "
            f"acceleration limit x{last.accel_scale:.4f}"
            + ("" if last.joint_scale is None else
               f", joint acceleration limits x{last.joint_scale:.4f}")
        )
    if Overshoot.FEED in violations:
        notes.append(
            f"VIOLATION: feed reaches {last.feed_ratio:.6f} of v_max on the fine samples"
        )
    if Overshoot.JERK in violations:
        notes.append(
            f"VIOLATION: jerk reaches {last.max_jerk:.6g} m/s^3 > limit {j_lim:.6g} m/s^3"
        )
    if Overshoot.ACCELERATION in violations:
        notes.append(
            f"VIOLATION: acceleration reaches {last.max_accel:.6g} m/s^2 > {a_lim:.6g} m/s^2"
        )
    if Overshoot.REVERSAL in violations:
        notes.append("VIOLATION: the smoothed feed becomes negative (the tool would reverse)")
    if Overshoot.JOINT_ACCELERATION in violations:
        notes.append(f"VIOLATION: a joint acceleration reaches {last.joint_ratio:.6f} of its "
                     "limit")
    return notes


def plan_convex(
    problem: ScheduleProblem,
    options: ConvexOptions | None = None,
    *,
    topp: Trajectory | None = None,
) -> Trajectory:
    """Minimum-time jerk-limited C2 timing law (SOCP of Verscheure et al. 2009, cvxpy +
    Clarabel; see the module docstring).

    Parameters
    ----------
    problem : ScheduleProblem
        Path samples, feed bound and limits. ``jerk_max`` must be finite.
    options : ConvexOptions, optional
        Grid, margins, re-solves and solver settings (default: :class:`ConvexOptions`).
    topp : Trajectory, optional
        A ``plan_topp`` result for the same problem: ``stats.gap_to_topp`` is
        ``duration / topp.duration - 1``. Without it and with ``options.compare_topp``,
        toppra is run after planning (``stats.topp_time_s``, not part of
        ``stats.planning_time_s``).

    Returns
    -------
    Trajectory
        ``law="convex"``, quintic pieces, ``continuity=2``, :class:`ConvexStats`.
    """
    options = ConvexOptions() if options is None else options
    t_start = time.perf_counter()
    peaks = interval_peaks(problem)
    v_sample = _check_inputs(problem, peaks)
    grid = _grid(problem, v_sample, peaks, options)
    timing, attempts, solve_total, socp_total = _solve_until_within_limits(
        problem, grid, options)
    last = attempts[-1]
    violations = _violations(last, problem)
    notes = _notes(grid.s.size, attempts, violations, problem)
    planning_time = time.perf_counter() - t_start
    topp_time = None
    if topp is None and options.compare_topp:
        t0 = time.perf_counter()
        topp = plan_topp(problem)
        topp_time = time.perf_counter() - t0
    duration = float(timing.x[-1] - timing.x[0])
    stats = ConvexStats(
        gridpoints=int(grid.s.size),
        solver="cvxpy + Clarabel",
        status=last.status,
        resolves=len(attempts) - 1,
        attempts=attempts,
        solver_time_s=solve_total,
        socp_time_s=socp_total,
        feed_ratio=last.feed_ratio,
        max_jerk_m_s3=last.max_jerk,
        max_accel_m_s2=last.max_accel,
        lower_bound_s=problem.lower_bound_time(),
        planning_time_s=planning_time,
        topp_time_s=topp_time,
        topp_duration_s=None if topp is None else topp.duration,
        gap_to_topp=None if topp is None else duration / topp.duration - 1.0,
        joint_refined_gridpoints=grid.refined or None,
        violations=violations,
    )
    return Trajectory(law="convex", timing=timing, continuity=2, notes=tuple(notes), stats=stats)
