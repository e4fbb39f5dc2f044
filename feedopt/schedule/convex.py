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
* |a_k| <= accel_max, joint accelerations |q' a_k + q'' b_k| <= limit at the gridpoints;
* jerk: sdddot = (da/ds) sdot and sdot <= w_k on interval k, so
  |a_{k+1} - a_k| <= jerk_max ds_k / w_k is a convex, conservative jerk limit (no sequential
  convexification). w_k is the interval's feed bound, and near a rest end the feed a
  jerk-limited start could reach there (plus a margin);
* a = 0 and b = v^2 at both ends.

The travel time sum 2 ds_k / (sqrt(b_k) + sqrt(b_{k+1})) is minimised through second-order
cones: c_k^2 <= b_k and d_k (c_k + c_{k+1}) >= 1, objective sum 2 ds_k d_k.

The output s(t) is a quintic Hermite piece in t per grid interval through (s, sdot, sddot) at
the gridpoints (C2), with a piece duration that is exact for constant-jerk motion. It is
verified on the fine samples; if the smoothing overshoots the feed, jerk or acceleration
limit, those limits are shrunk by the measured margin and the SOCP is solved again (reported
in ``stats["resolves"]`` and in ``notes``). The solver grid is the samples, or, on long
paths, an adaptive subset (dense where v_max varies, coarse where it is flat) capped at
``max_gridpoints``, plus graded points near a rest end (between samples).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.topp import (
    SampledJointPath,
    plan_topp,
    quintic_hermite_coefficients,
    sample_feed_bound,
)
from feedopt.schedule.trajectory import Trajectory, ppoly_from_pieces

_MM = 1e3  # the SOCP is solved in mm and s (b ~ 10 mm^2/s^2) for good conditioning


def adaptive_grid(
    problem: ScheduleProblem, v_sample: np.ndarray, max_gridpoints: int
) -> np.ndarray:
    """Arc lengths [m] of the solver grid (about ``max_gridpoints`` points or fewer).

    Every sample when there are few enough; otherwise points are placed at equal steps of a
    measure that is half arc length and half the variation of log(v_max), the latter spread
    over a braking distance so the grid is also dense where the tool slows down before a drop
    of the bound. Near a boundary at rest the grid is graded (s ~ i^3, the shape of a
    jerk-limited start) over the jerk-limited acceleration distance, with points between
    samples: the node model (sddot linear in s) cannot describe a start from rest, so the
    pieces there must be short.
    """
    n = problem.n
    s = problem.s
    v_top = float(np.max(v_sample))
    a_lim = problem.accel_max if np.isfinite(problem.accel_max) else np.inf
    j_lim = problem.jerk_max
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
        idx = np.searchsorted(measure, np.linspace(0.0, 1.0, max(max_gridpoints - 120, 2)))
        pts = [s[np.clip(idx, 0, n - 1)], s[[0, n - 1]]]
    graded = zone * np.linspace(0.0, 1.0, 61) ** 3
    if problem.v_start == 0:
        pts.append(graded)
    if problem.v_end == 0:
        pts.append(s[-1] - graded)
    grid = np.unique(np.clip(np.concatenate(pts), 0.0, s[-1]))
    # drop points closer than 1e-9 of the length to a neighbour (keep the end points)
    keep = np.concatenate([[True], np.diff(grid) > 1e-9 * s[-1]])
    keep[-1] = True
    grid = grid[keep]
    if grid.size > 2 and grid[-1] - grid[-2] <= 1e-9 * s[-1]:
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


def _solve_socp(
    s_mm: np.ndarray,
    b_node: np.ndarray,
    b_int: np.ndarray,
    q1: np.ndarray,
    q2: np.ndarray,
    qdd_max: np.ndarray,
    a_max: float,
    j_max: float,
    b_start: float,
    b_end: float,
    w: np.ndarray,
    solver_options: dict,
):
    """Solve the SOCP in mm / s units; returns (b, a, status, solve time, setup time)."""
    import cvxpy as cp

    t0 = time.perf_counter()
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
    a_cap = a_max if np.isfinite(a_max) else np.inf
    for j in range(q1.shape[1]):
        # drop gridpoints where |q' a + q'' b| cannot reach the limit (most of them)
        reach = np.abs(q1[:, j]) * a_cap + np.abs(q2[:, j]) * b_node
        k = np.flatnonzero(~(reach < qdd_max[j]))
        if k.size:
            qdd = cp.multiply(q1[k, j], a[k]) + cp.multiply(q2[k, j], b[k])
            cons += [qdd <= qdd_max[j], qdd >= -qdd_max[j]]
    prob = cp.Problem(cp.Minimize(2 * ds @ d), cons)
    opts = {"solver": cp.CLARABEL}
    opts.update(solver_options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "inaccurate": reported via status
        prob.solve(**opts)
    total = time.perf_counter() - t0
    stats = prob.solver_stats
    solve_time = float(stats.solve_time) if stats and stats.solve_time else float("nan")
    if b.value is None:
        return None, None, prob.status, solve_time, total
    return np.asarray(b.value), np.asarray(a.value), prob.status, solve_time, total


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
            f"the feed is zero on both ends of the grid interval at s = {s[k] * 1e3:.3f} mm "
            f"(gridpoint {k}): the bound or the limits stop the motion there"
        )
    coeffs = quintic_hermite_coefficients(dt, s[:-1], v[:-1], a[:-1], s[1:], v[1:], a[1:])
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return ppoly_from_pieces(t, coeffs)


