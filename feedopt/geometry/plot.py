"""Figure of a path: XY view with its blends and the curvature vector along s (thesis
Fig. 3.4-3.8)."""

from __future__ import annotations

from pathlib import Path as FilePath

import numpy as np
from matplotlib.figure import Figure

from feedopt.geometry.path import Path
from feedopt.geometry.registry import LINE, blend_kinds, segment_kinds
from feedopt.units import MM, MM_PER_M

LINE_COLOUR = "0.55"
UNREGISTERED_COLOUR = "k"  # a kind no longer in the registry is still drawn, and labelled so


def kind_colours(kinds: tuple[str, ...] | list[str]) -> dict[str, tuple[str, str]]:
    """Colour and legend label of every kind in ``kinds``: "line" first, then the blend and
    segment kinds in registry order with their registered colour, then any kind not in the
    registry."""
    present = set(kinds)
    out = {LINE: (LINE_COLOUR, LINE)} if LINE in present else {}
    for blend in (*blend_kinds(), *segment_kinds()):
        if blend.name in present:
            out[blend.name] = (blend.colour, blend.name)
    for kind in dict.fromkeys(kinds):
        if kind not in out:
            out[kind] = (UNREGISTERED_COLOUR, f"{kind} (unregistered)")
    return out


def plot_path(path: Path, out: str | FilePath, spacing: float = 1e-4,
              waypoints: np.ndarray | None = None, title: str | None = None) -> None:
    """Write a PNG of :func:`path_figure` to ``out``."""
    path_figure(path, spacing, waypoints, title).savefig(out, dpi=120)


def path_figure(path: Path, spacing: float = 1e-4, waypoints: np.ndarray | None = None,
                title: str | None = None) -> Figure:
    """Left, the path in the XY plane [mm] coloured by segment kind, every kind in its
    registered colour (3D paths are shown projected); right, curvature components and
    magnitude [1/mm] against s [mm]."""
    pts = path.sample(spacing)
    fig = Figure(figsize=(12, 4.8), layout="constrained")
    ax, axk = fig.subplots(1, 2, width_ratios=[1.3, 1])
    xy = pts.position[:, :2] * MM_PER_M
    kinds = np.array(path.segment_kind)[pts.segment]
    for kind, (colour, label) in kind_colours(path.segment_kind).items():
        mask = kinds == kind
        unsampled = not mask.any()
        if unsampled:  # segments shorter than the spacing: mark where they are
            mask = _nearest(pts.s, path, kind)
        # break the polyline between separate pieces of the same kind
        y = np.where(mask[:, None], xy, np.nan)
        ax.plot(y[:, 0], y[:, 1], color=colour, lw=2 if kind != LINE else 1.2, label=label,
                marker="o" if unsampled else None)
    if waypoints is not None:
        wp = np.asarray(waypoints) * MM_PER_M
        ax.plot(wp[:, 0], wp[:, 1], "k:", lw=0.8, marker="o", ms=3, label="waypoints")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "path (XY view)")
    s = pts.s * MM_PER_M
    k = pts.curvature * MM  # 1/m -> 1/mm: times metres per millimetre
    for i, name in enumerate("xyz"):
        if np.any(k[:, i] != 0):
            axk.plot(s, k[:, i], lw=1, label=f"k{name}")
    axk.plot(s, np.linalg.norm(k, axis=1), "k", lw=1.2, label="|k|")
    axk.set_xlabel("s [mm]")
    axk.set_ylabel("curvature [1/mm]")
    axk.set_title("curvature vector d2p/ds2")
    axk.legend(loc="best", fontsize=8)
    axk.grid(alpha=0.3)
    return fig


def _nearest(s: np.ndarray, path: Path, kind: str) -> np.ndarray:
    """Samples nearest to the start of every segment of ``kind`` (n,) bool."""
    out = np.zeros(s.size, dtype=bool)
    starts = path.segment_start[[i for i, k in enumerate(path.segment_kind) if k == kind]]
    out[np.clip(np.searchsorted(s, starts), 0, s.size - 1)] = True
    return out


