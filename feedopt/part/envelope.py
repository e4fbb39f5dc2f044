"""The machined walls and floor as the envelope of the deflected cutting edges, on dexels.

A dexel is a line through a point of a nominal surface along its normal (Van Hook, "Real-time
shaded NC milling display", SIGGRAPH 1986; here one dexel per measured point, like a CMM
probe's): the machined surface on it is the furthest point the cutting edges reach. The tool
is swept along the path samples; at sample k its centre is c_k, displaced by the deflection
d_k(psi) of the instant psi (rotation of tooth 1) at which an edge passes the dexel:

* **wall dexel** at sample i, height z_j, side sigma (+1 left, -1 right), through the nominal
  wall point P = c_i + sigma R y_i along n = sigma y_i (into the material): the undeflected
  rim of sample k crosses it at t0 = -v.n + sqrt((v.n)^2 - |v|^2 + R^2), v = P - c_k, where
  the edge is at immersion phi (u = (v + t0 n) / R = sin(phi) x_k + cos(phi) y_k); the edge at
  height z_j is there when psi = phi + lag_j (mod the pitch), and the rim translated by
  D = d_k(psi) crosses at t0 + (D.u) / (u.n) (first order in |D| / R). The wall on the dexel
  is the furthest reach over the samples k within the window where the rim can still reach
  it, ``e = -max_k t`` (material left > 0, as :mod:`feedopt.schedule.surface`).
* **floor dexel** at sample i, lateral offset lambda: Q = c_i + lambda y_i; every sample whose
  disc covers Q sweeps it with the end edge at phi = its polar angle about c_k, i.e. at
  psi = phi (mod the pitch), the tip at ``D.z``; the floor is the deepest pass,
  ``e = min_k D.z``.

With D the same at every instant this gives e = -sigma D.y on the walls and D.z on the floor
(the surface location error of :mod:`feedopt.schedule.surface`); with D varying over the
revolution it adds what that leaves out: the neighbouring passes of the edges (a wall point
is also swept just before and after the instant the edge is normal to it) and the floor
across the slot's width. Deflections between the uniform angles are interpolated linearly.

Valid for 3-axis cuts at one depth at a time: only cutting samples whose tip is at the
dexel's sample's height (within :data:`SAME_LEVEL`) sweep it; a later pass over the same
surface (a finishing pass of a pocket) is not combined with this one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Neighbouring samples whose tip is within this height of the dexel's sample sweep it [m].
SAME_LEVEL = 1e-5
#: Dexels per chunk (bounds the (dexels, window, heights, 3) temporaries).
_CHUNK = 32
#: Most fixed-point steps of the deflected rim's crossing with a wall dexel, and the change of
#: the crossing [m] below which it has settled (:func:`_wall_chunk`).
_CROSSING_ITERATIONS = 16
_CROSSING_TOL = 1e-10


@dataclass(frozen=True)
class SweptTool:
    """The tool along the path as the envelope sees it (base frame, SI).

    Attributes
    ----------
    centres : (n, 3) tool tip positions; frames : (n, 3, 3) force-model frames (x feed,
    y left, z tool axis); s : (n,) arc length [m]; cutting : (n,) the sample cuts;
    radius : R [m]; pitch : tooth pitch [rad]; lag_rate : helix lag per height [rad/m].
    """

    centres: np.ndarray
    frames: np.ndarray
    s: np.ndarray
    cutting: np.ndarray
    radius: float
    pitch: float
    lag_rate: float


@dataclass(frozen=True)
class DeflectionTable:
    """d_k(psi) of some samples at knots over one pitch, linear between knots: ``values``
    (r, m, 3) [m], base frame, row ``row_of[k - first]`` for sample k (default: the samples
    ``first .. first + r - 1`` in order). ``knots`` (r, m) per row, increasing from 0 to the
    pitch (both ends, the same value: periodic), e.g. a grid joined with both sides of every
    angle where the force jumps, so that no interval straddles a jump; None: ``m`` uniform
    angles ``j pitch / m``."""

    first: int
    values: np.ndarray
    pitch: float
    row_of: np.ndarray | None = None
    knots: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.knots is not None:  # rows 2 pitches apart in one sorted array, built once
            keys = (np.arange(self.knots.shape[0])[:, None] * (2.0 * self.pitch)
                    + self.knots).ravel()
            object.__setattr__(self, "_keys", keys)

    def at(self, k: np.ndarray, psi: np.ndarray) -> np.ndarray:
        """Deflections (..., 3) of samples ``k`` at rotation angles ``psi`` (same shape),
        linear between knots, periodic over the pitch."""
        rows = k - self.first if self.row_of is None else self.row_of[k - self.first]
        m = self.values.shape[1]
        if self.knots is None:
            pos = np.mod(psi, self.pitch) * (m / self.pitch)
            i0 = np.floor(pos).astype(np.intp)
            w = (pos - i0)[..., None]
            i0 %= m
            lo, hi = rows * m + i0, rows * m + np.where(i0 + 1 == m, 0, i0 + 1)
        else:
            keys = self._keys
            q = rows * (2.0 * self.pitch) + np.mod(psi, self.pitch)
            hi = np.clip(np.searchsorted(keys, q, side="right"), rows * m + 1, rows * m + m - 1)
            lo = hi - 1
            width = keys[hi] - keys[lo]
            w = (np.where(width > 0, (q - keys[lo]) / np.where(width > 0, width, 1.0), 0.0)
                 )[..., None]
        flat = self.values.reshape(-1, 3)  # one gather per end of the interval
        a, b = np.take(flat, lo, axis=0), np.take(flat, hi, axis=0)
        return a + w * (b - a)


def _windows(tool: SweptTool, dexels: np.ndarray, reach: float) -> tuple[np.ndarray, ...]:
    """Per dexel the neighbour samples within ``reach`` of arc length, padded: (B, W)
    sample indices and a validity mask (cutting, at the dexel's level)."""
    lo = np.searchsorted(tool.s, tool.s[dexels] - reach, side="left")
    hi = np.searchsorted(tool.s, tool.s[dexels] + reach, side="right")
    width = int(np.max(hi - lo))
    k = lo[:, None] + np.arange(width)[None, :]
    ok = k < hi[:, None]
    k = np.minimum(k, tool.s.size - 1)
    axis = tool.frames[dexels, :, 2]
    level = np.einsum("bwi,bi->bw", tool.centres[k] - tool.centres[dexels][:, None], axis)
    ok &= tool.cutting[k] & (np.abs(level) <= SAME_LEVEL)
    return k, ok


def _in_plane(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    return v - np.einsum("...i,...i->...", v, axis)[..., None] * axis


def wall_envelope(tool: SweptTool, table: DeflectionTable, dexels: np.ndarray, side: int,
                  heights: np.ndarray, reach: float) -> np.ndarray:
    """(B, H) wall error [m] (material left > 0) on the wall dexels of samples ``dexels`` at
    ``heights`` (B, H) above the tip, side +1 (left, +y) or -1 (right); NaN where no cutting
    sample reaches the dexel. ``reach``: arc length either side searched [m]."""
    out = np.full(heights.shape, np.nan)
    for start in range(0, dexels.size, _CHUNK):
        b = slice(start, start + _CHUNK)
        out[b] = _wall_chunk(tool, table, dexels[b], side, heights[b], reach)
    return out


def _crossing(v: np.ndarray, n: np.ndarray, r: float) -> tuple[np.ndarray, ...]:
    """Where the line ``v + t n`` (v from a rim's centre, in-plane) leaves the rim of radius r:
    t, the unit radial u there and whether it meets the rim at all."""
    vn = np.einsum("...i,...i->...", v, n)
    disc = vn * vn - np.einsum("...i,...i->...", v, v) + r * r
    t = -vn + np.sqrt(np.maximum(disc, 0.0))
    return t, (v + t[..., None] * n) / r, disc >= 0.0


def _wall_chunk(tool, table, dexels, side, heights, reach):
    """The exact crossing of the deflected rim: the edge that reaches the dexel is at the
    angle phi' of the crossing about the displaced centre c_k + D, and D is taken at that
    edge's instant, so D and phi' are found together: a fixed point, iterated on the
    crossings that still move by more than :data:`_CROSSING_TOL` (most settle in two steps;
    near a jump of the force, where D changes fast with the angle, it takes up to ten)."""
    r = tool.radius
    k, ok = _windows(tool, dexels, reach)
    shape = (dexels.size, k.shape[1], heights.shape[1])
    axis = tool.frames[dexels, :, 2]
    n = np.broadcast_to(side * tool.frames[dexels, :, 1][:, None, None, :], shape + (3,))
    point = tool.centres[dexels][:, None, None, :] + r * n
    v = _in_plane(point - tool.centres[k][:, :, None, :], axis[:, None, None, :])
    flat = _Flat(v.reshape(-1, 3), n.reshape(-1, 3),
                 np.broadcast_to(axis[:, None, None, :], shape + (3,)).reshape(-1, 3),
                 np.broadcast_to(tool.frames[k, :, 0][:, :, None], shape + (3,)).reshape(-1, 3),
                 np.broadcast_to(tool.frames[k, :, 1][:, :, None], shape + (3,)).reshape(-1, 3),
                 np.broadcast_to(k[:, :, None], shape).ravel(),
                 np.broadcast_to(tool.lag_rate * heights[:, None, :], shape).ravel())
    t, meets = _settle(flat, table, r)
    t = np.where(ok[..., None] & meets.reshape(shape), t.reshape(shape), -np.inf)
    best = _peak(t, tool.s[k])
    return np.where(np.isfinite(best), -best, np.nan)


@dataclass(frozen=True)
class _Flat:
    """Per crossing (flattened): v from the rim's centre, the dexel's direction n, the tool
    axis, the sample's feed and left axes, its index and the helix lag of the height."""

    v: np.ndarray
    n: np.ndarray
    axis: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    k: np.ndarray
    lag: np.ndarray


def _settle(f: _Flat, table: DeflectionTable, r: float) -> tuple[np.ndarray, np.ndarray]:
    """The fixed point of :func:`_wall_chunk`: t along the dexel and whether the rim meets it."""
    d = np.zeros_like(f.v)
    t_prev = np.full(f.k.size, np.nan)
    active = np.arange(f.k.size)
    for _ in range(_CROSSING_ITERATIONS):
        v = f.v[active] - _in_plane(d[active], f.axis[active])
        t, u, _ = _crossing(v, f.n[active], r)
        phi = np.arctan2(np.einsum("ij,ij->i", u, f.fx[active]),
                         np.einsum("ij,ij->i", u, f.fy[active]))
        d[active] = table.at(f.k[active], phi + f.lag[active])
        moving = ~(np.abs(t - t_prev[active]) <= _CROSSING_TOL)
        t_prev[active] = t
        active = active[moving]
        if not active.size:
            break
    t, _, meets = _crossing(f.v - _in_plane(d, f.axis), f.n, r)
    return t, meets


def _peak(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Max over axis 1 of ``t`` (B, W, H), refined between samples by the parabola through
    the best sample and its nearest valid neighbours at their arc lengths ``x`` (B, W) (the
    reach is smooth in the centre's position there; without it the wall falls short by up to
    ds^2 / 8R between two samples)."""
    b, w, _ = t.shape
    finite = np.isfinite(t)
    idx = np.arange(w)[None, :, None]
    before = np.maximum.accumulate(np.where(finite, idx, -1), axis=1)
    after = np.minimum.accumulate(np.where(finite, idx, w)[:, ::-1], axis=1)[:, ::-1]
    j = np.argmax(t, axis=1)[:, None, :]
    j0 = np.take_along_axis(before, np.maximum(j - 1, 0), axis=1)
    j0 = np.where(j > 0, j0, -1)
    j2 = np.take_along_axis(after, np.minimum(j + 1, w - 1), axis=1)
    j2 = np.where(j < w - 1, j2, w)
    ok = ((j0 >= 0) & (j2 < w))[:, 0]
    j0, j2 = np.clip(j0, 0, w - 1), np.clip(j2, 0, w - 1)
    xs = np.broadcast_to(x[:, :, None], t.shape)

    def at(k):
        return (np.take_along_axis(t, k, axis=1)[:, 0], np.take_along_axis(xs, k, axis=1)[:, 0])

    (t0, x0), (t1, x1), (t2, x2) = at(j0), at(j), at(j2)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        d0, d2 = x0 - x1, x2 - x1
        s0, s2 = (t0 - t1) / d0, (t2 - t1) / d2
        q = (s0 - s2) / (d0 - d2)
        p = s0 - q * d0
        apex = -p / (2.0 * q)
        lift = np.where(ok & (q < 0) & (apex > d0) & (apex < d2), -p * p / (4.0 * q), 0.0)
    return t1 + np.nan_to_num(lift, nan=0.0, posinf=0.0, neginf=0.0)


def floor_envelope(tool: SweptTool, table: DeflectionTable, dexels: np.ndarray,
                   offsets: np.ndarray) -> np.ndarray:
    """(B, F) floor error [m] (material left > 0) on the floor dexels of samples ``dexels`` at
    lateral offsets ``offsets`` (F,) [m] along y (|offset| < R); NaN where none sweeps it."""
    out = np.full((dexels.size, offsets.size), np.nan)
    for start in range(0, dexels.size, _CHUNK):
        b = slice(start, start + _CHUNK)
        out[b] = _floor_chunk(tool, table, dexels[b], offsets)
    return out


def _floor_chunk(tool, table, dexels, offsets):
    k, ok = _windows(tool, dexels, tool.radius)
    axis = tool.frames[dexels, :, 2][:, None, None, :]
    y = tool.frames[dexels, :, 1]
    q = tool.centres[dexels][:, None, :] + offsets[None, :, None] * y[:, None, :]  # (B, F, 3)
    v = _in_plane(q[:, None, :, :] - tool.centres[k][:, :, None, :], axis)  # (B, W, F, 3)
    inside = ok[..., None] & (np.einsum("bwfi,bwfi->bwf", v, v) < tool.radius ** 2)
    fx, fy = tool.frames[k, :, 0][:, :, None], tool.frames[k, :, 1][:, :, None]
    phi = np.arctan2(np.einsum("bwfi,bwfi->bwf", v, np.broadcast_to(fx, v.shape)),
                     np.einsum("bwfi,bwfi->bwf", v, np.broadcast_to(fy, v.shape)))
    d = table.at(np.broadcast_to(k[:, :, None], phi.shape), phi)
    dz = np.einsum("bwfi,bwfi->bwf", d, np.broadcast_to(axis, d.shape))
    dz = np.where(inside, dz, np.inf)
    best = dz.min(axis=1)
    return np.where(np.isfinite(best), best, np.nan)
