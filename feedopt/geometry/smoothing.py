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
assembled from the B-spline design matrix and solved with scipy's sparse LU; the end
conditions are imposed by fixing the clamped end coefficients (see :func:`smooth_chain`),
which are eliminated from the system.

:func:`smooth_chains` fits all chains of a program at once: every step (least squares, the
deviation and coverage measurements, the knot refinement) is one vectorised computation over
the chains still being refined, on the flat arrays of :mod:`feedopt.geometry.bsplines` (one
block-diagonal sparse system for all of them), so a raster of a thousand chains costs about
what one chain of the same total size does. :func:`smooth_chain` is the one-chain case.

:class:`SplineEvaluator` evaluates such curves by arc length (thesis Eq. 3.23) through a
per-chain s(u) table (Gauss-Legendre on every half knot span) inverted by a cubic Hermite guess
and safeguarded Newton steps to 1e-12 of the length, all chains of a path in one call, with
the chain rule of :func:`~feedopt.geometry.arclength.arc_length_derivatives`. Importing this
module registers the segment kind ``"spline"`` (:data:`SPLINE`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse.linalg import splu

from feedopt.errors import InputError
from feedopt.geometry.arclength import arc_length_derivatives
from feedopt.geometry.bsplines import (
    ArcTable,
    Inverter,
    SplineBatch,
    arc_length,
    arc_table,
    segment_of,
    shifted_keys,
)
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


def _ramp(counts: np.ndarray) -> np.ndarray:
    """0 .. counts[0]-1, 0 .. counts[1]-1, ... (one run per entry)."""
    counts = np.asarray(counts, dtype=np.intp)
    return np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)


def _group_quantile(values: np.ndarray, owner: np.ndarray, m: int, q: float) -> np.ndarray:
    """Per owner 0..m-1 the ``q`` quantile of its values (numpy's linear interpolation)."""
    order = np.lexsort((values, owner))
    v = values[order]
    count = np.bincount(owner, minlength=m)
    start = np.cumsum(count) - count
    pos = (count - 1) * q
    lo = np.floor(pos).astype(np.intp)
    hi = np.minimum(lo + 1, count - 1)
    return v[start + lo] + (pos - lo) * (v[start + hi] - v[start + lo])


# --- the chains' polylines ------------------------------------------------------------------


@dataclass(frozen=True)
class _Polys:
    """The polylines of ``m`` chains in flat arrays: chain c's points at
    ``points[pstart[c]:pstart[c+1]]``, its moves at ``[mstart[c]:mstart[c+1]]`` (the move
    starting at point p of chain c is move p - c)."""

    points: np.ndarray  # (P, 3)
    pstart: np.ndarray  # (m+1,)
    u: np.ndarray  # (P,) chord length from the chain's start [m]
    vec: np.ndarray  # (M, 3) move vectors
    length2: np.ndarray  # (M,) squared move lengths (guarded > 0)
    moves: np.ndarray  # (7, M) start point, move vector, squared length
    mstart: np.ndarray  # (m+1,)
    owner_m: np.ndarray  # (M,) chain of each move
    window: np.ndarray  # (m,) moves either side searched for the nearest polyline point
    tol: np.ndarray  # (m,)
    t_start: np.ndarray  # (m, 3) unit start tangent, NaN where none is imposed
    t_end: np.ndarray  # (m, 3)
    u_shift: tuple[np.ndarray, np.ndarray]  # for segment_of on u

    def __len__(self) -> int:
        return self.pstart.size - 1


def _polys(pts: Sequence[np.ndarray], tol: np.ndarray, t_start: np.ndarray,
           t_end: np.ndarray) -> _Polys:
    m = len(pts)
    npts = np.array([len(p) for p in pts])
    pstart = np.concatenate([[0], np.cumsum(npts)])
    mstart = pstart - np.arange(m + 1)
    points = np.concatenate(pts)
    owner_m = np.repeat(np.arange(m), npts - 1)
    first = np.ones(points.shape[0], dtype=bool)
    first[pstart[:-1]] = False
    vec = (points[1:] - points[:-1])[first[1:]]
    length = np.linalg.norm(vec, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(length)])
    u = np.repeat(-cum[mstart[:-1]], npts) + np.insert(cum, mstart[1:-1], cum[mstart[1:-1]])
    moving = length > 1e-12
    short = _group_quantile(length[moving], owner_m[moving], m, 0.05)
    window = np.clip(np.ceil(3.0 * tol / short), 1, 12).astype(np.intp)
    length2 = np.maximum(length * length, 1e-300)
    return _Polys(points=points, pstart=pstart, u=u, vec=vec, length2=length2,
                  moves=np.vstack([points[np.arange(vec.shape[0]) + owner_m].T, vec.T,
                                   length2]),
                  mstart=mstart, owner_m=owner_m, window=window, tol=tol,
                  t_start=t_start, t_end=t_end, u_shift=shifted_keys(u, pstart))


