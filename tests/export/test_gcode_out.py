"""G-code out: read back with feedopt's G-code reader, no block's F exceeds the feed bound on
the stretch it covers, F is within the stated tolerance of the law's feed, and blocks split
where the feed changes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.export.gcode_out import (
    FEED_TOLERANCE,
    _f_word,
    _g1_blocks,
    _num,
    feed_pieces,
    gcode_text,
    law_feed_targets,
    piece_feeds,
)
from feedopt.gcode import MoveCategory, MoveKind, parse_gcode, read_gcode
from feedopt.runner import run_scenario
from tests.export.conftest import run_triangle_at_1mm

quiet = lambda _m: None  # noqa: E731


def _synthetic(spacing_mm: float = 0.5):
    """A 100 mm line along x, a quarter circle of radius 20 mm, a 60 mm line along y; a bound
    that dips near the arc and steps down on the second line; a law that ramps from rest and
    follows the bound."""
    s_line1 = np.arange(0.0, 100.0, spacing_mm)
    arc_len = 0.5 * np.pi * 20.0
    s_arc = 100.0 + np.arange(0.0, arc_len, spacing_mm)
    s_line2 = 100.0 + arc_len + np.arange(0.0, 60.0 + 1e-9, spacing_mm)
    s = np.concatenate([s_line1, s_arc, s_line2])
    p = np.zeros((s.size, 3))
    n1, n2 = s_line1.size, s_arc.size
    p[:n1, 0] = s_line1
    phi = (s_arc - 100.0) / 20.0
    p[n1:n1 + n2, 0] = 100.0 + 20.0 * np.sin(phi)
    p[n1:n1 + n2, 1] = 20.0 - 20.0 * np.cos(phi)
    p[n1 + n2:, 0] = 120.0
    p[n1 + n2:, 1] = 20.0 + (s_line2 - 100.0 - arc_len)
    p[:, 2] = 5.0
    bound = 4.0 - 1.5 * np.exp(-(((s - 100.0 - 0.5 * arc_len) / 15.0) ** 2))
    bound = np.where(s > 100.0 + arc_len + 30.0, 2.2, bound) * 1e-3  # m/s
    law = np.minimum(bound, np.sqrt(2 * 0.05 * s * 1e-3) + 1e-6)  # from rest at 50 mm/s^2
    law[-1] = 0.0
    line = np.ones(s.size, dtype=bool)
    line[n1:n1 + n2] = False
    breaks = [n1, n1 + n2]
    return s, p, bound, law, line, breaks


def _feed_blocks(program, s, p):
    """(s_start, s_end, F [mm/s]) of each cutting G1 block: ends mapped to the nearest sample."""
    out = []
    for m in program.moves:
        if m.kind is not MoveKind.LINE or m.category is MoveCategory.PLUNGE:
            continue
        ia = int(np.argmin(np.linalg.norm(p - np.asarray(m.start), axis=1)))
        ib = int(np.argmin(np.linalg.norm(p - np.asarray(m.end), axis=1)))
        out.append((ia, ib, m.feed_mm_s))
    return out


def test_synthetic_program_reads_back_under_the_bound_within_the_tolerance() -> None:
    s, p, bound, law, line, breaks = _synthetic()
    target = law_feed_targets(law, bound, keeps_bound=True)
    text = gcode_text(p, target, line, breaks, ["synthetic"], spindle_rpm=2500)
    program = parse_gcode(text)
    blocks = _feed_blocks(program, s, p)
    assert blocks[0][0] == 0 and blocks[-1][1] == s.size - 1
    for (ia, ib, f), nxt in zip(blocks, blocks[1:] + [None], strict=True):
        assert ib > ia
        if nxt is not None:
            assert nxt[0] == ib  # contiguous
        v = bound[ia:ib + 1] * 1e3
        assert f <= v.min() * (1 + 1e-12)  # never above the bound on the block
        g = target[ia:ib + 1] * 1e3  # and at most the tolerance below the law (+ F rounding)
        assert f >= g.max() / (1 + FEED_TOLERANCE) - 0.1 / 60 - 1e-9 or ib - ia == 1
    # lines are single blocks where the feed is flat: the first line's plateau after the
    # replaced start ramp is one block; the arc is chords, one per sample
    n_arc = breaks[1] - breaks[0]
    assert sum(1 for ia, ib, _ in blocks if breaks[0] <= ia < breaks[1]) == n_arc
    assert len(blocks) < 0.6 * s.size
    # the start ramp is not written: the first block runs at the plateau, not near zero
    assert blocks[0][2] > 3.9
    assert any("S2500 M3" in line for line in text.splitlines())
    assert program.units == "mm" and text.startswith("%\n(synthetic)\nG21 G90 G94 G17\nG54\n")


def test_f_words_are_rounded_down() -> None:
    assert _f_word(4.23) == "F253.8"  # 253.8 exactly: kept
    assert _f_word(4.2299999) == "F253.7"
    assert _f_word(1.0 / 60.0 * 100.05) == "F100.0"
    assert _f_word(0.1 / 60 * 5999.99999999999) == "F600.0"  # rounding noise of 600


def test_law_feed_targets_replace_the_ramps_and_cap() -> None:
    v_max = np.array([3.0, 3.0, 2.0, 2.5, 2.5, 3.0, 3.0])
    law = np.array([0.0, 1.5, 2.0, 2.4, 2.4, 1.0, 0.0])
    got = law_feed_targets(law, v_max, keeps_bound=True)
    np.testing.assert_allclose(got, [2.4, 2.4, 2.0, 2.4, 2.4, 2.4, 2.4])  # capped at 2
    # a law that does not keep the bound keeps its own plateau
    const = np.array([0.0, 4.0, 4.23, 4.23, 4.23, 2.0, 0.0])
    np.testing.assert_allclose(law_feed_targets(const, v_max, keeps_bound=False), 4.23)


@settings(max_examples=60, deadline=None)
@given(g=st.lists(st.floats(0.5, 5.0), min_size=2, max_size=300),
       tol=st.floats(0.001, 0.2), brk=st.lists(st.integers(0, 299), max_size=5))
def test_feed_pieces_keep_the_tolerance(g, tol, brk) -> None:
    g = np.asarray(g)
    bounds = feed_pieces(g, tol, brk)
    assert bounds[0] == 0 and bounds[-1] == g.size - 1 and np.all(np.diff(bounds) > 0)
    assert set(b for b in brk if 0 < b < g.size - 1) <= set(bounds.tolist())
    feeds = piece_feeds(g, bounds)
    for (a, b), f in zip(zip(bounds[:-1], bounds[1:], strict=True), feeds, strict=True):
        assert f == g[a:b + 1].min()
        assert b - a == 1 or g[a:b + 1].max() <= (1 + tol) * f * (1 + 1e-12)


def test_bad_input_is_refused() -> None:
    s, p, bound, law, line, breaks = _synthetic()
    with pytest.raises(InputError, match="positive"):
        gcode_text(p, np.zeros(s.size), line, breaks)
    with pytest.raises(InputError, match="n >= 2"):
        gcode_text(p[:1], law[:1], line[:1], [])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return run_triangle_at_1mm(tmp_path_factory.mktemp("g"), ["thesis", "jerk"])


@pytest.mark.parametrize("law", ["jerk", "thesis"])
def test_run_program_reads_back_and_keeps_the_bound(run, law) -> None:
    assert run.summary["laws"][law]["gcode_program"] == f"{law}.nc"
    program = read_gcode(run.out_dir / f"{law}.nc")
    prepared = run.prepared
    problem = prepared.problem
    p = prepared.placement.to_base(prepared.path.evaluate(problem.s).position) * 1e3
    blocks = _feed_blocks(program, problem.s, p)
    assert blocks[0][0] == 0 and blocks[-1][1] == problem.n - 1
    ends = np.array([program.moves[i].end for i in range(len(program.moves))])
    assert np.min(np.linalg.norm(ends[:, None, :] - p[None, -1:, :], axis=2)) < 1e-3
    v_max = problem.v_max * 1e3
    for ia, ib, f in blocks:
        assert f <= v_max[ia:ib + 1].min() * (1 + 1e-12)
    # the program's feeds follow the law: its time is within the tolerance of the law's
    # cruise (the ramps are the controller's)
    length = np.array([np.linalg.norm(p[ib] - p[ia]) for ia, ib, _ in blocks])
    t_nc = float(np.sum(length / np.array([f for *_, f in blocks])))
    assert t_nc >= run.laws[law].trajectory.duration * 0.9
    assert program.moves[0].kind is MoveKind.RAPID or program.moves[0].category in (
        MoveCategory.PLUNGE, MoveCategory.RAPID)


def test_tilted_tool_axis_writes_no_gcode(tmp_path, quick_scenario) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["jerk"],
                       workpiece__rpy_deg=[8.0, 0.0, 0.0])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
    entry = result.summary["laws"]["jerk"]
    assert entry["gcode_program"] is None and "tool axis leaves the base +Z" in \
        entry["gcode_not_written"]
    assert not (tmp_path / "out" / "jerk.nc").exists()
    assert (tmp_path / "out" / "jerk.csv").is_file()


def test_a_finely_sampled_arc_gets_chords_within_the_tolerance_not_one_per_sample() -> None:
    """A 90 deg arc of radius 12.7 mm sampled every 5 um (the 1e5-sample scale): chords as
    long as a 1 um sag allows (about sqrt(8 r tol) = 0.32 mm, so ~63 of them, not 4,000),
    and every sample within the tolerance of the written polyline."""
    from feedopt.export.gcode_out import CHORD_TOLERANCE_MM, _chord_sag_mm, _curve_chord_ends

    r = 12.7
    n = int(round(0.5 * np.pi * r / 0.005)) + 1
    t = np.linspace(0.0, 0.5 * np.pi, n)
    p = np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(n)])
    kept = _curve_chord_ends(p, np.ones(n, dtype=bool))
    kept[0] = kept[-1] = True
    expected = 0.5 * np.pi * r / np.sqrt(8 * r * CHORD_TOLERANCE_MM)
    assert 0.9 * expected <= kept.sum() <= 1.2 * expected + 3
    assert _chord_sag_mm(p, kept) <= CHORD_TOLERANCE_MM * 1.05
    # independent: distance of every sample from the circle's chords between kept points
    idx = np.flatnonzero(kept)
    half = np.diff(t[idx]) / 2
    assert np.max(r * (1 - np.cos(half))) <= CHORD_TOLERANCE_MM * 1.05


_COORD = st.one_of(st.floats(-1e5, 1e5, allow_nan=False), st.sampled_from(
    [0.0, -0.0, -0.00004, 0.00005, -0.00005, 1.0, -1.0, 100.0, 0.1, 12.34565, 1e-7, -1e-7]))


@settings(max_examples=200, deadline=None)
@given(points=st.lists(st.tuples(_COORD, _COORD, _COORD), min_size=1, max_size=30),
       feeds=st.lists(st.floats(1e-3, 1e3, allow_nan=False), min_size=30, max_size=30))
def test_g1_blocks_are_the_block_by_block_text(points, feeds):
    """The array formatting of the G1 blocks against the block-by-block reference (_num and
    _f_word on each block, F where its text changes)."""
    p = np.array(points, dtype=float)
    f = np.array(feeds[:len(points)], dtype=float)
    f[1::3] = f[0::3][:f[1::3].size]  # repeated feeds: F words left out
    ref, last = [], None
    for q, feed in zip(p, f, strict=True):
        word = _f_word(feed)
        ref.append("G1 " + " ".join(f"{a}{_num(v)}" for a, v in zip("XYZ", q, strict=True))
                   + ("" if word == last else f" {word}"))
        last = word
    assert _g1_blocks(p, f) == ref


def test_an_interior_stop_keeps_the_feed_around_it():
    """A law stopping at a reversal has feed 0 at an interior sample: its target is the feed
    before it (the controller stops at the reversal by itself); G-code out refused zero
    feeds (a five-axis out-and-back path, hostile pass)."""
    feed = np.array([0.0, 2.0, 5.0, 5.0, 0.0, 4.0, 4.0, 1.0, 0.0])
    target = law_feed_targets(feed, np.full(feed.size, np.inf), keeps_bound=False)
    assert np.all(target > 0)
    np.testing.assert_array_equal(target, [5, 5, 5, 5, 5, 4, 4, 4, 4])
