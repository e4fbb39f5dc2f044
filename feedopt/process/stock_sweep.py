"""The cutting loop of :func:`feedopt.process.stock.sweep`: per-sample geometry along the path,
the candidate cells of blocks of samples, the front and capsule tests, and the gather/scatter
over the Z-map.

Along the path (issue 28)
-------------------------
The material a tooth meets at sample i is the material the cutter's disc sweeps along the path
just ahead, in the tool frame of the path's own tangent. Near a sample a line, an arc, a helix
(in xy) and a ramp are their own osculating arcs, so the path ahead is taken as the arc tangent
to the feed at sample i through the next sample at least half a cell on (``kappa_ahead``;
the lookahead follows it while it turns by at most 90 deg, and is dropped where the path turns
by more than that within the next step: a corner), and the step just taken as the arc tangent
to the feed at sample i through sample i-1 (``kappa_back``), which the cutter sweeps along
(:func:`arc_capsule_cells`). Signed curvature kappa > 0 turns left (towards +y of the
force-model frame).

For a circle of radius rho = 1 / kappa about O, a cell q at distance d_q from O is first met by
the rim when the centre is where ``|q - c'| = R``; in the frame of the tangent there, q sits at
the lateral offset (law of cosines in the triangle O, c', q)::

    y' = (R^2 + rho^2 - d_q^2) / (2 rho) = y + kappa (R^2 - |q - c|^2) / 2

with (x, y) its offset from the current centre c in the current frame, and the tooth that meets
it is at ``phi = arccos(y' / R)`` (Kardes & Altintas, "Mechanics and dynamics of the circular
milling process", J. Manuf. Sci. Eng. 129, 2007: the immersion of circular interpolation; for
kappa = 0, y' = y, the straight cut). q is reachable by the rim iff ``|y'| <= R`` (the annulus
|rho - R| <= d_q <= rho + R; on a circle tighter than the cutter, rho < R, the core d_q < R - rho
is never met by the side edges: only the bottom cuts it), and the arc length from c to that
contact is ``sigma = u(x, y) - u(sqrt(R^2 - y'^2), y')`` with ``u(x, y) = atan2(kappa x,
1 - kappa y) / kappa`` the arc coordinate of a point's projection on the circle (x at kappa = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Margin [m] of the candidate cell sets: far above the float64 rounding of the coordinates
# (~1e-16 m at 1 m), far below a cell.
_EPS = 1e-9
# Samples whose per-row intervals are computed at once, and candidate cells expanded at once
# (bounds the temporaries to some 10 arrays of this many float64).
_BLOCK = 512
_CELL_BUDGET = 250_000
# Material thinner than this above the tool tip is not material (float32 heights round to
# ~4e-9 m at |z| = 0.05 m, far below it).
MIN_DEPTH = 1e-6
# A curvature whose shift kappa r^2 / 2 of the lateral offsets stays below this [m] is 0.
_FLAT = 1e-12


def expand(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ranges ``[starts[k], starts[k] + counts[k])`` concatenated, and each element's k."""
    owner = np.repeat(np.arange(counts.size), counts)
    shift = np.repeat(starts - (np.cumsum(counts) - counts), counts)
    return shift + np.arange(owner.size), owner


@dataclass(frozen=True)
class SweepGeometry:
    """Per-sample geometry of a sweep, arrays (n,), SI units (from :func:`sweep_geometry`).

    ``c*`` the tool tip, ``p*`` the previous tip (sample 0: its own), ``f*`` the unit feed in
    xy, ``ds`` the xy step from the previous sample, ``lam_max`` the lookahead along the path
    (0 where the path turns by more than 90 deg within it: a corner the arc cannot follow),
    ``k_ahead``/``k_back`` the curvatures ahead and of the step taken, ``r_out`` a radius about
    the centre that holds every front cell, ``fast`` whether the step leaves the previous disc uncut
    (a level or rising tip), ``first`` sample 0 (it has no previous disc to leave out),
    ``sheared`` where the arcs move the teeth that meet the front cells by more than half a
    cell against their lateral offsets (``R |kappa| (lam_max + ds)``, module docstring): the
    cells then spread unevenly over the teeth.
    """

    cx: np.ndarray
    cy: np.ndarray
    z: np.ndarray
    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    ds: np.ndarray
    lam_max: np.ndarray
    k_ahead: np.ndarray
    k_back: np.ndarray
    r_out: np.ndarray
    fast: np.ndarray
    first: np.ndarray
    sheared: np.ndarray

    @property
    def curved(self) -> np.ndarray:
        """(n,) bool: the arc ahead or the step taken is curved (else both are straight)."""
        return self._curved

    def __post_init__(self) -> None:
        object.__setattr__(self, "_curved", (self.k_ahead != 0.0) | (self.k_back != 0.0))

    @property
    def n(self) -> int:
        return int(self.cx.size)


def _chord_curvature(t: np.ndarray, chord: np.ndarray, ahead: bool) -> tuple[np.ndarray, ...]:
    """Signed curvature of the arc tangent to ``t`` (unit, (n, 2)) at one end whose chord is
    ``chord`` (n, 2) (to the point ahead, or from the point behind): ``2 sin(theta) / L``,
    theta the angle between tangent and chord. Returns (kappa, ok): ok where the arc turns
    by at most 90 deg over the chord (|theta| <= 45 deg); kappa is 0 elsewhere."""
    cross = t[:, 0] * chord[:, 1] - t[:, 1] * chord[:, 0]
    cross = cross if ahead else -cross
    dot = t[:, 0] * chord[:, 0] + t[:, 1] * chord[:, 1]
    length2 = chord[:, 0] ** 2 + chord[:, 1] ** 2
    ok = (length2 > _EPS**2) & (dot >= np.abs(cross))
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(ok, 2.0 * cross / np.where(ok, length2, 1.0), 0.0)
    return kappa, ok