def _unit(poly: _Polys) -> np.ndarray:
    return poly.vec / np.maximum(np.sqrt(poly.length2), 1e-300)[:, None]


# --- public ---------------------------------------------------------------------------------


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
    return smooth_chains([points], [tolerance], start_tangents=[start_tangent],
                         end_tangents=[end_tangent])[0]


def smooth_chains(chains: Sequence[ArrayLike], tolerances: ArrayLike, *,
                  start_tangents: Sequence[ArrayLike | None] | None = None,
                  end_tangents: Sequence[ArrayLike | None] | None = None
                  ) -> list[SmoothedChain]:
    """:func:`smooth_chain` of every chain (each with its own tolerance and optional end
    tangents), all fitted together; the same curves as one call per chain. A chain that
    cannot be smoothed raises the InputError of :func:`smooth_chain` (the first such chain)."""
    m = len(chains)
    tols = np.broadcast_to(np.asarray(tolerances, dtype=object), (m,))
    starts = start_tangents if start_tangents is not None else [None] * m
    ends = end_tangents if end_tangents is not None else [None] * m
    checked = [_validate(p, t, a, b) for p, t, a, b in zip(chains, tols, starts, ends,
                                                            strict=True)]
    if not checked:
        return []
    pts = [c[0] for c in checked]
    nan = np.full(3, np.nan)
    poly = _polys(pts, np.array([c[1] for c in checked]),
                  np.array([nan if c[2] is None else c[2] for c in checked]),
                  np.array([nan if c[3] is None else c[3] for c in checked]))
    return _smooth(poly)


# --- validation -----------------------------------------------------------------------------


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


# --- fitting: the chains still being refined, all at once -------------------------------------


@dataclass(frozen=True)
class _Knots:
    """Distinct knots (both ends included) of some chains, flat: chain a's at
    ``values[start[a]:start[a+1]]``; ``chain`` (a,) the global index of each."""

    values: np.ndarray
    start: np.ndarray
    chain: np.ndarray

    @property
    def owner(self) -> np.ndarray:
        return np.repeat(np.arange(self.chain.size), np.diff(self.start))

    def spans(self) -> tuple[np.ndarray, np.ndarray]:
        """(span lengths, owner) of all knot spans, flat (chain a's spans at
        ``[start[a] - a : start[a+1] - a - 1]``)."""
        own = self.owner
        keep = np.ones(self.values.size, dtype=bool)
        keep[self.start[1:] - 1] = False
        return (np.diff(self.values, append=self.values[-1:])[keep], own[keep])

    def span_of(self, a: np.ndarray, x: np.ndarray, left: bool = False) -> np.ndarray:
        """Flat span index of parameter ``x`` in chain ``a`` (``left``: a knot belongs to the
        span before it)."""
        g = segment_of(self.values, self.start, a, x)
        if left:
            g = np.where((x <= self.values[g]) & (g > self.start[a]), g - 1, g)
        return g - a

    def batch(self, coef: np.ndarray | None = None) -> SplineBatch:
        """The clamped quintics on these knots (coefficients ``coef`` or zeros)."""
        reps = np.ones(self.values.size, dtype=np.intp)
        reps[self.start[:-1]] = DEGREE + 1
        reps[self.start[1:] - 1] = DEGREE + 1
        full = np.repeat(self.values, reps)
        n_dist = np.diff(self.start)
        fstart = np.concatenate([[0], np.cumsum(n_dist + 2 * DEGREE)])
        cstart = np.concatenate([[0], np.cumsum(n_dist + DEGREE - 1)])
        c = np.zeros((cstart[-1], 3)) if coef is None else coef
        return SplineBatch(DEGREE, full, fstart, c, cstart)


def _initial_knots(poly: _Polys) -> _Knots:
    """Distinct knots (including both ends): every ``INITIAL_SPAN_MOVES``-th vertex."""
    m = len(poly)
    k = np.diff(poly.mstart)
    n_span = np.maximum(1, np.round(k / INITIAL_SPAN_MOVES).astype(np.intp))
    j = _ramp(n_span - 1) + 1
    own = np.repeat(np.arange(m), n_span - 1)
    vertex = np.round(k[own] * j / n_span[own]).astype(np.intp)
    inner = poly.u[poly.pstart[own] + vertex]
    ends = np.concatenate([np.zeros(m), poly.u[poly.pstart[1:] - 1]])
    return _dedupe(np.concatenate([ends, inner]),
                   np.concatenate([np.arange(m), np.arange(m), own]), np.arange(m))


