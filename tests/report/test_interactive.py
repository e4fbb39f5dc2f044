"""The interactive report figures (feedopt.report.interactive) and the per-sample data they
show (feedopt.report.data.SampleInfo, built by feedopt.report.run from a run's bound,
program moves and trajectories)."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.geometry.program_tables import MoveTable
from feedopt.report.data import (
    PathCurvesSI,
    ReportData,
    SampleInfo,
    TimeCurvesSI,
    law_series_from_si,
)
from feedopt.report.interactive import (
    MAX_POINTS_2D,
    MAX_POINTS_3D,
    bucket_count,
    bucket_index,
    constraint_runs,
    decimate_minmax,
    deflection_figure,
    feed_figure,
    interactive_figures,
    path_figure,
)
from feedopt.report.run import SampleSources, program_lines, sample_info, with_sample_times

CONSTRAINTS = ("deflection", "max_feed", "spindle_power")
RAPID_MM_S = 150.0


# ---------------------------------------------------------------- decimation


def _brute_buckets(x: np.ndarray, buckets: int) -> list[np.ndarray]:
    """The samples of each bucket, one sample at a time: bucket floor((x - x0) / (x1 - x0)
    * buckets), the last one closed (the reference)."""
    out: list[list[int]] = [[] for _ in range(buckets)]
    for i, xi in enumerate(x.tolist()):
        out[min(int((xi - x[0]) / (x[-1] - x[0]) * buckets), buckets - 1)].append(i)
    return [np.array(members, dtype=int) for members in out]


@given(
    n=st.integers(2, 600),
    max_points=st.integers(7, 120),
    columns=st.integers(1, 3),
    seed=st.integers(0, 2**31 - 1),
    nan_share=st.sampled_from([0.0, 0.1, 1.0]),
)
def test_decimation_keeps_every_buckets_extremes_and_both_ends(n, max_points, columns, seed,
                                                               nan_share) -> None:
    rng = np.random.default_rng(seed)
    x = np.sort(np.round(rng.uniform(0, 50, n), 1))  # repeated x values too
    ys = rng.normal(size=(columns, n))
    ys[rng.uniform(size=ys.shape) < nan_share] = np.nan
    if max_points < 2 + 2 * columns:
        with pytest.raises(InputError, match="max_points"):
            decimate_minmax(x, ys, max_points)
        return
    idx = decimate_minmax(x, ys, max_points)
    assert idx.size <= max_points
    assert np.all(np.diff(idx) > 0)
    if n <= max_points:
        assert np.array_equal(idx, np.arange(n))
        return
    assert idx[0] == 0 and idx[-1] == n - 1
    kept = set(idx.tolist())
    buckets = bucket_count(max_points, columns)
    if x[-1] > x[0]:
        assert all(np.array_equal(a, np.flatnonzero(bucket_index(x, buckets) == b))
                   for b, a in enumerate(_brute_buckets(x, buckets)))
    for members in _brute_buckets(x, buckets) if x[-1] > x[0] else [np.arange(n)]:
        if not members.size:
            continue
        assert members[0] in kept  # the bucket's first sample
        for y in ys:
            vals = y[members]
            if np.isnan(vals).all():
                continue
            got = y[[i for i in members if i in kept]]
            assert np.nanmin(got) == np.nanmin(vals) and np.nanmax(got) == np.nanmax(vals)


def test_decimation_refuses_x_going_back() -> None:
    x = np.concatenate([np.arange(50.0), np.arange(50.0)])
    with pytest.raises(InputError, match="must not decrease"):
        decimate_minmax(x, [x], 20)


def test_constraint_runs_against_a_loop() -> None:
    codes = np.array([0, 0, 1, 1, 1, 0, 2, 2, 0])
    runs = constraint_runs(codes)
    expected, start = [], 0
    for i in range(1, codes.size + 1):
        if i == codes.size or codes[i] != codes[start]:
            expected.append((start, i, codes[start]))
            start = i
    assert list(zip(runs.start.tolist(), runs.stop.tolist(), runs.code.tolist(),
                    strict=True)) == expected


# ---------------------------------------------------------------- a program-like run


def _moves() -> MoveTable:
    """Five moves: cut, rapid up and over, cut, plunge, cut (s in m)."""
    return MoveTable(
        s_start=np.array([0.0, 0.1, 0.2, 0.3, 0.32]),
        line=np.array([5, 6, 7, 9, 9]), n_number=np.array([50, -1, 70, 90, 90]),
        category=np.array(["cut", "rapid", "cut", "plunge", "cut"]),
        kind=np.array(["line", "rapid", "line", "line", "line"]),
        feed=np.array([4e-3, np.nan, 4e-3, 1e-3, 4e-3]), spindle_rpm=np.full(5, 2500.0),
        tool=np.ones(5, dtype=int))


def _run(k: int = 401, laws: tuple[str, ...] = ("programmed", "convex", "jerk"),
         seed: int = 0) -> tuple[ReportData, SimpleNamespace]:
    """A synthetic run of ``k`` samples over 0.4 m: the path, its sample info and laws."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 0.4, k)
    moves = _moves()
    move = moves.index_at(s)
    air = moves.category[move] != "cut"
    x_mm = s * 1e3
    z_mm = np.where(moves.category[move] == "rapid", 100.0, 0.0)
    xyz = np.column_stack([x_mm, 10 * np.sin(s * 40), z_mm])
    active = rng.integers(0, len(CONSTRAINTS), k)
    v_max = np.where(air, RAPID_MM_S, 3.0 + rng.uniform(0, 1, k)) * 1e-3
    problem = SimpleNamespace(s=s, v_max=v_max)
    series = []
    for j, law in enumerate(laws):
        feed = np.minimum(v_max * (0.9 + 0.02 * j), v_max)
        defl = np.where(air, 0.0, 0.2e-3 + 0.1e-3 * rng.uniform(0, 1, k) * (j == 0))
        t = np.linspace(0.0, 10.0, 50)
        timed = TimeCurvesSI(t, np.full(50, 3e-3), np.zeros(50), np.zeros(50), np.zeros((50, 6)))
        series.append(law_series_from_si(law, PathCurvesSI(s, feed, defl), timed))
    trajectories = {law: SimpleNamespace(time_at=lambda q, j=j: q * (100.0 + j))
                    for j, law in enumerate(laws)}
    sources = SampleSources(active=active, constraints=CONSTRAINTS, moves=moves,
                            trajectories=trajectories)
    series = with_sample_times(series, s, trajectories)
    data = ReportData(
        scenario="synthetic", summary={"laws": {law: {"exported": law != "programmed",
                                                       "cycle_time_s": 10.0 + j}
                                                 for j, law in enumerate(laws)}},
        path_xyz_mm=xyz, segment_kind=np.full(k, "line"), laws=tuple(series),
        joint_velocity_limit_deg_s=np.full(6, 100.0), deflection_limit_mm=0.25,
        samples=sample_info(problem, sources))
    return data, SimpleNamespace(s=s, moves=moves, air=air, active=active, v_max=v_max)


