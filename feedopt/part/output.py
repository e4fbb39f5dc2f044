"""The part stage of a run's outputs: per law the predicted part (:mod:`feedopt.part.predict`),
``part_<law>.csv`` (one row per dexel) and summary.json's ``part`` (per segment, like the
thesis's CMM tables: :mod:`feedopt.part.measure`)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from feedopt.part.measure import segment_table
from feedopt.part.predict import PredictedPart, predict_parts
from feedopt.schedule.surface import part_spacing, surface_lower_bound
from feedopt.units import MM

#: Longest path (samples) on which a norm-mode run also finds T* of planning for its part.
OTHER_MODE_MAX_SAMPLES = 10_000

COLUMNS = ("s_mm", "segment", "x_mm", "y_mm", "z_mm",
           "left_wall_mean_mm", "left_wall_min_mm", "left_wall_max_mm",
           "right_wall_mean_mm", "right_wall_min_mm", "right_wall_max_mm",
           "floor_centre_mm", "floor_min_mm", "floor_max_mm",
           "sle_left_wall_mm", "sle_right_wall_mm", "sle_floor_mm")
HEADER = ("# predicted part: material left (mm, > 0 proud of the nominal surface, < 0 "
          "overcut) on dexels every {spacing:g} mm of cutting path; walls: the deflected "
          "edges' envelope over the heights (mean/min/max), left = +y of the feed (up-milling "
          "side), right = -y; floor across the cut (centre line, min, max); sle_*: the surface "
          "location error at the same samples (feedopt.schedule.surface); x/y/z: nominal tool "
          "tip, base frame; empty: no such surface there\n")


def row_means(values: np.ndarray) -> np.ndarray:
    """Mean of each row of ``values`` (k, ...) over the rest, NaN where a row is all NaN."""
    return _stats(values.reshape(values.shape[0], -1))[0]


def _stats(values: np.ndarray) -> list[np.ndarray]:
    """Mean, min, max over the last axis, NaN where all are NaN."""
    has = np.any(np.isfinite(values), axis=-1)
    return [_nan_aware(fn, values, has) for fn in (np.nanmean, np.nanmin, np.nanmax)]


def _nan_aware(fn, values: np.ndarray, has: np.ndarray) -> np.ndarray:
    out = np.full(has.shape, np.nan)
    out[has] = fn(values[has], axis=-1)
    return out


def part_rows(part: PredictedPart, positions: np.ndarray) -> np.ndarray:
    """(B, len(COLUMNS)) the CSV's values in mm (NaN: no such surface)."""
    xyz = positions[part.sample] / MM
    left, right = (_stats(part.wall[:, j] / MM) for j in (0, 1))
    _, fmin, fmax = _stats(part.floor / MM)
    sle = [_stats(part.sle_wall[:, j] / MM)[0] for j in (0, 1)]
    return np.column_stack([part.s / MM, part.segment + 1, xyz, *left, *right,
                            part.centre_floor / MM, fmin, fmax, *sle, part.sle_floor / MM])


def write_part_csv(path: Path, part: PredictedPart, positions: np.ndarray,
                   spacing: float) -> None:
    """``part_<law>.csv`` (:data:`COLUMNS`, NaN written as an empty cell)."""
    buf = io.StringIO()
    np.savetxt(buf, part_rows(part, positions), fmt="%.6g", delimiter=",")
    body = buf.getvalue().replace("nan", "")
    path.write_text(HEADER.format(spacing=spacing / MM) + ",".join(COLUMNS) + "\n" + body,
                    encoding="ascii")


def part_summary(part: PredictedPart, kinds: tuple[str, ...], depth: np.ndarray) -> dict:
    """summary.json's ``part.laws[law]``: largest errors and the per-segment table."""
    def extreme(values: np.ndarray, fn) -> float | None:
        return float(fn(values)) / MM if np.any(np.isfinite(values)) else None

    return {"max_overcut_wall_mm": extreme(-part.wall, np.nanmax),
            "max_proud_wall_mm": extreme(part.wall, np.nanmax),
            "deepest_floor_mm": extreme(part.floor, np.nanmin),
            "segments_measured": int(np.unique(part.segment).size),
            "segments": segment_table(part, kinds, depth)}


def floor_points(part: PredictedPart, positions: np.ndarray, frames: np.ndarray,
                 radius: float) -> np.ndarray:
    """(B * F, 3) base-frame positions [m] of the floor dexels (sample, then offset)."""
    y = frames[part.sample, :, 1]
    pts = positions[part.sample][:, None, :] + (part.offsets * radius)[None, :, None] * y[
        :, None, :]
    return pts.reshape(-1, 3)


def part_stage(prepared, results: dict, out_dir: Path
               ) -> tuple[dict | None, dict[str, PredictedPart]]:
    """Predict, write and summarise the part of every replayed law: summary.json's ``part``
    (None: nothing cuts) and the parts by law."""
    model = prepared.model
    cutting = model.engagement.exit > model.engagement.entry
    if not cutting.any():
        return None, {}
    kinds = tuple(prepared.path.segment_kind)
    replayed = {law: res.verification for law, res in results.items()
                if res.verification.surface is not None}
    if not replayed:
        return None, {}
    parts = predict_parts(model, prepared.positions, prepared.problem.s,
                          prepared.samples.segment,
                          {law: ver.feed for law, ver in replayed.items()},
                          {law: ver.surface for law, ver in replayed.items()})
    laws = {}
    for law, part in parts.items():
        name = f"part_{law}.csv"
        write_part_csv(out_dir / name, part, prepared.positions,
                       part_spacing(prepared.problem.s, cutting))
        laws[law] = {"csv": name, **part_summary(part, kinds, model.engagement.axial_depth)}
    spacing = part_spacing(prepared.problem.s, cutting)
    return {"dexel_spacing_mm": spacing / MM, "laws": laws}, parts


def other_mode(prepared, law: str | None, result) -> dict | None:
    """summary.json's ``part.other_mode`` of a norm-mode run: the part tolerances its program
    law ``law`` reaches (largest |wall| and |floor| surface errors) and T* when the feed is
    planned for them instead (``deflection.mode: surface``); None in the other modes."""
    sc = prepared.scenario.deflection
    if law is None or result is None or sc.mode != "norm":
        return None
    if prepared.problem.n > OTHER_MODE_MAX_SAMPLES:  # a whole extra force pass
        return {"mode": "norm", "law": law, "skipped": (
            f"{prepared.problem.n} samples: the surface bound is a force pass of its own; "
            f"computed up to {OTHER_MODE_MAX_SAMPLES}")}
    surface = result.verification.surface
    if surface is None:
        return None
    wall, floor = surface.worst_wall(), np.abs(surface.floor)
    tol = tuple(float(np.nanmax(x)) if np.any(np.isfinite(x)) else np.inf
                for x in (wall, floor))
    t_other = surface_lower_bound(prepared.model, prepared.bound.parts, prepared.problem, tol)
    if t_other is None:
        return None
    mm = [x / MM if np.isfinite(x) else None for x in tol]
    return {"mode": "norm", "law": law, "wall_limit_mm": mm[0], "floor_limit_mm": mm[1],
            "lower_bound_s": prepared.problem.lower_bound_time(),
            "other_lower_bound_s": t_other}
