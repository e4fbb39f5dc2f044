"""Distances between a modified stretch of a path and the program it replaces, both ways.

A corner blend or a G2 transition replaces the programmed geometry near a junction by a curve.
How far the result is from the program is the two-sided (Hausdorff) distance of the two:

- *path -> program*: the largest distance of a point of the curve from the programmed moves
  near the junction (how far the tool leaves the programmed geometry);
- *program -> path*: the largest distance of a point of the replaced programmed geometry from
  the path (how much of a programmed corner is cut short). At a sharp corner this is the
  larger one: a circle of radius r in a corner turning by gamma stays r (1 - cos(gamma/2))
  from the lines but passes r (1/cos(gamma/2) - 1) from the corner, 1/cos(gamma/2) times as
  far (3.9x at 150 deg, 11.5x at 170 deg).

Both are maxima of a distance along a parameter, found by :func:`zoomed_max` (uniform samples,
then twice around the best: the distance to the nearer of two pieces has a kink at its
maximum, where a single sampling is off linearly in the step). The distance of a point to a
curve (:func:`nearest_on_curve`) is the distance to its nearest sample refined by Newton
steps on (p(s) - x).T(s) = 0: the distance of an actual curve point, so an upper bound of the
true one, exact to the convergence of the steps. The distance to programmed moves is the
distance to their polylines (lines exact, arcs with a sag below 1e-3 of the tolerance).
Everything is vectorised over rows (junctions), in batches that bound the memory.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: samples per interval at which a maximum is first searched (then zoomed)
DEVIATION_SAMPLES = 64
#: samples of a curve for the nearest-point search before the Newton steps
CURVE_SAMPLES = 128
NEWTON_STEPS = 2
#: elements (rows x samples x segments) per batch of a distance computation
BUDGET = 1 << 21

#: ``curve(t)`` with t (m, k) -> position and its first two derivatives by the curve's
#: parameter (by arc length: the unit tangent and the curvature vector), each (m, k, 3)
Curve = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def zoomed_max(f, lo: np.ndarray, hi: np.ndarray, q: int = DEVIATION_SAMPLES + 1,
               rounds: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Largest value of ``f`` on each interval [lo_i, hi_i] and where: ``q`` samples, then
    ``rounds`` times ``q`` samples across the two sample steps around the best one.

    ``f`` takes an (m, k) array of parameters and returns (m, k) values. A distance to the
    nearer of two curves has a kink where they are equally far, so its maximum is not a smooth
    peak and a single uniform sampling misses it linearly in the step; zooming makes that error
    q^-rounds of it.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    grid = np.linspace(0.0, 1.0, q)
    t = lo[:, None] + grid[None, :] * (hi - lo)[:, None]
    best_v = np.full(lo.size, -np.inf)
    best_t = lo.copy()
    step = (hi - lo) / (q - 1)
    rows = np.arange(lo.size)
    for _ in range(rounds + 1):
        v = f(t)
        k = np.argmax(v, axis=1)
        vk = v[rows, k]
        better = vk > best_v
        best_v = np.where(better, vk, best_v)
        best_t = np.where(better, t[rows, k], best_t)
        a = np.maximum(best_t - step, lo)
        b = np.minimum(best_t + step, hi)
        t = a[:, None] + grid[None, :] * (b - a)[:, None]
        step = (b - a) / (q - 1)
    return best_v, best_t


def segment_distance(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points x (m, q, 3) to the nearest of the segments a -> b (m, k, 3) of
    their row (a zero-length segment is its point)."""
    ab = b - a
    den = np.maximum(np.einsum("mij,mij->mi", ab, ab), 1e-300)
    t = np.clip(np.einsum("mqij,mij->mqi", x[:, :, None, :] - a[:, None], ab)
                / den[:, None], 0.0, 1.0)
    near = a[:, None] + t[..., None] * ab[:, None]
    return np.linalg.norm(x[:, :, None, :] - near, axis=3).min(axis=2)