def _decode(value) -> np.ndarray:
    """A Plotly JSON array: a list, or a base64 typed array ({"dtype", "bdata"})."""
    if isinstance(value, dict):
        arr = np.frombuffer(base64.b64decode(value["bdata"]), dtype=np.dtype(value["dtype"]))
        if "shape" in value:
            arr = arr.reshape([int(d) for d in str(value["shape"]).split(",")])
        return arr
    return np.array([np.nan if v is None else v for v in value], dtype=object)


def _traces(fig) -> list[dict]:
    return json.loads(fig.to_json())["data"]


def test_sample_info_of_a_program_against_its_moves() -> None:
    data, run = _run()
    info = data.samples
    for i in range(0, run.s.size, 7):  # sample by sample, through MoveTable itself
        move = int(run.moves.index_at(run.s[i]))
        assert info.air[i] == (run.moves.category[move] != "cut")
        assert info.labels_at(np.array([i]))[0] == run.moves.label(move)
        assert info.active_names_at(np.array([i]))[0] == CONSTRAINTS[run.active[i]]
    assert np.allclose(info.v_max_mm_s, run.v_max * 1e3)
    assert not info.v_max_mm_s.flags.writeable and not info.air.flags.writeable
    assert info.active.dtype == np.uint8 and info.program_line.dtype == np.int32
    for ls, j in zip(data.laws, range(3), strict=True):
        assert np.allclose(ls.path_t_s, run.s * (100.0 + j))


