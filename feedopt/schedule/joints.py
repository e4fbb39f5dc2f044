"""The joint rates between the samples: q'(s) per sample interval, its bounds, a dense replay.

The robot follows ``q(s(t))`` with ``q(s)`` the cubic joint spline through the path samples
(:func:`feedopt.robot.stage.joint_spline`; the exporters evaluate it at every controller
cycle). A :class:`~feedopt.schedule.problem.ScheduleProblem` carries ``q'`` and ``q''`` at the
samples; on each sample interval ``q'`` is taken as the cubic Hermite through ``q'`` and
``q''`` at both ends. That is the spline's own ``q'`` (a quadratic there, which the cubic
reproduces) and needs no joint positions (a problem whose ``q`` does not integrate ``q'``
still has a well-defined rate model). At an interior stop the arrays hold the following
piece's derivatives, so the interval arriving there takes its own side's from the samples
before it (:func:`one_sided_end`).

Between two samples the joint rates

    q_dot = q'(s) sdot,    q_ddot = q'(s) sddot + q''(s) sdot^2

are not bounded by their values at the samples: where a corner transition is shorter than
the sample spacing, ``q''`` spikes at one sample and ``q'`` turns within the interval. What
is given here:

* :func:`rate_pieces` / :func:`bernstein`: the pieces and their Bernstein coefficients
  (Farin, *Curves and Surfaces for CAGD*, ch. 5: a polynomial on an interval lies within the
  range of its Bernstein coefficients, exact at both ends);
* :func:`interval_peaks`: the largest ``|q'|`` and ``|q''|`` on each interval;
* :func:`dense_joint_extrema`: the joint rates of a trajectory replayed at ``points`` instants
  per sample interval (both ends included, left limits at the right end), for the verifier.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb
from typing import Any, Protocol

import numpy as np

from feedopt.schedule.polynomial import derivative_coefficients, horner
from feedopt.schedule.trajectory import Trajectory


class ScheduleProblem(Protocol):
    """What this module reads of a :class:`feedopt.schedule.problem.ScheduleProblem` (which
    imports this module for its joint screen, so it is named here by its shape): the
    samples' arc lengths [m] and stops, the joints' first and second derivatives in s and
    their limits."""

    s: np.ndarray
    dq_ds: np.ndarray
    d2q_ds2: np.ndarray
    joint_velocity_max: np.ndarray
    joint_acceleration_max: np.ndarray
    stops: Any  # StopSamples (its ``index``) or None

    @property
    def n(self) -> int: ...

    @property
    def joint_screen(self) -> JointScreen: ...

#: Instants per sample interval of the dense replay (both ends included).
DENSE_POINTS = 9
# Sample intervals per chunk of the dense replay (bounds its (chunk * points, dof) arrays).
_CHUNK = 1 << 14


def one_sided_end(values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The last row of ``values`` (m, ...) re-estimated from the rows before it alone.

    Quadratic extrapolation (Lagrange) in ``s`` from the three samples before the last one;
    linear from two, constant from one on shorter pieces. At a stop the arrays hold the
    following segment's values; the piece that arrives there needs its own side's (the path
    may have a corner at the stop).
    """
    m = s.size
    if m < 2:
        return values[-1]
    pts = np.arange(max(m - 4, 0), m - 1)  # up to three samples before the last
    x = s[-1]
    out = np.zeros_like(values[-1], dtype=float)
    for j in pts:
        w = 1.0
        for i in pts:
            if i != j:
                w *= (x - s[i]) / (s[j] - s[i])
        out += w * values[j]
    return out


def _interior_stops(problem: ScheduleProblem) -> np.ndarray:
    if problem.stops is None:
        return np.zeros(0, dtype=int)
    idx = np.unique(np.asarray(problem.stops.index, dtype=int))
    return idx[(idx > 0) & (idx < problem.n - 1)]


@dataclass(frozen=True)
class RateEnds:
    """What fixes q'(s) on sample intervals: width ``h`` (m,) and first and second derivative
    at both ends, (m, dof) each (in the unit of s given by ``scale``)."""

    h: np.ndarray
    dq0: np.ndarray
    dq1: np.ndarray
    d2q0: np.ndarray
    d2q1: np.ndarray


