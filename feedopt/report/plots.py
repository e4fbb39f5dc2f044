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
from feedopt.schedule.laws import LAWS

_FALLBACK = ["tab:red", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
_LIMIT_STYLE = {"color": "tab:red", "linestyle": "--", "linewidth": 1.2}
_DPI = 100
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


def _plot(ax, x: np.ndarray, y: np.ndarray, **kw):
    i = _env(y)
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


def plot_path_feed(data: ReportData) -> Figure:
    """The path (projected on its two widest base axes) coloured by feed, one panel per law.

    Blends (samples whose segment kind is not ``"line"``) are underlaid in grey.
    """
    kind = data.segment_kind
    n_pts = kind.shape[0]
    # Long paths: every step-th sample plus both samples around each change of segment kind.
    step = max(1, -(-n_pts // MAX_PATH_SEGMENTS))
    change = np.flatnonzero(kind[1:] != kind[:-1])
    keep = np.unique(np.concatenate([np.arange(0, n_pts, step), change, change + 1, [n_pts - 1]]))
    xyz = data.path_xyz_mm[keep]
    i, j = _plane_axes(xyz)
    pts = xyz[:, [i, j]]
    segs = np.stack([pts[:-1], pts[1:]], axis=1)
    blend = kind[keep] != "line"
    blend_seg = blend[:-1] & blend[1:]
    n = len(data.laws)
    ncols = min(n, 2)
    nrows = -(-n // ncols)
    fig = _new_figure(6.0 * ncols, 3.6 * nrows, nrows, ncols,
                      Margins(right=0.1, hgap=0.9, wgap=0.95))
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    feeds = np.concatenate([ls.feed_mm_s for ls in data.laws])
    norm = Normalize(vmin=float(np.min(feeds)), vmax=float(np.max(feeds)))
    if norm.vmin == norm.vmax:
        norm = Normalize(vmin=norm.vmin - 0.5, vmax=norm.vmax + 0.5)
    names = "xyz"
    lc = None
    for ax, ls in zip(axes, data.laws, strict=False):
        if blend_seg.any():
            ax.add_collection(
                LineCollection(segs[blend_seg], colors="0.8", linewidths=7, zorder=1,
                               label="blend")
            )
        feed = ls.feed_mm_s[keep]
        seg_feed = 0.5 * (feed[:-1] + feed[1:])
        lc = LineCollection(segs, array=seg_feed, cmap="viridis", norm=norm, linewidths=2.5,
                            zorder=2)
        ax.add_collection(lc)
        ax.autoscale_view()
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(_label(ls))
        ax.set_xlabel(f"{names[i]} [mm] (robot base)")
        ax.set_ylabel(f"{names[j]} [mm] (robot base)")
        if blend_seg.any():
            ax.legend(loc="best", fontsize="small")
    for ax in axes[n:]:
        ax.set_visible(False)
    if lc is not None:
        fig.colorbar(lc, ax=axes[:n].tolist(), label="feed [mm/s]", shrink=0.9)
    return fig


def plot_deflection(data: ReportData) -> Figure:
    """Predicted deflection vs s: constant feed against each law, limit line (Fig. 3.18/4.4)."""
    const = _baseline(data)
    others = [ls for ls in data.laws if ls is not const] or [const]
    n = len(others)
    fig = _new_figure(8.0, 2.4 * n + 0.6, n, 1, Margins(top=0.15, hgap=0.15))
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True, squeeze=False)).ravel()
    for k, (ax, ls) in enumerate(zip(axes, others, strict=True)):
        if const is not None and ls is not const:
            _plot(ax, const.s_mm, const.deflection_mm, color=law_color(const.law), lw=1.0,
                    label=_label(const))
        _plot(ax, ls.s_mm, ls.deflection_mm, color=law_color(ls.law, k), lw=1.4, label=_label(ls))
        ax.axhline(data.deflection_limit_mm, label=f"limit {data.deflection_limit_mm:g} mm",
                   **_LIMIT_STYLE)
        ax.set_ylabel("deflection [mm]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("arc length s [mm]")
    return fig


def plot_feed(data: ReportData) -> Figure:
    """Feed vs arc length and vs time, every law (Fig. 3.19/4.5)."""
    fig = _new_figure(8.0, 6.0, 2, 1, Margins(top=0.15))
    ax_s, ax_t = fig.subplots(2, 1)
    for k, ls in enumerate(data.laws):
        c = law_color(ls.law, k)
        _plot(ax_s, ls.s_mm, ls.feed_mm_s, color=c, lw=1.3, label=_label(ls))
        _plot(ax_t, ls.t_s, ls.feed_t_mm_s, color=c, lw=1.3, label=_label(ls))
    ax_s.set_xlabel("arc length s [mm]")
    ax_t.set_xlabel("time t [s]")
    for ax in (ax_s, ax_t):
        ax.set_ylabel("feed [mm/s]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    return fig


def plot_accel_jerk(data: ReportData) -> Figure:
    """Tangential acceleration and jerk vs time, every law."""
    fig = _new_figure(8.0, 6.0, 2, 1, Margins(left=1.0, top=0.15, hgap=0.15))
    ax_a, ax_j = fig.subplots(2, 1, sharex=True)
    for k, ls in enumerate(data.laws):
        c = law_color(ls.law, k)
        _plot(ax_a, ls.t_s, ls.accel_mm_s2, color=c, lw=1.2, label=_label(ls))
        _plot(ax_j, ls.t_s, ls.jerk_mm_s3, color=c, lw=1.2, label=_label(ls))
    ax_a.set_ylabel("tangential acceleration [mm/s^2]")
    ax_j.set_ylabel("tangential jerk [mm/s^3]")
    ax_j.set_xlabel("time t [s]")
    for ax in (ax_a, ax_j):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    return fig


def plot_joint_velocity(data: ReportData) -> Figure:
    """Joint velocities vs time against their limits, one panel per joint."""
    joints = data.joint_velocity_limit_deg_s.size
    rows = max(1, -(-joints // 3))
    fig = _new_figure(11.0, 2.75 * rows, rows, 3, Margins(top=0.4, hgap=0.65, wgap=0.8))
    axes = fig.subplots(rows, 3, sharex=True, squeeze=False).ravel()
    for ax in axes[joints:]:
        ax.set_visible(False)
    for j, ax in enumerate(axes[:joints]):
        lim = data.joint_velocity_limit_deg_s[j]
        for k, ls in enumerate(data.laws):
            _plot(ax, ls.t_s, ls.joint_velocity_deg_s[:, j], color=law_color(ls.law, k), lw=1.1,
                    label=_label(ls))
        peak = max(float(np.max(np.abs(ls.joint_velocity_deg_s[:, j]))) for ls in data.laws)
        unit = f"{data.joint_unit(j)}/s"
        ax.axhline(lim, label=f"limit {lim:g} {unit}", **_LIMIT_STYLE)
        ax.axhline(-lim, **_LIMIT_STYLE)
        ax.set_title(f"A{j + 1}: peak {peak:.3g} {unit} = {peak / lim:.2%} of {lim:g}"
                     if lim > 0 else f"A{j + 1}", fontsize="medium")
        ax.set_ylabel(f"velocity [{unit}]")
        ax.grid(alpha=0.3)
        # The limits are usually far above milling speeds: zoom on the data, say so in title.
        span = max(peak * 1.3, 1e-9)
        ax.set_ylim(-min(span, 1.1 * lim), min(span, 1.1 * lim))
    for ax in axes[max(0, joints - 3):joints]:
        ax.set_xlabel("time t [s]")
    axes[0].legend(loc="best", fontsize="x-small")
    return fig


@dataclass(frozen=True)
class FigureSpec:
    """A report figure: file key, caption, and the function that draws it."""

    key: str
    caption: str
    draw: object


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


FIGURES: tuple[FigureSpec, ...] = (
    FigureSpec(
        "path",
        "Tool path in the robot base frame, coloured by commanded feed, one panel per law; "
        "blends are underlaid in grey.",
        plot_path_feed,
    ),
    FigureSpec(
        "deflection",
        "Predicted static deflection vs arc length at the commanded feed: constant feed "
        "against each law, with the deflection limit (thesis Fig. 3.18 / 4.4).",
        plot_deflection,
    ),
    FigureSpec(
        "feed",
        "Commanded feed vs arc length (top) and vs time (bottom) (thesis Fig. 3.19 / 4.5).",
        plot_feed,
    ),
    FigureSpec(
        "accel_jerk",
        "Tangential acceleration (top) and jerk (bottom) vs time.",
        plot_accel_jerk,
    ),
    FigureSpec(
        "joints",
        "Joint velocities vs time against the joint velocity limits (dashed); the axes are "
        "zoomed on the data when the limits are far away (see each panel's title).",
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
)
