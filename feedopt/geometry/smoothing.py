"""Smoothing of a chain of short G1 moves into one quintic B-spline within a tolerance.

CAM programs give free-form curves as thousands of short (0.05-1 mm), nearly tangent-continuous
linear moves; blending every tiny corner (thesis 3.3) gives a curvature spike per corner. The
thesis lists "an arbitrary set of points approximated into a C2 path" as future work (5.3);
:func:`smooth_chain` does it for one chain: it replaces the polyline by a single parametric
quintic B-spline (C4, so the path is G2 and its curvature is C2 in arc length) that stays within
a tolerance of the programmed polyline and passes exactly through its two end points.

The fit is a weighted least-squares B-spline in the spirit of Dierckx's FITPACK (Dierckx,
"Curve and Surface Fitting with Splines", 1993, ch. 5 and 9): a parametric curve over the
chord-length parameter u (the polyline's own arc length [m]), few knots to start with, knots
added in the knot spans where the tolerance is not met (FITPACK's curfit/parcur add knots
where the residual is largest; here the criterion is the max-norm tolerance rather than
FITPACK's sum of squared residuals, which cannot bound a distance). The least squares are
assembled from scipy's B-spline design matrix (:meth:`scipy.interpolate.BSpline.design_matrix`)
and solved with scipy's sparse LU; the end conditions are imposed by fixing the clamped end
coefficients (see :func:`smooth_chain`), which are eliminated from the system.

:class:`SplineEvaluator` evaluates such curves by arc length (thesis Eq. 3.23) through a
per-chain s(u) table (Gauss-Legendre on every half knot span) inverted by a cubic Hermite guess
and safeguarded Newton steps to 1e-12 of the length, with the chain rule of
:func:`~feedopt.geometry.arclength.arc_length_derivatives`. Importing this module registers
the segment kind ``"spline"`` (:data:`SPLINE`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline
from scipy.sparse.linalg import splu

from feedopt.errors import InputError
from feedopt.geometry.arclength import arc_length_derivatives
from feedopt.geometry.registry import SegmentKind, register_segment_kind
from feedopt.units import MM_PER_M

if TYPE_CHECKING:  # pragma: no cover
    from feedopt.geometry.path import Segment

SPLINE_KIND = "spline"
DEGREE = 5  #: quintic: C4 curve, curvature C2 in arc length
#: the fit stops when deviation and coverage are at most this fraction of the tolerance; the
#: rest covers the error of the sampled measurement (well below 1% of the tolerance)
TARGET = 0.98
INITIAL_SPAN_MOVES = 64  # first knot vector: an interior knot every this many moves
MAX_ITERATIONS = 40
MAX_DATA_PER_MOVE = 256  # densification limit when knot spans become shorter than moves
RIDGE = 1e-10  # relative weight of a second-difference penalty (only guards empty spans)
SAMPLES_PER_INTERVAL = 2  # deviation samples per data interval (before refinement) ...
SAMPLES_PER_SPAN = 32  # ... and at least this many per knot span
TABLE_SPLIT = 2  # arc-length table nodes per knot span
_GL_TABLE = np.polynomial.legendre.leggauss(8)
_GL_NEWTON = np.polynomial.legendre.leggauss(6)
_MAX_NEWTON = 60
_PROJECTION_STEPS = 3
_CHUNK = 4096
_CROSSING_STEPS = 3
_BISECTION_STEPS = 30


@dataclass(frozen=True)
class SmoothedChain:
    """A chain of moves smoothed into one quintic B-spline.

    Attributes
    ----------
    params : the ``params`` of one ``Segment("spline", s0, length, -1, params)``: ``knots``
        (n+6,) [m of chord length], ``coefficients`` (n, 3) [m], ``degree`` (5), and the
        arc-length table ``t_nodes``, ``s_nodes``, ``sigma_nodes`` (N+1,) (parameter [m], arc
        length [m], speed |dp/du|)
    length : arc length of the curve [m]
    node_s : (k+1,) arc length of the curve point closest to each input point, monotone
        non-decreasing, ``node_s[0] = 0``, ``node_s[-1] = length``
    deviation : max distance from the curve to the programmed polyline [m] (every curve point
        is within it of the polyline)
    coverage : max distance from the programmed vertices to the curve [m]
    """

    params: dict[str, np.ndarray]
    length: float
    node_s: np.ndarray
    deviation: float
    coverage: float


# --- fitting ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Polyline:
    points: np.ndarray  # (k+1, 3)
    u: np.ndarray  # (k+1,) chord length at the vertices [m]
    vec: np.ndarray  # (k, 3) move vectors
    length2: np.ndarray  # (k,) squared move lengths (guarded > 0)
    moves: np.ndarray  # (7, k) start point, move vector, squared length
    bisector: np.ndarray  # (k-1, 3) sum of the unit directions either side of each vertex
    window: int  # moves either side searched for the nearest polyline point


def smooth_chain(points: ArrayLike, tolerance: float, *,
                 start_tangent: ArrayLike | None = None,
                 end_tangent: ArrayLike | None = None) -> SmoothedChain:
    """Smooth a chain of short linear moves into one quintic B-spline within ``tolerance``.

    Parameters
    ----------
    points : (k+1, 3) vertices [m]: the start of the first move, then every move's end;
        k >= 3 moves ((k+1, 2) is taken as z = 0). Repeated consecutive points are allowed.
    tolerance : the largest allowed distance between curve and polyline [m], > 0, both ways
        (curve -> polyline: ``deviation``; vertices -> curve: ``coverage``)
    start_tangent, end_tangent : optional directions (3,) the curve must leave the first point
        and reach the last point in (normalised here); they may differ from the first and last
        moves' directions as far as the tolerance allows (not by 90 degrees or more).

    Returns
    -------
    SmoothedChain

    Notes
    -----
    The curve p(u) is a clamped quintic B-spline over the chord-length parameter u in [0, U]
    (U = polyline length), fitted by weighted least squares to the polyline sampled at its
    vertices and at least one interior point per move (trapezoid weights, i.e. the L2 distance
    to the polyline). The end points are exact because the first and last coefficients are
    fixed to them (a clamped B-spline interpolates its end coefficients). A given start tangent
    T0 fixes the second coefficient too, c1 = P0 + (u_6 / 5) T0, which makes p'(0) = T0 (unit
    speed, natural for a chord-length parameter; u_6 is the first interior knot), and likewise
    c_{n-2} = P_k - ((U - u_{n-1}) / 5) T1 at the end. Those coefficients are eliminated from
    the normal equations; the rest are free.

    Knots: first an interior knot every ``INITIAL_SPAN_MOVES`` moves (so the knots follow the
    move density of the program), then, until deviation and coverage are at most ``TARGET``
    times the tolerance, every knot span where either is exceeded is split into 2 to 4 equal
    parts by its error ratio (and the moves there sampled more densely when the spans become
    shorter than about 4 data intervals). Where the tolerance is below the chord sag of the
    moves (their corners are visible at that scale) the curve has to follow the corners and
    gets many short spans: its curvature then peaks at the vertices like tiny blends.

    Measurement (the reported ``deviation`` and ``coverage``): the curve is sampled at the data
    parameters and more points in between (>= 2 per data interval, >= 4 per move, >= 32 per
    knot span); each sample's distance to the moves within ``window`` moves of its own (an
    upper bound of the distance to the whole polyline: another pass of the chain nearby does
    not count) is taken; then every smooth local maximum is refined by the vertex of a parabola
    through it and its neighbours, and the kinks of the distance (where the nearest move
    changes: the crossings of every vertex's bisector plane by Newton steps, other switches by
    bisection) are measured too. The values are distances of actual curve points, so at most
    the true maximum; what is left is the O(h^3) error of the parabolas, in tests < 1e-3 of the
    value (< 1e-4 of the tolerance on smooth chains), which the fit's 2% margin (``TARGET``)
    covers. Coverage projects every vertex onto the curve by Newton steps from its own
    parameter and reports the distance to that curve point (an upper bound).

    Raises
    ------
    InputError
        for fewer than 3 moves, non-finite points, a tolerance that is not a positive finite
        number, a zero or non-finite tangent or one pointing backwards, a chain of zero
        length, and a chain the spline cannot follow within the tolerance (a sharp corner:
        split the chain there).
    """
    pts, tol, t_start, t_end = _validate(points, tolerance, start_tangent, end_tangent)
    poly = _polyline(pts, tol)
    knots = _initial_knots(poly)
    sub = _initial_subdivision(poly)
    target = TARGET * tol
    for _ in range(MAX_ITERATIONS):
        u_data, y_data, w_data = _data(poly, sub)
        spline = _fit(u_data, y_data, w_data, knots, pts[0], pts[-1], t_start, t_end)
        dev_u, dev = _deviation(spline, poly, u_data)
        cov_u, cov = _coverage(spline, poly)
        bad, parts = _bad_spans(knots, dev_u, dev, cov_u, cov, target)
        if not bad.size:
            break
        knots, sub = _refine(knots, bad, parts, poly, sub)
        if sub.max() > MAX_DATA_PER_MOVE:
            _refuse(poly, dev_u, dev, cov, tol)
    else:
        _refuse(poly, dev_u, dev, cov, tol)
    return _result(spline, poly, dev, cov, cov_u)


def _validate(points, tolerance, start_tangent, end_tangent):
    try:
        pts = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"chain points must be an (n, 3) array of numbers: {exc}") from None
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise InputError(f"chain points must be an (n, 3) array (x, y, z), got shape {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    if len(pts) < 4:
        raise InputError(f"a chain to smooth needs at least 3 moves (4 points), got "
                         f"{max(len(pts) - 1, 0)} move(s)")
    bad = np.flatnonzero(~np.all(np.isfinite(pts), axis=1))
    if bad.size:
        raise InputError(f"chain point {bad[0]} is not finite ({bad.size} point(s) contain NaN "
                         "or inf)")
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        raise InputError(f"smoothing tolerance must be a number, got {tolerance!r}") from None
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"smoothing tolerance must be a positive, finite number of mm, got "
                         f"{tol * MM_PER_M:g} mm")
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if step.sum() <= 1e-9:
        raise InputError("a chain to smooth needs a length: all its points coincide")
    moving = np.flatnonzero(step > 1e-12)
    first = (pts[moving[0] + 1] - pts[moving[0]]) / step[moving[0]]
    last = (pts[moving[-1] + 1] - pts[moving[-1]]) / step[moving[-1]]
    return (pts, tol, _tangent(start_tangent, first, "start"),
            _tangent(end_tangent, last, "end"))


def _tangent(t, move_dir: np.ndarray, which: str) -> np.ndarray | None:
    if t is None:
        return None
    try:
        v = np.asarray(t, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise InputError(f"{which}_tangent must be a 3-vector, got {t!r}") from None
    n = float(np.linalg.norm(v))
    if not (np.all(np.isfinite(v)) and n > 1e-12):
        raise InputError(f"{which}_tangent must be a finite, non-zero 3-vector, got {v}")
    v = v / n
    if v @ move_dir <= 0.0:
        raise InputError(
            f"{which}_tangent {v} points backwards from the chain's {which} move (direction "
            f"{move_dir}, {np.degrees(np.arccos(np.clip(v @ move_dir, -1, 1))):.1f} deg apart); "
            "a smooth curve within the tolerance cannot do that")
    return v


def _polyline(pts: np.ndarray, tol: float) -> _Polyline:
    vec = np.diff(pts, axis=0)
    length = np.linalg.norm(vec, axis=1)
    u = np.concatenate([[0.0], np.cumsum(length)])
    short = np.percentile(length[length > 1e-12], 5)
    window = int(np.clip(np.ceil(3.0 * tol / short), 1, 12))
    length2 = np.maximum(length * length, 1e-300)
    unit = vec / np.maximum(length, 1e-300)[:, None]
    return _Polyline(points=pts, u=u, vec=vec, length2=length2,
                     moves=np.vstack([pts[:-1].T, vec.T, length2]),
                     bisector=unit[:-1] + unit[1:], window=window)


def _initial_knots(poly: _Polyline) -> np.ndarray:
    """Distinct knots (including both ends): every ``INITIAL_SPAN_MOVES``-th vertex."""
    k = len(poly.u) - 1
    n_span = max(1, int(round(k / INITIAL_SPAN_MOVES)))
    inner = poly.u[np.round(np.linspace(0, k, n_span + 1)[1:-1]).astype(int)]
    return np.unique(np.concatenate([[0.0], inner, [poly.u[-1]]]))


def _initial_subdivision(poly: _Polyline) -> np.ndarray:
    """Data points per move: at least 2 (vertex and midpoint), more on moves much longer than
    the typical one."""
    length = np.diff(poly.u)
    typical = np.median(length[length > 1e-12])
    return np.maximum(2, np.ceil(length / (2.0 * typical))).astype(np.intp)


def _data(poly: _Polyline, sub: np.ndarray):
    """Polyline samples: vertices plus ``sub - 1`` equally spaced interior points per move;
    parameters, positions and trapezoid weights."""
    k = len(sub)
    move = np.repeat(np.arange(k), sub)
    frac = (np.arange(move.size) - np.repeat(np.cumsum(sub) - sub, sub)) / sub[move]
    u = np.concatenate([poly.u[move] + frac * (poly.u[move + 1] - poly.u[move]), poly.u[-1:]])
    y = np.concatenate([poly.points[move] + frac[:, None] * poly.vec[move], poly.points[-1:]])
    du = np.diff(u)
    w = np.zeros(u.size)
    w[:-1] += 0.5 * du
    w[1:] += 0.5 * du
    w /= w.mean()
    return u, y, w


def _full_knots(knots: np.ndarray) -> np.ndarray:
    return np.concatenate([np.repeat(knots[0], DEGREE), knots, np.repeat(knots[-1], DEGREE)])


def _fit(u, y, w, knots, p_start, p_end, t_start, t_end) -> BSpline:
    """Weighted least-squares quintic with the end coefficients fixed (see smooth_chain)."""
    t = _full_knots(knots)
    n = len(t) - DEGREE - 1
    b = BSpline.design_matrix(u, t, DEGREE)
    bw = sp.diags_array(w) @ b
    normal = (b.T @ bw).tocsc()
    rhs = b.T @ (w[:, None] * y)
    diff2 = sp.diags_array([np.ones(n - 2), -2.0 * np.ones(n - 2), np.ones(n - 2)],
                           offsets=[0, 1, 2], shape=(n - 2, n))
    normal = normal + (RIDGE * normal.diagonal().mean()) * (diff2.T @ diff2).tocsc()
    fixed = {0: p_start, n - 1: p_end}
    if t_start is not None:
        fixed[1] = p_start + (t[DEGREE + 1] - t[1]) / DEGREE * t_start
    if t_end is not None:
        fixed[n - 2] = p_end - (t[n + DEGREE - 1] - t[n - 1]) / DEGREE * t_end
    fix = np.array(sorted(fixed))
    free = np.setdiff1d(np.arange(n), fix)
    c = np.empty((n, 3))
    c[fix] = np.array([fixed[i] for i in fix])
    normal = normal.tocsr()
    rows = normal[free]
    rhs_free = rhs[free] - rows[:, fix] @ c[fix]
    c[free] = splu(rows[:, free].tocsc()).solve(np.ascontiguousarray(rhs_free))
    return BSpline(t, c, DEGREE)


def _window_distance(x: np.ndarray, u: np.ndarray, poly: _Polyline
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Distance of points ``x`` (n, 3) at curve parameters ``u`` to the moves within
    ``poly.window`` of the move holding ``u`` (an upper bound of the polyline distance), and
    the index of the nearest of those moves."""
    k = len(poly.vec)
    i = np.clip(np.searchsorted(poly.u, u, side="right") - 1, 0, k - 1)
    dist = np.empty(len(u))
    move = np.empty(len(u), dtype=np.intp)
    near = np.arange(-poly.window, poly.window + 1)
    for lo in range(0, len(u), _CHUNK):  # chunks that stay in cache
        part = slice(lo, lo + _CHUNK)
        idx = np.clip(i[part, None] + near, 0, k - 1)
        ax, ay, az, vx, vy, vz, ll = poly.moves[:, idx]
        xp = x[part]
        rx, ry, rz = xp[:, 0, None] - ax, xp[:, 1, None] - ay, xp[:, 2, None] - az
        f = (rx * vx + ry * vy + rz * vz) / ll
        np.clip(f, 0.0, 1.0, out=f)
        rx -= f * vx
        ry -= f * vy
        rz -= f * vz
        d2 = rx * rx + ry * ry + rz * rz
        best = d2.argmin(axis=1)
        rows = np.arange(best.size)
        dist[part] = np.sqrt(d2[rows, best])
        move[part] = idx[rows, best]
    return dist, move