def padded(polys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Polylines (one per row, any number of points >= 1) as (m, k, 3) points padded by
    repeating each row's last point, and their cumulative arc length (m, k)."""
    n = np.array([len(p) for p in polys])
    k = int(n.max())
    flat = np.concatenate(polys)
    row = np.repeat(np.arange(len(polys)), n)
    col = np.arange(flat.shape[0]) - np.repeat(np.cumsum(n) - n, n)
    pts = np.empty((len(polys), k, 3))
    pts[row, col] = flat
    fill = np.arange(k)[None, :] >= n[:, None]
    last = flat[np.cumsum(n) - 1]
    pts[fill] = np.broadcast_to(last[:, None], pts.shape)[fill]
    step = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    return pts, np.concatenate([np.zeros((len(polys), 1)), np.cumsum(step, axis=1)], axis=1)


def polyline_points(pts: np.ndarray, cum: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points (m, q, 3) at arc lengths u (m, q) along each row's polyline (clamped)."""
    m, k = cum.shape
    u = np.clip(u, 0.0, cum[:, -1:])
    # a globally increasing key: row r's lengths shifted past those of the rows before
    off = np.concatenate([[0.0], np.cumsum(cum[:, -1] + 1.0)])[:-1]
    keys = (cum + off[:, None]).ravel()
    g = np.searchsorted(keys, (u + off[:, None]).ravel(), side="right") - 1
    g = g.reshape(u.shape) - np.arange(m)[:, None] * k
    i = np.clip(g, 0, k - 2)
    rows = np.arange(m)[:, None]
    a, b = pts[rows, i], pts[rows, i + 1]
    ca, cb = cum[rows, i], cum[rows, i + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(cb > ca, (u - ca) / (cb - ca), 0.0)
    return a + np.clip(f, 0.0, 1.0)[..., None] * (b - a)


def curve_samples(curve: Curve, lo: np.ndarray, hi: np.ndarray,
                  samples: int = CURVE_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """``samples`` + 1 uniform parameters (m, samples+1) of each row's curve over [lo, hi] and
    the positions there (m, samples+1, 3): the start of :func:`nearest_on_curve`."""
    grid = lo[:, None] + np.linspace(0.0, 1.0, samples + 1)[None, :] * (hi - lo)[:, None]
    return grid, curve(grid)[0]


def nearest_on_curve(curve: Curve, sampled: tuple[np.ndarray, np.ndarray], lo: np.ndarray,
                     hi: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance of points x (m, q, 3) to the curve of their row over [lo, hi] (m,) and the
    curve parameter of the point it is measured to: nearest of the samples ``sampled``
    (:func:`curve_samples`), then Newton steps on g(t) = (p(t) - x).p'(t) (g' = |p'|^2 +
    (p - x).p'', kept >= |p'|^2 / 2), clipped to the interval; the distance is the better of
    the sample's and the refined point's (an upper bound of the distance to the curve)."""
    grid, pos = sampled
    m, q = x.shape[:2]
    best_d = np.empty((m, q))
    best_s = np.empty((m, q))
    per = max(1, BUDGET // max(q * grid.shape[1], 1))
    for r0 in range(0, m, per):
        r = slice(r0, r0 + per)
        diff = x[r, :, None, :] - pos[r, None, :, :]
        d2 = np.einsum("mqpi,mqpi->mqp", diff, diff)
        k = np.argmin(d2, axis=2)
        best_d[r] = np.sqrt(np.take_along_axis(d2, k[..., None], axis=2)[..., 0])
        best_s[r] = np.take_along_axis(grid[r], k, axis=1)
    s = best_s.copy()
    for _ in range(NEWTON_STEPS):
        p, d1, d2 = curve(s)
        rel = p - x
        g = np.einsum("mqi,mqi->mq", rel, d1)
        g11 = np.einsum("mqi,mqi->mq", d1, d1)
        gp = np.maximum(g11 + np.einsum("mqi,mqi->mq", rel, d2), 0.5 * g11)
        s = np.clip(s - g / gp, lo[:, None], hi[:, None])
    d = np.linalg.norm(curve(s)[0] - x, axis=2)
    better = d < best_d
    return np.where(better, d, best_d), np.where(better, s, best_s)


def batches(sizes: np.ndarray, per_row: int, budget: int = BUDGET) -> list[np.ndarray]:
    """Row indices in batches of similar ``sizes`` (within a factor 1.25, so padding to the
    largest costs little), each at most ``budget`` rows x ``per_row`` x size."""
    order = np.argsort(sizes, kind="stable")
    bucket = np.floor(np.log(np.maximum(sizes[order], 1)) / np.log(1.25)).astype(int)
    out = []
    for rows in np.split(order, np.flatnonzero(np.diff(bucket)) + 1):
        if not rows.size:
            continue
        per = max(1, budget // (per_row * int(sizes[rows].max())))
        out += [rows[lo:lo + per] for lo in range(0, rows.size, per)]
    return out