def _dedupe(values: np.ndarray, owner: np.ndarray, chains: np.ndarray) -> _Knots:
    """Knots of owners 0..len(chains)-1 sorted and made distinct per owner."""
    order = np.lexsort((values, owner))
    v, o = values[order], owner[order]
    keep = np.ones(v.size, dtype=bool)
    keep[1:] = (o[1:] != o[:-1]) | (v[1:] != v[:-1])
    v, o = v[keep], o[keep]
    start = np.concatenate([[0], np.cumsum(np.bincount(o, minlength=chains.size))])
    return _Knots(v, start, chains)


def _initial_subdivision(poly: _Polys) -> np.ndarray:
    """Data points per move: at least 2 (vertex and midpoint), more on moves much longer than
    the typical one."""
    length = np.sqrt(poly.length2)
    moving = length > 1e-12
    typical = _group_quantile(length[moving], poly.owner_m[moving], len(poly), 0.5)
    return np.maximum(2, np.ceil(length / (2.0 * typical[poly.owner_m]))).astype(np.intp)


@dataclass(frozen=True)
class _Data:
    """Polyline samples of the active chains (a = index among them), chain by chain."""

    owner: np.ndarray
    u: np.ndarray
    y: np.ndarray
    w: np.ndarray


def _local(chains: np.ndarray, m: int) -> np.ndarray:
    """Global chain -> index among ``chains`` (-1 for the others)."""
    out = np.full(m, -1, dtype=np.intp)
    out[chains] = np.arange(chains.size)
    return out


def _data(poly: _Polys, chains: np.ndarray, sub: np.ndarray) -> _Data:
    """Vertices plus ``sub - 1`` equally spaced interior points per move of ``chains``;
    parameters, positions and trapezoid weights (mean 1 per chain)."""
    local = _local(chains, len(poly))
    mv = np.flatnonzero(local[poly.owner_m] >= 0)
    cnt = sub[mv]
    move = np.repeat(mv, cnt)
    frac = _ramp(cnt) / sub[move]
    p = move + poly.owner_m[move]
    last = poly.pstart[chains + 1] - 1
    u = np.concatenate([poly.u[p] + frac * (poly.u[p + 1] - poly.u[p]), poly.u[last]])
    y = np.concatenate([poly.points[p] + frac[:, None] * poly.vec[move], poly.points[last]])
    owner = np.concatenate([local[poly.owner_m[move]], np.arange(chains.size)])
    order = np.argsort(owner, kind="stable")
    u, y, owner = u[order], y[order], owner[order]
    du = np.where(owner[1:] == owner[:-1], np.diff(u), 0.0)
    w = np.zeros(u.size)
    w[:-1] += 0.5 * du
    w[1:] += 0.5 * du
    mean = np.bincount(owner, w) / np.bincount(owner)
    return _Data(owner, u, y, w / mean[owner])