def _move_distance(x: np.ndarray, j: np.ndarray, poly: _Polyline) -> np.ndarray:
    """Distance of points ``x`` (n, 3) to moves ``j`` (n,)."""
    rel = x - poly.points[j]
    vec = poly.vec[j]
    f = np.clip(np.einsum("ij,ij->i", rel, vec) / poly.length2[j], 0.0, 1.0)
    return np.linalg.norm(rel - f[:, None] * vec, axis=1)


def _deviation(spline: BSpline, poly: _Polyline, u_data: np.ndarray):
    """Sampled curve -> polyline distance: parameters and distances, with every smooth local
    maximum refined by a parabola, plus the crossings of the vertices' bisector planes (where
    the distance has a kink, a maximum inside a corner) and the equal-distance points of
    other pairs of nearest moves (bisection)."""
    du = np.diff(u_data)
    knots = np.unique(spline.t)
    span = np.diff(knots)[np.clip(np.searchsorted(knots, u_data[:-1] + 0.5 * du) - 1, 0,
                                  len(knots) - 2)]
    q = np.maximum(SAMPLES_PER_INTERVAL, np.ceil(SAMPLES_PER_SPAN * du / span)).astype(np.intp)
    start = np.repeat(np.arange(du.size), q)
    frac = (np.arange(start.size) - np.repeat(np.cumsum(q) - q, q)) / q[start]
    v = np.concatenate([u_data[start] + frac * du[start], u_data[-1:]])
    x = spline(v)
    d, move = _window_distance(x, v, poly)
    # parabola through every local maximum and its neighbours: its vertex
    i = 1 + np.flatnonzero((d[1:-1] >= d[:-2]) & (d[1:-1] >= d[2:])
                           & (d[1:-1] >= 0.5 * d.max()))
    h0, h2 = v[i - 1] - v[i], v[i + 1] - v[i]
    ok = (h0 < 0) & (h2 > 0)
    i, h0, h2 = i[ok], h0[ok], h2[ok]
    f0, f2 = d[i - 1] - d[i], d[i + 1] - d[i]
    a = (f0 / h0 - f2 / h2) / (h0 - h2)
    conc = a < 0
    i, h0, h2, f0, a = i[conc], h0[conc], h2[conc], f0[conc], a[conc]
    b = f0 / h0 - a * h0
    vr = v[i] + np.clip(-b / (2.0 * a), h0, h2)
    # kinks: where the curve crosses a vertex's bisector plane (p - V).(a + b) = 0 (a, b the
    # unit directions of the moves before and after V), the distances to the two moves are
    # equal and their minimum has a kink (a maximum inside a corner): Newton from u(V)
    nrm, u_v = poly.bisector, poly.u[1:-1]
    vc = u_v.copy()
    d1 = spline.derivative(1)
    for _ in range(_CROSSING_STEPS):
        h = np.einsum("ij,ij->i", spline(vc) - poly.points[1:-1], nrm)
        hp = np.einsum("ij,ij->i", d1(vc), nrm)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.where(np.abs(hp) > 1e-3, h / hp, 0.0)
        vc = np.clip(vc - step, poly.u[:-2], poly.u[2:])
    # kinks between moves that are not neighbours (tolerance above the move lengths, noisy
    # chains): bisection on the equal-distance point between the two samples
    sw = np.flatnonzero((np.abs(move[1:] - move[:-1]) >= 2)
                        & (np.maximum(d[1:], d[:-1]) >= 0.5 * d.max()))
    ja, jb, lo, hi = move[sw], move[sw + 1], v[sw], v[sw + 1]
    for _ in range(_BISECTION_STEPS if sw.size else 0):
        mid = 0.5 * (lo + hi)
        xm = spline(mid)
        near_a = _move_distance(xm, ja, poly) <= _move_distance(xm, jb, poly)
        lo, hi = np.where(near_a, mid, lo), np.where(near_a, hi, mid)
    extra = np.concatenate([vr, vc, 0.5 * (lo + hi)])
    dr, _ = _window_distance(spline(extra), extra, poly)
    return np.concatenate([v, extra]), np.concatenate([d, dr])


