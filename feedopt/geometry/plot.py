"""Figure of a path: XY view with its blends and the curvature vector along s (thesis
Fig. 3.4-3.8)."""

from __future__ import annotations

from pathlib import Path as FilePath

import numpy as np
from matplotlib.figure import Figure

from feedopt.geometry.path import Path

_COLOURS = {"line": "0.55", "circle": "tab:red", "bezier4": "tab:orange",
            "bezier5": "tab:green", "varying_radius": "tab:blue"}


def plot_path(path: Path, out: str | FilePath, spacing: float = 1e-4,
              waypoints: np.ndarray | None = None, title: str | None = None) -> None:
    """Write a PNG: left, the path in the XY plane [mm] coloured by segment kind (3D paths are
    shown projected); right, curvature components and magnitude [1/mm] against s [mm]."""
    pts = path.sample(spacing)
    fig = Figure(figsize=(12, 4.8), layout="constrained")
    ax, axk = fig.subplots(1, 2, width_ratios=[1.3, 1])
    xy = pts.position[:, :2] * 1e3
    kinds = np.array(path.segment_kind)[pts.segment]
    seen = set()
    for kind, colour in _COLOURS.items():
        mask = kinds == kind
        if not mask.any():
            continue
        # break the polyline between separate pieces of the same kind
        y = np.where(mask[:, None], xy, np.nan)
        ax.plot(y[:, 0], y[:, 1], color=colour, lw=2 if kind != "line" else 1.2,
                label=kind if kind not in seen else None)
        seen.add(kind)
    if waypoints is not None:
        wp = np.asarray(waypoints) * 1e3
        ax.plot(wp[:, 0], wp[:, 1], "k:", lw=0.8, marker="o", ms=3, label="waypoints")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "path (XY view)")
    s = pts.s * 1e3
    k = pts.curvature * 1e-3
    for i, name in enumerate("xyz"):
        if np.any(k[:, i] != 0):
            axk.plot(s, k[:, i], lw=1, label=f"k{name}")
    axk.plot(s, np.linalg.norm(k, axis=1), "k", lw=1.2, label="|k|")
    axk.set_xlabel("s [mm]")
    axk.set_ylabel("curvature [1/mm]")
    axk.set_title("curvature vector d2p/ds2")
    axk.legend(loc="best", fontsize=8)
    axk.grid(alpha=0.3)
    fig.savefig(out, dpi=120)
