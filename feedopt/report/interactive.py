"""The report's interactive figures (Plotly, self-contained: no network at view time).

Plotly builds each figure's JSON here; :func:`interactive_figures` renders every figure to a
``<div>`` with its own inline ``<script>`` calling ``Plotly.newPlot``, and
:func:`plotly_script` gives plotly.js itself, to be inlined once in the page's ``<head>``.

What is drawn is decimated, not what is computed: a curve longer than its budget keeps, per
bucket of equal width in s, its first sample and the samples of every column's minimum and
maximum (:func:`decimate_minmax`), so peaks and drops survive; the active-constraint band is
drawn from runs of samples, not samples (:func:`constraint_runs`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio
from matplotlib.colors import to_hex

from feedopt.errors import InputError
from feedopt.report.data import LawSeries, ReportData
from feedopt.schedule.laws import LAWS

#: Most points of one drawn 2D curve (a law's feed or deflection against s).
MAX_POINTS_2D = 12_000
#: Most points of one law's 3D path (cut and air moves together).
MAX_POINTS_3D = 8_000
#: Most over-the-limit markers of one law.
MAX_MARKS = 2_000
#: Most runs of the active-constraint band (beyond: the constraint of most samples per bin).
MAX_BAND_RUNS = 2_000
_FALLBACK = ("#d62728", "#8c564b", "#e377c2", "#bcbd22", "#17becf")
_DASHES = ("solid", "dash", "dot", "dashdot", "longdash", "longdashdot")
_BAND_COLOURS = ("#e45756", "#4c78a8", "#f58518", "#72b7b2", "#54a24b", "#b279a2",
                 "#ff9da6", "#9d755d")
_AIR_COLOUR = "#b8b8b8"
_CONFIG = {"displaylogo": False, "responsive": True}
_FEED_SCALE = "Viridis"


@dataclass(frozen=True)
class InteractiveFigure:
    """One figure of report.html: ``html`` is a ``<div>`` with its own inline ``<script>``
    (no ``src``) that draws it with the page's plotly.js (:func:`plotly_script`)."""

    key: str
    title: str
    caption: str
    html: str


@dataclass(frozen=True)
class Runs:
    """Runs of equal codes along the samples: ``start`` and ``stop`` (exclusive) sample
    indices and the ``code`` of each run, (r,) each."""

    start: np.ndarray
    stop: np.ndarray
    code: np.ndarray


def plotly_script() -> str:
    """The full plotly.js bundled with the plotly package (inline it once per page)."""
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def bucket_index(x: np.ndarray, buckets: int) -> np.ndarray:
    """(n,) bucket of each ``x`` when [x[0], x[-1]] is cut into ``buckets`` of equal width
    (the last one closed)."""
    x = np.asarray(x, dtype=float)
    span = x[-1] - x[0]
    if not span > 0:
        return np.zeros(x.shape, dtype=np.int64)
    return np.clip(((x - x[0]) / span * buckets).astype(np.int64), 0, buckets - 1)


def bucket_count(max_points: int, n_columns: int) -> int:
    """Buckets :func:`decimate_minmax` cuts x into: each keeps at most 1 + 2 ``n_columns``
    samples, and the last sample is added."""
    return (max_points - 1) // (1 + 2 * n_columns)


def _columns(y_columns, n: int) -> np.ndarray:
    """(c, n) float array of the columns to keep the extremes of (InputError otherwise)."""
    cols = np.atleast_2d(np.asarray(y_columns, dtype=float))
    if cols.ndim != 2 or cols.shape[1] != n:
        raise InputError(f"decimate_minmax: y_columns must be columns of the {n} samples of x "
                         f"(a sequence of (n,) arrays), got shape {np.shape(y_columns)}")
    return cols


def _group_extreme(y: np.ndarray, start: np.ndarray, smallest: bool) -> np.ndarray:
    """Index of the first minimum (``smallest``) or maximum of ``y`` in each contiguous
    group beginning at ``start`` (NaN never chosen unless a group is all NaN)."""
    fill = np.inf if smallest else -np.inf
    v = np.where(np.isnan(y), fill, y)
    best = (np.minimum if smallest else np.maximum).reduceat(v, start)
    size = np.diff(np.append(start, v.size))
    hit = v == np.repeat(best, size)
    pos = np.where(hit, np.arange(v.size), v.size)
    return np.minimum.reduceat(pos, start)