def _coverage(spline: BSpline, poly: _Polyline):
    """Vertex -> curve: parameters of the projections and distances (upper bounds)."""
    x, u0 = poly.points, poly.u
    lo = np.concatenate([u0[:1], u0[:-1]])
    hi = np.concatenate([u0[1:], u0[-1:]])
    d1, d2 = spline.derivative(1), spline.derivative(2)
    u = u0.copy()
    for _ in range(_PROJECTION_STEPS):
        rel = spline(u) - x
        g1 = d1(u)
        g = np.einsum("ij,ij->i", rel, g1)
        gp = np.einsum("ij,ij->i", g1, g1) + np.einsum("ij,ij->i", rel, d2(u))
        gp = np.maximum(gp, 0.5 * np.einsum("ij,ij->i", g1, g1))
        u = np.clip(u - g / gp, lo, hi)
    d_proj = np.linalg.norm(spline(u) - x, axis=1)
    d_own = np.linalg.norm(spline(u0) - x, axis=1)
    better = d_proj <= d_own
    return np.where(better, u, u0), np.where(better, d_proj, d_own)


def _bad_spans(knots, dev_u, dev, cov_u, cov, target) -> tuple[np.ndarray, np.ndarray]:
    """The knot spans where deviation or coverage exceed ``target`` and into how many parts
    to split each: 1.25 (error / target)^(1/6) (a quintic's error falls like h^6), 2 to 4."""
    n_span = len(knots) - 1
    err = np.zeros(n_span)
    for q, val in ((dev_u, dev), (cov_u, cov)):
        over = val > target
        span = np.clip(np.searchsorted(knots, q[over], side="right") - 1, 0, n_span - 1)
        np.maximum.at(err, span, val[over])
    bad = np.flatnonzero(err > target)
    parts = np.clip(np.ceil(1.25 * (err[bad] / target) ** (1.0 / 6.0)), 2, 4).astype(np.intp)
    return bad, parts