def plot_program_path(result, out: str | FilePath, spacing: float = 1e-4,
                      title: str | None = None) -> None:
    """Write a PNG of :func:`program_figure` to ``out``."""
    program_figure(result, spacing, title).savefig(out, dpi=120)


def program_figure(result, spacing: float = 1e-4, title: str | None = None) -> Figure:
    """The path of a G-code program (a :class:`~feedopt.geometry.program_path.ProgramPath`):
    left, XY view by segment kind with the programmed move ends; middle, |curvature| along s
    (log scale) with the air moves shaded; right (when the program has smoothed chains), the
    first chain's curvature against the discrete curvature of its programmed polyline
    (2 sin(turn/2) / mean of the two chords at each vertex): the tiny-blend spikes the
    smoothing avoids."""
    path, moves = result.path, result.moves
    chains = result.chains
    pts = path.sample(spacing)
    fig = Figure(figsize=(17 if chains else 12, 4.8), layout="constrained")
    axes = fig.subplots(1, 3 if chains else 2, width_ratios=[1.3, 1, 1][:3 if chains else 2])
    ax, axk = axes[0], axes[1]
    xy = pts.position[:, :2] * MM_PER_M
    kinds = np.array(path.segment_kind)[pts.segment]
    for kind, (colour, label) in kind_colours(path.segment_kind).items():
        y = np.where((kinds == kind)[:, None], xy, np.nan)
        ax.plot(y[:, 0], y[:, 1], color=colour, lw=2 if kind != LINE else 1.2, label=label)
    ends = path.evaluate(moves.s_start).position * MM_PER_M
    ax.plot(ends[:, 0], ends[:, 1], "k.", ms=2, label="move starts")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "program path (XY view)")
    s = pts.s * MM_PER_M
    kappa = np.linalg.norm(pts.curvature, axis=1) * MM
    axk.semilogy(s, np.maximum(kappa, 1e-6), "k", lw=1)
    air = moves.category[moves.index_at(pts.s)] != "cut"
    axk.fill_between(s, 1e-6, kappa.max() * 2 + 1e-6, where=air, color="0.85", step="mid",
                     label="rapid / plunge / retract")
    axk.set_ylim(1e-4, kappa.max() * 2 + 1e-4)
    axk.set_xlabel("s [mm]")
    axk.set_ylabel("|curvature| [1/mm]")
    axk.set_title("curvature along the path (G2: no jumps)")
    axk.legend(loc="best", fontsize=8)
    axk.grid(alpha=0.3, which="both")
    if chains:
        _chain_panel(axes[2], result, chains[0], spacing)
    return fig


def _chain_panel(ax, result, chain, spacing: float) -> None:
    moves = result.moves
    i0, i1 = chain.first_move, chain.first_move + chain.moves
    s0 = moves.s_start[i0]
    s1 = moves.s_start[i1] if i1 < len(moves) else result.path.length
    s = np.arange(s0, s1, min(spacing, (s1 - s0) / 2000))
    k = np.linalg.norm(result.path.evaluate(s).curvature, axis=1) * MM
    ax.plot((s - s0) * MM_PER_M, k, "tab:cyan", lw=1.5, label="smoothed spline")
    d = np.diff(chain.points, axis=0)
    chord = np.linalg.norm(d, axis=1)
    u = d / chord[:, None]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0))
    discrete = 2.0 * np.sin(0.5 * turn) / (0.5 * (chord[:-1] + chord[1:])) * MM
    ax.plot((moves.s_start[i0 + 1:i1] - s0) * MM_PER_M, discrete, "k.", ms=3,
            label="polyline: 2 sin(turn/2) / chord")
    ax.set_xlabel("s from the chain start [mm]")
    ax.set_ylabel("|curvature| [1/mm]")
    ax.set_title(f"{chain.moves} G1 moves, lines {chain.first_line}-{chain.last_line}, "
                 f"smoothed within {chain.deviation * MM_PER_M:.2g} mm")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