def test_program_line_labels_are_the_move_tables() -> None:
    moves = _moves()
    line, numbers, labels = program_lines(moves, moves.s_start)
    assert line.tolist() == moves.line.tolist()
    table = dict(zip(numbers.tolist(), labels.tolist(), strict=True))
    assert table == {int(moves.line[i]): moves.label(i) for i in range(len(moves))}


def test_sample_info_refuses_what_does_not_fit() -> None:
    ok = dict(v_max_mm_s=np.ones(4), active=np.zeros(4), constraints=("deflection",),
              air=np.zeros(4, bool), program_line=np.zeros(4))
    SampleInfo(**ok)
    with pytest.raises(ValueError, match="air has 3 samples"):
        SampleInfo(**{**ok, "air": np.zeros(3, bool)})
    with pytest.raises(ValueError, match="active must index"):
        SampleInfo(**{**ok, "active": np.full(4, 1)})
    with pytest.raises(ValueError, match="no label"):
        SampleInfo(**{**ok, "program_line": np.full(4, 12)})
    data, _ = _run(k=50)
    with pytest.raises(ValueError, match="samples has 4 path samples"):
        ReportData(**{**data.__dict__, "samples": SampleInfo(**ok)})


def test_a_path_without_program_cuts_everywhere_and_has_no_lines() -> None:
    s = np.linspace(0, 0.1, 30)
    info = sample_info(SimpleNamespace(s=s, v_max=np.full(30, 4e-3)),
                       SampleSources(active=np.zeros(30, int), constraints=("deflection",)))
    assert not info.air.any() and info.line_numbers.size == 0
    assert set(info.labels_at(np.arange(30)).tolist()) == {""}


# ---------------------------------------------------------------- the figures


def test_3d_path_one_trace_set_per_law_and_air_samples_only_in_the_grey_trace() -> None:
    data, run = _run()
    traces = _traces(path_figure(data))
    cutting = [t for t in traces if t["name"].endswith(": cutting")]
    air = [t for t in traces if t["name"].startswith("air moves")]
    assert [t["name"] for t in cutting] == [f"{ls.law}: cutting" for ls in data.laws]
    assert len(air) == len(data.laws)
    for t in cutting:
        s = _decode(t["customdata"])[:, 0].astype(float)
        drawn = s[np.isfinite(s)]
        cut_s = run.s[~run.air] * 1e3
        assert np.all(np.min(np.abs(drawn[:, None] - cut_s[None, :]), axis=1) < 1e-3)
        assert np.nanmax(_decode(t["z"]).astype(float)) == 0.0  # the rapid flies at z=100
    for t in air:
        assert np.nanmax(_decode(t["z"]).astype(float)) == 100.0
    visible = [t.get("visible", True) for t in traces if t["name"].endswith(": cutting")]
    assert visible == [False, True, False]  # the fastest exported law (convex) first


def test_3d_hover_of_a_sample_shows_its_program_line_and_active_constraint() -> None:
    data, run = _run()
    trace = next(t for t in _traces(path_figure(data)) if t["name"] == "jerk: cutting")
    cd = _decode(trace["customdata"]).astype(float)
    for i in (3, 99, 250, 390):  # cutting samples on lines 5, 7 and 9
        assert not run.air[i]
        row = int(np.flatnonzero(np.abs(cd[:, 0] - run.s[i] * 1e3) < 1e-3)[0])
        move = int(run.moves.index_at(run.s[i]))
        assert trace["text"][row] == run.moves.label(move)
        assert trace["hovertext"][row] == CONSTRAINTS[run.active[i]]
        assert cd[row, 3] == pytest.approx(run.v_max[i] * 1e3, rel=1e-6)
        assert cd[row, 1] == pytest.approx(run.s[i] * 102.0, rel=1e-6)  # t of the jerk law
    assert "%{text}" in trace["hovertemplate"] and "%{hovertext}" in trace["hovertemplate"]


def test_the_law_selector_has_one_entry_per_law_showing_its_traces() -> None:
    data, _ = _run()
    fig = json.loads(path_figure(data).to_json())
    buttons = fig["layout"]["updatemenus"][0]["buttons"]
    assert [b["label"] for b in buttons] == [ls.law for ls in data.laws]
    for b, ls in zip(buttons, data.laws, strict=True):
        shown = [t["legendgroup"] for t, v in zip(fig["data"], b["args"][0]["visible"],
                                                  strict=True) if v]
        assert set(shown) == {ls.law} and len(shown) == 3  # cutting, air, marks


