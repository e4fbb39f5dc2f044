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
_CHUNK = 64


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
    """d_k(psi) of samples ``first .. first + values.shape[0]`` on a uniform grid of ``m``
    angles over one pitch: ``values`` (k, m, 3) [m], base frame."""

    first: int
    values: np.ndarray
    pitch: float

    def at(self, k: np.ndarray, psi: np.ndarray) -> np.ndarray:
        """Deflections (..., 3) of samples ``k`` at rotation angles ``psi`` (same shape),
        linear between grid angles, periodic over the pitch."""
        m = self.values.shape[1]
        pos = np.mod(psi, self.pitch) * (m / self.pitch)
        i0 = np.floor(pos).astype(np.intp)
        w = (pos - i0)[..., None]
        i0 %= m
        rows = k - self.first
        return (1.0 - w) * self.values[rows, i0] + w * self.values[rows, (i0 + 1) % m]


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


def _wall_chunk(tool, table, dexels, side, heights, reach):
    r = tool.radius
    k, ok = _windows(tool, dexels, reach)
    axis = tool.frames[dexels, :, 2][:, None, :]
    n = side * tool.frames[dexels, :, 1][:, None, :]  # (B, 1, 3), into the material
    point = tool.centres[dexels][:, None, :] + r * n
    v = _in_plane(point - tool.centres[k], axis)  # (B, W, 3)
    vn = np.einsum("bwi,bwi->bw", v, np.broadcast_to(n, v.shape))
    disc = vn * vn - np.einsum("bwi,bwi->bw", v, v) + r * r
    ok = ok & (disc >= 0.0)
    t0 = -vn + np.sqrt(np.maximum(disc, 0.0))
    u = (v + t0[..., None] * n) / r
    fx, fy = tool.frames[k, :, 0], tool.frames[k, :, 1]
    phi = np.arctan2(np.einsum("bwi,bwi->bw", u, fx), np.einsum("bwi,bwi->bw", u, fy))
    psi = phi[:, :, None] + tool.lag_rate * heights[:, None, :]  # (B, W, H)
    d = table.at(np.broadcast_to(k[:, :, None], psi.shape), psi)  # (B, W, H, 3)
    un = np.einsum("bwi,bwi->bw", u, np.broadcast_to(n, u.shape))
    t = t0[..., None] + np.einsum("bwhi,bwi->bwh", d, u) / un[..., None]
    t = np.where(ok[..., None], t, -np.inf)
    best = t.max(axis=1)
    return np.where(np.isfinite(best), -best, np.nan)


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
