"""The report's figure of the predicted part (:mod:`feedopt.part`): the walls and the floor
along the path for every law, and a map of the floor of one law."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from feedopt.report.data import ReportData


def plot_part(data: ReportData, new_figure) -> Figure | None:
    """Material left on the left and right walls and the floor vs arc length (a line per law)
    and the floor of the verdict's law across the cut (a map). None without a part."""
    p = data.part
    if p is None or not p.laws:
        return None
    fig = new_figure(10, 10, 4, 1)
    axes = fig.subplots(4, 1)
    rows = (("left wall (+y, up-milling side)", p.left_mm),
            ("right wall (-y, down-milling side)", p.right_mm),
            ("floor (mean across the cut)", p.floor_mm))
    for ax, (title, values) in zip(axes[:3], rows, strict=True):
        for k, law in enumerate(p.laws):
            ax.plot(p.s_mm[k], values[k], lw=1.0, label=law,
                    ls=("-", "--", "-.", ":")[k % 4])
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel("material left [mm]")
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
    axes[2].set_xlabel("s [mm]")
    axes[0].legend(loc="lower right", fontsize=7, ncol=len(p.laws))
    ax = axes[3]
    ok = np.isfinite(p.map_floor_mm)
    if ok.any():
        sc = ax.scatter(p.map_xy_mm[ok, 0], p.map_xy_mm[ok, 1], c=p.map_floor_mm[ok], s=3,
                        cmap="viridis")
        fig.colorbar(sc, ax=ax, label="floor, material left [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"floor of the {p.map_law} law across the cut (base frame)", fontsize=9)
    return fig