def _fit(poly: _Polys, knots: _Knots, data: _Data) -> SplineBatch:
    """Weighted least-squares quintics with the end coefficients fixed (see smooth_chain),
    one block-diagonal system for all chains."""
    batch = knots.batch()
    cstart, fstart = batch.coef_start, batch.knot_start
    b = batch.design_matrix(data.owner, data.u)
    normal = (b.T @ (sp.diags_array(data.w) @ b)).tocsr()
    rhs = b.T @ (data.w[:, None] * data.y)
    n_c = np.diff(cstart)
    mean = np.add.reduceat(normal.diagonal(), cstart[:-1]) / n_c
    rows = n_c - 2
    base = np.repeat(cstart[:-1], rows) + _ramp(rows)
    scale = np.repeat(np.sqrt(RIDGE * mean), rows)
    r = np.arange(base.size)
    diff2 = sp.csr_array((np.concatenate([scale, -2.0 * scale, scale]),
                          (np.tile(r, 3), np.concatenate([base, base + 1, base + 2]))),
                         shape=(base.size, cstart[-1]))
    normal = (normal + diff2.T @ diff2).tocsr()
    c = np.zeros((cstart[-1], 3))
    fixed = np.zeros(cstart[-1], dtype=bool)
    ch = knots.chain
    first, last = poly.points[poly.pstart[ch]], poly.points[poly.pstart[ch + 1] - 1]
    c[cstart[:-1]], c[cstart[1:] - 1] = first, last
    fixed[cstart[:-1]] = fixed[cstart[1:] - 1] = True
    t0, t1 = poly.t_start[ch], poly.t_end[ch]
    has0, has1 = ~np.isnan(t0[:, 0]), ~np.isnan(t1[:, 0])
    full = batch.knots
    h0 = (full[fstart[:-1] + DEGREE + 1] - full[fstart[:-1] + 1]) / DEGREE
    h1 = (full[fstart[1:] - 2] - full[fstart[1:] - DEGREE - 2]) / DEGREE
    c[cstart[:-1][has0] + 1] = (first + h0[:, None] * t0)[has0]
    c[cstart[1:][has1] - 2] = (last - h1[:, None] * t1)[has1]
    fixed[cstart[:-1][has0] + 1] = True
    fixed[cstart[1:][has1] - 2] = True
    free, fix = np.flatnonzero(~fixed), np.flatnonzero(fixed)
    block = normal[free]
    rhs_free = rhs[free] - block[:, fix] @ c[fix]
    c[free] = splu(block[:, free].tocsc()).solve(np.ascontiguousarray(rhs_free))
    return SplineBatch(DEGREE, full, fstart, c, cstart)


