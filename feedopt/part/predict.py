"""The predicted part of each law: the deflected tool's envelope (:mod:`feedopt.part.envelope`)
on wall and floor dexels at the samples where the part is measured
(:func:`feedopt.schedule.surface.part_samples`), next to the surface location error of the same
samples (:mod:`feedopt.schedule.surface`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.parallel import for_each_chunk
from feedopt.part.envelope import DeflectionTable, SweptTool, floor_envelope, wall_envelope
from feedopt.process.forces import critical_angles
from feedopt.schedule.deflection import DeflectionModel
from feedopt.schedule.surface import SurfaceErrors, part_samples, wall_sides

#: Floor dexels across the cut, as fractions of the radius (0 = the path's centre line).
FLOOR_OFFSETS = np.linspace(-0.9, 0.9, 7)
#: Heights of wall dexels per point along the wall (of the force model's axial slices).
WALL_HEIGHTS = 4
#: Outside a slice's entry (exit) by this much, the other side of its force jump [rad]
#: (as :mod:`feedopt.schedule.surface`).
_OUTSIDE = 1e-9
#: Angular step of the deflection table the envelope interpolates [rad].
TABLE_STEP = math.radians(2.0)
#: Dexels per block (one deflection table per block).
_BLOCK = 64


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


def window_samples(s: np.ndarray, dexels: np.ndarray, radius: float) -> np.ndarray:
    """The samples within ``radius`` of arc length of any of ``dexels`` (increasing): every
    sample whose tool can reach them (the walls' reach is less than the radius)."""
    lo = np.searchsorted(s, s[dexels] - radius, side="left")
    hi = np.searchsorted(s, s[dexels] + radius, side="right")
    counts = hi - lo
    starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
    return np.unique(starts + np.arange(int(counts.sum())))


def table_knots(model: DeflectionModel, index: np.ndarray) -> np.ndarray:
    """(k, M) increasing rotation angles over one pitch for the samples ``index``: a uniform
    grid (:data:`TABLE_STEP`), the pitch itself, and both sides of every angle where a slice
    enters or leaves the cut (:func:`feedopt.process.forces.critical_angles`: its entry
    columns are inside the cut, 1e-9 rad before is outside; its exit columns are 1e-9 rad
    inside, 2e-9 rad later is outside)."""
    pitch = model.tool.pitch
    m = max(8, math.ceil(pitch / TABLE_STEP))
    eng = model.engagement_slice(index)
    crit = critical_angles(model.tool, eng.hull_only() if eng.pieces is not None else eng,
                           model.axial_slices)
    h = crit.shape[1] // 2
    sides = np.concatenate([crit, crit[:, :h] - _OUTSIDE, crit[:, h:] + 2.0 * _OUTSIDE],
                           axis=1)
    grid = np.broadcast_to(np.arange(m + 1) * (pitch / m), (index.size, m + 1))
    return np.sort(np.concatenate([grid, np.mod(sides, pitch)], axis=1), axis=1)


def deflection_terms(model: DeflectionModel, index: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """d_k(psi) = c_k A + B of the samples ``index`` at :func:`table_knots` (k, M): A (k, M, 3)
    [m per m of feed per tooth], B (k, M, 3) [m] and the knots [rad]."""
    knots = table_knots(model, index)
    split = model.forces_at(index, np.minimum(knots, np.nextafter(model.tool.pitch, 0.0)))
    crt = np.swapaxes(model.compliance[index] @ model.frames[index], 1, 2)  # F @ (C R)^T
    return split.cutting @ crt, split.edge @ crt, knots


def predict_parts(model: DeflectionModel, centres: np.ndarray, s: np.ndarray,
                  segment: np.ndarray, feeds: dict[str, np.ndarray],
                  surfaces: dict[str, SurfaceErrors]) -> dict[str, PredictedPart]:
    """The part each feed profile of ``feeds`` ({law: (n,) [m/s]}) leaves (module docstring),
    with its surface location errors ``surfaces`` ({law: ...}). The forces of a block of
    dexels are computed once for every law; blocks run on the threads."""
    # the tool is swept at every sample: every 0.25 mm instead moved walls by up to 8 um on
    # the triangle slot (the envelope's peak is sharp next to a force jump) and 0.14 mm at a
    # pocket's corners
    tool = swept_tool(model, centres, s)
    dexels = samples = part_samples(s, tool.cutting)
    sides = wall_sides(model, samples)
    some = next(iter(surfaces.values()))
    rows = height_rows(some.heights.shape[1])
    at = {law: surface.rows_of(samples) for law, surface in surfaces.items()}
    heights = some.heights[at[next(iter(surfaces))]][:, rows]
    c = {law: np.maximum(np.asarray(f, dtype=float), 0.0) / model.feed_per_unit_c
         for law, f in feeds.items()}
    walls = {law: np.full((samples.size, 2, heights.shape[1]), np.nan) for law in feeds}
    floors = {law: np.full((samples.size, FLOOR_OFFSETS.size), np.nan) for law in feeds}

    def block(b: slice) -> int:
        d = dexels[b]
        rows = window_samples(tool.s, d, tool.radius)
        row_of = np.full(rows[-1] - rows[0] + 1, -1, dtype=np.intp)
        row_of[rows - rows[0]] = np.arange(rows.size)
        a_terms, b_terms, knots = deflection_terms(model, rows)
        for law in feeds:
            table = DeflectionTable(int(rows[0]), c[law][rows, None, None] * a_terms + b_terms,
                                    tool.pitch, row_of, knots)
            _sweep_block(tool, table, (d, sides[b], heights[b]),
                         (walls[law][b], floors[law][b]))
        return d.size

    for_each_chunk(block, (slice(i, i + _BLOCK) for i in range(0, dexels.size, _BLOCK)))
    return {law: PredictedPart(sample=samples, s=s[samples], segment=segment[samples],
                               wall=walls[law], heights=heights, floor=floors[law],
                               offsets=FLOOR_OFFSETS,
                               sle_wall=surfaces[law].wall[at[law]][:, :, rows],
                               sle_floor=surfaces[law].floor[at[law]])
            for law in feeds}


def height_rows(count: int) -> np.ndarray:
    """Which of the ``count`` wall heights (the axial slices) carry wall dexels: at most
    :data:`WALL_HEIGHTS`, evenly spread from the lowest to the highest."""
    if count <= WALL_HEIGHTS:
        return np.arange(count)
    return np.unique(np.round(np.linspace(0, count - 1, WALL_HEIGHTS)).astype(int))


def _sweep_block(tool: SweptTool, table: DeflectionTable, dexels: tuple, out: tuple) -> None:
    """Wall and floor envelopes of one block of dexels ((samples, sides, heights)) into
    ``out`` ((wall (b, 2, H), floor (b, F)) views)."""
    d, sides, heights = dexels
    wall, floor = out
    largest = math.sqrt(float(np.max(np.einsum("kmi,kmi->km", table.values, table.values))))
    reach = tool.radius * math.sin(math.acos(max(-1.0, 1.0 - 2.2 * largest / tool.radius)))
    for j, side in enumerate((1, -1)):
        has = sides[:, j]
        if has.any():
            wall[np.flatnonzero(has), j] = wall_envelope(tool, table, d[has], side,
                                                         heights[has], reach)
    floor[:] = floor_envelope(tool, table, d, FLOOR_OFFSETS * tool.radius)


def predict_part(model: DeflectionModel, centres: np.ndarray, s: np.ndarray,
                 segment: np.ndarray, feed: np.ndarray, surface: SurfaceErrors,
                 ) -> PredictedPart:
    """The part one feed profile ``feed`` [m/s] leaves (:func:`predict_parts`)."""
    return predict_parts(model, centres, s, segment, {"": feed}, {"": surface})[""]
