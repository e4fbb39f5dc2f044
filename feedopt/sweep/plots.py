"""Heat maps of a sweep: the objective over every pair of swept fields.

A pair's map shows, per cell, the best (smallest) objective over the other swept fields, so
a cell is grey only when no point with those two values is feasible; a red frame marks
the best point. A sweep of a single field gets a curve instead. Written with matplotlib (Agg).
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from feedopt.outfile import write_atomically
from feedopt.sweep.grid import Grid, point_key
from feedopt.sweep.objective import Objective
from feedopt.sweep.table import Row

#: Largest number of cells whose value is written into the map.
_ANNOTATE_CELLS = 150


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name)


def plot_names(grid: Grid) -> list[tuple[str, tuple[int, ...]]]:
    """File name and axes (indices into ``grid.axes``) of every plot of ``grid``."""
    varied = [i for i, a in enumerate(grid.axes) if len(a.values) > 1]
    if len(varied) == 1:
        return [(f"sweep_{_safe(grid.axes[varied[0]].name)}.png", (varied[0],))]
    return [(f"heatmap_{_safe(grid.axes[i].name)}__{_safe(grid.axes[j].name)}.png", (i, j))
            for i, j in itertools.combinations(varied, 2)]


def objective_array(grid: Grid, rows: dict[tuple[float, ...], Row],
                    objective: Objective) -> np.ndarray:
    """The objective at every grid point (``grid.shape``), NaN where it is not a candidate."""
    out = np.full(grid.size, np.nan)
    for k, values in enumerate(grid.points()):
        row = rows.get(point_key(values))
        v = objective.value(row) if row is not None else None
        if v is not None:
            out[k] = v
    return out.reshape(grid.shape)


def _figure(grid: Grid, values: np.ndarray, dims: tuple[int, ...], objective: Objective,
            best: tuple[int, ...] | None):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.patches
    import matplotlib.pyplot as plt

    others = [a.name for k, a in enumerate(grid.axes) if k not in dims and len(a.values) > 1]
    reduced = best_over_others(values, dims)
    fig, ax = plt.subplots(figsize=(7.5, 5.5), layout="constrained")
    if len(dims) == 1:
        axis = grid.axes[dims[0]]
        x = np.asarray(axis.values, dtype=float)
        ax.plot(x, reduced, "o-", color="tab:blue", label="feasible")
        bad = np.isnan(reduced)
        if bad.any():
            lo = np.nanmin(reduced) if not bad.all() else 0.0
            ax.plot(x[bad], np.full(bad.sum(), lo), "x", color="tab:red",
                    label="no feasible point")
        if best is not None:
            ax.plot(x[best[dims[0]]], reduced[best[dims[0]]], "*", ms=16, color="gold",
                    mec="k", label="best")
        ax.set_xlabel(axis.name)
        ax.set_ylabel(objective.label)
        ax.legend()
    else:
        a, b = (grid.axes[k] for k in dims)
        image = reduced.T  # rows: b's values, columns: a's values
        cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.85")
        mesh = ax.pcolormesh(np.ma.masked_invalid(image), cmap=cmap, edgecolors="w",
                             linewidth=0.3)
        fig.colorbar(mesh, ax=ax, label=objective.label)
        if image.size <= _ANNOTATE_CELLS:
            for (r, c), v in np.ndenumerate(image):
                ax.text(c + 0.5, r + 0.5, "-" if np.isnan(v) else f"{v:.4g}", ha="center",
                        va="center", fontsize=7, color=_text_colour(cmap, mesh.norm, v))
        if best is not None:
            ax.add_patch(matplotlib.patches.Rectangle(
                (best[dims[0]], best[dims[1]]), 1, 1, fill=False, ec="red", lw=2.5))
        ax.set_xticks(np.arange(len(a.values)) + 0.5)
        ax.set_yticks(np.arange(len(b.values)) + 0.5)
        _ticks_centered(ax, a.values, "x")
        _ticks_centered(ax, b.values, "y")
        ax.set_xlabel(a.name)
        ax.set_ylabel(b.name)
    title = f"{objective.name}: smallest over feasible points"
    if others:
        title += f"\n(best over {', '.join(others)}; grey: no feasible point)"
    elif len(dims) == 2:
        title += " (grey: not feasible)"
    ax.set_title(title, fontsize=10)
    return fig


def best_over_others(values: np.ndarray, dims: tuple[int, ...]) -> np.ndarray:
    """The smallest value over every axis but ``dims`` (ascending), NaN where all are NaN."""
    other = tuple(k for k in range(values.ndim) if k not in dims)
    return np.fmin.reduce(values, axis=other) if other else values


def _text_colour(cmap, norm, value: float) -> str:
    """Black on light cells, white on dark ones."""
    if np.isnan(value):
        return "k"
    r, g, b, _ = cmap(norm(value))
    return "k" if 0.299 * r + 0.587 * g + 0.114 * b > 0.5 else "w"


def _ticks_centered(ax, values: Sequence[float], axis: str) -> None:
    step = max(1, int(np.ceil(len(values) / 12)))
    idx = np.arange(0, len(values), step)
    getattr(ax, f"set_{axis}ticks")(idx + 0.5)
    getattr(ax, f"set_{axis}ticklabels")([f"{values[i]:g}" for i in idx])


def write_plots(out_dir: Path, grid: Grid, values: np.ndarray, objective: Objective,
                best: tuple[int, ...] | None) -> list[Path]:
    """Every plot of :func:`plot_names` into ``out_dir``; the files written.

    ``values`` is :func:`objective_array`; ``best`` the grid index of the best point.
    """
    import matplotlib.pyplot as plt

    written = []
    for name, dims in plot_names(grid):
        fig = _figure(grid, values, dims, objective, best)
        try:
            written.append(write_atomically(out_dir / name,
                                            lambda p, f=fig: f.savefig(p, dpi=110)))
        finally:
            plt.close(fig)
    return written