def _refine(knots, bad, parts, poly: _Polyline, sub):
    """Split the bad spans into ``parts`` equal pieces; sample the moves more densely where the
    spans became shorter than 4 data intervals."""
    rep = np.repeat(np.arange(bad.size), parts - 1)
    frac = (np.arange(rep.size) - np.repeat(np.cumsum(parts - 1) - (parts - 1), parts - 1)
            + 1) / parts[rep]
    lo, hi = knots[bad][rep], knots[bad + 1][rep]
    knots = np.unique(np.concatenate([knots, lo + frac * (hi - lo)]))
    span = np.diff(knots)
    first = np.clip(np.searchsorted(knots, poly.u[:-1], side="right") - 1, 0, len(span) - 1)
    last = np.clip(np.searchsorted(knots, poly.u[1:], side="left") - 1, 0, len(span) - 1)
    last = np.maximum(last, first)
    shortest = np.minimum(np.minimum.reduceat(span, first), span[last])
    need = np.ceil(4.0 * np.diff(poly.u) / shortest).astype(np.intp)
    return knots, np.maximum(sub, need)


def _refuse(poly: _Polyline, dev_u, dev, cov, tol):
    i_dev = int(np.argmax(dev))
    i = int(np.clip(np.searchsorted(poly.u, dev_u[i_dev]), 0, len(poly.u) - 1))
    if cov.max() > dev.max():
        i = int(np.argmax(cov))
    p = poly.points[i] * MM_PER_M
    raise InputError(
        f"cannot smooth the chain of {len(poly.vec)} moves within the tolerance "
        f"{tol * MM_PER_M:g} mm: near point {i} ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}) mm the "
        f"spline stays {max(dev.max(), cov.max()) * MM_PER_M:.3g} mm away (a sharp corner or "
        "a tangent the chain does not follow); split the chain there or raise the tolerance")


