"""The report's figures rendered on two cores: the same bytes as one by one, in order."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from feedopt import background
from feedopt.report import plots
from feedopt.report.plots import render_png, render_pngs, split_by_axes


def _figure(panels: int, seed: int) -> Figure:
    fig = Figure(figsize=(4, 3), dpi=50)
    FigureCanvasAgg(fig)
    rng = np.random.default_rng(seed)
    for ax in np.atleast_1d(fig.subplots(panels, 1)).ravel():
        ax.plot(rng.normal(size=50))
    return fig


def test_two_cores_give_the_bytes_of_one_in_the_given_order() -> None:
    figures = {f"f{k}": _figure(panels, k) for k, panels in enumerate([1, 3, 2, 1])}
    got = render_pngs(figures)
    assert list(got) == list(figures)
    for key, fig in figures.items():
        assert got[key] == render_png(fig)
        assert got[key].startswith(b"\x89PNG")


def test_without_fork_every_figure_is_rendered_here(monkeypatch) -> None:
    monkeypatch.setattr(background, "fork_available", lambda: False)
    figures = {"a": _figure(1, 0), "b": _figure(2, 1)}
    assert render_pngs(figures) == {k: render_png(f) for k, f in figures.items()}


def test_a_figure_that_fails_in_the_child_fails_the_call(monkeypatch) -> None:
    figures = {"big": _figure(4, 0), "small": _figure(1, 1)}  # "small" goes to the child
    assert split_by_axes(figures) == (["big"], ["small"])
    real = plots.render_png

    def failing(fig):
        if fig is figures["small"]:
            raise RuntimeError("no canvas")
        return real(fig)

    monkeypatch.setattr(plots, "render_png", failing)
    if background.fork_available():
        with pytest.raises(RuntimeError, match="no canvas"):
            render_pngs(figures)


def test_split_balances_the_axes() -> None:
    figures = {"path": _figure(5, 0), "deflection": _figure(5, 1), "feed": _figure(2, 2),
               "accel": _figure(2, 3), "joints": _figure(6, 4)}
    here, there = split_by_axes(figures)
    assert sorted(here + there) == sorted(figures)
    load = [sum(len(figures[k].axes) for k in g) for g in (here, there)]
    assert abs(load[0] - load[1]) <= 2  # 10 and 10, or 11 and 9 (greedy)