def arriving(problem: ScheduleProblem, values: np.ndarray, i: np.ndarray) -> np.ndarray:
    """``values`` (n, dof) at the end of the sample intervals ``i`` as that interval sees it:
    the next sample's row, except at an interior stop (the rows there hold the following
    piece's derivatives), where :func:`one_sided_end` of the samples before it."""
    out = np.asarray(values, dtype=float)[i + 1]
    for k in _interior_stops(problem):
        at = np.flatnonzero(i + 1 == k)
        if at.size:
            lo = max(int(k) - 3, 0)
            out[at] = one_sided_end(values[lo:k + 1], problem.s[lo:k + 1])
    return out


def rate_ends(problem: ScheduleProblem, intervals: np.ndarray | None = None,
              scale: float = 1.0) -> RateEnds:
    """:class:`RateEnds` of the sample ``intervals`` (indices i of [s_i, s_i+1]; default
    all), s in units of ``1 / scale`` m (``MM_PER_M``: mm), the arriving end of each from
    :func:`arriving`."""
    i = np.arange(problem.n - 1) if intervals is None else np.asarray(intervals, dtype=int)
    dq = np.asarray(problem.dq_ds, dtype=float)
    d2q = np.asarray(problem.d2q_ds2, dtype=float)
    return RateEnds(h=(problem.s[i + 1] - problem.s[i]) * scale, dq0=dq[i] / scale,
                    dq1=arriving(problem, dq, i) / scale, d2q0=d2q[i] / scale**2,
                    d2q1=arriving(problem, d2q, i) / scale**2)


def rate_pieces(problem: ScheduleProblem, intervals: np.ndarray | None = None,
                scale: float = 1.0) -> np.ndarray:
    """(4, m, dof) PPoly coefficients of q'(s) on the sample ``intervals`` (default all;
    local variable ``scale (s - s_i)``, highest power first): the cubic Hermite through
    :func:`rate_ends`."""
    e = rate_ends(problem, intervals, scale)
    h = e.h[:, None]
    d = e.dq1 - e.dq0
    c2 = (3 * d - (2 * e.d2q0 + e.d2q1) * h) / (h * h)
    c3 = ((e.d2q0 + e.d2q1) * h - 2 * d) / (h * h * h)
    return np.stack([c3, c2, e.d2q0, e.dq0])


def chunks(n_intervals: int, size: int = _CHUNK):
    """``(first, last)`` ranges of at most ``size`` sample intervals covering all of them."""
    for first in range(0, n_intervals, size):
        yield first, min(first + size, n_intervals)


def _bernstein_matrix(degree: int) -> np.ndarray:
    """M with Bernstein coefficient j = sum_k M[j, k] a_k h^k for p = sum_k a_k x^k on
    [0, h]: M[j, k] = C(j, k) / C(degree, k) for k <= j."""
    m = np.zeros((degree + 1, degree + 1))
    for j in range(degree + 1):
        for k in range(j + 1):
            m[j, k] = comb(j, k) / comb(degree, k)
    return m