def sweep_geometry(p: np.ndarray, feed: np.ndarray, radius: float, look: float,
                   look_cap: float, z0: float, cell: float) -> SweepGeometry:
    """The per-sample geometry of a sweep of tips ``p`` (n, 3) with unit feeds ``feed``
    (n, 2) on cells of size ``cell``: the lookahead ``min(look_cap - ds, remaining path)`` (in
    xy arc length), the arcs of the path ahead and of the step taken (module docstring), and
    the bounds of the candidate cells."""
    n = p.shape[0]
    steps = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)
    s_xy = np.concatenate([[0.0], np.cumsum(steps)])
    ds = np.concatenate([[0.0], steps])
    prev = np.concatenate([p[:1], p[:-1]])
    lam_max = np.minimum(np.maximum(0.0, look_cap - ds), s_xy[-1] - s_xy)
    # the osculating arc ahead: through the next sample at least half a cell on in xy (a point
    # of the path, so that an arc's samples give the arc itself); the lookahead follows it
    # while it turns by at most 90 deg
    near = np.maximum(np.minimum(lam_max, 0.5 * cell), _EPS)
    j = np.clip(np.searchsorted(s_xy, s_xy + near, side="left"), np.arange(n) + 1, n - 1)
    k_ahead, ok = _chord_curvature(feed, p[j, :2] - p[:, :2], ahead=True)
    with np.errstate(divide="ignore"):
        lam_max = np.where(ok, np.minimum(lam_max, 0.5 * math.pi / np.abs(k_ahead)), 0.0)
    k_back, _ = _chord_curvature(feed, p[:, :2] - prev[:, :2], ahead=False)
    shift = 0.5 * (radius + look_cap) ** 2  # |y' - y| per unit curvature, at most
    k_ahead = np.where(np.abs(k_ahead) * shift > _FLAT, k_ahead, 0.0)
    k_back = np.where(np.abs(k_back) * shift > _FLAT, k_back, 0.0)
    r_out = np.sqrt(radius**2 + 2.0 * radius * look + lam_max**2 * (1.0 + radius * np.abs(k_ahead)))
    r_out += _EPS
    first = np.zeros(n, dtype=bool)
    first[:1] = True
    fast = (np.maximum(p[:, 2], z0) >= np.maximum(prev[:, 2], z0)) & ~first
    shear = radius * (np.abs(k_ahead) * (lam_max + ds) + np.abs(k_back) * ds)
    return SweepGeometry(p[:, 0], p[:, 1], p[:, 2], prev[:, 0], prev[:, 1], prev[:, 2],
                         feed[:, 0], feed[:, 1], ds, lam_max, k_ahead, k_back, r_out, fast,
                         first, shear > 0.5 * cell)


def _arc_coordinate(x: np.ndarray, y: np.ndarray, kappa: np.ndarray) -> np.ndarray:
    """Arc length along the circle of curvature ``kappa`` through the origin (tangent +x)
    to the projection of (x, y) on it: ``atan2(kappa x, 1 - kappa y) / kappa``."""
    return np.arctan2(kappa * x, 1.0 - kappa * y) / kappa


def front_cells(wx: np.ndarray, wy: np.ndarray, k, g: SweepGeometry, radius: float,
                look: float) -> tuple[np.ndarray, np.ndarray]:
    """Which candidate cells are in front of the cutter along the path, and the lateral offset
    y' at which the rim meets each (force-model frame, in [-R, R] where in front).

    ``wx, wy``: cell centre minus the centre of its sample [m]; ``k`` the samples (an index
    array) or a function giving a per-sample array at the cells; the candidates are
    already outside the disc of the previous sample (:func:`block_pieces`). A cell is in
    front when it lies on the leading half-plane (x >= 0 along the feed) and either inside
    the cutter's disc (the crescent the step swept, met at y' of the arc of the step), or
    outside it and met by the rim after an arc length sigma with ``0 < sigma <= clip(look R /
    sqrt(R^2 - y'^2) - ds, 0, lam_max)`` along the arc ahead (a crescent ``look`` thick
    normal to the rim; on a straight path exactly the lookahead of
    :func:`feedopt.process.stock.lookahead_reach`).
    """
    at = k if callable(k) else (lambda a: a[k])  # noqa: E731
    fx, fy = at(g.fx), at(g.fy)
    dx = wx * fx
    dx += wy * fy
    dy = wy * fx
    dy -= wx * fy
    r2 = radius * radius
    dy2 = dy * dy
    half = np.sqrt(np.maximum(r2 - dy2, 0.0))
    reach = np.maximum(half, 1e-300)  # the lookahead at y (kappa = 0), plus half
    np.divide(look * radius, reach, out=reach)
    reach -= at(g.ds)
    np.minimum(np.maximum(reach, 0.0, out=reach), at(g.lam_max), out=reach)
    reach += half
    keep = (dx >= 0.0) & (dy2 <= r2) & (dx <= reach)
    curved = at(g.curved)
    if curved.any():
        c = np.flatnonzero(curved)
        keep[c], dy[c] = _front_on_arcs(dx[c], dy[c], (at(g.k_back)[c], at(g.k_ahead)[c]),
                                        (at(g.ds)[c], at(g.lam_max)[c]), radius, look)
    return keep, dy