def _result(spline: BSpline, poly: _Polyline, dev, cov, cov_u) -> SmoothedChain:
    table = _arc_length_table(spline)
    params = {"knots": spline.t.copy(), "coefficients": np.asarray(spline.c).copy(),
              "degree": np.array(DEGREE), **table}
    length = float(table["s_nodes"][-1])
    chain = _Chain(params)
    node_s = np.maximum.accumulate(np.clip(chain.arc_length(cov_u), 0.0, length))
    node_s[0], node_s[-1] = 0.0, length
    return SmoothedChain(params=params, length=length, node_s=node_s,
                         deviation=float(dev.max()), coverage=float(cov.max()))


def _arc_length_table(spline: BSpline) -> dict[str, np.ndarray]:
    """s(u) at ``TABLE_SPLIT`` nodes per knot span (Gauss-Legendre, 8 points each)."""
    knots = np.unique(spline.t)
    frac = np.arange(TABLE_SPLIT) / TABLE_SPLIT
    t_nodes = np.concatenate([(knots[:-1, None] + np.diff(knots)[:, None] * frac).ravel(),
                              knots[-1:]])
    d1 = spline.derivative(1)
    x, w = _GL_TABLE
    h = np.diff(t_nodes)
    tq = t_nodes[:-1, None] + 0.5 * h[:, None] * (x[None, :] + 1.0)
    inc = 0.5 * h * (np.linalg.norm(d1(tq), axis=-1) @ w)
    s_nodes = np.concatenate([[0.0], np.cumsum(inc)])
    return {"t_nodes": t_nodes, "s_nodes": s_nodes,
            "sigma_nodes": np.linalg.norm(d1(t_nodes), axis=-1)}