def bernstein(c: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Bernstein coefficients (k+1, m, ...) on ``[0, h_i]`` of the polynomials ``c`` (k+1, m,
    ...) (PPoly order: highest power first, piece ``i`` in its local variable). The
    polynomial lies within their range on the interval and equals the first and the last at
    its ends."""
    c = np.asarray(c, dtype=float)
    return bernstein_ascending(c[::-1], h)


def bernstein_ascending(a: np.ndarray, h: np.ndarray) -> np.ndarray:
    """:func:`bernstein` of polynomials given by ascending power coefficients ``a`` (k+1, m,
    ...) in the variable ``x - x_i`` on ``[0, h_i]``."""
    a = np.asarray(a, dtype=float)
    degree = a.shape[0] - 1
    h = np.asarray(h, dtype=float).reshape((-1,) + (1,) * (a.ndim - 2))
    scaled = np.stack([a[k] * h**k for k in range(degree + 1)])  # a_k h^k
    return np.tensordot(_bernstein_matrix(degree), scaled, axes=1)


@dataclass(frozen=True)
class IntervalPeaks:
    """The largest |q'| [rad/m] and |q''| [rad/m^2] on each sample interval, (n-1, dof)."""

    dq_ds: np.ndarray
    d2q_ds2: np.ndarray

    def at_samples(self, problem: ScheduleProblem) -> tuple[np.ndarray, np.ndarray]:
        """(n, dof) |q'| and |q''| a per-sample feed bound must use: the value at the sample
        (from both sides: at a stop the path may turn), raised to the peak of a neighbouring
        interval whose interior exceeds both its ends. A law that keeps the feed under the
        smaller of the bounds at the two ends of an interval (topp's and convex's interval
        bounds, the jerk law's sections, a constant feed) then keeps the joint term within on
        all of it; where the peak is at an end (q'' of the cubic joint spline is linear) this
        is the sample's own value, no more conservative than a bound at the samples."""
        i = np.arange(problem.n - 1)
        return tuple(_sample_cover(peak, np.abs(x[:-1]), np.abs(arriving(problem, x, i)))
                     for peak, x in ((self.dq_ds, problem.dq_ds),
                                     (self.d2q_ds2, problem.d2q_ds2)))


def _rate_peaks(e: RateEnds) -> tuple[np.ndarray, np.ndarray]:
    """max |q'| and max |q''| on each interval of the cubic Hermite q' of ``e``. The extremes
    lie at the ends, at the vertex of q'' (a quadratic: only where it is inside) and at the
    roots of q'' (only where q'' changes sign inside: its ends, or an end and the vertex,
    differ in sign), evaluated on those intervals alone (few: q'' is linear on the joint
    spline, and changes sign at inflections)."""
    h = e.h[:, None]
    d = e.dq1 - e.dq0
    c3 = ((e.d2q0 + e.d2q1) * h - 2.0 * d) / (h * h * h)
    c2 = (3.0 * d - (2.0 * e.d2q0 + e.d2q1) * h) / (h * h)
    p = np.maximum(np.abs(e.dq0), np.abs(e.dq1))
    dp = np.maximum(np.abs(e.d2q0), np.abs(e.d2q1))
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = -c2 / (3.0 * c3)
    inside = (vertex > 0.0) & (vertex < h)
    at_vertex = e.d2q0[inside] - c2[inside] ** 2 / (3.0 * c3[inside])
    dp[inside] = np.maximum(dp[inside], np.abs(at_vertex))
    turns = e.d2q0 * e.d2q1 < 0.0
    turns[inside] |= at_vertex * e.d2q0[inside] < 0.0
    if np.any(turns):
        r = np.nonzero(turns)
        a3, a2, a1, a0 = c3[r], c2[r], e.d2q0[r], e.dq0[r]
        with np.errstate(divide="ignore", invalid="ignore"):
            disc = np.sqrt(np.maximum(a2 * a2 - 3.0 * a3 * a1, 0.0))
            big = -(a2 + np.copysign(disc, a2))  # stable roots of 3 a3 x^2 + 2 a2 x + a1
            for x in (big / (3.0 * a3), a1 / big):
                x = np.clip(np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0), 0.0,
                            np.broadcast_to(h, turns.shape)[r])
                p[r] = np.maximum(p[r], np.abs(((a3 * x + a2) * x + a1) * x + a0))
    return p, dp