def _window_distance(poly: _Polys, chain: np.ndarray, x: np.ndarray, u: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Distance of points ``x`` (n, 3) at parameters ``u`` of chains ``chain`` (global) to the
    moves within the chain's ``window`` of the move holding ``u`` (an upper bound of the
    polyline distance), and the index of the nearest of those moves (global)."""
    n = len(u)
    mv = segment_of(poly.u, poly.pstart, chain, u, poly.u_shift) - chain
    win = poly.window[chain]
    dist = np.empty(n)
    move = np.empty(n, dtype=np.intp)
    for lo in range(0, n, _CHUNK):  # chunks that stay in cache
        part = slice(lo, lo + _CHUNK)
        w = int(win[part].max()) if win[part].size else 0
        near = np.arange(-w, w + 1)
        c = chain[part]
        idx = np.clip(mv[part, None] + near, poly.mstart[c][:, None],
                      poly.mstart[c + 1][:, None] - 1)
        ax, ay, az, vx, vy, vz, ll = poly.moves[:, idx]
        xp = x[part]
        rx, ry, rz = xp[:, 0, None] - ax, xp[:, 1, None] - ay, xp[:, 2, None] - az
        f = (rx * vx + ry * vy + rz * vz) / ll
        np.clip(f, 0.0, 1.0, out=f)
        rx -= f * vx
        ry -= f * vy
        rz -= f * vz
        d2 = rx * rx + ry * ry + rz * rz
        d2[np.abs(near)[None, :] > win[part, None]] = np.inf
        best = d2.argmin(axis=1)
        rows = np.arange(best.size)
        dist[part] = np.sqrt(d2[rows, best])
        move[part] = idx[rows, best]
    return dist, move


def _move_distance(x: np.ndarray, j: np.ndarray, poly: _Polys) -> np.ndarray:
    """Distance of points ``x`` (n, 3) to moves ``j`` (n,)."""
    rel = x - poly.points[j + poly.owner_m[j]]
    vec = poly.vec[j]
    f = np.clip(np.einsum("ij,ij->i", rel, vec) / poly.length2[j], 0.0, 1.0)
    return np.linalg.norm(rel - f[:, None] * vec, axis=1)


@dataclass(frozen=True)
class _Measured:
    """Parameters ``u`` of chains ``owner`` (index among the active ones) and a distance
    measured there."""

    owner: np.ndarray
    u: np.ndarray
    d: np.ndarray


def _samples(knots: _Knots, data: _Data) -> tuple[np.ndarray, np.ndarray]:
    """Deviation samples: the data parameters and more in between (>= 2 per data interval,
    >= 32 per knot span), chain by chain: (owner, u)."""
    own, u_d = data.owner, data.u
    e = np.flatnonzero(own[1:] == own[:-1])
    du = u_d[e + 1] - u_d[e]
    g = knots.span_of(own[e], u_d[e] + 0.5 * du) + own[e]
    span = knots.values[g + 1] - knots.values[g]
    q = np.maximum(SAMPLES_PER_INTERVAL, np.ceil(SAMPLES_PER_SPAN * du / span)).astype(np.intp)
    start = np.repeat(e, q)
    frac = _ramp(q) / np.repeat(q, q)
    ends = np.flatnonzero(np.append(own[1:] != own[:-1], True))
    v = np.concatenate([u_d[start] + frac * np.repeat(du, q), u_d[ends]])
    ow = np.concatenate([own[start], own[ends]])
    order = np.argsort(ow, kind="stable")
    return ow[order], v[order]


def _deviation(poly: _Polys, knots: _Knots, spline: SplineBatch, data: _Data) -> _Measured:
    """Sampled curve -> polyline distance: parameters and distances, with every smooth local
    maximum refined by a parabola, plus the crossings of the vertices' bisector planes (where
    the distance has a kink, a maximum inside a corner) and the equal-distance points of
    other pairs of nearest moves (bisection)."""
    ow, v = _samples(knots, data)
    ch = knots.chain
    d, move = _window_distance(poly, ch[ow], spline.evaluate(ow, v)[0], v)
    dmax = np.zeros(ch.size)
    np.maximum.at(dmax, ow, d)
    vr, own_r = _parabola_peaks(ow, v, d, dmax)
    vc, own_c = _bisector_crossings(poly, knots, spline)
    vb, own_b = _switches(poly, spline, ow, v, d, move, dmax)
    extra = np.concatenate([vr, vc, vb])
    own_x = np.concatenate([own_r, own_c, own_b])
    dr, _ = _window_distance(poly, ch[own_x], spline.evaluate(own_x, extra)[0], extra)
    return _Measured(np.concatenate([ow, own_x]), np.concatenate([v, extra]),
                     np.concatenate([d, dr]))


def _parabola_peaks(ow, v, d, dmax) -> tuple[np.ndarray, np.ndarray]:
    """The vertex of the parabola through every local maximum (at least half the chain's
    largest) and its neighbours in the same chain."""
    i = 1 + np.flatnonzero((d[1:-1] >= d[:-2]) & (d[1:-1] >= d[2:])
                           & (ow[:-2] == ow[1:-1]) & (ow[2:] == ow[1:-1])
                           & (d[1:-1] >= 0.5 * dmax[ow[1:-1]]))
    h0, h2 = v[i - 1] - v[i], v[i + 1] - v[i]
    ok = (h0 < 0) & (h2 > 0)
    i, h0, h2 = i[ok], h0[ok], h2[ok]
    f0, f2 = d[i - 1] - d[i], d[i + 1] - d[i]
    a = (f0 / h0 - f2 / h2) / (h0 - h2)
    conc = a < 0
    i, h0, h2, f0, a = i[conc], h0[conc], h2[conc], f0[conc], a[conc]
    b = f0 / h0 - a * h0
    return v[i] + np.clip(-b / (2.0 * a), h0, h2), ow[i]


def _bisector_crossings(poly: _Polys, knots: _Knots, spline: SplineBatch
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Where the curve crosses a vertex's bisector plane (p - V).(a + b) = 0 (a, b the unit
    directions of the moves before and after V) the distances to the two moves are equal and
    their minimum has a kink (a maximum inside a corner): Newton from u(V)."""
    ch = knots.chain
    inner = np.diff(poly.pstart)[ch] - 2
    own = np.repeat(np.arange(ch.size), inner)
    p = np.repeat(poly.pstart[ch] + 1, inner) + _ramp(inner)
    mv = p - ch[own]
    unit = _unit(poly)
    nrm = unit[mv - 1] + unit[mv]
    vc = poly.u[p].copy()
    lo, hi = poly.u[p - 1], poly.u[p + 1]
    for _ in range(_CROSSING_STEPS):
        ev = spline.evaluate(own, vc, 1)
        h = np.einsum("ij,ij->i", ev[0] - poly.points[p], nrm)
        hp = np.einsum("ij,ij->i", ev[1], nrm)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.where(np.abs(hp) > 1e-3, h / hp, 0.0)
        vc = np.clip(vc - step, lo, hi)
    return vc, own


def _switches(poly: _Polys, spline: SplineBatch, ow, v, d, move, dmax
              ) -> tuple[np.ndarray, np.ndarray]:
    """Kinks between moves that are not neighbours (tolerance above the move lengths, noisy
    chains): bisection on the equal-distance point between two samples."""
    sw = np.flatnonzero((ow[1:] == ow[:-1]) & (np.abs(move[1:] - move[:-1]) >= 2)
                        & (np.maximum(d[1:], d[:-1]) >= 0.5 * dmax[ow[:-1]]))
    ja, jb, lo, hi, own = move[sw], move[sw + 1], v[sw], v[sw + 1], ow[sw]
    for _ in range(_BISECTION_STEPS if sw.size else 0):
        mid = 0.5 * (lo + hi)
        xm = spline.evaluate(own, mid)[0]
        near_a = _move_distance(xm, ja, poly) <= _move_distance(xm, jb, poly)
        lo, hi = np.where(near_a, mid, lo), np.where(near_a, hi, mid)
    return 0.5 * (lo + hi), own


