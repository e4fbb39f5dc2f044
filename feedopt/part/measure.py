"""The predicted part measured per segment like the thesis's CMM (section 3.7, Tables 3.5-3.7;
section 4.5, Tables 4.1-4.2).

* **Wall flatness**: the distance between two parallel planes containing the wall's points
  (thesis Table 3.5); here the planes parallel to the least-squares plane of the points
  (error against arc length along the wall and height), an upper bound of the minimum-zone
  value, as CMM software reports by default. Lines only (the thesis measured the linear
  sections), at least 5 dexels.
* **Mean distance to the nominal plane** (Eq. 3.28, Table 3.7): the mean |error| of the wall's
  points, and their signed mean (material left > 0).
* **Floor**: mean and standard deviation of the floor error over the segment's floor dexels
  (all across the cut); the depth is the nominal depth minus the material left (Table 3.6).
"""

from __future__ import annotations

import numpy as np

from feedopt.part.predict import PredictedPart
from feedopt.schedule.surface import WALL_SIDES
from feedopt.units import MM

#: Most rows of the per-segment table (a program has a segment per move).
MAX_SEGMENT_ROWS = 100
#: Fewest wall points of a line for its flatness.
MIN_FLATNESS_POINTS = 5


def flatness(along: np.ndarray, height: np.ndarray, error: np.ndarray) -> float:
    """Peak-to-valley [m] of ``error`` about its least-squares plane in (along, height)."""
    ok = np.isfinite(error)
    a, h, e = along[ok], height[ok], error[ok]
    design = np.column_stack([np.ones_like(a), a - a.mean(), h - h.mean()])
    coef, *_ = np.linalg.lstsq(design, e, rcond=None)
    residual = e - design @ coef
    return float(residual.max() - residual.min())


def _wall_row(part: PredictedPart, mine: np.ndarray, side: int, line: bool) -> dict | None:
    err = part.wall[mine, side]  # (b, H)
    if np.all(np.isnan(err)):
        return None
    along = np.broadcast_to(part.s[mine, None], err.shape)
    flat = (flatness(along.ravel(), part.heights[mine].ravel(), err.ravel()) / MM
            if line and np.sum(np.any(np.isfinite(err), axis=1)) >= MIN_FLATNESS_POINTS
            else None)
    sle = part.sle_wall[mine, side]
    return {"flatness_mm": flat,
            "mean_distance_mm": float(np.nanmean(np.abs(err))) / MM,
            "mean_error_mm": float(np.nanmean(err)) / MM,
            "min_error_mm": float(np.nanmin(err)) / MM,
            "max_error_mm": float(np.nanmax(err)) / MM,
            "sle_mean_error_mm": float(np.nanmean(sle)) / MM}


def shown_segments(segment: np.ndarray) -> np.ndarray:
    """The segments of the table, in path order: every segment with a dexel, or on a long
    program the :data:`MAX_SEGMENT_ROWS` with the most dexels (the longest cuts)."""
    found, counts = np.unique(segment, return_counts=True)
    if found.size <= MAX_SEGMENT_ROWS:
        return found
    return np.sort(found[np.argsort(-counts, kind="stable")[:MAX_SEGMENT_ROWS]])


def segment_table(part: PredictedPart, kinds: tuple[str, ...], depth: np.ndarray
                  ) -> list[dict]:
    """One row per segment that cuts: its number (1-based, as the thesis's), kind, walls
    (``left``/``right``: :func:`_wall_row`) and floor (depth [mm] below the top, as Table
    3.6, ``depth`` (n,) the nominal axial depth per sample [m])."""
    rows = []
    for g in shown_segments(part.segment):
        mine = np.flatnonzero(part.segment == g)
        kind = kinds[int(g)] if int(g) < len(kinds) else "line"
        floor = part.floor[mine]
        nominal = depth[part.sample[mine]][:, None]
        row = {"segment": int(g) + 1, "kind": kind, "dexels": int(mine.size),
               "from_s_mm": float(part.s[mine[0]]) / MM, "to_s_mm": float(part.s[mine[-1]]) / MM}
        for side, name in enumerate(WALL_SIDES):
            row[f"{name}_wall"] = _wall_row(part, mine, side, kind == "line")
        if np.any(np.isfinite(floor)):
            level = -(nominal - floor)
            row["floor"] = {"depth_mean_mm": float(np.nanmean(level)) / MM,
                            "depth_std_mm": float(np.nanstd(level)) / MM,
                            "mean_error_mm": float(np.nanmean(floor)) / MM,
                            "flatness_mm": (flatness(
                                np.broadcast_to(part.s[mine, None], floor.shape).ravel(),
                                np.broadcast_to(part.offsets, floor.shape).ravel(),
                                floor.ravel()) if kind == "line"
                                else float(np.nanmax(floor) - np.nanmin(floor))) / MM,
                            "sle_mean_error_mm": float(np.nanmean(part.sle_floor[mine])) / MM}
        else:
            row["floor"] = None
        rows.append(row)
    return rows
