"""Which samples cut, and the axis ranges of the cutting alone (rapids are off scale).

A G-code program's rapids run at tens of times the cutting feed: axes that span them show
the cutting as a flat line. The static figures therefore scale their feed, acceleration and
jerk axes on the samples that cut. Which samples are air comes from the run
(``ReportData.samples.air`` when it has it) or, for data without it, from the feed: a sample
where some law runs faster than the fastest cutting feed of the scenario
(``scenario.max_feed_mm_s`` of summary.json) is taken as air. Pure numpy, no matplotlib.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from feedopt.report.data import LawSeries, ReportData

#: A feed this much above the scenario's max cutting feed is a rapid (fallback rule).
RAPID_RTOL = 1e-3
#: Joint velocities below this fraction of the joint's limit are drawn as 0 (round-off).
NOISE_FRACTION = 1e-9
#: Margin added above and below the cutting range, as a fraction of it.
MARGIN = 0.06


def _run_mask(data: ReportData) -> np.ndarray | None:
    """The run's own air mask (``data.samples.air``), None when the data has none."""
    value = getattr(getattr(data, "samples", None), "air", None)
    if value is None:
        return None
    mask = np.asarray(value, dtype=bool)
    return mask if mask.shape == (data.path_xyz_mm.shape[0],) else None


def v_max_mm_s(data: ReportData) -> np.ndarray | None:
    """(k,) the feed bound v_max(s) [mm/s] when the data has it (``data.samples``)."""
    value = getattr(getattr(data, "samples", None), "v_max_mm_s", None)
    return None if value is None else np.asarray(value, dtype=float)


def max_cutting_feed_mm_s(data: ReportData) -> float | None:
    """The scenario's max cutting feed [mm/s] from the summary, None when not stated."""
    sc = data.summary.get("scenario") if hasattr(data.summary, "get") else None
    value = sc.get("max_feed_mm_s") if hasattr(sc, "get") else None
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0
    return float(value) if ok else None


def air_samples(data: ReportData) -> np.ndarray:
    """(k,) bool: the path samples that do not cut (rapids, plunges, retracts).

    The run's own mask when :class:`ReportData` carries one (``samples.air``); else the samples
    where some law's feed exceeds the scenario's max cutting feed by :data:`RAPID_RTOL`
    (none when the summary does not state it)."""
    mask = _run_mask(data)
    if mask is not None:
        return mask
    cap = max_cutting_feed_mm_s(data)
    if cap is None:
        return np.zeros(data.path_xyz_mm.shape[0], dtype=bool)
    feeds = np.stack([ls.feed_mm_s for ls in data.laws])
    return np.any(feeds > cap * (1 + RAPID_RTOL), axis=0)


def air_times(data: ReportData, ls: LawSeries, air: np.ndarray) -> np.ndarray:
    """(m,) bool: the time samples of ``ls`` in air. With the law's time at each path
    sample (``ls.path_t_s``) a time is air when the path sample reached by then is;
    else the fallback feed rule on the timed feed."""
    t_path = getattr(ls, "path_t_s", None)
    if t_path is not None and np.shape(t_path) == air.shape and air.size:
        k = np.searchsorted(np.asarray(t_path, dtype=float), ls.t_s, side="right") - 1
        return air[np.clip(k, 0, air.size - 1)]
    cap = max_cutting_feed_mm_s(data)
    if cap is None or not air.any():
        return np.zeros(ls.t_s.shape, dtype=bool)
    return ls.feed_t_mm_s > cap * (1 + RAPID_RTOL)


def cut_range(values: Sequence[np.ndarray], air: Sequence[np.ndarray],
              from_zero: bool = False) -> tuple[float, float] | None:
    """(low, high) axis range of ``values`` where not ``air`` (pairwise), with a
    :data:`MARGIN`; None when nothing is air (autoscale shows it all) or nothing cuts.
    ``from_zero``: the range starts at 0 (feeds)."""
    if not any(np.any(a) for a in air):
        return None
    cut = [np.asarray(v, dtype=float)[~np.asarray(a, dtype=bool)] for v, a in zip(
        values, air, strict=True)]
    cut = [c[np.isfinite(c)] for c in cut]
    if not any(c.size for c in cut):
        return None
    lo = min(float(c.min()) for c in cut if c.size)
    hi = max(float(c.max()) for c in cut if c.size)
    if from_zero:
        lo = min(lo, 0.0)
    pad = MARGIN * (hi - lo) if hi > lo else max(abs(hi), 1.0) * MARGIN
    return (0.0 if from_zero and lo >= 0 else lo - pad), hi + pad


def off_scale_peak(values: Sequence[np.ndarray], limits: tuple[float, float] | None) -> float:
    """The largest |value| outside ``limits`` (0 when all inside or no limits)."""
    if limits is None:
        return 0.0
    lo, hi = limits
    out = [np.abs(v[(v < lo) | (v > hi)]) for v in map(np.asarray, values)]
    return max((float(o.max()) for o in out if o.size), default=0.0)


def denoise(velocity: np.ndarray, limit: float) -> np.ndarray:
    """``velocity`` with |v| < :data:`NOISE_FRACTION` x ``limit`` set to 0 (round-off of
    joints that do not move, 1e-13 deg/s, is not a motion)."""
    v = np.asarray(velocity, dtype=float)
    if not limit > 0:
        return v
    return np.where(np.abs(v) < NOISE_FRACTION * limit, 0.0, v)