# --- evaluation by arc length -------------------------------------------------------------------


class _Chain:
    """One smoothed chain: p(u) and its u-derivatives, s(u) and its inverse u(s)."""

    def __init__(self, params: dict[str, np.ndarray]):
        k = int(params["degree"])
        self.p = BSpline(np.asarray(params["knots"], float),
                         np.asarray(params["coefficients"], float), k)
        self.d1 = self.p.derivative(1)
        self.d2 = self.p.derivative(2)
        self.d3 = self.p.derivative(3)
        self.t_nodes = np.asarray(params["t_nodes"], float)
        self.s_nodes = np.asarray(params["s_nodes"], float)
        self.sigma_nodes = np.asarray(params["sigma_nodes"], float)
        self.length = float(self.s_nodes[-1])
        self.tol = 1e-12 * self.length + 1e-300
        # Newton from residual r leaves ~ |sigma'| r^2 / (2 sigma^2) <= bound r^2 (|sigma'| <=
        # |p''|; factor 4 for the p'' between the nodes): below tol no check is needed
        mid = 0.5 * (self.t_nodes[:-1] + self.t_nodes[1:])
        p2 = np.linalg.norm(self.d2(np.concatenate([self.t_nodes, mid])), axis=-1).max()
        self.quad_bound = 4.0 * 0.5 * p2 / self.sigma_nodes.min() ** 2

    def speed(self, t: np.ndarray) -> np.ndarray:
        d = self.d1(t)
        return np.sqrt(np.einsum("...j,...j->...", d, d))

    def arc_length(self, t: np.ndarray) -> np.ndarray:
        """s(u): table node below plus Gauss-Legendre (8 points)."""
        t = np.clip(np.asarray(t, float), self.t_nodes[0], self.t_nodes[-1])
        k = np.clip(np.searchsorted(self.t_nodes, t, side="right") - 1, 0,
                    len(self.t_nodes) - 2)
        x, w = _GL_TABLE
        half = 0.5 * (t - self.t_nodes[k])
        tq = self.t_nodes[k][:, None] + half[:, None] * (x + 1.0)
        return self.s_nodes[k] + half * (self.speed(tq) @ w)

    def invert(self, s: np.ndarray) -> np.ndarray:
        """u(s): cubic Hermite guess on the table interval, then safeguarded Newton steps on
        s(u) - s = 0 until |s(u) - s| <= 1e-12 of the length (as in
        :func:`feedopt.geometry.arclength.invert`)."""
        s = np.clip(s, 0.0, self.length)
        n_int = len(self.t_nodes) - 1
        k = np.clip(np.searchsorted(self.s_nodes, s, side="right") - 1, 0, n_int - 1)
        t0, t1 = self.t_nodes[k], self.t_nodes[k + 1]
        s0, s1 = self.s_nodes[k], self.s_nodes[k + 1]
        ds = s1 - s0
        with np.errstate(invalid="ignore", divide="ignore"):
            tau = np.where(ds > 0, (s - s0) / ds, 0.0)
        m0, m1 = ds / self.sigma_nodes[k], ds / self.sigma_nodes[k + 1]
        tau2, tau3 = tau * tau, tau * tau * tau
        t = (t0 * (2 * tau3 - 3 * tau2 + 1) + m0 * (tau3 - 2 * tau2 + tau)
             + t1 * (-2 * tau3 + 3 * tau2) + m1 * (tau3 - tau2))
        t = np.clip(t, t0, t1)
        lo, hi = t0.copy(), t1.copy()
        x, w = _GL_NEWTON
        todo = np.arange(s.size)
        stepped = np.zeros(s.size, dtype=bool)
        for _ in range(_MAX_NEWTON):
            ta, t0a = t[todo], t0[todo]
            half = 0.5 * (ta - t0a)
            tq = np.empty((ta.size, x.size + 1))
            tq[:, :-1] = t0a[:, None] + half[:, None] * (x + 1.0)
            tq[:, -1] = ta
            sig = self.speed(tq)
            res = s0[todo] + half * (sig[:, :-1] @ w) - s[todo]
            # converged, or one Newton step from a residual small enough to need no check
            done = np.abs(res) <= self.tol
            quick = ~done & ~stepped[todo] & (self.quad_bound * res * res <= 0.01 * self.tol)
            sig_t = sig[:, -1]
            step = ta - res / sig_t
            t[todo[quick]] = np.clip(step[quick], lo[todo[quick]], hi[todo[quick]])
            keep = ~done & ~quick
            todo, ta, res, step = todo[keep], ta[keep], res[keep], step[keep]
            if not todo.size:
                break
            stepped[todo] = True
            lo[todo] = np.where(res < 0, ta, lo[todo])
            hi[todo] = np.where(res > 0, ta, hi[todo])
            inside = (step >= lo[todo]) & (step <= hi[todo])
            t[todo] = np.where(inside, step, 0.5 * (lo[todo] + hi[todo]))
        return t

    def eval(self, sl: np.ndarray):
        t = self.invert(sl)
        return (self.p(t), *arc_length_derivatives(self.d1(t), self.d2(t), self.d3(t)))