def decimate_minmax(x: np.ndarray, y_columns: Sequence[np.ndarray] | np.ndarray,
                    max_points: int) -> np.ndarray:
    """Increasing indices of the samples to draw, at most ``max_points`` of them.

    Every sample when there are at most ``max_points``; else [x[0], x[-1]] is cut into
    buckets of equal width (:func:`bucket_index`) and each keeps its first sample and, for
    every column of ``y_columns``, the sample of its minimum and of its maximum (NaN
    ignored), plus the last sample: peaks and drops survive. ``x`` must not decrease.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    cols = _columns(y_columns, n)
    if max_points < 1 + 2 * cols.shape[0] + 1:
        raise InputError(f"decimate_minmax: max_points must be at least "
                         f"{2 + 2 * cols.shape[0]} for {cols.shape[0]} column(s), "
                         f"got {max_points}")
    if n <= max_points:
        return np.arange(n)
    if np.any(np.diff(x) < 0):
        raise InputError("decimate_minmax: x must not decrease (give the samples in order "
                         "of arc length)")
    bucket = bucket_index(x, bucket_count(max_points, cols.shape[0]))
    start = np.flatnonzero(np.diff(bucket, prepend=-1))
    keep = [start, [n - 1]]
    for y in cols:
        keep += [_group_extreme(y, start, True), _group_extreme(y, start, False)]
    return np.unique(np.concatenate(keep))


def constraint_runs(codes: np.ndarray) -> Runs:
    """The runs of equal values of ``codes`` (n,)."""
    codes = np.asarray(codes)
    start = np.flatnonzero(np.diff(codes, prepend=codes[:1] - 1) != 0) if codes.size else \
        np.zeros(0, np.int64)
    return Runs(start, np.append(start[1:], codes.size), codes[start])


def band_runs(x: np.ndarray, codes: np.ndarray, n_codes: int, max_runs: int) -> Runs:
    """:func:`constraint_runs` of ``codes``; when there are more than ``max_runs``, those of
    ``max_runs`` bins of equal width in ``x``, each given the code most of its samples have
    (``start``/``stop`` then index the first sample of a bin / after the last)."""
    runs = constraint_runs(codes)
    if runs.code.size <= max_runs:
        return runs
    b = bucket_index(x, max_runs)
    counts = np.bincount(b * n_codes + codes, minlength=max_runs * n_codes)
    dominant = counts.reshape(max_runs, n_codes).argmax(axis=1)
    per_sample = dominant[b]  # empty bins take no samples: runs of the filled ones
    return constraint_runs(per_sample)


def _breaks(idx: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Positions into the drawn samples ``idx`` of those in ``mask``, with -1 where the
    line must break (a sample outside ``mask`` lies between two drawn ones)."""
    pos = np.flatnonzero(mask[idx])
    if pos.size < 2:
        return pos
    outside = np.cumsum(~mask)
    gap = outside[idx[pos[1:]]] - outside[idx[pos[:-1]]] > 0
    out = np.full(pos.size + int(gap.sum()), -1, dtype=np.int64)
    shift = np.concatenate([[0], np.cumsum(gap)])
    out[np.arange(pos.size) + shift] = pos
    return out