def _sample_cover(peak: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(n, dof) per sample: its values at the ends of its intervals and the peak of a
    neighbouring interval whose interior exceeds both ends (:meth:`IntervalPeaks.at_samples`)."""
    excess = np.where(peak > np.maximum(start, end), peak, 0.0)
    out = np.zeros((peak.shape[0] + 1,) + peak.shape[1:])
    out[:-1] = np.maximum(start, excess)
    out[1:] = np.maximum(out[1:], np.maximum(end, excess))
    return out


def interval_peaks(problem: ScheduleProblem) -> IntervalPeaks:
    """:class:`IntervalPeaks` of :func:`rate_pieces`, exact (to rounding): the largest of
    |q'| and |q''| at the ends and at the interior extrema (:func:`_rate_peaks`)."""
    parts: list[list[np.ndarray]] = [[], []]
    for first, last in chunks(problem.n - 1):
        for part, x in zip(parts, _rate_peaks(rate_ends(problem, np.arange(first, last))),
                           strict=True):
            part.append(x)
    return IntervalPeaks(dq_ds=np.concatenate(parts[0]), d2q_ds2=np.concatenate(parts[1]))


@dataclass(frozen=True)
class JointScreen:
    """Per sample interval, (n-1,) each: max over the joints of max|q'| / velocity limit
    [s/m], max|q'| / acceleration limit [s^2/m] and max|q''| / acceleration limit
    [s^2/m^2]. Then |q_dot| / limit <= ``velocity`` sdot and |q_ddot| / limit <=
    ``accel_dq`` |sddot| + ``accel_d2q`` sdot^2 on the interval: where that cannot exceed
    a ratio already found, a replay need not look (:func:`dense_joint_extrema`). A problem
    keeps its own (``ScheduleProblem.joint_screen``): 24 bytes a sample, where the per-joint
    peaks (:func:`interval_peaks`) are made and dropped by the laws that need them."""

    velocity: np.ndarray
    accel_dq: np.ndarray
    accel_d2q: np.ndarray


def joint_screen(problem: ScheduleProblem) -> JointScreen:
    """:class:`JointScreen` of ``problem``, one chunk of intervals at a time."""
    vmax = np.asarray(problem.joint_velocity_max, dtype=float)
    amax = np.asarray(problem.joint_acceleration_max, dtype=float)
    parts: list[list[np.ndarray]] = [[], [], []]
    for first, last in chunks(problem.n - 1):
        p, dp = _rate_peaks(rate_ends(problem, np.arange(first, last)))
        for part, x in zip(parts, (p / vmax, p / amax, dp / amax), strict=True):
            part.append(np.max(x, axis=1))
    return JointScreen(*(np.concatenate(x) for x in parts))


@dataclass(frozen=True)
class JointExtreme:
    """The largest |joint rate| / limit of a replay and where: time [s], arc length [m],
    joint (0-based), value [rad/s or rad/s^2], the sample interval ``(i, i + 1)`` and the
    sample when the instant is one (else None)."""

    ratio: float
    t: float
    s: float
    joint: int
    value: float
    interval: int
    sample: int | None = None

    @property
    def where(self) -> str:
        """``sample i`` or ``between samples i and i + 1``."""
        if self.sample is not None:
            return f"sample {self.sample}"
        return f"between samples {self.interval} and {self.interval + 1}"


@dataclass(frozen=True)
class DenseJoints:
    """Joint velocity and acceleration extremes of a dense replay (:func:`dense_joint_extrema`)."""

    velocity: JointExtreme
    acceleration: JointExtreme


def _replay_times(t0: np.ndarray, t1: np.ndarray, points: int) -> np.ndarray:
    """(m, points) instants from ``t0`` to ``t1`` (m,), uniform in time, both ends included."""
    u = np.linspace(0.0, 1.0, points)
    return t0[:, None] + (t1 - t0)[:, None] * u[None, :]


def _motion_at(c: np.ndarray, x: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """s, sdot, sddot of the PPoly (c, x) at ``t`` (m, points): the piece holding each
    instant, and for the last column of each row the piece ending there (its left limit)."""
    right = np.searchsorted(x, t[:, :-1], side="right") - 1
    left = np.searchsorted(x, t[:, -1:], side="left") - 1
    piece = np.clip(np.hstack([right, left]), 0, x.size - 2)
    local = t - x[piece]
    return tuple(horner(derivative_coefficients(c, k)[:, piece], local) for k in (0, 1, 2))


def motion_bounds(trajectory: Trajectory, sample_times: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Upper bounds of |sdot| and |sddot| between consecutive sample times, (n-1,) each:
    the largest absolute Bernstein coefficient of the derivative on every s(t) piece that
    overlaps the interval (rigorous, whatever the law's pieces)."""
    pp = trajectory.timing
    h = np.diff(pp.x)
    vb, ab = (np.max(np.abs(bernstein(derivative_coefficients(pp.c, k), h)), axis=0)
              for k in (1, 2))
    last = pp.x.size - 2
    lo = np.clip(np.searchsorted(pp.x, sample_times[:-1], side="right") - 1, 0, last)
    hi = np.clip(np.searchsorted(pp.x, sample_times[1:], side="left") - 1, lo, last)
    return tuple(np.maximum(np.maximum.reduceat(x, lo), x[hi]) for x in (vb, ab))


def _worst(ratio: np.ndarray, values: np.ndarray, t: np.ndarray, s: np.ndarray,
           rows: np.ndarray) -> JointExtreme:
    """The largest entry of ``ratio`` (m, points, dof) of the sample intervals ``rows`` as a
    :class:`JointExtreme`."""
    i, p, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    end = ratio.shape[1] - 1
    sample = int(rows[i]) + (1 if p == end else 0) if p in (0, end) else None
    return JointExtreme(float(ratio[i, p, j]), float(t[i, p]), float(s[i, p]), int(j),
                        float(values[i, p, j]), int(rows[i]), sample)


def _at_samples(trajectory: Trajectory, problem: ScheduleProblem,
                sample_times: np.ndarray) -> DenseJoints:
    """The joint rates at the samples themselves (the path's own derivatives there)."""
    m = trajectory.at(sample_times)
    qd = problem.dq_ds * m.sdot[:, None]
    qdd = problem.d2q_ds2 * (m.sdot**2)[:, None] + problem.dq_ds * m.sddot[:, None]
    rows = np.minimum(np.arange(problem.n), problem.n - 2)
    found = []
    for values, limit in ((qd, problem.joint_velocity_max),
                          (qdd, problem.joint_acceleration_max)):
        r = np.abs(values) / np.asarray(limit, dtype=float)
        i, j = np.unravel_index(int(np.argmax(r)), r.shape)
        found.append(JointExtreme(float(r[i, j]), float(m.t[i]), float(problem.s[i]), int(j),
                                  float(values[i, j]), int(rows[i]), int(i)))
    return DenseJoints(*found)


@dataclass(frozen=True)
class _Candidates:
    """(interval, joint) pairs of a coarse replay worth refining, with the bracket of
    instants around each one's best point and its coarse ratio."""

    rows: np.ndarray
    joints: np.ndarray
    t_lo: np.ndarray
    t_hi: np.ndarray
    ratio: np.ndarray

    @staticmethod
    def concat(parts: list[_Candidates]) -> _Candidates:
        return _Candidates(*(np.concatenate([getattr(p, f) for p in parts])
                             for f in ("rows", "joints", "t_lo", "t_hi", "ratio")))


def _candidates(ratio: np.ndarray, t: np.ndarray, rows: np.ndarray, floor: float
                ) -> _Candidates:
    """The (interval, joint) pairs of ``ratio`` (m, points, dof) whose best point reaches
    ``floor``, bracketed by the instants on either side of that point."""
    best = np.argmax(ratio, axis=1)  # (m, dof)
    value = np.take_along_axis(ratio, best[:, None, :], axis=1)[:, 0, :]
    i, j = np.nonzero(value >= floor)
    p = best[i, j]
    last = t.shape[1] - 1
    return _Candidates(rows[i], j, t[i, np.maximum(p - 1, 0)], t[i, np.minimum(p + 1, last)],
                       value[i, j])


def _rates_at(trajectory: Trajectory, problem: ScheduleProblem, pieces: np.ndarray,
              rows: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Arc length, joint velocity and acceleration at instants ``t`` (m,) of one joint each:
    ``pieces`` (4, m) are its q' pieces on the sample intervals ``rows``."""
    pp = trajectory.timing
    s = pp(t)
    v, a = pp(t, 1), pp(t, 2)
    sigma = np.clip(s - problem.s[rows], 0.0, problem.s[rows + 1] - problem.s[rows])
    q1 = horner(pieces, sigma)
    q2 = horner(derivative_coefficients(pieces), sigma)
    return s, q1 * v, q2 * v * v + q1 * a


_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
#: Golden-section steps refining a coarse maximum (the bracket shrinks to 0.618^24 ~ 1e-5;
#: near a maximum the ratio changes with the square of that).
_REFINE_STEPS = 24
#: Pairs whose coarse ratio is within this fraction of the largest are refined (9 points per
#: interval miss a peak between them by about 1 %).
_REFINE_WITHIN = 0.1


def _refined(trajectory: Trajectory, problem: ScheduleProblem, cand: _Candidates,
             kind: int, limit: np.ndarray) -> JointExtreme | None:
    """Golden-section search for the largest ratio of each candidate in its bracket
    (``kind`` 1: velocity, 2: acceleration); the best as a :class:`JointExtreme`."""
    if not cand.rows.size:
        return None
    pieces = rate_pieces(problem, cand.rows)[:, np.arange(cand.rows.size), cand.joints]
    lim = limit[cand.joints]

    def ratio(t: np.ndarray) -> np.ndarray:
        return np.abs(_rates_at(trajectory, problem, pieces, cand.rows, t)[kind]) / lim

    lo, hi = cand.t_lo.copy(), cand.t_hi.copy()
    x1, x2 = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
    f1, f2 = ratio(x1), ratio(x2)
    for _ in range(_REFINE_STEPS):
        left = f1 >= f2  # the maximum lies in [lo, x2], else in [x1, hi]
        hi, lo = np.where(left, x2, hi), np.where(left, lo, x1)
        x_keep, f_keep = np.where(left, x1, x2), np.where(left, f1, f2)
        x_new = np.where(left, hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo))
        f_new = ratio(x_new)
        x1, f1 = np.where(left, x_new, x_keep), np.where(left, f_new, f_keep)
        x2, f2 = np.where(left, x_keep, x_new), np.where(left, f_keep, f_new)
    tt = np.where(f1 >= f2, x1, x2)
    s, qd, qdd = _rates_at(trajectory, problem, pieces, cand.rows, tt)
    values = qd if kind == 1 else qdd
    r = np.abs(values) / lim
    k = int(np.argmax(r))
    return JointExtreme(float(r[k]), float(tt[k]), float(s[k]), int(cand.joints[k]),
                        float(values[k]), int(cand.rows[k]), None)


def dense_joint_extrema(trajectory: Trajectory, problem: ScheduleProblem,
                        sample_times: np.ndarray, points: int = DENSE_POINTS) -> DenseJoints:
    """Joint velocity and acceleration of ``q(s(t))`` relative to their limits: at the
    samples, and at ``points`` instants of every sample interval whose bound (the problem's
    :class:`JointScreen` and :func:`motion_bounds`) exceeds the largest ratio at the samples, i.e.
    wherever the maximum can lie (elsewhere nothing is evaluated: a long path at cutting
    feeds costs little more than its samples); then the best point of every (interval,
    joint) within :data:`_REFINE_WITHIN` of the largest is refined by a golden-section
    search between its neighbouring instants, so the maximum is found to rounding, not to
    the spacing of the instants.

    The instants are uniform in time between the samples' times (no inversion of s(t)); the
    last of each interval is evaluated on the s(t) piece ending there, so a C1 law's
    acceleration is seen on both sides of its breakpoints. The arc length reached is kept
    within its interval (rounding), where its rate piece (:func:`rate_pieces`) is evaluated.
    """
    best = _at_samples(trajectory, problem, sample_times)
    screen = problem.joint_screen
    vb, ab = motion_bounds(trajectory, sample_times)
    limits = (np.asarray(problem.joint_velocity_max, dtype=float),
              np.asarray(problem.joint_acceleration_max, dtype=float))
    bound_v = screen.velocity * vb
    bound_a = screen.accel_dq * ab + screen.accel_d2q * vb * vb
    todo = np.flatnonzero((bound_v > best.velocity.ratio)
                          | (bound_a > best.acceleration.ratio))
    found = [best.velocity, best.acceleration]
    cands: list[list[_Candidates]] = [[], []]
    pp = trajectory.timing
    for first, last in chunks(todo.size):
        rows = todo[first:last]
        qc = rate_pieces(problem, rows)[:, :, None, :]
        t = _replay_times(sample_times[rows], sample_times[rows + 1], points)
        s, v, a = _motion_at(pp.c, pp.x, t)
        sigma = np.clip(s - problem.s[rows, None], 0.0, (problem.s[rows + 1]
                                                          - problem.s[rows])[:, None])
        q1 = horner(qc, sigma[..., None])  # (m, points, dof)
        q2 = horner(derivative_coefficients(qc, 1), sigma[..., None])
        for k, values in enumerate((q1 * v[..., None],
                                    q2 * (v * v)[..., None] + q1 * a[..., None])):
            ratio = np.abs(values) / limits[k]
            e = _worst(ratio, values, t, s, rows)
            found[k] = e if e.ratio > found[k].ratio else found[k]
            cands[k].append(_candidates(ratio, t, rows, (1 - _REFINE_WITHIN) * found[k].ratio))
    for k in (0, 1):
        if cands[k]:
            c = _Candidates.concat(cands[k])
            keep = c.ratio >= (1 - _REFINE_WITHIN) * found[k].ratio
            e = _refined(trajectory, problem, _Candidates(
                c.rows[keep], c.joints[keep], c.t_lo[keep], c.t_hi[keep], c.ratio[keep]),
                k + 1, limits[k])
            found[k] = e if e is not None and e.ratio > found[k].ratio else found[k]
    return DenseJoints(velocity=found[0], acceleration=found[1])