def _front_on_arcs(dx, dy, curvature, reach, radius: float, look: float):
    """:func:`front_cells` for cells (offsets dx, dy in the frame of their sample) of samples
    whose step or path ahead is curved (``curvature`` = (k_back, k_ahead) per cell,
    ``reach`` = (ds, lam_max)): y' of the arc of the step inside the disc, of the arc ahead
    outside (module docstring); returns (in front, y' clipped to [-R, R])."""
    k_back, k_ahead = curvature
    ds, lam_max = reach
    excess = radius**2 - (dx * dx + dy * dy)
    inside = excess >= 0.0
    dyc = dy + 0.5 * np.where(inside, k_back, k_ahead) * excess
    half = np.sqrt(np.maximum(radius**2 - dyc * dyc, 0.0))
    sigma = dx - half
    arc = ~inside & (k_ahead != 0.0)
    if arc.any():
        ka = k_ahead[arc]
        sigma[arc] = (_arc_coordinate(dx[arc], dy[arc], ka)
                      - _arc_coordinate(half[arc], dyc[arc], ka))
    lam = np.clip(look * radius / np.maximum(half, 1e-300) - ds, 0.0, lam_max)
    ahead = ~inside & (np.abs(dyc) <= radius) & (sigma > 0.0) & (sigma <= lam)
    return (inside | ahead) & (dx >= 0.0), np.clip(dyc, -radius, radius)


def capsule_cells(u, step, z_prev, z_tip, z0: float, radius: float):
    """Cells the cutter sweeps over from the previous sample, and the height it leaves them.

    ``u`` = (ux, uy): cell centre minus the previous tool centre [m]; ``step`` = (sx, sy,
    len2) the xy step and its squared length. A cell is swept when its centre is within R of
    the step (the capsule). The flat bottom of the cylinder covers it over the part
    ``[s_p - w, s_p + w]`` of the step (s_p its projection, w the half chord, as fractions of
    the step), and the tip descends or rises linearly, so the cut height is the tip's at the
    last covering point of a descending step and the first of a rising one (the lowest the
    bottom passes over it: the exact swept volume of the cylinder), never below ``z0``.
    """
    ux, uy = u
    sx, sy, len2 = step
    with np.errstate(divide="ignore", invalid="ignore"):
        sp = np.where(len2 > 0.0, (ux * sx + uy * sy) / len2, 0.0)
    s = np.clip(sp, 0.0, 1.0)
    inside = (ux - s * sx) ** 2 + (uy - s * sy) ** 2 <= radius**2
    z_cut = np.array(np.broadcast_to(z_prev, inside.shape), dtype=float)
    moving = np.broadcast_to(z_tip != z_prev, inside.shape)
    if moving.any():
        m = np.flatnonzero(moving)
        pick = (lambda a: a[m] if np.ndim(a) else a)  # noqa: E731
        z_cut[m] = _swept_height(pick(ux), pick(uy), pick(sp), pick(len2), pick(z_prev),
                                 pick(z_tip), radius)
    return inside, np.maximum(z_cut, z0)