def _coverage(poly: _Polys, knots: _Knots, spline: SplineBatch) -> _Measured:
    """Vertex -> curve: parameters of the projections and distances (upper bounds)."""
    ch = knots.chain
    cnt = np.diff(poly.pstart)[ch]
    own = np.repeat(np.arange(ch.size), cnt)
    p = np.repeat(poly.pstart[ch], cnt) + _ramp(cnt)
    x, u0 = poly.points[p], poly.u[p]
    first = np.zeros(p.size, dtype=bool)
    first[np.cumsum(cnt) - cnt] = True
    last = np.zeros(p.size, dtype=bool)
    last[np.cumsum(cnt) - 1] = True
    lo = np.where(first, u0, poly.u[np.maximum(p - 1, 0)])
    hi = np.where(last, u0, poly.u[np.minimum(p + 1, poly.u.size - 1)])
    u = u0.copy()
    for _ in range(_PROJECTION_STEPS):
        ev = spline.evaluate(own, u, 2)
        rel = ev[0] - x
        g = np.einsum("ij,ij->i", rel, ev[1])
        g11 = np.einsum("ij,ij->i", ev[1], ev[1])
        gp = np.maximum(g11 + np.einsum("ij,ij->i", rel, ev[2]), 0.5 * g11)
        u = np.clip(u - g / gp, lo, hi)
    d_proj = np.linalg.norm(spline.evaluate(own, u)[0] - x, axis=1)
    d_own = np.linalg.norm(spline.evaluate(own, u0)[0] - x, axis=1)
    better = d_proj <= d_own
    return _Measured(own, np.where(better, u, u0), np.where(better, d_proj, d_own))