def _exact_jerk_max(pp) -> float:
    """max |sdddot| over all quintic pieces (jerk is quadratic in t: ends and vertex)."""
    c = pp.c
    h = np.diff(pp.x)
    c5, c4, c3 = c[0], c[1], c[2]
    jerk0 = 6 * c3
    jerk1 = 60 * c5 * h**2 + 24 * c4 * h + 6 * c3
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = np.where(c5 != 0, -24 * c4 / (120 * c5), -1.0)
    inside = (tv > 0) & (tv < h)
    jerkv = np.where(inside, 60 * c5 * tv**2 + 24 * c4 * tv + 6 * c3, 0.0)
    return float(np.max(np.abs(np.concatenate([jerk0, jerk1, jerkv]))))


def plan_convex(
    problem: ScheduleProblem,
    *,
    max_gridpoints: int = 3000,
    jerk_margin: float = 0.02,
    max_resolves: int = 3,
    topp: Trajectory | None = None,
    compare_topp: bool = True,
    reach_margin: float = 0.05,
    solver_options: dict | None = None,
) -> Trajectory:
    """Minimum-time jerk-limited C2 timing law (SOCP, cvxpy + Clarabel).

    Parameters
    ----------
    problem : ScheduleProblem
        Path samples, feed bound and limits. ``jerk_max`` must be finite.
    max_gridpoints : int
        Cap on the solver grid (adaptive; every sample when the path has fewer).
    jerk_margin : float
        Relative margin on the jerk limit for the first solve (the quintic smoothing may
        exceed the discrete jerk slightly).
    max_resolves : int
        How many times to shrink the limits by the measured overshoot and solve again.
    topp : Trajectory, optional
        A ``plan_topp`` result for the same problem: ``stats["gap_to_topp"]`` is
        ``duration / topp.duration - 1``.
    compare_topp : bool
        When ``topp`` is not given, run ``plan_topp`` after planning to report the gap (its
        time is ``stats["topp_time_s"]``, not part of ``stats["planning_time_s"]``).
    reach_margin : float
        Relative margin on the jerk-limited reach feed from / to a rest end, used as the
        feed w_k in the jerk constraint there (see :func:`jerk_limited_reach`).
    solver_options : dict, optional
        Extra keyword arguments for ``cvxpy.Problem.solve`` (e.g. tolerances).

    Returns
    -------
    Trajectory
        ``law="convex"``, quintic pieces, ``continuity=2``.
    """
    t_start = time.perf_counter()
    if not np.isfinite(problem.jerk_max) or problem.jerk_max <= 0:
        raise InputError(
            f"jerk_max = {problem.jerk_max} m/s^3: the convex law needs a finite positive jerk "
            "limit (use the topp law for an unlimited jerk)"
        )
    v_sample = sample_feed_bound(problem)
    if np.any(~(v_sample > 0)):
        k = int(np.argmax(~(v_sample > 0)))
        raise InputError(
            f"feed bound is {v_sample[k]} m/s at sample {k} (s = {problem.s[k] * 1e3:.3f} mm); "
            "every sample needs a positive bound"
        )
    for name, v, k in (("v_start", problem.v_start, 0), ("v_end", problem.v_end, problem.n - 1)):
        if v < 0 or v > v_sample[k]:
            raise InputError(
                f"{name} = {v * 1e3:.6g} mm/s is outside [0, {v_sample[k] * 1e3:.6g}] mm/s, "
                f"the feed bound at sample {k}"
            )

    s_grid = adaptive_grid(problem, v_sample, max_gridpoints)
    v_int, v_node = grid_bounds_at(problem.s, v_sample, s_grid)
    s_mm = s_grid * _MM
    path = SampledJointPath(problem)
    q1 = path(s_grid, 1) / _MM
    q2 = path(s_grid, 2) / _MM**2
    qdd_max = np.asarray(problem.joint_acceleration_max, dtype=float)
    a_lim = float(problem.accel_max)
    j_lim = float(problem.jerk_max)

    # feed bound w_k of each interval in the jerk constraint: v_max, and near a rest end the
    # jerk-limited reach (v_max alone would make the start from rest very slow)
    w_bound = np.minimum(v_int, (1 + reach_margin) * _rest_reach_feed(problem, s_grid))

    feed_scale, accel_scale, jerk_scale = 1.0, 1.0, 1.0 - jerk_margin
    history = []
    notes: list[str] = []
    traj = None
    solve_total = 0.0
    socp_total = 0.0
    for attempt in range(max_resolves + 1):
        b_node = (v_node * feed_scale * _MM) ** 2
        b_int = (v_int * feed_scale * _MM) ** 2
        b_start = min((problem.v_start * _MM) ** 2, b_node[0])
        b_end = min((problem.v_end * _MM) ** 2, b_node[-1])
        b, a, status, solve_time, total = _solve_socp(
            s_mm, b_node, b_int, q1, q2, qdd_max,
            a_lim * accel_scale * _MM, j_lim * jerk_scale * _MM,
            b_start, b_end, w_bound * feed_scale * _MM, solver_options or {},
        )
        solve_total += solve_time
        socp_total += total
        if b is None or status not in ("optimal", "optimal_inaccurate"):
            raise InputError(
                f"the convex SOCP is {status}: the boundary feeds, the feed bound and the "
                "acceleration / jerk limits are inconsistent (try the topp law to see which)"
            )
        b = np.clip(b, 0.0, b_node)
        b[0], b[-1] = b_start, b_end
        v = np.sqrt(b) / _MM
        acc = a / _MM
        acc[0] = acc[-1] = 0.0
        timing = quintic_timing(s_grid, v, acc)
        traj = Trajectory(law="convex", timing=timing, continuity=2)
        chk = check_timing(traj, problem)
        jerk = _exact_jerk_max(timing)
        reversing = any("negative" in p for p in chk.problems)
        history.append(
            {
                "feed_ratio": chk.feed_ratio,
                "max_accel": chk.max_accel,
                "max_jerk": jerk,
                "status": status,
                "feed_scale": feed_scale,
                "jerk_scale": jerk_scale,
                "accel_scale": accel_scale,
            }
        )
        over_feed = chk.feed_ratio > 1.0
        over_jerk = jerk > j_lim
        over_acc = chk.max_accel > a_lim
        if not (over_feed or over_jerk or over_acc or reversing):
            break
        if attempt == max_resolves:
            break
        # shrink by the measured overshoot (plus a little) and solve again
        if over_feed:
            feed_scale *= (1.0 - 1e-6) / chk.feed_ratio
        if over_jerk:
            jerk_scale *= 0.999 * j_lim / jerk
        if over_acc:
            accel_scale *= 0.999 * a_lim / chk.max_accel
        if reversing:
            jerk_scale *= 0.9

    last = history[-1]
    resolves = len(history) - 1
    notes.append(
        f"SOCP (Verscheure et al. 2009) on {s_grid.size} gridpoints, solved by Clarabel; s(t) is "
        "quintic Hermite in t through (s, sdot, sddot) at gridpoints: C2, jerk-limited."
    )
    if resolves:
        notes.append(
            f"the quintic smoothing overshot a limit; re-solved {resolves} time(s) with the feed "
            f"bound x{feed_scale:.6f}, jerk limit x{jerk_scale:.4f}, "
            f"acceleration limit x{accel_scale:.4f}"
        )
    if last["feed_ratio"] > 1 + 1e-9:
        notes.append(
            f"VIOLATION: feed reaches {last['feed_ratio']:.6f} of v_max on the fine samples"
        )
    if last["max_jerk"] > j_lim * (1 + 1e-9):
        notes.append(
            f"VIOLATION: jerk reaches {last['max_jerk']:.6g} m/s^3 > limit {j_lim:.6g} m/s^3"
        )
    if last["max_accel"] > a_lim * (1 + 1e-9):
        notes.append(
            f"VIOLATION: acceleration reaches {last['max_accel']:.6g} m/s^2 > {a_lim:.6g} m/s^2"
        )

    stats = {
        "gridpoints": int(s_grid.size),
        "solver": "cvxpy + Clarabel",
        "status": last["status"],
        "resolves": resolves,
        "attempts": history,
        "solver_time_s": solve_total,
        "socp_time_s": socp_total,
        "feed_ratio": last["feed_ratio"],
        "max_jerk_m_s3": last["max_jerk"],
        "max_accel_m_s2": last["max_accel"],
        "lower_bound_s": problem.lower_bound_time(),
    }
    stats["planning_time_s"] = time.perf_counter() - t_start
    if topp is None and compare_topp:
        t0 = time.perf_counter()
        topp = plan_topp(problem)
        stats["topp_time_s"] = time.perf_counter() - t0
    if topp is not None:
        stats["topp_duration_s"] = topp.duration
        stats["gap_to_topp"] = traj.duration / topp.duration - 1.0
    return Trajectory(
        law="convex", timing=traj.timing, continuity=2, notes=tuple(notes), stats=stats
    )
