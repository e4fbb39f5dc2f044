"""The report's figures (matplotlib, Agg canvas; no pyplot global state).

Each ``plot_*`` function takes a :class:`~feedopt.report.data.ReportData` and returns a
:class:`matplotlib.figure.Figure`; :func:`figures` lists them with their captions and
:func:`render_png` turns one into PNG bytes (:func:`render_pngs` several, on two cores).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from feedopt import background
from feedopt.report.data import LawSeries, ReportData
from feedopt.report.scales import (
    air_samples,
    air_times,
    cut_range,
    denoise,
    off_scale_peak,
    v_max_mm_s,
)
from feedopt.report.verdict import BASELINE_NAMES
from feedopt.schedule.laws import LAWS

_FALLBACK = ["tab:red", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
_LIMIT_STYLE = {"color": "tab:red", "linestyle": "--", "linewidth": 1.2}
# Dash patterns and markers of the laws on one axes, in turn (coincident laws stay apart).
_DASHES = ("-", (0, (5, 2)), (0, (1, 1.5)), (0, (6, 2, 1, 2)), (0, (3, 1, 1, 1, 1, 1)))
_MARKERS = ("o", "s", "^", "D", "v", "x")
_DPI = 150
#: Right margin [inch] of the figures whose legends sit right of the axes.
LEGEND_MARGIN = 1.9
# Curves longer than this are drawn through their min/max envelope (peaks kept, see _env).
MAX_CURVE_POINTS = 4000
MAX_PATH_SEGMENTS = 1500


def law_color(law: str, index: int = 0) -> str:
    """Stable colour of a timing law across all figures (its registry colour)."""
    spec = LAWS.get(law)
    return spec.colour if spec is not None else _FALLBACK[index % len(_FALLBACK)]


def _baseline(data: ReportData) -> LawSeries | None:
    """The baseline law of the run (registry: ignores the limit), drawn under every law."""
    return next((ls for ls in data.laws if LAWS.get(ls.law) is not None
                 and LAWS[ls.law].baseline), None)


def _label(ls: LawSeries) -> str:
    return ls.law if ls.verified else f"{ls.law} (NOT verified)"


def _env(y: np.ndarray, max_points: int = MAX_CURVE_POINTS) -> np.ndarray:
    """Indices of a min/max envelope of ``y`` with at most ~``max_points`` points.

    The samples are cut into ``max_points // 2`` consecutive buckets and the smallest and
    largest sample of each are kept (plus both ends), so peaks survive the decimation.
    """
    n = y.shape[0]
    if n <= max_points:
        return np.arange(n)
    nb = max_points // 2
    size = -(-n // nb)
    padded = np.concatenate([y, np.full(nb * size - n, y[-1])]).reshape(nb, size)
    base = np.arange(nb) * size
    idx = np.concatenate([[0, n - 1], base + padded.argmin(axis=1), base + padded.argmax(axis=1)])
    idx = np.unique(idx)
    return idx[idx < n]


#: Markers per drawn curve of a law (:func:`law_style`).
MARKS_PER_CURVE = 10


def _plot(ax, x: np.ndarray, y: np.ndarray, marks: tuple[int, int] | None = None, **kw):
    """``y`` against ``x`` through its envelope (:func:`_env`). ``marks = (k, n)``: the
    ``k``-th of ``n`` laws, its :data:`MARKS_PER_CURVE` markers offset from the others'."""
    i = _env(y)
    if marks is not None:
        step = max(1, i.size // MARKS_PER_CURVE)
        kw["markevery"] = (marks[0] * step // max(marks[1], 1), step)
    return ax.plot(x[i], y[i], **kw)


@dataclass(frozen=True)
class Margins:
    """Margins of a figure's subplot grid and the gaps between its axes [inch]: room for
    the tick labels, axis labels and titles drawn here."""

    left: float = 0.85
    right: float = 0.2
    bottom: float = 0.55
    top: float = 0.4
    hgap: float = 0.6
    wgap: float = 0.85


def _new_figure(width: float, height: float, nrows: int = 1, ncols: int = 1,
                margins: Margins | None = None) -> Figure:
    """A figure whose subplot grid (``nrows`` x ``ncols``) has fixed ``margins`` [inch]
    (default :class:`Margins`).

    Fixed margins instead of matplotlib's constrained layout, which measures every text in
    extra draw passes and took a third of the report's time (0.6 of 1.6 s in the default
    run) for the same placement to a few pixels.
    """
    m = Margins() if margins is None else margins
    fig = Figure(figsize=(width, height), dpi=_DPI)
    FigureCanvasAgg(fig)
    axes_w = (width - m.left - m.right - (ncols - 1) * m.wgap) / ncols
    axes_h = (height - m.bottom - m.top - (nrows - 1) * m.hgap) / nrows
    fig.subplots_adjust(left=m.left / width, right=1 - m.right / width,
                        bottom=m.bottom / height, top=1 - m.top / height,
                        wspace=m.wgap / axes_w, hspace=m.hgap / axes_h)
    return fig


def render_png(fig: Figure) -> bytes:
    """PNG bytes of a figure (no timestamp metadata, so identical inputs give identical bytes)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    return buf.getvalue()


def render_pngs(figures: dict[str, Figure]) -> dict[str, bytes]:
    """PNG bytes of several figures (same keys, same order), rendered on two cores.

    Rendering (Agg drawing of every tick and text, then PNG encoding) is most of a report's
    time. The figures are split in two groups of about equal axes count (matplotlib's cost
    grows with the axes, not with the decimated data); a forked child renders one group
    while this process renders the other (:mod:`feedopt.background`; in turn here where fork
    is unavailable). The bytes are those of :func:`render_png` in either process.
    """
    if len(figures) < 2 or not background.fork_available():
        return {key: render_png(fig) for key, fig in figures.items()}
    here, there = split_by_axes(figures)
    child = background.start(lambda: {key: render_png(figures[key]) for key in there},
                             "rendering report figures")
    try:
        done = {key: render_png(figures[key]) for key in here}
    except BaseException:
        child.join(cancel=True)
        raise
    done.update(child.join(reraise=True))
    return {key: done[key] for key in figures}


def split_by_axes(figures: dict[str, Figure]) -> tuple[list[str], list[str]]:
    """Two groups of figure keys with about the same number of axes: the figures by
    decreasing axes count, each to the group that has fewer so far (greedy partition)."""
    groups: tuple[list[str], list[str]] = ([], [])
    load = [0, 0]
    for key in sorted(figures, key=lambda k: -len(figures[k].axes)):
        g = 0 if load[0] <= load[1] else 1
        groups[g].append(key)
        load[g] += len(figures[key].axes)
    return groups


def _plane_axes(xyz: np.ndarray) -> tuple[int, int]:
    """The two base-frame axes along which the path extends most, in x<y<z order."""
    extent = np.ptp(xyz, axis=0) if xyz.shape[0] else np.ones(3)
    i, j = sorted(np.argsort(extent)[-2:])
    return int(i), int(j)


def _legend_right(ax, **kw) -> None:
    """The legend of ``ax`` outside the data, right of the axes (the figure's right
    margin, :data:`LEGEND_MARGIN`, leaves room for it)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                  fontsize="small", frameon=False, **kw)


def _path_segments(data: ReportData) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Decimated path samples (indices ``keep``), their 2D segments on the two widest base
    axes and those axes. Long paths: every step-th sample plus both samples around each
    change of segment kind or of air/cut."""
    kind, air = data.segment_kind, air_samples(data)
    n_pts = kind.shape[0]
    step = max(1, -(-n_pts // MAX_PATH_SEGMENTS))
    change = np.flatnonzero((kind[1:] != kind[:-1]) | (air[1:] != air[:-1]))
    keep = np.unique(np.concatenate([np.arange(0, n_pts, step), change, change + 1, [n_pts - 1]]))
    i, j = _plane_axes(data.path_xyz_mm[keep])
    pts = data.path_xyz_mm[keep][:, [i, j]]
    return keep, np.stack([pts[:-1], pts[1:]], axis=1), (i, j)


def _feed_norm(data: ReportData, air: np.ndarray) -> Normalize:
    """Colour scale of the feed on the cutting samples (all samples when none cuts)."""
    cut = ~air if (~air).any() else np.ones_like(air)
    feeds = np.concatenate([ls.feed_mm_s[cut] for ls in data.laws])
    lo, hi = float(np.min(feeds)), float(np.max(feeds))
    return Normalize(vmin=lo - 0.5, vmax=hi + 0.5) if lo == hi else Normalize(lo, hi)


def plot_path_feed(data: ReportData) -> Figure:
    """The path (projected on its two widest base axes) coloured by feed on the cutting
    samples, one panel per law; air moves (rapids, plunges, retracts) thin grey, off the
    colour scale; blends (segment kind not ``"line"``) underlaid in light grey."""
    keep, segs, (i, j) = _path_segments(data)
    air = air_samples(data)
    blend = data.segment_kind[keep] != "line"
    blend_seg = blend[:-1] & blend[1:]
    air_seg = air[keep][:-1] & air[keep][1:]
    n = len(data.laws)
    ncols = min(n, 2)
    nrows = -(-n // ncols)
    fig = _new_figure(6.0 * ncols, 3.6 * nrows + 0.3, nrows, ncols,
                      Margins(right=0.1, bottom=0.85, hgap=0.9, wgap=0.95))
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    norm = _feed_norm(data, air)
    lc = None
    for ax, ls in zip(axes, data.laws, strict=False):
        if blend_seg.any():
            ax.add_collection(LineCollection(segs[blend_seg], colors="0.85", linewidths=7,
                                             zorder=1, label="blend"))
        if air_seg.any():
            ax.add_collection(LineCollection(segs[air_seg], colors="0.55", linewidths=0.7,
                                             zorder=2, label="air (rapid, plunge, retract)"))
        feed = ls.feed_mm_s[keep]
        lc = LineCollection(segs[~air_seg], array=0.5 * (feed[:-1] + feed[1:])[~air_seg],
                            cmap="viridis", norm=norm, linewidths=2.5, zorder=3)
        ax.add_collection(lc)
        ax.autoscale_view()
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(_label(ls))
        ax.set_xlabel(f"{'xyz'[i]} [mm] (robot base)")
        ax.set_ylabel(f"{'xyz'[j]} [mm] (robot base)")
    for ax in axes[n:]:
        ax.set_visible(False)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower left", ncol=len(handles), frameon=False,
                   fontsize="small", bbox_to_anchor=(0.01, 0.0))
    if lc is not None:
        fig.colorbar(lc, ax=axes[:n].tolist(), label="feed on cutting moves [mm/s]",
                     shrink=0.9)
    return fig


def plot_deflection(data: ReportData) -> Figure:
    """Predicted deflection vs s: the baseline against each law, limit line (Fig. 3.18/4.4)."""
    const = _baseline(data)
    others = [ls for ls in data.laws if ls is not const] or [const]
    n = len(others)
    fig = _new_figure(8.0 + LEGEND_MARGIN, 2.4 * n + 0.6, n, 1,
                      Margins(top=0.15, hgap=0.15, right=LEGEND_MARGIN))
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True, squeeze=False)).ravel()
    for k, (ax, ls) in enumerate(zip(axes, others, strict=True)):
        if const is not None and ls is not const:
            _plot(ax, const.s_mm, const.deflection_mm, color=law_color(const.law), lw=1.0,
                  label=_label(const))
        _plot(ax, ls.s_mm, ls.deflection_mm, color=law_color(ls.law, k), lw=1.4,
              label=_label(ls))
        ax.axhline(data.deflection_limit_mm, label=f"limit {data.deflection_limit_mm:g} mm",
                   **_LIMIT_STYLE)
        ax.set_ylabel("deflection [mm]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        _legend_right(ax)
    axes[-1].set_xlabel("arc length s [mm]")
    return fig


def law_style(k: int, n: int) -> dict:
    """Line style of the ``k``-th of ``n`` laws drawn on one axes: its own dash pattern and
    marker, the markers offset from law to law, so that laws that coincide stay apart."""
    return {"linestyle": _DASHES[k % len(_DASHES)], "marker": _MARKERS[k % len(_MARKERS)],
            "marks": (k, n), "markersize": 4.5, "markerfacecolor": "none"}


def _scaled(ax, limits: tuple[float, float] | None, peak: float, unit: str) -> None:
    """Set a cutting-only range on ``ax`` and say what is off scale."""
    if limits is None:
        return
    ax.set_ylim(*limits)
    if peak > 0:
        ax.set_title(f"air moves off scale (up to {peak:.3g} {unit})", loc="right",
                     fontsize="x-small", color="0.35")


def plot_feed(data: ReportData) -> Figure:
    """Feed vs arc length (with the bound v_max(s) when the data has it) and vs time, every
    law (Fig. 3.19/4.5); axes scaled on the cutting samples."""
    fig = _new_figure(8.0 + LEGEND_MARGIN, 6.0, 2, 1, Margins(top=0.3, right=LEGEND_MARGIN))
    ax_s, ax_t = fig.subplots(2, 1)
    air = air_samples(data)
    n = len(data.laws)
    v_max = v_max_mm_s(data)
    if v_max is not None:
        _plot(ax_s, data.laws[0].s_mm, v_max, color="k", lw=0.9, linestyle=":",
              label="feed bound v_max(s)")
    t_air = [air_times(data, ls, air) for ls in data.laws]
    for k, ls in enumerate(data.laws):
        style = {"color": law_color(ls.law, k), "lw": 1.3, "label": _label(ls),
                 **law_style(k, n)}
        _plot(ax_s, ls.s_mm, ls.feed_mm_s, **style)
        _plot(ax_t, ls.t_s, ls.feed_t_mm_s, **style)
    s_feeds = [ls.feed_mm_s for ls in data.laws]
    t_feeds = [ls.feed_t_mm_s for ls in data.laws]
    for ax, feeds, masks in ((ax_s, s_feeds, [air] * n), (ax_t, t_feeds, t_air)):
        limits = cut_range(feeds, masks, from_zero=True)
        ax.set_ylim(bottom=0)
        _scaled(ax, limits, off_scale_peak(feeds, limits), "mm/s")
        ax.set_ylabel("feed [mm/s]")
        ax.grid(alpha=0.3)
        _legend_right(ax)
    ax_s.set_xlabel("arc length s [mm]")
    ax_t.set_xlabel("time t [s]")
    return fig


def _data_range(values: list[np.ndarray], air: list[np.ndarray]) -> tuple[float, float]:
    """The y range of the cutting samples (:func:`cut_range`), else of all the samples,
    with a margin: the limit lines do not stretch the axes."""
    limits = cut_range(values, air)
    if limits is not None:
        return limits
    finite = np.concatenate([v[np.isfinite(v)] for v in values])
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
    pad = 0.06 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.06
    return lo - pad, hi + pad


def _limit_lines(ax, value, shown: tuple[float, float]) -> None:
    """Dashed +-limit lines (``value`` from summary.json, None: none); the legend says when
    they lie outside the ``shown`` range."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
        off = "" if shown[0] <= -value or value <= shown[1] else " (off scale)"
        ax.axhline(value, label=f"limit +-{value:g}{off}", **_LIMIT_STYLE)
        ax.axhline(-value, **_LIMIT_STYLE)


def _busy(values: np.ndarray) -> float:
    """Share of the samples above half the largest |value| (1: a bang-bang curve)."""
    mag = np.abs(values[np.isfinite(values)])
    return float(np.mean(mag > 0.5 * mag.max())) if mag.size and mag.max() > 0 else 0.0


def _is_c2(data: ReportData, law: str) -> bool:
    """False when summary.json says the law is not C2 (its jerk is unbounded)."""
    row = data.summary.get("laws", {}).get(law) if hasattr(data.summary, "get") else None
    return not (isinstance(row, dict) and row.get("c2") is False)


def plot_accel_jerk(data: ReportData) -> Figure:
    """Tangential acceleration and jerk vs time, every law, with the scenario's limits;
    axes scaled on the cutting samples. The jerk is drawn thin (bang-bang pulses of one law
    would hide the others) and only for the C2 laws (the others' jerk is unbounded)."""
    fig = _new_figure(8.0 + LEGEND_MARGIN, 6.0, 2, 1,
                      Margins(left=1.0, top=0.3, hgap=0.3, right=LEGEND_MARGIN))
    ax_a, ax_j = fig.subplots(2, 1, sharex=True)
    air = air_samples(data)
    n = len(data.laws)
    t_air = [air_times(data, ls, air) for ls in data.laws]
    smooth = [k for k, ls in enumerate(data.laws) if _is_c2(data, ls.law)] or list(range(n))
    for k, ls in enumerate(data.laws):
        c = law_color(ls.law, k)
        _plot(ax_a, ls.t_s, ls.accel_mm_s2, color=c, lw=1.1, label=_label(ls), **law_style(k, n))
        if k in smooth:  # a law busy at its jerk limit (bang-bang) goes below the others
            _plot(ax_j, ls.t_s, ls.jerk_mm_s3, color=c, lw=0.6, alpha=0.8, label=_label(ls),
                  linestyle=_DASHES[k % len(_DASHES)], zorder=3 - _busy(ls.jerk_mm_s3))
    sc = data.summary.get("scenario", {}) if hasattr(data.summary, "get") else {}
    for ax, values, masks, key in (
            (ax_a, [ls.accel_mm_s2 for ls in data.laws], t_air, "tangential_acceleration_mm_s2"),
            (ax_j, [data.laws[k].jerk_mm_s3 for k in smooth], [t_air[k] for k in smooth],
             "tangential_jerk_mm_s3")):
        unit = "mm/s^2" if ax is ax_a else "mm/s^3"
        shown = _data_range(values, masks)
        _limit_lines(ax, sc.get(key), shown)
        _scaled(ax, shown, off_scale_peak(values, cut_range(values, masks)), unit)
        ax.grid(alpha=0.3)
        _legend_right(ax)
    ax_a.set_ylabel("tangential acceleration [mm/s^2]")
    ax_j.set_ylabel("tangential jerk [mm/s^3]")
    ax_j.set_xlabel("time t [s]")
    return fig


def _joint_panel(ax, data: ReportData, j: int) -> None:
    """One joint's velocities (round-off below 1e-9 of the limit drawn as 0) and limits."""
    lim = float(data.joint_velocity_limit_deg_s[j])
    curves = [denoise(ls.joint_velocity_deg_s[:, j], lim) for ls in data.laws]
    for k, (ls, v) in enumerate(zip(data.laws, curves, strict=True)):
        _plot(ax, ls.t_s, v, color=law_color(ls.law, k), lw=1.1, label=_label(ls),
              linestyle=_DASHES[k % len(_DASHES)])
    peak = max(float(np.max(np.abs(v), initial=0.0)) for v in curves)
    unit = f"{data.joint_unit(j)}/s"
    ax.axhline(lim, label="joint velocity limit", **_LIMIT_STYLE)
    ax.axhline(-lim, **_LIMIT_STYLE)
    if peak == 0:
        title = f"A{j + 1}: does not move"
    elif lim > 0:
        title = f"A{j + 1}: peak {peak:.3g} {unit} = {peak / lim:.2%} of {lim:g}"
    else:
        title = f"A{j + 1}"
    ax.set_title(title, fontsize="medium")
    ax.set_ylabel(f"velocity [{unit}]")
    ax.grid(alpha=0.3)
    # The limits are usually far above milling speeds: zoom on the data, say so in title.
    span = peak * 1.3 if peak > 0 else 0.05 * lim if lim > 0 else 1.0
    top = min(span, 1.1 * lim) if lim > 0 else span
    ax.set_ylim(-top, top)


def plot_joint_velocity(data: ReportData) -> Figure:
    """Joint velocities vs time against their limits, one panel per joint; one legend above
    the panels."""
    joints = data.joint_velocity_limit_deg_s.size
    rows = max(1, -(-joints // 3))
    fig = _new_figure(11.0, 2.75 * rows + 0.35, rows, 3, Margins(top=0.8, hgap=0.65, wgap=0.8))
    axes = fig.subplots(rows, 3, sharex=True, squeeze=False).ravel()
    for ax in axes[joints:]:
        ax.set_visible(False)
    for j, ax in enumerate(axes[:joints]):
        _joint_panel(ax, data, j)
    for ax in axes[max(0, joints - 3):joints]:
        ax.set_xlabel("time t [s]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(len(handles), 6), frameon=False,
               fontsize="small", bbox_to_anchor=(0.5, 1.0))
    return fig


@dataclass(frozen=True)
class FigureSpec:
    """A report figure: file key, caption, and the function that draws it.

    ``{baseline}`` in the caption names the run's baseline law (:func:`caption_of`);
    ``cut_scaled``: its axes are scaled on the cutting samples (said when the run has air).
    """

    key: str
    caption: str
    draw: object
    cut_scaled: bool = False


def baseline_name(data: ReportData) -> str:
    """``the constant feed``, ``the programmed feed`` (the run's baseline), or ``no baseline``."""
    base = _baseline(data)
    if base is None:
        return "no baseline"
    return BASELINE_NAMES.get(base.law, f"the {base.law} law")


def caption_of(spec: FigureSpec, data: ReportData) -> str:
    """The caption of ``spec`` for this run: its baseline named, the cutting-only scale
    said when some samples are air."""
    text = spec.caption.format(baseline=baseline_name(data))
    if spec.cut_scaled and air_samples(data).any():
        text += (" Axes scaled on the cutting moves: rapids and other air moves run off "
                 "scale (the largest value off scale is printed in the panel).")
    return text


def engagement_figure(eng) -> Figure:
    """Left: the stock's top view after the run (height, mm) with the path coloured by the
    radial depth the stock gave (grey where in air); right: entry/exit angles and axial
    depth along s. ``eng`` is a :class:`~feedopt.report.data.EngagementSeries`."""
    fig = _new_figure(14, 5, 1, 2, Margins(right=0.7, top=0.45, wgap=1.6))
    ax, axa = fig.subplots(1, 2, width_ratios=[1.3, 1])
    x0, x1, y0, y1 = eng.extent_mm
    im = ax.imshow(eng.stock_top_mm.T, origin="lower", extent=(x0, x1, y0, y1), cmap="Greys",
                   alpha=0.6, aspect="equal")
    fig.colorbar(im, ax=ax, label="stock top after the run [mm]", shrink=0.8)
    air = eng.radial_mm <= 0
    xy = eng.xy_mm
    ax.plot(np.where(air, xy[:, 0], np.nan), np.where(air, xy[:, 1], np.nan), color="0.6",
            lw=0.6, label="air")
    step = max(1, xy.shape[0] // MAX_CURVE_POINTS)
    sc = ax.scatter(xy[::step, 0], xy[::step, 1], c=np.where(air, np.nan, eng.radial_mm)[::step],
                    s=2, cmap="viridis", label="cutting")
    fig.colorbar(sc, ax=ax, label="radial depth of cut [mm]", shrink=0.8)
    ax.set_xlabel("x [mm] (workpiece frame)")
    ax.set_ylabel("y [mm]")
    ax.set_title("engagement from the stock")
    ax.legend(loc="best", fontsize=8)
    _plot(axa, eng.s_mm, eng.entry_deg, lw=1, label="entry angle [deg]")
    _plot(axa, eng.s_mm, eng.exit_deg, lw=1, label="exit angle [deg]")
    axd = axa.twinx()
    _plot(axd, eng.s_mm, eng.axial_mm, color="k", lw=0.8, label="axial depth [mm]")
    axa.set_xlabel("s [mm]")
    axa.set_ylabel("angle [deg] (0-180: the leading half)")
    axd.set_ylabel("axial depth [mm]")
    axa.set_ylim(-5, 185)
    axa.legend(loc="upper left", fontsize=8)
    axd.legend(loc="upper right", fontsize=8)
    axa.grid(alpha=0.3)
    return fig


def plot_engagement(data: ReportData) -> Figure | None:
    """The engagement figure of a run with a stock (None without one)."""
    return None if data.engagement is None else engagement_figure(data.engagement)


def plot_redundancy(data: ReportData) -> Figure | None:
    """``robot.redundancy: optimise``: psi(s) (top), the principal in-plane stiffnesses with
    the nearest IK and with psi(s) (middle) and the stiffest direction's angle from the feed
    (bottom). None without the optimisation."""
    r = data.redundancy
    if r is None:
        return None
    fig = _new_figure(10, 8, 3, 1)
    ax_psi, ax_k, ax_a = fig.subplots(3, 1, sharex=True)
    if r.profile_nearest is not None:
        _plot(ax_psi, r.s_mm, r.profile_nearest, color="0.5", lw=1.0)
    _plot(ax_psi, r.s_mm, r.psi_deg, color="tab:purple", lw=1.2)
    ax_psi.set_ylabel(r.profile_label)
    ax_psi.set_title(r.title or f"rotation about the tool axis ({r.status}): T* "
                     f"{r.t_star_before:.2f} s nearest -> {r.t_star_after:.2f} s")
    for k, style in ((0, "-"), (1, "--")):
        which = "stiffest" if k == 0 else "softest"
        _plot(ax_k, r.s_mm, r.stiffness_before[:, k], color="0.5", ls=style,
              label=f"nearest IK, {which}")
        _plot(ax_k, r.s_mm, r.stiffness_after[:, k], color="tab:purple", ls=style,
              label=f"optimised, {which}")
    ax_k.set_ylabel("in-plane stiffness [N/um]")
    ax_k.legend(fontsize=8, loc="best")
    _plot(ax_a, r.s_mm, r.angle_before_deg, color="0.5", lw=0.8, label="nearest IK")
    _plot(ax_a, r.s_mm, r.angle_after_deg, color="tab:purple", lw=0.8, label="optimised")
    ax_a.set_ylabel("stiffest direction\nfrom the feed [deg]")
    ax_a.set_xlabel("s [mm]")
    ax_a.legend(fontsize=8, loc="best")
    for ax in (ax_psi, ax_k, ax_a):
        ax.grid(alpha=0.3)
    return fig


def _plot_part(data: ReportData) -> Figure | None:
    from feedopt.report.part_figure import plot_part

    return plot_part(data, _new_figure)


FIGURES: tuple[FigureSpec, ...] = (
    FigureSpec(
        "path",
        "Tool path in the robot base frame, coloured by the commanded feed on cutting moves, "
        "one panel per law; air moves (rapids, plunges, retracts) thin grey, blends "
        "underlaid in light grey.",
        plot_path_feed,
    ),
    FigureSpec(
        "deflection",
        "Predicted static deflection vs arc length at the commanded feed: {baseline} "
        "against each law, with the deflection limit (thesis Fig. 3.18 / 4.4).",
        plot_deflection,
    ),
    FigureSpec(
        "feed",
        "Commanded feed vs arc length (top, with the feed bound v_max(s) when known) and "
        "vs time (bottom), every law in its own dash pattern and markers (thesis Fig. "
        "3.19 / 4.5).",
        plot_feed,
        cut_scaled=True,
    ),
    FigureSpec(
        "accel_jerk",
        "Tangential acceleration (top) and jerk (bottom, thin; laws that are not C2 left "
        "out: their jerk is unbounded) vs time, with the scenario's limits (dashed).",
        plot_accel_jerk,
        cut_scaled=True,
    ),
    FigureSpec(
        "joints",
        "Joint velocities vs time against the joint velocity limits (dashed); the axes are "
        "zoomed on the data when the limits are far away (see each panel's title); "
        "velocities below 1e-9 of the limit (round-off) are drawn as 0.",
        plot_joint_velocity,
    ),
    FigureSpec(
        "engagement",
        "Engagement from the stock: the stock's top view after the run with the path coloured "
        "by radial depth, and the entry/exit angles and axial depth along s.",
        plot_engagement,
    ),
    FigureSpec(
        "redundancy",
        "The rotation about the tool axis psi(s) chosen by robot.redundancy: optimise (on a "
        "7-axis robot: its extra axis, held), the stiffness ellipse in the plane normal to "
        "the tool axis with the nearest IK and with the optimised posture (principal "
        "stiffnesses and the stiffest direction's angle from the feed).",
        plot_redundancy,
    ),
    FigureSpec(
        "part",
        "The predicted part: material left on the walls and the floor along the path (> 0 "
        "proud of the nominal surface, < 0 overcut; the deflected edges' envelope, "
        "feedopt.part), and the floor of one law across the cut.",
        _plot_part,
    ),
)