class SplineEvaluator:
    """Evaluator of ``"spline"`` segments (:func:`smooth_chain`'s ``params``) by arc length.

    Each segment is its own chain (knots, coefficients, arc-length table); ``eval(j, sl)``
    groups the samples by chain and returns position, unit tangent dp/ds, curvature vector
    d2p/ds2 and d3p/ds3 at local arc lengths ``sl`` in [0, length of chain j], from the
    B-spline's u-derivatives 1..3 and the chain rule
    (:func:`~feedopt.geometry.arclength.arc_length_derivatives`).
    """

    def __init__(self, segs: Sequence[Segment]):
        self.chains = [_Chain(g.params) for g in segs]

    def eval(self, j, sl):
        j = np.asarray(j, dtype=np.intp)
        sl = np.asarray(sl, dtype=float)
        if len(self.chains) == 1:
            return self.chains[0].eval(sl)
        out = tuple(np.empty((sl.size, 3)) for _ in range(4))
        order = np.argsort(j, kind="stable")
        js = j[order]
        cuts = np.flatnonzero(np.diff(js)) + 1
        for part in np.split(order, cuts):
            if part.size:
                for o, r in zip(out, self.chains[j[part[0]]].eval(sl[part]), strict=True):
                    o[part] = r
        return out


SPLINE = register_segment_kind(SegmentKind(
    name=SPLINE_KIND, evaluator=SplineEvaluator, colour="tab:cyan",
    description="quintic smoothing spline through a chain of short moves, within the path "
                "tolerance"))
