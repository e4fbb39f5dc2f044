"""The predicted part of one law: the deflected tool's envelope (:mod:`feedopt.part.envelope`)
on wall and floor dexels every :data:`DEXEL_SPACING` of the path, next to the surface location
error of the same samples (:mod:`feedopt.schedule.surface`)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from feedopt.part.envelope import DeflectionTable, SweptTool, floor_envelope, wall_envelope
from feedopt.schedule.deflection import DeflectionModel
from feedopt.schedule.surface import SurfaceErrors, wall_sides

#: Arc length between dexels [m] (the CMM's point spacing along a wall).
DEXEL_SPACING = 0.5e-3
#: Floor dexels across the cut, as fractions of the radius (0 = the path's centre line).
FLOOR_OFFSETS = np.linspace(-0.9, 0.9, 7)
#: Angular step of the deflection table the envelope interpolates [rad].
TABLE_STEP = math.radians(1.0)
#: Dexels per block (one deflection table per block).
_BLOCK = 512


@dataclass(frozen=True)
class PredictedPart:
    """Walls and floor of the part one law leaves, per dexel (material left > 0, [m]).

    Attributes
    ----------
    sample : (B,) path sample of each dexel; s : (B,) its arc length [m]; segment : (B,)
    wall : (B, 2, H) envelope wall error per side (left, right) and height (NaN: no wall)
    heights : (B, H) heights above the tip [m]
    floor : (B, F) envelope floor error at ``offsets`` (F,) [m] across the cut
    sle_wall : (B, 2, H), sle_floor : (B,) the surface location error at the same samples
    """

    sample: np.ndarray
    s: np.ndarray
    segment: np.ndarray
    wall: np.ndarray
    heights: np.ndarray
    floor: np.ndarray
    offsets: np.ndarray
    sle_wall: np.ndarray
    sle_floor: np.ndarray

    @property
    def centre_floor(self) -> np.ndarray:
        """(B,) floor error on the path's centre line [m]."""
        return self.floor[:, int(np.argmin(np.abs(self.offsets)))]


def swept_tool(model: DeflectionModel, centres: np.ndarray, s: np.ndarray) -> SweptTool:
    """The :class:`SweptTool` of a run's deflection model, tip positions and arc lengths."""
    e = model.engagement
    tool = model.tool
    return SweptTool(centres=centres, frames=model.frames, s=s, cutting=e.exit > e.entry,
                     radius=tool.diameter / 2.0, pitch=tool.pitch,
                     lag_rate=2.0 * math.tan(tool.helix) / tool.diameter)


def deflection_table(model: DeflectionModel, first: int, last: int,
                     c: np.ndarray) -> DeflectionTable:
    """d_k(psi) of samples ``first .. last - 1`` at feeds per tooth ``c`` (n,) on a uniform
    grid over one pitch."""
    pitch = model.tool.pitch
    m = max(8, math.ceil(pitch / TABLE_STEP))
    grid_model = dataclasses.replace(model, angles=np.arange(m) * (pitch / m))
    idx = np.arange(first, last)
    split, row = grid_model.forces(idx)
    cr = model.compliance[first:last] @ model.frames[first:last]
    a = np.einsum("kij,kmj->kmi", cr, split.cutting[row])
    b = np.einsum("kij,kmj->kmi", cr, split.edge[row])
    return DeflectionTable(first, c[first:last, None, None] * a + b, pitch)


def dexel_samples(s: np.ndarray, cutting: np.ndarray, spacing: float = DEXEL_SPACING
                  ) -> np.ndarray:
    """Cutting samples about ``spacing`` apart in arc length."""
    bins = np.floor(s / spacing).astype(np.int64)
    first = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
    return first[cutting[first]]


def predict_part(model: DeflectionModel, centres: np.ndarray, s: np.ndarray,
                 segment: np.ndarray, feed: np.ndarray, surface: SurfaceErrors,
                 ) -> PredictedPart:
    """The part the feed ``feed`` [m/s] at the samples leaves (module docstring)."""
    tool = swept_tool(model, centres, s)
    c = np.asarray(feed, dtype=float) / model.feed_per_unit_c
    dexels = dexel_samples(s, tool.cutting)
    h = surface.heights.shape[1]
    wall = np.full((dexels.size, 2, h), np.nan)
    floor = np.full((dexels.size, FLOOR_OFFSETS.size), np.nan)
    sides = wall_sides(model, dexels)
    for start in range(0, dexels.size, _BLOCK):
        b = slice(start, start + _BLOCK)
        d = dexels[b]
        first = int(np.searchsorted(s, s[d[0]] - tool.radius, side="left"))
        last = int(np.searchsorted(s, s[d[-1]] + tool.radius, side="right"))
        table = deflection_table(model, first, last, c)
        largest = float(np.max(np.linalg.norm(table.values, axis=2)))
        reach = tool.radius * math.sin(math.acos(max(-1.0, 1.0 - 2.2 * largest / tool.radius)))
        for j, side in enumerate((1, -1)):
            has = sides[b, j]
            if has.any():
                wall[start + np.flatnonzero(has), j] = wall_envelope(
                    tool, table, d[has], side, surface.heights[d[has]], reach)
        floor[b] = floor_envelope(tool, table, d, FLOOR_OFFSETS * tool.radius)
    return PredictedPart(sample=dexels, s=s[dexels], segment=segment[dexels], wall=wall,
                         heights=surface.heights[dexels], floor=floor, offsets=FLOOR_OFFSETS,
                         sle_wall=surface.wall[dexels], sle_floor=surface.floor[dexels])