def _bad_spans(knots: _Knots, dev: _Measured, cov: _Measured, target: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The knot spans (flat) where deviation or coverage exceed ``target`` (per active chain),
    into how many parts to split each: 1.25 (error / target)^(1/6) (a quintic's error falls
    like h^6), 2 to 4; and the error per span."""
    _, span_owner = knots.spans()
    err = np.zeros(span_owner.size)
    for m in (dev, cov):
        over = m.d > target[m.owner]
        np.maximum.at(err, knots.span_of(m.owner[over], m.u[over]), m.d[over])
    bad = np.flatnonzero(err > target[span_owner])
    ratio = err[bad] / target[span_owner[bad]]
    parts = np.clip(np.ceil(1.25 * ratio ** (1.0 / 6.0)), 2, 4).astype(np.intp)
    return bad, parts, span_owner


def _refine(poly: _Polys, knots: _Knots, bad: np.ndarray, parts: np.ndarray,
            span_owner: np.ndarray, sub: np.ndarray) -> tuple[_Knots, np.ndarray]:
    """Split the bad spans into ``parts`` equal pieces (the chains without one leave); sample
    the moves more densely where the spans became shorter than 4 data intervals."""
    own_b = span_owner[bad]
    keep = np.unique(own_b)  # active chains that go on (index among the active ones)
    rep = np.repeat(np.arange(bad.size), parts - 1)
    frac = (_ramp(parts - 1) + 1) / parts[rep]
    g = bad + own_b  # flat knot index of each bad span's start
    lo, hi = knots.values[g][rep], knots.values[g + 1][rep]
    renum = np.full(knots.chain.size, -1, dtype=np.intp)
    renum[keep] = np.arange(keep.size)
    own_k = knots.owner
    sel = renum[own_k] >= 0
    new = _dedupe(np.concatenate([knots.values[sel], lo + frac * (hi - lo)]),
                  np.concatenate([renum[own_k[sel]], renum[own_b[rep]]]), knots.chain[keep])
    span, _ = new.spans()
    local = _local(new.chain, len(poly))
    mv = np.flatnonzero(local[poly.owner_m] >= 0)
    a = local[poly.owner_m[mv]]
    p = mv + poly.owner_m[mv]
    first = new.span_of(a, poly.u[p])
    last = np.maximum(new.span_of(a, poly.u[p + 1], left=True), first)
    shortest = np.minimum(np.minimum.reduceat(span, first), span[last])
    need = np.ceil(4.0 * (poly.u[p + 1] - poly.u[p]) / shortest).astype(np.intp)
    sub = sub.copy()
    sub[mv] = np.maximum(sub[mv], need)
    return new, sub


@dataclass
class _Done:
    """Per chain (global index) its final spline and measurements, as they finish."""

    knots: list
    coef: list
    dev: np.ndarray
    cov: np.ndarray
    dev_at: np.ndarray  # parameter of the largest deviation
    cov_at: np.ndarray  # vertex (index in the chain) of the largest coverage
    cov_u: list
    failed: dict


def _smooth(poly: _Polys) -> list[SmoothedChain]:
    m = len(poly)
    knots = _initial_knots(poly)
    sub = _initial_subdivision(poly)
    done = _Done([None] * m, [None] * m, np.zeros(m), np.zeros(m), np.zeros(m),
                 np.zeros(m, dtype=np.intp), [None] * m, {})
    target_all = TARGET * poly.tol
    for _ in range(MAX_ITERATIONS):
        data = _data(poly, knots.chain, sub)
        spline = _fit(poly, knots, data)
        dev = _deviation(poly, knots, spline, data)
        cov = _coverage(poly, knots, spline)
        bad, parts, span_owner = _bad_spans(knots, dev, cov, target_all[knots.chain])
        _store(done, knots, spline, dev, cov)
        if not bad.size:
            break
        knots, sub = _refine(poly, knots, bad, parts, span_owner, sub)
        over = np.zeros(m)
        np.maximum.at(over, poly.owner_m, sub)
        for c in knots.chain[over[knots.chain] > MAX_DATA_PER_MOVE].tolist():
            done.failed[c] = True
        knots = _without(knots, over[knots.chain] <= MAX_DATA_PER_MOVE)
        if not knots.chain.size:
            break
    else:
        for c in knots.chain.tolist():
            done.failed[c] = True
    if done.failed:
        _refuse(poly, min(done.failed), done)
    return _results(poly, done)


def _without(knots: _Knots, keep: np.ndarray) -> _Knots:
    """The knots of the chains ``keep`` (bool per chain) only."""
    sel = keep[knots.owner]
    count = np.diff(knots.start)[keep]
    return _Knots(knots.values[sel], np.concatenate([[0], np.cumsum(count)]),
                  knots.chain[keep])


def _store(done: _Done, knots: _Knots, spline: SplineBatch, dev: _Measured,
           cov: _Measured) -> None:
    """Record every active chain's current spline and measurements (the last stored is the
    final one)."""
    ch = knots.chain
    n = ch.size
    dmax = np.full(n, -np.inf)
    np.maximum.at(dmax, dev.owner, dev.d)
    at = np.zeros(n)
    is_max = dev.d == dmax[dev.owner]
    at[dev.owner[is_max]] = dev.u[is_max]
    cmax = np.zeros(n)
    np.maximum.at(cmax, cov.owner, cov.d)
    count = np.bincount(cov.owner, minlength=n)
    vertex = np.arange(cov.d.size) - np.repeat(np.cumsum(count) - count, count)
    cov_at = np.zeros(n, dtype=np.intp)
    is_cmax = cov.d == cmax[cov.owner]
    cov_at[cov.owner[is_cmax]] = vertex[is_cmax]
    done.dev[ch], done.cov[ch], done.dev_at[ch], done.cov_at[ch] = dmax, cmax, at, cov_at
    ks, cs = spline.knot_start, spline.coef_start
    cov_split = np.split(cov.u, np.cumsum(count)[:-1])
    for a, c in enumerate(ch.tolist()):  # bookkeeping: slices, no computation
        done.knots[c] = spline.knots[ks[a]:ks[a + 1]]
        done.coef[c] = spline.coef[cs[a]:cs[a + 1]]
        done.cov_u[c] = cov_split[a]


def _refuse(poly: _Polys, c: int, done: _Done):
    pts = poly.points[poly.pstart[c]:poly.pstart[c + 1]]
    u = poly.u[poly.pstart[c]:poly.pstart[c + 1]]
    i = int(np.clip(np.searchsorted(u, done.dev_at[c]), 0, len(u) - 1))
    worst = max(done.dev[c], done.cov[c])
    if done.cov[c] > done.dev[c]:
        i = int(done.cov_at[c])
    p = pts[i] * MM_PER_M
    raise InputError(
        f"cannot smooth the chain of {len(pts) - 1} moves within the tolerance "
        f"{poly.tol[c] * MM_PER_M:g} mm: near point {i} ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}) "
        f"mm the spline stays {worst * MM_PER_M:.3g} mm away (a sharp corner or a tangent the "
        "chain does not follow); split the chain there or raise the tolerance")


def _results(poly: _Polys, done: _Done) -> list[SmoothedChain]:
    m = len(poly)
    batch = SplineBatch.from_lists(DEGREE, done.knots, done.coef)
    table = arc_table(batch, TABLE_SPLIT)
    length = table.length
    cnt = np.diff(poly.pstart)
    own = np.repeat(np.arange(m), cnt)
    s = np.clip(arc_length(batch, table, own, np.concatenate(done.cov_u)), 0.0, length[own])
    off = np.concatenate([[0.0], np.cumsum(length + 1.0)])[:-1]
    s = np.maximum.accumulate(s + off[own]) - off[own]
    s[poly.pstart[:-1]] = 0.0
    s[poly.pstart[1:] - 1] = length
    out = []
    for c in range(m):  # one params dict per chain (a Segment's params)
        params = {"knots": done.knots[c].copy(), "coefficients": done.coef[c].copy(),
                  "degree": np.array(DEGREE), **table.curve(c)}
        out.append(SmoothedChain(params=params, length=float(length[c]),
                                 node_s=s[poly.pstart[c]:poly.pstart[c + 1]],
                                 deviation=float(done.dev[c]), coverage=float(done.cov[c])))
    return out


# --- evaluation by arc length -------------------------------------------------------------------


def _batch_of(params: Sequence[dict]) -> tuple[SplineBatch, ArcTable]:
    degrees = {int(p["degree"]) for p in params}
    if len(degrees) != 1:
        raise ValueError(f"spline segments of one path must share a degree, got {degrees}")
    batch = SplineBatch.from_lists(degrees.pop(), [np.asarray(p["knots"], float) for p in params],
                                   [np.asarray(p["coefficients"], float) for p in params])
    sizes = [len(p["t_nodes"]) for p in params]
    table = ArcTable(np.concatenate([p["t_nodes"] for p in params]).astype(float),
                     np.concatenate([p["s_nodes"] for p in params]).astype(float),
                     np.concatenate([p["sigma_nodes"] for p in params]).astype(float),
                     np.concatenate([[0], np.cumsum(sizes)]))
    return batch, table


class _Chain:
    """One smoothed chain: p(u), s(u) and its inverse u(s) (a batch of one)."""

    def __init__(self, params: dict[str, np.ndarray]):
        self.batch, self.table = _batch_of([params])
        self.inverter = Inverter.of(self.batch, self.table)
        self.length = float(self.table.length[0])

    def arc_length(self, t: np.ndarray) -> np.ndarray:
        """s(u): table node below plus Gauss-Legendre (8 points)."""
        t = np.atleast_1d(np.asarray(t, float))
        return arc_length(self.batch, self.table, np.zeros(t.size, dtype=np.intp), t)

    def invert(self, s: np.ndarray) -> np.ndarray:
        """u(s) to 1e-12 of the length (:meth:`~feedopt.geometry.bsplines.Inverter.invert`)."""
        s = np.atleast_1d(np.asarray(s, float))
        return self.inverter.invert(np.zeros(s.size, dtype=np.intp), s)


class SplineEvaluator:
    """Evaluator of ``"spline"`` segments (:func:`smooth_chain`'s ``params``) by arc length.

    All chains form one :class:`~feedopt.geometry.bsplines.SplineBatch`; ``eval(j, sl)``
    inverts the arc length of chain ``j[i]`` at ``sl[i]`` and evaluates position, unit tangent
    dp/ds, curvature vector d2p/ds2 and d3p/ds3 from the B-spline's u-derivatives 1..3 and
    the chain rule (:func:`~feedopt.geometry.arclength.arc_length_derivatives`), every sample
    of every chain in one vectorised call.
    """

    def __init__(self, segs: Sequence[Segment]):
        self.batch, table = _batch_of([g.params for g in segs])
        self.inverter = Inverter.of(self.batch, table)

    def eval(self, j, sl):
        j = np.asarray(j, dtype=np.intp)
        t = self.inverter.invert(j, np.asarray(sl, dtype=float))
        d = self.batch.evaluate(j, t, 3)
        return (d[0], *arc_length_derivatives(d[1], d[2], d[3]))


SPLINE = register_segment_kind(SegmentKind(
    name=SPLINE_KIND, evaluator=SplineEvaluator, colour="tab:cyan",
    description="quintic smoothing spline through a chain of short moves, within the path "
                "tolerance"))