def _take(values: np.ndarray, idx: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """``values[idx[pos]]`` as float32 with NaN where ``pos`` is -1 (a break)."""
    got = np.asarray(values, dtype=np.float32)[idx[np.maximum(pos, 0)]]
    got[pos < 0] = np.nan
    return got


def law_colour(law: str, index: int = 0) -> str:
    """The law's registry colour as CSS hex (the PNG figures' colour)."""
    spec = LAWS.get(law)
    return to_hex(spec.colour) if spec is not None else _FALLBACK[index % len(_FALLBACK)]


def _label(ls: LawSeries) -> str:
    return ls.law if ls.verified else f"{ls.law} (NOT verified)"


def _air(data: ReportData) -> np.ndarray:
    """(k,) bool: samples that do not cut (none without sample information)."""
    k = data.path_xyz_mm.shape[0]
    return np.zeros(k, bool) if data.samples is None else np.asarray(data.samples.air)


def _boundaries(air: np.ndarray, budget: int) -> np.ndarray:
    """The samples on both sides of every cut/air change, when there are at most
    ``budget`` (else none: decimation alone decides)."""
    change = np.flatnonzero(air[1:] != air[:-1])
    if 2 * change.size > budget:
        return np.zeros(0, np.int64)
    return np.concatenate([change, change + 1])


def _where(data: ReportData, idx: np.ndarray) -> dict:
    """Hover fields of the drawn samples ``idx``: ``text`` their program line label (a
    program only), ``hovertext`` the bound's active constraint (when the run gave them)."""
    info = data.samples
    if info is None:
        return {}
    out = {"hovertext": info.active_names_at(idx)}
    if info.line_numbers.size:
        out["text"] = info.labels_at(idx)
    return out


def _where_template(data: ReportData) -> str:
    """The hovertemplate part showing :func:`_where`'s fields."""
    info = data.samples
    if info is None:
        return ""
    return ("%{text}<br>" if info.line_numbers.size else "") + "limit: %{hovertext}<br>"


def _customdata(data: ReportData, ls: LawSeries, idx: np.ndarray) -> np.ndarray:
    """(m, 5) float32 hover columns: s [mm], t [s], feed, v_max [mm/s], deflection [mm]."""
    nan = np.full(idx.size, np.nan)
    t = ls.path_t_s[idx] if ls.path_t_s is not None else nan
    vmax = data.samples.v_max_mm_s[idx] if data.samples is not None else nan
    return np.column_stack([ls.s_mm[idx], t, ls.feed_mm_s[idx], vmax,
                            ls.deflection_mm[idx]]).astype(np.float32)


def _numbers_template(data: ReportData, ls: LawSeries) -> str:
    """The hovertemplate part showing :func:`_customdata` (the columns the run has)."""
    t = ", t %{customdata[1]:.3f} s" if ls.path_t_s is not None else ""
    vmax = ", v_max %{customdata[3]:.4g} mm/s" if data.samples is not None else ""
    return (f"s %{{customdata[0]:.2f}} mm{t}<br>feed %{{customdata[2]:.4g}} mm/s{vmax}<br>"
            "deflection %{customdata[4]:.4g} mm")


def _cut_range(data: ReportData, air: np.ndarray) -> tuple[float, float]:
    """Feed range [mm/s] over the cutting samples of every law and the bound."""
    cut = ~air if (~air).any() else np.ones_like(air)
    vals = [ls.feed_mm_s[cut] for ls in data.laws]
    if data.samples is not None:
        vals.append(data.samples.v_max_mm_s[cut])
    top = np.concatenate(vals)
    top = top[np.isfinite(top)]
    hi = float(top.max()) if top.size else 1.0
    return 0.0, hi * 1.08 if hi > 0 else 1.0


def _render(fig: go.Figure, key: str) -> str:
    """The figure as a ``<div>`` with an inline script (plotly.js not included)."""
    return pio.to_html(fig, config=_CONFIG, include_plotlyjs=False, full_html=False,
                       div_id=f"feedopt-{key}", default_height=f"{fig.layout.height or 450}px")


def _default_law(data: ReportData) -> int:
    """Index of the law shown first: the fastest one summary.json says was exported (the
    program to run), else the first law."""
    rows = data.summary.get("laws", {}) if isinstance(data.summary, dict) else {}
    times = [(rows.get(ls.law, {}).get("cycle_time_s") or np.inf, k)
             for k, ls in enumerate(data.laws) if rows.get(ls.law, {}).get("exported")]
    return min(times)[1] if times else 0


def _dilate(mask: np.ndarray) -> np.ndarray:
    """``mask`` and the samples next to it (an air move's line reaches the cut on both
    sides)."""
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    return out


def _path_line(data: ReportData, ls: LawSeries, idx: np.ndarray, pos: np.ndarray) -> dict:
    """The coordinates and hover of the drawn samples ``idx[pos]`` (breaks at -1)."""
    xyz = data.path_xyz_mm
    at = idx[np.maximum(pos, 0)]
    cd = _customdata(data, ls, at)
    cd[pos < 0] = np.nan
    where = {key: np.where(pos < 0, "", v) for key, v in _where(data, at).items()}
    return dict(x=_take(xyz[:, 0], idx, pos), y=_take(xyz[:, 1], idx, pos),
                z=_take(xyz[:, 2], idx, pos), customdata=cd, **where)


def _marks(data: ReportData, ls: LawSeries, air: np.ndarray, tag: str) -> go.Scatter3d:
    """Markers where the law's deflection is largest and where the bound is lowest on the
    cut ("where the feed drops")."""
    k = [int(np.nanargmax(ls.deflection_mm))]
    names = ["largest deflection"]
    if data.samples is not None and (~air).any():
        k.append(int(np.argmin(np.where(air, np.inf, data.samples.v_max_mm_s))))
        names.append("lowest bound v_max")
    at = np.array(k)
    line = _path_line(data, ls, at, np.arange(at.size))
    line["text"] = np.strings.add(np.strings.add(np.array(names), "<br>"), line["text"]) \
        if "text" in line else np.array(names)
    where = "limit: %{hovertext}<br>" if data.samples is not None else ""
    return go.Scatter3d(
        **line, mode="markers", name="largest deflection, lowest bound", legendgroup=ls.law,
        hovertemplate="%{text}<br>" + where + _numbers_template(data, ls) + tag,
        marker=dict(size=6, color="#d62728", symbol="diamond"))


def _feed_colours(data: ReportData, air: np.ndarray) -> tuple[float, float]:
    """Feed colour range [mm/s]: the cutting feeds of every law, from their 2nd percentile
    (start/stop ramps and stops take the lowest colour, not the scale)."""
    cut = ~air if (~air).any() else np.ones_like(air)
    feeds = np.concatenate([ls.feed_mm_s[cut] for ls in data.laws])
    feeds = feeds[np.isfinite(feeds)]
    if not feeds.size:
        return 0.0, 1.0
    lo, hi = float(np.percentile(feeds, 2)), float(feeds.max())
    return (lo, hi) if hi > lo else (0.0, max(hi, 1.0))


def _path_traces(data: ReportData, k: int, air: np.ndarray, colours: tuple[float, float],
                 visible: bool) -> list:
    """One law's 3D traces: cut samples coloured by feed, air moves thin and grey, marks."""
    ls = data.laws[k]
    bnd = _boundaries(air, MAX_POINTS_3D // 4)
    idx = np.union1d(decimate_minmax(ls.s_mm, [ls.feed_mm_s, ls.deflection_mm],
                                     MAX_POINTS_3D - bnd.size), bnd)
    cut = _path_line(data, ls, idx, _breaks(idx, ~air))
    lo, hi = colours
    hover = _where_template(data) + _numbers_template(data, ls) + f"<extra>{ls.law}</extra>"
    traces = [go.Scatter3d(
        **cut, mode="lines", name=f"{_label(ls)}: cutting", legendgroup=ls.law,
        hovertemplate=hover, showlegend=False,  # a colour-array line has no legend colour
        line=dict(color=np.nan_to_num(cut["customdata"][:, 2], nan=lo), colorscale=_FEED_SCALE,
                  cmin=lo, cmax=hi, width=6,
                  colorbar=dict(title=dict(text="feed [mm/s]"), thickness=14)))]
    if air.any():
        traces.append(go.Scatter3d(
            **_path_line(data, ls, idx, _breaks(idx, _dilate(air))), mode="lines",
            name="air moves (rapids, plunges)", legendgroup=ls.law,
            line=dict(color=_AIR_COLOUR, width=2), hovertemplate="air move<br>" + hover))
    traces.append(_marks(data, ls, air, f"<extra>{ls.law}</extra>"))
    for trace in traces:
        trace.visible = visible
    return traces


def _scene(xyz: np.ndarray) -> dict:
    """Equal scale on the three axes; a flat path's box is given some height (a tenth of
    its width) so that it is seen from above at an angle, not edge-on."""
    lo, hi = np.nanmin(xyz, axis=0), np.nanmax(xyz, axis=0)
    mid, half = (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-6)
    half = np.maximum(half * 1.02, 0.1 * half.max())
    ratio = half / half.max()
    axes = {f"{a}axis": dict(title=f"{a} [mm]", range=[float(m - h), float(m + h)])
            for a, m, h in zip("xyz", mid, half, strict=True)}
    return dict(aspectmode="manual", aspectratio=dict(zip("xyz", ratio.tolist(), strict=True)),
                camera=dict(eye=dict(x=0.7, y=-1.05, z=0.8)), **axes)


def path_figure(data: ReportData) -> go.Figure:
    """The 3D path coloured by the feed on cutting samples, one trace set per law and a
    dropdown choosing the law (laws that coincide are then told apart)."""
    air = _air(data)
    colours = _feed_colours(data, air)
    shown = _default_law(data)
    sets = [_path_traces(data, k, air, colours, k == shown) for k in range(len(data.laws))]
    owner = np.repeat(np.arange(len(sets)), [len(s) for s in sets])
    buttons = [dict(label=_label(ls), method="restyle",
                    args=[{"visible": (owner == k).tolist()}]) for k, ls in enumerate(data.laws)]
    fig = go.Figure([t for s in sets for t in s])
    fig.update_layout(
        template="plotly_white", height=560, margin=dict(l=0, r=0, t=40, b=0),
        scene=_scene(data.path_xyz_mm),
        legend=dict(x=0, y=0, bgcolor="rgba(255,255,255,0.7)"),
        updatemenus=[dict(buttons=buttons, active=shown, x=0, y=1.0, xanchor="left",
                          yanchor="bottom", direction="down", showactive=True)])
    return fig


def _curve(x: np.ndarray, y: np.ndarray, **kw) -> go.Scatter | go.Scattergl:
    """A 2D line, decimated to :data:`MAX_POINTS_2D` (WebGL when it is long)."""
    idx = decimate_minmax(x, [y], MAX_POINTS_2D)
    kind = go.Scattergl if idx.size > 4000 else go.Scatter
    per_point = kw.pop("per_point", None)
    if per_point is not None:
        kw.update(per_point(idx))
    return kind(x=x[idx].astype(np.float32), y=y[idx].astype(np.float32), mode="lines", **kw)


def _band(data: ReportData, s_mm: np.ndarray, air: np.ndarray) -> list[go.Bar]:
    """The active constraint along s as a strip of bars, one trace per constraint (and
    one for the air moves, which no constraint limits)."""
    info = data.samples
    names = [*info.constraints, "air move"]
    codes = np.where(air, len(info.constraints), info.active).astype(np.int64)
    runs = band_runs(s_mm, codes, len(names), MAX_BAND_RUNS)
    s0 = s_mm[runs.start]
    s1 = s_mm[np.minimum(runs.stop, s_mm.size - 1)]
    bars = []
    for c in np.unique(runs.code):
        on = runs.code == c
        colour = _AIR_COLOUR if c == len(info.constraints) else \
            _BAND_COLOURS[int(c) % len(_BAND_COLOURS)]
        bars.append(go.Bar(
            x=s0[on].astype(np.float32), width=(s1[on] - s0[on]).astype(np.float32),
            y=np.ones(int(on.sum()), np.float32), offset=0, marker=dict(color=colour, line=dict(
                width=0)), name=f"limit: {names[c]}", legendgroup="band",
            customdata=np.column_stack([s0[on], s1[on]]).astype(np.float32),
            hovertemplate=f"{names[c]}" + " (s %{customdata[0]:.1f}-%{customdata[1]:.1f} mm)"
            "<extra></extra>", xaxis="x", yaxis="y2"))
    return bars


def _range_buttons(lo: float, hi: float) -> list[dict]:
    """Buttons switching the feed axis between cutting feeds and every feed."""
    return [dict(type="buttons", direction="right", x=0.0, y=1.02, xanchor="left",
                 yanchor="bottom", active=0, buttons=[
                     dict(label="cutting feeds", method="relayout",
                          args=[{"yaxis.range": [lo, hi], "yaxis.autorange": False}]),
                     dict(label="include rapids", method="relayout",
                          args=[{"yaxis.autorange": True}])])]


def feed_figure(data: ReportData) -> go.Figure:
    """Every law's feed against s with the bound v_max and the active constraint as a band
    under the axis; the feed axis spans the cutting feeds (a button includes the rapids)."""
    air = _air(data)
    s = data.laws[0].s_mm
    traces: list = []
    if data.samples is not None:
        traces.append(_curve(s, data.samples.v_max_mm_s, name="bound v_max",
                             line=dict(color="#444444", width=1.5, dash="dot"),
                             per_point=lambda i: _where(data, i),
                             hovertemplate="v_max %{y:.4g} mm/s<br>" + _where_template(data)
                             + "<extra></extra>"))
    for k, ls in enumerate(data.laws):
        traces.append(_curve(s, ls.feed_mm_s, name=_label(ls), legendgroup=ls.law,
                             line=dict(color=law_colour(ls.law, k), width=2,
                                       dash=_DASHES[k % len(_DASHES)]),
                             hovertemplate="%{y:.4g} mm/s"))
    band = _band(data, s, air) if data.samples is not None else []
    fig = go.Figure(traces + band)
    lo, hi = _cut_range(data, air)
    fig.update_layout(
        template="plotly_white", height=460, margin=dict(l=60, r=10, t=40, b=40),
        hovermode="x unified", barmode="overlay", bargap=0,
        xaxis=dict(title="s [mm]", anchor="y2", range=[float(s[0]), float(s[-1])],
                   hoverformat=".2f"),
        yaxis=dict(title="feed [mm/s]", domain=[0.14, 1.0],
                   **({"range": [lo, hi]} if air.any() else {})),
        yaxis2=dict(domain=[0.0, 0.08], range=[0, 1], showticklabels=False, fixedrange=True,
                    showgrid=False, zeroline=False, title=dict(text="limit", font_size=11)),
        legend=dict(orientation="h", y=-0.18, x=0),
        updatemenus=_range_buttons(lo, hi) if air.any() else [])
    return fig


def deflection_figure(data: ReportData) -> go.Figure:
    """Every law's predicted deflection against s, the limit, and where it is exceeded."""
    limit = data.deflection_limit_mm
    fig = go.Figure()
    for k, ls in enumerate(data.laws):
        colour = law_colour(ls.law, k)
        fig.add_trace(_curve(ls.s_mm, ls.deflection_mm, name=_label(ls), legendgroup=ls.law,
                             line=dict(color=colour, width=2, dash=_DASHES[k % len(_DASHES)]),
                             hovertemplate="%{y:.4g} mm"))
        over = np.flatnonzero(ls.deflection_mm > limit * (1 + 1e-9))
        if over.size:
            i = over[decimate_minmax(ls.s_mm[over], [ls.deflection_mm[over]], MAX_MARKS)]
            fig.add_trace(go.Scatter(
                x=ls.s_mm[i].astype(np.float32), y=ls.deflection_mm[i].astype(np.float32),
                mode="markers", name=f"{ls.law} over the limit", legendgroup=ls.law,
                marker=dict(color="#d62728", symbol="x", size=4, opacity=0.7),
                **_where(data, i),
                customdata=(ls.deflection_mm[i] / limit).astype(np.float32),
                hovertemplate="%{y:.4g} mm = %{customdata:.3f} x limit<br>"
                + _where_template(data)))
    fig.add_hline(y=limit, line=dict(color="#d62728", dash="dash", width=1.5),
                  annotation_text=f"limit {limit:g} mm", annotation_position="top left")
    fig.update_layout(
        template="plotly_white", height=380, margin=dict(l=60, r=10, t=30, b=40),
        hovermode="x unified", yaxis_title="deflection [mm]",
        xaxis=dict(title="s [mm]", range=[float(data.laws[0].s_mm[0]),
                                          float(data.laws[0].s_mm[-1])], hoverformat=".2f"),
        legend=dict(orientation="h", y=-0.2, x=0))
    return fig


def interactive_figures(data: ReportData) -> list[InteractiveFigure]:
    """The report's interactive figures, each a self-contained ``<div>`` + inline script."""
    made = [
        ("path3d", "Path in 3D, coloured by feed", path_figure,
         "The tool path in the robot base frame [mm], coloured by the chosen law's feed on "
         "cutting moves; air moves thin and grey. Hover: s, t, program line, feed, bound "
         "v_max, the constraint that sets it, predicted deflection. Red diamonds: the "
         "largest deflection and the lowest bound. Choose the law top left."),
        ("feed", "Feed along the path", feed_figure,
         "Each law's feed against arc length with the bound v_max(s) (dotted); the strip "
         "under the axis shows which constraint sets the bound. The axis spans the cutting "
         "feeds; 'include rapids' shows all. Drag to zoom, double-click to reset."),
        ("deflection", "Predicted deflection", deflection_figure,
         "Predicted static deflection at the commanded feed against the limit (dashed); "
         "red crosses mark samples over the limit."),
    ]
    return [InteractiveFigure(key, title, caption, _render(build(data), key))
            for key, title, build, caption in made]


def warm_up() -> None:
    """Build a tiny figure of every kind drawn here: plotly loads its validators on first
    use (~0.2 s), which the report child started before planning does meanwhile."""
    fig = go.Figure([go.Scatter3d(x=[0], y=[0], z=[0], line=dict(color=[0], colorbar=dict(
        title=dict(text="")))), go.Scatter(x=[0], y=[0]), go.Scattergl(x=[0], y=[0]),
        go.Bar(x=[0], y=[0])])
    fig.update_layout(template="plotly_white", scene=dict(camera=dict(eye=dict(x=1))),
                      updatemenus=[dict(buttons=[dict(label="")])], yaxis2=dict(domain=[0, 1]))
    fig.add_hline(y=0)
    _render(fig, "warm-up")
