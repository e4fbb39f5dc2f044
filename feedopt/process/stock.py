"""Stock model for 3-axis milling: a Z-map of the workpiece and the engagement it gives.

The workpiece is a height field (Z-map) in its frame W: one column of material per cell of a
regular grid, from the bottom ``z0`` up to a stored top height. This is the classic Z-map /
height-field NC simulation (Anderson 1978, "Detection of milling tool collision and
interference"; Choi & Jerard, "Sculptured Surface Machining", 1998, ch. on Z-map
verification), valid while the tool axis stays along +z of W (3-axis milling, no undercuts).

A flat end mill of radius R is swept along a sampled path. Before sample i removes its
material, the material still present in front of the cutter gives the engagement of sample i
in the force-model frame of :mod:`feedopt.process.forces` (x = feed, y = z x x, z = tool axis
into the spindle = +z of W), angles as in :mod:`feedopt.process.engagement` (Altintas: phi
clockwise from +y seen from the spindle, a tooth at phi is at ``R (sin phi x + cos phi y)``,
the leading half is phi in [0, pi]). Up milling (material on the +y side, left of the feed)
gives ``[0, arccos(1 - ae / R)]``, down milling ``[pi - arccos(1 - ae / R), pi]``.

Resolution and memory
---------------------
Cell size h (default 0.25 mm); heights are float32, so the Z-map takes 4 bytes per cell
(a 200 x 100 mm box at 0.25 mm: 800 x 400 cells, 1.28 MB). See :func:`angle_error_bound`
for the accuracy of the angles: about (h / sqrt 2) / (R sin phi) rad where the material
boundary crosses the cutter rim (1.1 deg at phi = 90 deg for h = 0.25 mm, R = 9.525 mm).

Removal (the swept-area choice)
-------------------------------
Sample i removes the swept capsule from sample i-1 to sample i (every cell whose centre is
within R of that segment in xy is lowered to the tool tip height interpolated along the
segment, never below z0); sample 0 removes its disc. Using segments instead of discs leaves
no scallops between samples and lets the path be curved and coarsely sampled. Python loops
over samples only; each step is numpy work on the window of cells under the capsule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.engagement import Engagement
from feedopt.process.tool import Tool
from feedopt.units import MM

__all__ = [
    "DEFAULT_CELL",
    "FlatEndMill",
    "StockEngagement",
    "ZMap",
    "angle_error_bound",
    "snap_angle",
    "sweep",
]

#: Default Z-map cell size [m].
DEFAULT_CELL = 0.25 * MM
# Material thinner than this above the tool tip is not material (float32 heights round to
# ~4e-9 m at |z| = 0.05 m, far below it).
_MIN_DEPTH = 1e-6


@dataclass(frozen=True)
class FlatEndMill:
    """A flat end mill for the stock sweep, SI units.

    Attributes
    ----------
    radius : float
        Cutter radius R [m].
    flute_length : float
        Length of cut [m]: the reported axial depth is clipped to it (deeper material is
        flagged ``beyond_flutes``).
    """

    radius: float
    flute_length: float

    def __post_init__(self) -> None:
        for name in ("radius", "flute_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"end mill {name} must be > 0 mm, got {value / MM:g} mm")

    @classmethod
    def from_tool(cls, tool: Tool) -> FlatEndMill:
        """The end mill of a process :class:`~feedopt.process.tool.Tool`."""
        return cls(radius=tool.diameter / 2.0, flute_length=tool.flute_length)


class ZMap:
    """Height field of the workpiece in its frame W (mutable: :func:`sweep` cuts it).

    Cell (i, j) covers ``x0 + [i, i+1) h`` by ``y0 + [j, j+1) h``; its column of material
    runs from ``bottom`` to ``heights[i, j]`` (empty when ``heights <= bottom``). Material
    outside the grid does not exist.

    Parameters
    ----------
    heights : (nx, ny) array
        Top of material per cell [m], stored as float32 (4 bytes per cell).
    origin : (x0, y0) [m]
        Lower corner of the grid.
    cell : float
        Cell size h [m].
    bottom : float
        Bottom z0 of the workpiece [m].
    """

    def __init__(
        self, heights: np.ndarray, origin: tuple[float, float], cell: float, bottom: float
    ) -> None:
        h = np.array(heights, dtype=np.float32)
        if h.ndim != 2 or h.size == 0:
            raise InputError(f"Z-map heights must be a non-empty 2-D array, got shape {h.shape}")
        if not (math.isfinite(cell) and cell > 0):
            raise InputError(f"Z-map cell size must be > 0 mm, got {cell / MM:g} mm")
        if not all(math.isfinite(v) for v in (*origin, bottom)) or not np.all(np.isfinite(h)):
            raise InputError("Z-map origin, bottom and heights must be finite")
        self.heights = np.maximum(h, np.float32(bottom))
        self.origin = (float(origin[0]), float(origin[1]))
        self.cell = float(cell)
        self.bottom = float(bottom)

    @classmethod
    def box(
        cls,
        x0: float,
        x1: float,
        y0: float,
        y1: float,
        z0: float,
        z1: float,
        cell: float = DEFAULT_CELL,
    ) -> ZMap:
        """A box of stock ``[x0, x1] x [y0, y1] x [z0, z1]`` [m] on cells of size ``cell``.

        The x and y extents are rounded up to whole cells (to ``x0 + nx h``, ``y0 + ny h``).
        """
        if not (x1 > x0 and y1 > y0 and z1 > z0):
            raise InputError(
                "stock box needs x1 > x0, y1 > y0 and z1 > z0, got "
                f"x {x0 / MM:g}..{x1 / MM:g}, y {y0 / MM:g}..{y1 / MM:g}, "
                f"z {z0 / MM:g}..{z1 / MM:g} mm"
            )
        if not (math.isfinite(cell) and cell > 0):
            raise InputError(f"Z-map cell size must be > 0 mm, got {cell / MM:g} mm")
        nx = max(1, math.ceil((x1 - x0) / cell - 1e-9))
        ny = max(1, math.ceil((y1 - y0) / cell - 1e-9))
        return cls(np.full((nx, ny), z1, dtype=np.float32), (x0, y0), cell, z0)

    @property
    def shape(self) -> tuple[int, int]:
        """Number of cells (nx, ny)."""
        return self.heights.shape  # type: ignore[return-value]

    @property
    def nbytes(self) -> int:
        """Memory of the height field [bytes] (4 per cell)."""
        return int(self.heights.nbytes)

    @property
    def x_centres(self) -> np.ndarray:
        """(nx,) x of the cell centres [m]."""
        return self.origin[0] + (np.arange(self.shape[0]) + 0.5) * self.cell

    @property
    def y_centres(self) -> np.ndarray:
        """(ny,) y of the cell centres [m]."""
        return self.origin[1] + (np.arange(self.shape[1]) + 0.5) * self.cell

    def volume(self) -> float:
        """Volume of material [m^3]."""
        return float(np.sum(self.heights.astype(float) - self.bottom)) * self.cell**2

    def copy(self) -> ZMap:
        """An independent copy."""
        return ZMap(self.heights.copy(), self.origin, self.cell, self.bottom)


@dataclass(frozen=True)
class StockEngagement:
    """Engagement found in the stock at ``n`` path samples.

    Attributes
    ----------
    engagement : Engagement
        Entry/exit [rad] and axial depth [m] for the force model. A sample in air has
        ``entry == exit == 0`` (not cutting, as :class:`Engagement` defines it) and, because
        :class:`Engagement` needs a positive depth, the flute length as its axial depth.
    in_air : (n,) bool
        No material in front of the cutter.
    axial_depth : (n,) float
        Axial depth of cut [m], 0 in air (top of the material in front minus the tool tip,
        or minus the bottom when the tip is below it; clipped to the flute length).
    beyond_flutes : (n,) bool
        Material in front of the cutter reaches above the flutes (shank contact).
    lateral : (n, 2) float
        Lateral extent [y_lo, y_hi] [m] of the material in front, in the force-model frame,
        clipped to [-R, R]; NaN in air. ``entry = arccos(y_hi / R)``,
        ``exit = arccos(y_lo / R)``.
    """

    engagement: Engagement
    in_air: np.ndarray
    axial_depth: np.ndarray
    beyond_flutes: np.ndarray
    lateral: np.ndarray


def snap_angle(cell: float, radius: float) -> float:
    """Angle [rad] from 0 (or pi) inside which a material end is reported at 0 (or pi).

    Material within ``sqrt(2) h`` (laterally) of the rim side of the cutter is taken to reach
    it: a grid of spacing h cannot resolve a boundary tangent to the rim more finely. Equals
    ``arccos(1 - sqrt(2) h / R)`` (0.23 rad = 13 deg for h = 0.25 mm, R = 9.525 mm); there the
    chip thickness c sin(phi) is below 0.23 c.
    """
    return math.acos(max(-1.0, 1.0 - math.sqrt(2.0) * cell / radius))


def angle_error_bound(angle: float | np.ndarray, cell: float, radius: float) -> np.ndarray:
    """Bound [rad] on the error of an entry or exit angle ``angle`` [rad] from the Z-map.

    For a straight cut the reported material boundary is within ``delta = h / sqrt 2``
    laterally of the true one (half the largest projected cell width), so the angle, which is
    ``arccos(y / R)`` of the lateral position y, is within
    ``max |arccos(cos(angle) +- delta / R) - angle|``: about ``delta / (R sin(angle))`` where
    the boundary crosses the rim, at most ``sqrt(2 delta / R)`` where it is tangent. Within
    :func:`snap_angle` of 0 or pi the end is reported at 0 or pi, so the bound there is the
    snap angle. A boundary across the feed (a wall ahead) adds the lookahead (at most
    ``sqrt 2 h``, see :func:`sweep`) divided by about ``R sin(angle)``.
    """
    phi = np.asarray(angle, dtype=float)
    delta = cell / math.sqrt(2.0)
    c = np.cos(phi)
    err = np.maximum(
        np.abs(np.arccos(np.clip(c + delta / radius, -1.0, 1.0)) - phi),
        np.abs(np.arccos(np.clip(c - delta / radius, -1.0, 1.0)) - phi),
    )
    snap = snap_angle(cell, radius)
    in_snap = (phi <= snap) | (phi >= math.pi - snap)
    return np.where(in_snap, np.maximum(err, snap), err)


def _feed_directions(tangents: np.ndarray, n: int) -> np.ndarray:
    t = np.asarray(tangents, dtype=float)
    if t.shape != (n, 3) or not np.all(np.isfinite(t)):
        raise InputError(f"tangents must be a finite (n, 3) array like positions, got {t.shape}")
    xy = t[:, :2]
    norm = np.linalg.norm(xy, axis=1)
    bad = norm < 1e-9 * np.maximum(np.linalg.norm(t, axis=1), 1e-300)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"tangent at sample {i} runs along the tool axis (z): a 3-axis stock sweep needs "
            "a feed direction across it"
        )
    return xy / norm[:, None]


def sweep(
    stock: ZMap,
    tool: FlatEndMill,
    positions: np.ndarray,
    tangents: np.ndarray,
    lookahead: float | None = None,
) -> StockEngagement:
    """Sweep a flat end mill along a path through ``stock`` (cut in place) and report engagement.

    At sample i, before its material is removed, the material in front of the cutter is the
    material still present (top above the tool tip by > 1 um) in the leading half of the
    cutter (cells with ``dx >= 0`` along the feed x, ``|dy| <= R`` across it) up to
    ``lookahead / sin(phi)`` beyond the rim along the feed at the lateral offset dy of tooth
    angle phi (capped at its value at :func:`snap_angle`, about 1.5 mm for h = 0.25 mm,
    R = 9.525 mm), less the step ds from sample i-1, never past the end of the path. The
    lookahead gives the crescent in front of the rim a thickness of at least ``lookahead``
    normal to the rim, so every part of the rim shows its material even when the samples
    are closer than the cells (with steps above the cap it is zero). Its price: a wall ahead
    is seen up to that distance early (at most ``lookahead`` normal to the rim).

    Each material cell is attributed to the tooth that meets it, the one at the same lateral
    offset y (force-model frame): phi = arccos(y / R), exact for a straight feed. One interval
    per sample: the hull of the engaged angles, ``entry = arccos(y_hi / R)``,
    ``exit = arccos(y_lo / R)`` with [y_lo, y_hi] the lateral extent of the material (cell
    centres widened by half the projected cell width; an end within sqrt(2) h of the rim is
    put on the rim, see :func:`snap_angle`). Two separate contacts (e.g. at an inside
    corner with a small radial depth) are reported as their hull.

    Parameters
    ----------
    stock : ZMap
        The workpiece, modified in place (use ``stock.copy()`` to keep it).
    tool : FlatEndMill
    positions : (n, 3) array
        Tool tip in W [m], in cutting order.
    tangents : (n, 3) array
        Path tangents in W (their xy part is the feed direction; need not be unit).
    lookahead : float, optional
        Crescent thickness normal to the rim [m], default ``sqrt(2) h``.

    Returns
    -------
    StockEngagement
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise InputError(f"positions must be a finite (n, 3) array [m], got shape {p.shape}")
    n = p.shape[0]
    feed = _feed_directions(tangents, n)
    h = stock.cell
    radius = tool.radius
    look = math.sqrt(2.0) * h if lookahead is None else float(lookahead)
    if not (math.isfinite(look) and look >= 0):
        raise InputError(f"lookahead must be >= 0 mm, got {look / MM:g} mm")
    snap = math.sqrt(2.0) * h
    look_cap = look / max(math.sin(snap_angle(h, radius)), 1e-12)

    steps = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)
    remaining = np.concatenate([np.cumsum(steps[::-1])[::-1], [0.0]]) if n else np.zeros(0)
    xc_all, yc_all = stock.x_centres, stock.y_centres
    (gx0, gy0), z0 = stock.origin, stock.bottom
    heights = stock.heights

    entry = np.zeros(n)
    exit_ = np.zeros(n)
    depth = np.zeros(n)
    in_air = np.ones(n, dtype=bool)
    beyond = np.zeros(n, dtype=bool)
    lateral = np.full((n, 2), np.nan)

    for i in range(n):
        c = p[i, :2]
        ztip = p[i, 2]
        fx, fy = feed[i]
        prev = p[i - 1] if i > 0 else p[i]
        ds = float(steps[i - 1]) if i > 0 else 0.0
        # lookahead per lateral offset y: ``look`` normal to the rim, i.e. look / sin(phi)
        # along the feed, capped at its value at the snap angle, less the step already taken,
        # never past the path end
        lam_max = min(max(0.0, look_cap - ds), float(remaining[i]))
        ahead = c + lam_max * feed[i]

        lo_x = min(c[0], prev[0], ahead[0]) - radius
        hi_x = max(c[0], prev[0], ahead[0]) + radius
        lo_y = min(c[1], prev[1], ahead[1]) - radius
        hi_y = max(c[1], prev[1], ahead[1]) + radius
        i0 = max(0, math.ceil((lo_x - gx0) / h - 0.5))
        i1 = min(stock.shape[0], math.floor((hi_x - gx0) / h - 0.5) + 1)
        j0 = max(0, math.ceil((lo_y - gy0) / h - 0.5))
        j1 = min(stock.shape[1], math.floor((hi_y - gy0) / h - 0.5) + 1)
        if i0 >= i1 or j0 >= j1:
            continue
        wx = xc_all[i0:i1, None] - c[0]
        wy = yc_all[None, j0:j1] - c[1]
        win = heights[i0:i1, j0:j1]

        # engagement from the material in front, before this sample cuts
        dx = wx * fx + wy * fy
        dy = -wx * fy + wy * fx
        half = np.sqrt(np.maximum(radius**2 - dy**2, 0.0))
        lam = np.clip(look * radius / np.maximum(half, 1e-300) - ds, 0.0, lam_max)
        front = (dx >= 0.0) & (np.abs(dy) <= radius) & (dx <= half + lam)
        floor = max(ztip, z0)
        material = front & (win > floor + _MIN_DEPTH)
        if np.any(material):
            y_m = dy[material]
            w_half = 0.5 * h * (abs(fx) + abs(fy))
            y_hi = float(y_m.max())
            y_lo = float(y_m.min())
            y_hi = radius if y_hi >= radius - snap else min(radius, y_hi + w_half)
            y_lo = -radius if y_lo <= -radius + snap else max(-radius, y_lo - w_half)
            top = float(win[material].max())
            in_air[i] = False
            entry[i] = math.acos(y_hi / radius)
            exit_[i] = math.acos(y_lo / radius)
            depth[i] = min(top - floor, tool.flute_length)
            beyond[i] = top - floor > tool.flute_length
            lateral[i] = (y_lo, y_hi)

        # remove the capsule swept from sample i-1 to sample i
        seg = c - prev[:2]
        seg_len2 = float(seg @ seg)
        ux = xc_all[i0:i1, None] - prev[0]
        uy = yc_all[None, j0:j1] - prev[1]
        if seg_len2 > 0.0:
            s = np.clip((ux * seg[0] + uy * seg[1]) / seg_len2, 0.0, 1.0)
        else:
            s = np.zeros_like(ux + uy)
        inside = (ux - s * seg[0]) ** 2 + (uy - s * seg[1]) ** 2 <= radius**2
        z_cut = np.maximum(prev[2] + s * (ztip - prev[2]), z0)
        np.copyto(win, np.minimum(win, z_cut).astype(np.float32), where=inside)

    eng = Engagement(entry, exit_, np.where(in_air, tool.flute_length, depth))
    return StockEngagement(eng, in_air, depth, beyond, lateral)