def test_feed_figure_cutting_range_by_default_rapids_on_request_and_a_band_of_runs() -> None:
    data, run = _run()
    fig = json.loads(feed_figure(data).to_json())
    names = [t["name"] for t in fig["data"]]
    assert names[:4] == ["bound v_max", "programmed", "convex", "jerk"]
    lo, hi = fig["layout"]["yaxis"]["range"]
    cutting = max(np.max(ls.feed_mm_s[~run.air]) for ls in data.laws)
    assert cutting <= hi < RAPID_MM_S * 0.9  # the rapids are off the default scale
    labels = [b["label"] for b in fig["layout"]["updatemenus"][0]["buttons"]]
    assert labels == ["cutting feeds", "include rapids"]
    band = [t for t in fig["data"] if t["type"] == "bar"]
    codes = np.where(run.air, len(CONSTRAINTS), run.active)
    assert sum(len(_decode(t["x"])) for t in band) == constraint_runs(codes).code.size
    assert {t["name"] for t in band} <= {f"limit: {c}" for c in (*CONSTRAINTS, "air move")}


def test_deflection_figure_marks_the_samples_over_the_limit() -> None:
    data, run = _run()
    traces = _traces(deflection_figure(data))
    over = [t for t in traces if t["name"].endswith("over the limit")]
    ls = data.laws[0]
    expected = ls.s_mm[ls.deflection_mm > data.deflection_limit_mm]
    assert [t["name"] for t in over] == ["programmed over the limit"]
    assert np.allclose(np.sort(_decode(over[0]["x"]).astype(float)), expected, atol=1e-3)


def test_rendered_divs_are_self_contained() -> None:
    data, _ = _run()
    figs = interactive_figures(data)
    assert [f.key for f in figs] == ["path3d", "feed", "deflection"]
    for f in figs:
        assert f.html.lstrip().startswith("<div") and "Plotly.newPlot" in f.html
        assert not re.search(r"<script[^>]*\bsrc\s*=", f.html)
        assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", f.html)
        assert "http" not in f.html


def test_figures_of_a_report_without_sample_information(report_data) -> None:
    assert report_data.samples is None and report_data.laws[0].path_t_s is None
    figs = interactive_figures(report_data)
    assert [f.key for f in figs] == ["path3d", "feed", "deflection"]
    traces = _traces(path_figure(report_data))
    cutting = [t for t in traces if t["name"].endswith(": cutting")]
    assert len(cutting) == len(report_data.laws)  # every sample cuts, no air trace
    assert not any(t["name"].startswith("air") for t in traces)
    assert "t %{" not in cutting[0]["hovertemplate"]
    assert "%{hovertext}" not in cutting[0]["hovertemplate"]
    assert not [t for t in _traces(feed_figure(report_data)) if t["type"] == "bar"]


def test_a_long_run_is_drawn_decimated_into_a_few_megabytes() -> None:
    data, run = _run(k=400_001, laws=("programmed", "topp", "convex", "jerk", "thesis"))
    figs = interactive_figures(data)
    total = sum(len(f.html) for f in figs)
    assert total < 4.5e6, {f.key: len(f.html) for f in figs}
    for fig, budget in ((path_figure(data), MAX_POINTS_3D), (feed_figure(data), MAX_POINTS_2D),
                        (deflection_figure(data), MAX_POINTS_2D)):
        for t in _traces(fig):
            if t["type"] != "bar":
                assert len(_decode(t["x"])) <= budget + MAX_POINTS_3D // 4, t["name"]
    # the largest deflection survives the decimation
    trace = next(t for t in _traces(deflection_figure(data)) if t["name"] == "programmed")
    assert np.nanmax(_decode(trace["y"]).astype(float)) == pytest.approx(
        data.laws[0].deflection_mm.max(), rel=1e-6)


def test_the_run_imports_no_plotly() -> None:
    code = ("import sys, feedopt.runner, feedopt.outputs, feedopt.report.run, "
            "feedopt.report.worker; print('plotly' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