def _swept_height(ux, uy, sp, len2, z_prev, z_tip, radius: float) -> np.ndarray:
    """The lowest tip height over a cell of a descending or rising step (see
    :func:`capsule_cells`)."""
    perp2 = np.maximum(ux * ux + uy * uy - sp * sp * len2, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(len2 > 0.0, np.sqrt(np.maximum(radius**2 - perp2, 0.0) / len2), np.inf)
    down = z_tip < z_prev
    s_last = np.clip(sp + w, 0.0, 1.0)
    s_first = np.clip(sp - w, 0.0, 1.0)
    return np.where(down, z_tip + (z_prev - z_tip) * (1.0 - s_last),
                    z_prev + (z_tip - z_prev) * s_first)


def arc_capsule_cells(d, arc, z_prev, z_tip, z0: float, radius: float):
    """:func:`capsule_cells` for a curved step: the cutter swept along the arc of the step
    (curvature kappa, tangent +x at its end, the sample), so that the wall an arc cuts is at
    ``rho + R`` everywhere, not only at the samples (a chord falls short by its sagitta,
    leaving full-height slivers the next turn of a helix would meet).

    ``d`` = (dx, dy): cell centre minus the sample's centre in the sample's frame; ``arc`` =
    (kappa, chord length). With u the cell's arc coordinate (:func:`_arc_coordinate`) and e its
    signed offset from the circle, the disc centred at arc coordinate sigma covers it iff
    ``e^2 + (1 - kappa e) (2 sin(kappa (u - sigma) / 2) / kappa)^2 <= R^2`` (law of cosines),
    i.e. for ``|u - sigma| <= 2 asin(kappa W / 2) / kappa``, ``W^2 = (R^2 - e^2) / (1 - kappa
    e)``; the step covers arc coordinates [-L, 0], L its arc length. Cut height: as the
    chord's, at the last (descending) or first (rising) covering point.
    """
    dx, dy = d
    k, chord = arc
    q2 = dx * dx + dy * dy
    ak = np.abs(k)
    length = 2.0 * np.arcsin(np.minimum(0.5 * ak * chord, 1.0)) / ak
    u = _arc_coordinate(dx, dy, k)
    e = (2.0 * dy - k * q2) / (1.0 + np.sqrt(np.maximum(1.0 - 2.0 * k * dy + k * k * q2, 0.0)))
    scale = 1.0 - k * e  # distance from the arc's centre over its radius
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.sqrt(np.maximum(radius**2 - e * e, 0.0) / scale)
        half = 2.0 * np.arcsin(np.minimum(0.5 * ak * w, 1.0)) / ak
    reach = (e * e <= radius**2) & (scale > 0.0)
    period = 2.0 * math.pi / ak
    full = half * ak >= math.pi  # covered all round the circle
    first = np.where(full, -length, np.inf)
    last = np.where(full, 0.0, -np.inf)
    for m in (-1.0, 0.0, 1.0):
        lo = np.maximum(u + m * period - half, -length)
        hi = np.minimum(u + m * period + half, 0.0)
        hit = lo <= hi
        first = np.where(hit, np.minimum(first, lo), first)
        last = np.where(hit, np.maximum(last, hi), last)
    inside = reach & (first <= last)
    with np.errstate(invalid="ignore"):
        s_first = np.clip(1.0 + first / length, 0.0, 1.0)
        s_last = np.clip(1.0 + last / length, 0.0, 1.0)
    z_cut = np.where(z_tip < z_prev, z_tip + (z_prev - z_tip) * (1.0 - s_last),
                     z_prev + (z_tip - z_prev) * s_first)
    return inside, np.maximum(np.where(inside, z_cut, z_prev), z0)


def _row_span(cx, r, i0, i1, gx0: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``[a0, a1)`` of the window ``[i0, i1)`` whose cell centres are within r of cx."""
    a0 = np.clip(np.ceil((cx - r - gx0) / h - 0.5), i0, i1).astype(np.int64)
    a1 = np.clip(np.floor((cx + r - gx0) / h - 0.5) + 1, a0, i1).astype(np.int64)
    return a0, a1


@dataclass(frozen=True)
class Grid:
    """The Z-map grid: origin (gx0, gy0), cell h, shape (nx, ny), cell centres xc, yc."""

    gx0: float
    gy0: float
    h: float
    nx: int
    ny: int
    xc: np.ndarray
    yc: np.ndarray


def _window(g: SweepGeometry, b: slice, radius: float, grid: Grid):
    """Per sample of block ``b`` the cells (i0, i1, j0, j1) that may be front or capsule."""
    cx, cy, px, py, r_out = g.cx[b], g.cy[b], g.px[b], g.py[b], g.r_out[b]
    r_step = radius + 0.2 * np.abs(g.k_back[b]) * g.ds[b] ** 2 + _EPS  # + an arc's sagitta
    lo_x = np.minimum(cx - r_out, px - r_step)
    hi_x = np.maximum(cx + r_out, px + r_step)
    lo_y = np.minimum(cy - r_out, py - r_step)
    hi_y = np.maximum(cy + r_out, py + r_step)
    h = grid.h
    i0 = np.maximum(0, np.ceil((lo_x - grid.gx0) / h - 0.5)).astype(np.int64)
    i1 = np.minimum(grid.nx, np.floor((hi_x - grid.gx0) / h - 0.5) + 1).astype(np.int64)
    j0 = np.maximum(0, np.ceil((lo_y - grid.gy0) / h - 0.5)).astype(np.int64)
    j1 = np.minimum(grid.ny, np.floor((hi_y - grid.gy0) / h - 0.5) + 1).astype(np.int64)
    return i0, i1, j0, j1


def block_pieces(g: SweepGeometry, b: slice, radius: float, grid: Grid,
                 recut: bool = False):
    """Candidate cells of the samples of block ``b``: front candidates as (sample, flat start,
    count), two pieces a row; capsule candidates as (sample, flat start, count, core), three a
    row.

    Front candidates: the cells in the disc ``r_out`` about the centre and the half-plane
    ``x >= 0`` along the feed (1 nm margin), less the cells surely inside the previous disc
    (all of them are at most as high as the previous tip: only the bottom cuts them; sample 0
    leaves none out). Capsule candidates: the cells within ``R + ds / 2`` of the middle of
    the step, less, on a level or rising step, the cells surely inside the previous disc
    (not cut again); on a descending step the cells surely inside the current disc are the
    ``core`` piece (cut to the tip height, :func:`capsule_cells`). The sets only need to hold
    the cells: y is in cell units (cell j's centre at j), and the rounding (~1e-12 cells) is
    far inside the 1 nm margin.
    """
    i0, i1, j0, j1 = _window(g, b, radius, grid)
    gx0, gy0, h, ny = grid.gx0, grid.gy0, grid.h, grid.ny
    cx, cy, px, py = g.cx[b], g.cy[b], g.px[b], g.py[b]
    fast = g.fast[b]
    mx, my = 0.5 * (cx + px), 0.5 * (cy + py)
    ds = g.ds[b]
    r_cap = radius + 0.5 * ds + 0.2 * np.abs(g.k_back[b]) * ds * ds + _EPS  # + the sagitta
    r_in = radius - _EPS
    a0, a1 = _row_span(cx, g.r_out[b], i0, i1, gx0, h)
    c0, c1 = _row_span(mx, r_cap, i0, i1, gx0, h)
    a0, a1 = np.minimum(a0, c0), np.maximum(a1, c1)
    a, k = expand(a0, a1 - a0)
    xa = grid.xc[a]

    def cells_of_disc(ox, oy, r):
        """[lo, hi] in cell units per row (lo > hi where the row misses the disc)."""
        d = xa - ox[k]
        r = r[k]
        w2 = r * np.abs(r) - d * d  # r < 0: no cell
        w = np.copysign(np.sqrt(np.abs(w2)), w2) / h
        yc = ((oy - gy0) / h - 0.5)[k]
        return d, yc - w, yc + w

    j_min, j_max = j0[k], j1[k] - 1
    base = a * ny

    def pieces(lo, hi, inner, core=None):
        # (clipped before the integer cast: a bound can be +-1e191 cells)
        _, in_lo_f, in_hi_f = cells_of_disc(*inner)
        in_hi = np.clip(np.floor(in_hi_f), -1, ny).astype(np.int64)
        in_lo = np.clip(np.ceil(in_lo_f), -1, in_hi + 1).astype(np.int64)  # empty: in_hi + 1
        j_lo = np.clip(np.ceil(lo), j_min, j_max + 1).astype(np.int64)
        j_hi = np.clip(np.floor(hi), j_min - 1, j_max).astype(np.int64)
        right = np.maximum(j_lo, in_hi + 1)
        starts = [j_lo, right]
        counts = [np.minimum(j_hi, in_lo - 1) - j_lo + 1, j_hi - right + 1]
        if core is not None:
            middle = np.maximum(j_lo, in_lo)
            starts.insert(1, middle)
            counts.insert(1, np.where(core[k], np.minimum(j_hi, in_hi) - middle + 1, 0))
        m = len(starts)
        out = (np.repeat(k, m), (np.stack(starts, 1) + base[:, None]).reshape(-1),
               np.maximum(np.stack(counts, 1), 0).reshape(-1))
        if core is None:
            return out
        return (*out, np.tile(np.arange(m) == 1, a.size))

    d, lo, hi = cells_of_disc(cx, cy, g.r_out[b])
    fx, fy = g.fx[b], g.fy[b]
    fy = np.where(fy == 0.0, 1e-200, fy)  # fy = 0: +-1e191 cells, the same cut
    bound = ((cy - gy0) / h - 0.5)[k] - (_EPS + d * fx[k]) * (1.0 / (fy * h))[k]
    up = (fy > 0)[k]
    lo = np.where(up, np.maximum(lo, bound), lo)
    hi = np.where(up, hi, np.minimum(hi, bound))
    front = pieces(lo, hi, (px, py, np.where(g.first[b], -1.0, r_in)))
    inner = (np.where(fast, px, cx), np.where(fast, py, cy),
             np.full(fast.size, -1.0 if recut else r_in))
    core = None if fast.all() else ~fast  # (no core piece when every step is level or rising)
    return [front, pieces(*cells_of_disc(mx, my, r_cap)[1:], inner, core=core)]


@dataclass(frozen=True)
class LateralBins:
    """Lateral bins of width h across the cutter (force-model y in [-R, R]) for the pieces."""

    radius: float
    width: float
    flute_length: float
    snap: float
    depth_step: float

    @property
    def count(self) -> int:
        return max(1, math.ceil(2.0 * self.radius / self.width - 1e-9))

    def key(self, k_local, dy):
        """The bin (flat over the samples) of front cells of local sample ``k_local`` met at
        lateral offset ``dy``."""
        nb, r = self.count, self.radius
        return k_local * nb + np.clip(np.floor((dy + r) / self.width), 0, nb - 1).astype(np.int64)

    def pieces(self, k_local, dy, height, ng: int, floor, w_half, seen=None):
        """Pieces of ``ng`` samples from their material cells (sample ``k_local``, lateral
        offset ``dy`` [m], top ``height`` [m]): per lateral bin the highest top and the
        extreme offsets; runs of material bins split where the depth, in steps of
        ``depth_step``, changes. Between two material bins, one empty bin is bridged (a grid
        of cells h apart may leave one empty), and so, on a sheared sample, is any run of bins
        no front cell falls in (``seen`` = (bins of all front cells, material or not, by
        :meth:`key`; (ng,) sheared)): on a tight arc the cells met along the path spread
        unevenly over the teeth (:class:`SweepGeometry` ``sheared``), and a bin without a
        cell says nothing. A bridged bin takes the larger depth of the nearest material bins
        beside it. A run's ends are widened and snapped to the rim like the hull's
        (:func:`feedopt.process.stock.sweep`); depth-split pieces meet on bin edges.

        Returns (local sample, y_lo, y_hi, depth) per piece, in sample then y order.
        """
        nb, r = self.count, self.radius
        key = self.key(k_local, dy)
        top = np.full(ng * nb, -np.inf)
        np.maximum.at(top, key, height.astype(float))
        y_min = np.full(ng * nb, np.inf)
        np.minimum.at(y_min, key, dy)
        y_max = np.full(ng * nb, -np.inf)
        np.maximum.at(y_max, key, dy)
        top, y_min, y_max = (a.reshape(ng, nb) for a in (top, y_min, y_max))
        mat = np.isfinite(top)
        depth = np.where(mat, np.minimum(top - floor[:, None], self.flute_length), 0.0)
        gap = _bridged(mat, seen, ng * nb)
        if gap.any():  # the larger depth of the nearest material bins on either side
            col = np.arange(nb)
            left = np.maximum.accumulate(np.where(mat, col, 0), axis=1)
            right = nb - 1 - np.maximum.accumulate(np.where(mat, nb - 1 - col, 0)[:, ::-1],
                                                   axis=1)[:, ::-1]
            rows = np.arange(ng)[:, None]
            depth = np.where(gap, np.maximum(depth[rows, left], depth[rows, right]), depth)
        member = mat | gap
        level = np.where(member, np.ceil(depth / self.depth_step - 1e-9), -1.0)
        prev_level = np.concatenate([np.full((ng, 1), -1.0), level[:, :-1]], axis=1)
        next_level = np.concatenate([level[:, 1:], np.full((ng, 1), -1.0)], axis=1)
        starts = member & (level != prev_level)
        ends = member & (level != next_level)
        run_start = member & (prev_level < 0)
        run_end = member & (next_level < 0)
        row, col = np.nonzero(starts)
        _, col_end = np.nonzero(ends)
        flat_member = np.flatnonzero(member.reshape(-1))
        first = np.searchsorted(flat_member, row * nb + col)
        piece_depth = np.maximum.reduceat(depth.reshape(-1)[flat_member], first)
        edge = -r + self.width * np.arange(nb + 1)
        wh = w_half[row]
        lo_raw = y_min[row, col]
        hi_raw = y_max[row, col_end]
        y_lo = np.where(run_start[row, col],
                        np.where(lo_raw <= -r + self.snap, -r, np.maximum(-r, lo_raw - wh)),
                        edge[col])
        y_hi = np.where(run_end[row, col_end],
                        np.where(hi_raw >= r - self.snap, r, np.minimum(r, hi_raw + wh)),
                        edge[col_end + 1])
        return row, y_lo, y_hi, piece_depth


def _bridged(mat: np.ndarray, seen, size: int) -> np.ndarray:
    """(ng, nb) bins to bridge between material bins: a single empty bin, or on a sheared
    sample any run of bins no front cell falls in (``seen`` = (flat bin keys of all front
    cells, (ng,) sheared); None: none)."""
    gap = np.zeros_like(mat)
    gap[:, 1:-1] = ~mat[:, 1:-1] & mat[:, :-2] & mat[:, 2:]
    if seen is None or not seen[1].any():
        return gap
    observed = np.zeros(size, dtype=bool)
    observed[seen[0]] = True
    between = np.maximum.accumulate(mat, axis=1) & np.maximum.accumulate(mat[:, ::-1],
                                                                         axis=1)[:, ::-1]
    unseen = between & ~mat & ~observed.reshape(mat.shape) & seen[1][:, None]
    return gap | unseen


@dataclass
class Found:
    """What the cutting loop finds per sample (n,): the lateral extent and top of the material
    in front (``engaged`` where there is any), and per step the volume [cells * m] removed,
    the thickest material cut (``swept``) and the thickest cut between the previous tip
    height and this one (``bottom``: the end edges' layer), [m]; ``pieces``: (sample, y_lo,
    y_hi, depth) per group."""

    y_lo: np.ndarray
    y_hi: np.ndarray
    top: np.ndarray
    engaged: np.ndarray
    removed: np.ndarray
    swept: np.ndarray
    bottom: np.ndarray
    pieces: list

    @classmethod
    def empty(cls, n: int) -> Found:
        z = np.zeros
        return cls(z(n), z(n), z(n), z(n, dtype=bool), z(n), z(n), z(n), [])


@dataclass(frozen=True)
class _Setup:
    """What every group of a sweep shares."""

    g: SweepGeometry
    grid: Grid
    bins: LateralBins
    radius: float
    look: float
    z0: float
    floor: np.ndarray  # per sample the tip, or the bottom where the tip is below it
    thr: np.ndarray  # material threshold per sample: above the floor by 1 um
    w_half: np.ndarray  # half the projected cell width across the feed per sample
    descent: np.ndarray  # how far the tip (or the bottom) descends into the sample, >= 0
    bulges: np.ndarray  # the step is swept along its arc (:func:`_bulges`)
    profile: object = None  # feedopt.process.cutter.Profile of a non-flat cutter, else None


def cut_along(flat: np.ndarray, setup: _Setup) -> Found:
    """Cut the Z-map (``flat``: its heights, float32, modified in place) sample by sample in
    blocks, recording what each sample finds (:class:`Found`)."""
    g, n = setup.g, setup.g.n
    out = Found.empty(n)
    for b0 in range(0, n, _BLOCK):
        b = slice(b0, min(n, b0 + _BLOCK))
        nb = b.stop - b0
        pieces = block_pieces(g, b, setup.radius, setup.grid, recut=setup.profile is not None)
        per_sample = sum(np.bincount(pc[0], weights=pc[2], minlength=nb) for pc in pieces)
        cum = np.cumsum(per_sample)
        g0 = 0
        while g0 < nb:
            base = cum[g0 - 1] if g0 else 0.0
            g1 = min(nb, max(g0 + 1, int(np.searchsorted(cum, base + _CELL_BUDGET, "right"))))
            _cut_group(flat, setup, pieces, (b0 + g0, b0 + g1), b0, out)
            g0 = g1
    return out


def make_setup(g: SweepGeometry, grid: Grid, bins: LateralBins, radius: float, look: float,
               z0: float, profile=None) -> _Setup:
    """The shared state of :func:`cut_along` (``profile``: a non-flat cutter's
    :class:`~feedopt.process.cutter.Profile`; None or a cylinder: a flat end mill)."""
    if profile is not None and profile.is_cylinder:
        profile = None
    floor = np.maximum(g.z, z0)
    w_half = 0.5 * grid.h * (np.abs(g.fx) + np.abs(g.fy))
    descent = np.where(g.first, 0.0, np.maximum(np.maximum(g.pz, z0) - floor, 0.0))
    return _Setup(g, grid, bins, radius, look, z0, floor, floor + MIN_DEPTH, w_half, descent,
                  _bulges(g), profile)


def _cells(pieces, k0: int, k1: int, b0: int):
    """The candidate cells of samples [k0, k1) of each kind: (flat index, sample), and for
    the capsule also whether each is in the core."""
    out = []
    for kind, (pk, starts, counts, *core) in enumerate(pieces):
        s0, s1 = np.searchsorted(pk, [k0 - b0, k1 - b0])
        idx, owner = expand(starts[s0:s1], counts[s0:s1])
        cells = (idx, pk[s0:s1][owner] + b0)
        if kind:
            cells += (core[0][s0:s1][owner] if core else np.zeros(idx.size, dtype=bool),)
        out.append(cells)
    return out


def _centres(idx: np.ndarray, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """x and y [m] of the centres of the cells of flat index ``idx``."""
    a = idx // grid.ny
    return grid.xc[a], grid.yc[idx - a * grid.ny]


def _cut_group(flat, s: _Setup, pieces, span: tuple[int, int], b0: int, out: Found) -> None:
    """Samples [k0, k1): their front and capsule cells (exact tests), read and cut in order,
    then what they found, reduced per sample."""
    g = s.g
    k0, k1 = span
    (f_idx, fk), (c_idx, ck, core) = _cells(pieces, k0, k1, b0)
    x, y = _centres(f_idx, s.grid)
    counts = np.bincount(fk - k0, minlength=k1 - k0)  # fk is sorted: repeat beats gathering

    def at(a: np.ndarray) -> np.ndarray:
        return np.repeat(a[k0:k1], counts)

    x -= at(g.cx)
    y -= at(g.cy)
    keep, dy = front_cells(x, y, at, g, s.radius, s.look)
    f_idx, f_dy, f_k = f_idx[keep], dy[keep], fk[keep]
    keep, c_z = _capsule_of(s, c_idx, ck, core)
    c_idx, c_z, c_k = c_idx[keep], c_z[keep], ck[keep]
    edges = np.arange(k0, k1 + 1)
    f_off, c_off = np.searchsorted(f_k, edges), np.searchsorted(c_k, edges)
    seen_f, seen_c, new_c = _gather_scatter(flat, (f_idx, f_off), (c_idx, c_z, c_off))
    _front_found(s, (seen_f, f_dy, f_k, f_off), k0, k1, out)
    sel = np.diff(c_off) > 0
    if sel.any():
        cut = np.subtract(seen_c, new_c.astype(np.float32), dtype=float)
        starts = c_off[:-1][sel]
        ks = edges[:-1][sel]
        out.removed[ks] = np.add.reduceat(cut, starts)
        out.swept[ks] = np.maximum.reduceat(cut, starts)
        # the bottom: the material between the previous tip height and this one
        layer = np.repeat(s.descent[k0:k1], np.diff(c_off))
        out.bottom[ks] = np.maximum.reduceat(np.minimum(cut, layer), starts)


def _bulges(g: SweepGeometry) -> np.ndarray:
    """(n,) bool: steps whose arc bulges from their chord by its sagitta ``kappa ds^2 / 8``
    more than 1e-12 m (the others are swept along the chord)."""
    return np.abs(g.k_back) * g.ds**2 > 8.0 * _FLAT


def _capsule_of(s: _Setup, idx: np.ndarray, ck: np.ndarray, core: np.ndarray):
    """Which capsule candidates (flat cell ``idx`` of sample ``ck``) the step sweeps and the
    heights it leaves them: the core (surely inside the disc a descending step ends in) at
    the tip height, the others by :func:`capsule_cells` on a straight step,
    :func:`arc_capsule_cells` on a curved one."""
    g = s.g
    keep = np.ones(ck.size, dtype=bool)
    z_cut = s.floor[ck]
    if s.profile is not None:
        return _profile_capsule(s, idx, ck)
    if not (~core).any():
        return keep, z_cut
    curved = s.bulges[ck]
    straight, arced = np.flatnonzero(~core & ~curved), np.flatnonzero(~core & curved)
    for arc, sel in ((False, straight), (True, arced)):
        if not sel.size:
            continue
        k = ck[sel]
        x, y = _centres(idx[sel], s.grid)
        if not arc:
            sx, sy = g.cx[k] - g.px[k], g.cy[k] - g.py[k]
            keep[sel], z_cut[sel] = capsule_cells((x - g.px[k], y - g.py[k]),
                                                  (sx, sy, sx * sx + sy * sy), g.pz[k], g.z[k],
                                                  s.z0, s.radius)
            continue
        wx, wy, fx, fy = x - g.cx[k], y - g.cy[k], g.fx[k], g.fy[k]
        keep[sel], z_cut[sel] = arc_capsule_cells(
            (wx * fx + wy * fy, wy * fx - wx * fy), (g.k_back[k], g.ds[k]), g.pz[k], g.z[k],
            s.z0, s.radius)
    return keep, z_cut


def _profile_capsule(s: _Setup, idx: np.ndarray, ck: np.ndarray):
    """:func:`_capsule_of` for a cutter with a profile: a cell within R of the step's chord
    (previous centre to this one; an arc's chord, its sagitta neglected) is cut to the
    cutter's surface over it, ``z(t) + height_at_radius(rho)`` with rho its distance from
    the chord at the closest point t and z(t) the tip height there (the lowest the surface
    passes over the cell when the tip is level; on a ramp the surface's minimum may lie a
    little off t: the cut is then shallower by at most the ramp's drop over the contact
    width), never below z0."""
    g = s.g
    x, y = _centres(idx, s.grid)
    ux, uy = x - g.px[ck], y - g.py[ck]
    sx, sy = g.cx[ck] - g.px[ck], g.cy[ck] - g.py[ck]
    len2 = sx * sx + sy * sy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(np.where(len2 > 0.0, (ux * sx + uy * sy) / len2, 1.0), 0.0, 1.0)
    rho = np.hypot(ux - t * sx, uy - t * sy)
    keep = rho <= s.radius
    z_tip = np.maximum(g.pz[ck] + t * (g.z[ck] - g.pz[ck]), s.z0)
    lift = s.profile.height_at_radius(np.minimum(rho, s.radius))
    return keep, np.maximum(z_tip + lift, s.z0)


def _gather_scatter(flat, front, capsule):
    """Per sample in order: read its front and capsule cells, then lower its capsule cells
    to the cut heights. Returns the front heights, the capsule heights before and after."""
    f_idx, f_off = front
    c_idx, c_z, c_off = capsule
    seen_f = np.empty(f_idx.size, dtype=np.float32)
    seen_c = np.empty(c_idx.size, dtype=np.float32)
    new_c = np.empty(c_idx.size)
    take, minimum = flat.take, np.minimum
    bounds = zip(f_off[:-1].tolist(), f_off[1:].tolist(), c_off[:-1].tolist(),
                 c_off[1:].tolist(), strict=True)
    for f0, f1, c0, c1 in bounds:
        if f0 < f1:
            take(f_idx[f0:f1], out=seen_f[f0:f1])
        if c0 < c1:
            cells = c_idx[c0:c1]
            take(cells, out=seen_c[c0:c1])
            flat[cells] = minimum(seen_c[c0:c1], c_z[c0:c1], out=new_c[c0:c1])
    return seen_f, seen_c, new_c


def _front_found(s: _Setup, front, k0: int, k1: int, out: Found) -> None:
    """The material among the front cells of samples [k0, k1): its lateral extent, top and
    pieces per sample."""
    seen, dy, fk, off = front
    sel = np.diff(off) > 0
    if not sel.any():
        return
    material = seen > s.thr[fk]
    if s.profile is not None:  # above the cutter's surface at the cell's lateral offset
        material &= seen > s.thr[fk] + s.profile.height_at_radius(np.abs(dy))
    starts = off[:-1][sel]
    hit = np.add.reduceat(material, starts) > 0
    tops = np.maximum.reduceat(seen, starts)
    y_lo = np.minimum.reduceat(np.where(material, dy, np.inf), starts)
    y_hi = np.maximum.reduceat(np.where(material, dy, -np.inf), starts)
    k_hit = np.arange(k0, k1)[sel][hit]
    out.engaged[k_hit] = True
    out.top[k_hit] = tops[hit]
    out.y_lo[k_hit] = y_lo[hit]
    out.y_hi[k_hit] = y_hi[hit]
    if material.any():
        k_g, *rest = s.bins.pieces(fk[material] - k0, dy[material], seen[material], k1 - k0,
                                   s.floor[k0:k1], s.w_half[k0:k1],
                                   seen=_seen(s, fk, dy, k0, k1))
        out.pieces.append((k_g + k0, *rest))


def _seen(s: _Setup, fk: np.ndarray, dy: np.ndarray, k0: int, k1: int):
    """(bins of the front cells of the sheared samples of [k0, k1), (k1 - k0,) sheared) for
    :meth:`LateralBins.pieces`; None when none is sheared."""
    sheared = s.g.sheared[k0:k1]
    if not sheared.any():
        return None
    mine = s.g.sheared[fk]
    return s.bins.key(fk[mine] - k0, dy[mine]), sheared


def intervals(found: list[tuple[np.ndarray, ...]], radius: float):
    """The pieces the sweep found (sample, y_lo, y_hi, depth), as angles in sample order:
    (sample, entry, exit, depth) arrays."""
    if not found:
        empty = np.zeros(0)
        return np.zeros(0, dtype=np.int64), empty, empty, empty
    sample, y_lo, y_hi, depth = (np.concatenate(a) for a in zip(*found, strict=True))
    entry = np.arccos(np.clip(y_hi / radius, -1.0, 1.0))
    exit_ = np.arccos(np.clip(y_lo / radius, -1.0, 1.0))
    keep = exit_ > entry  # a sliver on the rim that rounds to no angle cuts nothing
    sample, entry, exit_, depth = sample[keep], entry[keep], exit_[keep], depth[keep]
    order = np.lexsort((entry, sample))
    return sample[order], entry[order], exit_[order], depth[order]
