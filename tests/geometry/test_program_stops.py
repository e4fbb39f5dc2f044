"""Stops, G64 P, plunges and air links in program paths: programs built move by move (the
reader's part is tested in tests/gcode), checked against closed-form positions and distances
computed here."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.gcode.moves import Move, MoveCategory, MoveKind, Program, Stop, StopKind
from feedopt.geometry.path import Path, Segment, piecewise_uniform
from feedopt.geometry.program_path import ProgramPathOptions, Treatment, program_path
from feedopt.geometry.stops import StopTable
from feedopt.units import MM

TOL = 0.01 * MM
OPTS = ProgramPathOptions(stock_top=None, tolerance=TOL)


def _move(start, end, line, feed=4.0, **kw) -> Move:
    """A G1 (or a G0 with feed None) from ``start`` to ``end`` [mm] on ``line``."""
    start, end = tuple(map(float, start)), tuple(map(float, end))
    if feed is None:
        kind, cat = MoveKind.RAPID, MoveCategory.RAPID
    else:
        kind = MoveKind.LINE
        flat = math.hypot(end[0] - start[0], end[1] - start[1]) <= 1e-6
        cat = (MoveCategory.CUT if not flat else
               MoveCategory.PLUNGE if end[2] < start[2] else MoveCategory.RETRACT)
    return Move(kind, cat, start, end, feed, 2500.0, 1, 1, None, None, line, None,
                f"line {line} text", **kw)


def _polyline_moves(points, first_line=1, feed=4.0, **kw) -> list[Move]:
    return [_move(a, b, first_line + i, feed, **kw)
            for i, (a, b) in enumerate(zip(points[:-1], points[1:], strict=True))]


def _program(moves, stops=()) -> Program:
    return Program(moves=tuple(moves), units="mm", work_offsets=(), tools=(), warnings=(),
                   source="t.nc", stops=tuple(stops))


def _stop(after, kind, line, hold=0.0, text="M0") -> Stop:
    return Stop(after_move=after, kind=kind, hold_s=hold, line=line, n_number=None, text=text)


def _dist_polyline(p, pts):
    """Distance [mm] of points p (n, 3) to the polyline through pts (k, 3), brute force."""
    pts = np.asarray(pts, float)
    best = np.full(len(p), np.inf)
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (a + t[:, None] * (b - a)), axis=1))
    return best


# --- reversals ---------------------------------------------------------------------------


@pytest.mark.parametrize("spacing_mm", [0.1, 0.3, 0.77])
def test_reversal_is_one_stop_and_the_path_is_the_programmed_lines(spacing_mm):
    out = program_path(_program(_polyline_moves([(0, 0, -1), (10, 0, -1), (0, 0, -1)])), OPTS)
    stops = out.stops
    assert len(stops) == 1 and stops.kind == ("reversal",) and stops.line[0] == 2
    assert stops.s[0] == pytest.approx(10 * MM, abs=1e-15)
    assert out.junctions.treatment == (Treatment.STOP.value,)
    assert out.path.stops is stops
    pts = out.path.sample(spacing_mm * MM)
    k = stops.sample_index(pts.s)[0]
    assert pts.s[k] == stops.s[0]  # a sample exactly at the stop
    s_mm = pts.s / MM
    expect_x = np.where(s_mm <= 10, s_mm, 20 - s_mm)  # out along +x, back along -x
    assert np.allclose(pts.position / MM, np.c_[expect_x, 0 * s_mm, -1 + 0 * s_mm],
                       atol=1e-12, rtol=0)
    # right-sided: the stop's sample has the tangent of the move after it
    assert np.allclose(pts.tangent[k], [-1, 0, 0]) and np.allclose(pts.tangent[k - 1], [1, 0, 0])
    # uniform on each side, never further apart than the spacing
    ds = np.diff(pts.s)
    assert ds.max() <= spacing_mm * MM * (1 + 1e-9)
    assert np.allclose(ds[:k], ds[0]) and np.allclose(ds[k:], ds[-1])


# --- programmed stops --------------------------------------------------------------------


SQUARE = [(0, 0, -1), (30, 0, -1), (30, 30, -1), (0, 30, -1), (0, 0, -1), (30, 0, -1),
          (30, 30, -1)]


def test_exact_stop_mode_stops_at_every_junction_while_active():
    moves = _polyline_moves(SQUARE)
    exact = [_stop(i, StopKind.EXACT, i + 1, text=f"line {i + 1}") for i in (1, 2, 3)]
    out = program_path(_program(moves, exact), OPTS)
    treat = out.junctions.treatment
    assert treat == ("blend", "stop", "stop", "stop", "blend")
    assert out.stops.kind == ("exact stop",) * 3
    # the tool stops on the programmed corners, exactly
    at = out.path.evaluate(out.stops.s).position / MM
    assert np.allclose(at, [SQUARE[2], SQUARE[3], SQUARE[4]], atol=1e-12, rtol=0)
    # and the blended corners stay within the tolerance of the program
    pts = out.path.sample(0.02 * MM).position / MM
    assert _dist_polyline(pts, SQUARE).max() <= TOL / MM * (1 + 1e-6)
    assert np.all(out.junctions.deviation[[0, 4]] > 0.5 * TOL)


def test_dwell_holds_at_its_point_and_stops_at_one_point_merge():
    moves = _polyline_moves(SQUARE[:4])
    stops = [_stop(1, StopKind.DWELL, 7, 1.5, "G4 P1.5"),
             _stop(1, StopKind.DWELL, 8, 0.25, "G4 P0.25"),
             _stop(1, StopKind.EXACT, 6, text="G9 G1 Y30.")]
    out = program_path(_program(moves, stops), OPTS)
    st = out.stops
    assert len(st) == 1 and st.kind == ("dwell",)
    assert st.hold_s[0] == pytest.approx(1.75)
    assert "G4 P1.5 [dwell]" in st.label[0] and "G4 P0.25 [dwell]" in st.label[0]
    assert "[exact stop]" in st.label[0] and st.line[0] == 7
    assert np.allclose(out.path.evaluate(st.s).position / MM, [SQUARE[2]], atol=1e-12)


def test_stops_before_the_first_and_after_the_last_move_are_the_path_ends():
    moves = _polyline_moves(SQUARE[:3])
    stops = [_stop(-1, StopKind.TOOL_CHANGE, 1, text="T1 M6"),
             _stop(1, StopKind.PROGRAM_STOP, 5, text="M0")]
    out = program_path(_program(moves, stops), OPTS)
    assert out.stops.s[0] == 0.0 and out.stops.s[1] == out.path.length
    assert out.stops.kind == ("tool change", "program stop")
    assert out.junctions.treatment == ("blend",)  # no junction is a stop
    pts = out.path.sample(0.1 * MM)
    n = int(np.ceil(out.path.length / (0.1 * MM) - 1e-9)) + 1
    assert np.array_equal(pts.s, np.linspace(0.0, out.path.length, n))  # as without stops


def _chain_moves(n=40, r=30.0):
    """A quarter circle of ``n`` chords (~1.2 mm): smoothed as one chain."""
    ang = np.linspace(0, np.pi / 2, n + 1)
    pts = np.c_[r * np.sin(ang), r * (1 - np.cos(ang)), -np.ones(n + 1)]
    return _polyline_moves(pts)


@pytest.mark.parametrize(("kind", "code"), [(StopKind.PROGRAM_STOP, "an M0"),
                                            (StopKind.OPTIONAL_STOP, "an M1"),
                                            (StopKind.DWELL, "a G4 dwell")])
def test_a_stop_inside_a_smoothed_run_is_refused_naming_its_line(kind, code):
    moves = _chain_moves()
    assert len(program_path(_program(moves), OPTS).chains) == 1
    with pytest.raises(InputError, match=rf"t.nc line 99: {code} inside a run of short moves "
                       r"smoothed as one curve \(lines 1-40; it would stop between lines 20 "
                       r"and 21\).*G9 on line 20.*path.chain_max_move_mm below 1.178 mm"):
        program_path(_program(moves, [_stop(19, kind, 99)]), OPTS)


def test_an_exact_stop_splits_a_smoothed_run_and_allows_a_stop_there():
    moves = _chain_moves()
    stops = [_stop(19, StopKind.EXACT, 20), _stop(19, StopKind.PROGRAM_STOP, 99)]
    out = program_path(_program(moves, stops), OPTS)
    assert [(c.first_line, c.last_line) for c in out.chains] == [(1, 20), (21, 40)]
    assert out.junctions.treatment == ("stop",) and out.stops.kind == ("program stop",)
    assert np.allclose(out.path.evaluate(out.stops.s).position / MM, [moves[19].end],
                       atol=1e-12)
    # G61 over the whole run: no chain at all
    exact = [_stop(i, StopKind.EXACT, i + 1) for i in range(40)]
    assert program_path(_program(moves, exact), OPTS).chains == ()


# --- G64 P -------------------------------------------------------------------------------


def test_g64_p_is_the_tolerance_of_the_corners_after_its_moves():
    pts = [(0, 0, -1), (30, 0, -1), (30, 30, -1), (0, 30, -1), (0, 60, -1)]
    moves = _polyline_moves(pts[:3]) + _polyline_moves(pts[2:], 3, blend_tolerance_mm=0.05)
    out = program_path(_program(moves), OPTS)
    rep = out.junctions
    assert np.allclose(rep.tolerance / MM, [0.01, 0.05, 0.05])
    assert np.all(rep.deviation <= rep.tolerance * (1 + 1e-9))
    assert rep.deviation[0] < 0.0101 * MM and np.all(rep.deviation[1:] > 0.04 * MM)
    samples = out.path.sample(0.01 * MM).position / MM
    dist = _dist_polyline(samples, pts)
    # both ways (brute force): path -> program, and the programmed corners -> the path,
    # sampled every 1e-4 mm within 1 mm of each corner (chord sag < 1e-7 mm)
    near = [out.path.evaluate(np.clip(np.arange(s0 - 1 * MM, s0 + 1 * MM, 1e-4 * MM), 0,
                                      out.path.length)).position / MM
            for s0 in out.moves.s_start[[1, 2, 3]]]
    corners = np.array([np.linalg.norm(q - np.array(c, float), axis=1).min()
                        for q, c in zip(near, pts[1:4], strict=True)])
    assert dist.max() <= 0.05 * (1 + 1e-6) and corners.max() <= 0.05 * (1 + 1e-6)
    assert 0.04 < max(dist.max(), corners[1:].max())
    assert corners[0] <= 0.01 * (1 + 1e-6)
    near_first = np.linalg.norm(samples - [30, 0, -1], axis=1) < 2
    assert dist[near_first].max() <= 0.01 * (1 + 1e-6)  # the corner before keeps 0.01 mm


# --- plunges -----------------------------------------------------------------------------


def test_plunges_are_moves_and_below_the_stock_top_take_the_cutting_tolerance():
    moves = [_move((0, 0, 5), (10, 0, 2), 1, None),  # a rapid down towards the start
             _move((10, 0, 2), (10, 0, -3), 2),  # plunge into the stock
             _move((10, 0, -3), (40, 0, -3), 3), _move((40, 0, -3), (40, 0, 5), 4, None)]
    air = program_path(_program(moves), ProgramPathOptions(tolerance=TOL, stock_top=None))
    cut = program_path(_program(moves), ProgramPathOptions(tolerance=TOL, stock_top=0.0))
    assert list(cut.moves.category) == ["rapid", "plunge", "cut", "rapid"]
    assert air.junctions.tolerance[0] == 0.5 * MM and cut.junctions.tolerance[0] == TOL
    assert cut.junctions.deviation[0] <= TOL * (1 + 1e-9) < air.junctions.deviation[0]
    # a plunge ending above the stock top stays an air move
    high = program_path(_program(moves), ProgramPathOptions(tolerance=TOL, stock_top=-5 * MM))
    assert high.junctions.tolerance[0] == 0.5 * MM


# --- air links ---------------------------------------------------------------------------


def _tool_change_program():
    first = [_move((0, 0, 10), (0, 0, -1), 1), _move((0, 0, -1), (20, 0, -1), 2),
             _move((20, 0, -1), (20, 0, 3), 3, None)]
    # after T2 M6 (line 5) the reader knows the position again at (50, 40, 2)
    second = [replace(_move((50, 40, 2), (50, 40, -1), 9, 2.0), tool=2),
              _move((50, 40, -1), (80, 40, -1), 10), _move((80, 40, -1), (80, 40, 5), 11, None)]
    return _program(first + second, [_stop(2, StopKind.TOOL_CHANGE, 5, text="T2 M6")])


def test_a_tool_change_gap_is_linked_through_the_air_at_clearance_height():
    out = program_path(_tool_change_program(), OPTS)
    mv = out.moves
    assert list(mv.program_move) == [0, 1, 2, -1, -1, -1, 3, 4, 5]
    assert list(mv.category[3:6]) == ["rapid"] * 3 and list(mv.line[3:6]) == [9, 9, 9]
    zc = 10.0  # the highest point of the program (the first move's start)
    link = [(20, 0, 3), (20, 0, zc), (50, 40, zc), (50, 40, 2)]
    # the junction report runs over the same moves: the tool change is the stop after move 2
    rep = out.junctions
    assert list(rep.before) == [0, 1, 2, 3, 4, 5, 6, 7]
    assert rep.treatment[2] == "stop" and rep.labels[2] == "line 3->9"
    assert np.all(rep.tolerance[2:5] == 0.5 * MM)  # rapid-rapid corners: the air tolerance
    assert np.all(rep.deviation <= rep.tolerance * (1 + 1e-9))
    # the tool change stops where the first tool leaves off, exactly
    assert out.stops.kind == ("tool change",)
    assert np.allclose(out.path.evaluate(out.stops.s).position / MM, [link[0]], atol=1e-12)
    # the link: within the air tolerance of up, across, down; the middle of each leg on it
    s = np.linspace(mv.s_start[3], mv.s_start[6], 4001)
    pts = out.path.evaluate(s).position / MM
    assert _dist_polyline(pts, link).max() <= 0.5 * (1 + 1e-6)
    mid = out.path.evaluate(0.5 * (mv.s_start[3:6] + mv.s_start[4:7])).position / MM
    for k in range(3):
        assert _dist_polyline(mid[k:k + 1], link[k:k + 2])[0] < 1e-9
    assert pts[:, 2].max() == pytest.approx(zc, abs=1e-9)
    assert math.isclose(out.path.length / MM, 5 + 11 + 20 + 4 + 7 + 50 + 2 + 3 + 30 + 6,
                        abs_tol=1.0)  # blends shorten it by less than a mm
    note = next(w for w in out.warnings if "air link" in w)
    assert "lines 3-9" in note and "Z10 mm" in note and "(50, 40, 2)" in note


def test_a_link_or_a_first_approach_below_the_stock_top_is_refused_naming_the_line():
    prog = _tool_change_program()
    moves = list(prog.moves)
    low = moves[:2] + [replace(moves[2], end=(20.0, 0.0, -0.5))]
    with pytest.raises(InputError, match=r"t.nc line 3: the tool is at Z-0.5 mm, below the "
                       r"stock top \(Z0 mm\), when the program loses its position"):
        program_path(_program(low + moves[3:], prog.stops), ProgramPathOptions(stock_top=0.0))
    first = replace(moves[0], start=(0.0, 0.0, -1.0), end=(5.0, 0.0, -1.0),
                    category=MoveCategory.CUT, approach=True)
    with pytest.raises(InputError, match=r"t.nc line 1: the program's first move starts at "
                       r"Z-1 mm, below the stock top \(Z0 mm\)"):
        program_path(_program([first, _move((5, 0, -1), (9, 0, -1), 2)]),
                     ProgramPathOptions(stock_top=0.0))
    # above the stock an approach at the start is simply where the path starts
    ok = replace(first, start=(0.0, 0.0, 1.0))
    out = program_path(_program([ok, _move((5, 0, -1), (9, 0, -1), 2)]),
                       ProgramPathOptions(stock_top=0.0))
    assert np.allclose(out.path.evaluate([0.0]).position / MM, [[0, 0, 1]])
    assert len(out.moves) == 2


def test_an_approach_inside_the_program_is_linked_through_the_clearance_height():
    """After G28 Z the reader fills an approach's unknown Z from its end (here Z-1 below the
    previous end at X20): the link goes up to the clearance height (Z4) and straight down
    again, a reversal at the top (a stop); an approach starting where the tool already is at
    the clearance height needs no link."""
    moves = [_move((0, 0, 4), (0, 0, -1), 1), _move((0, 0, -1), (20, 0, -1), 2),
             _move((20, 0, -1), (20, 0, 2), 3, None),
             _move((20, 0, -1), (40, 0, -1), 6, approach=True)]
    out = program_path(_program(moves), OPTS)
    assert list(out.moves.program_move) == [0, 1, 2, -1, -1, 3]
    assert out.stops.kind == ("reversal",)
    assert np.allclose(out.path.evaluate(out.stops.s).position / MM, [[20, 0, 4]], atol=1e-12)
    moves[2:] = [_move((20, 0, -1), (20, 0, 4), 3, None),
                 _move((20, 0, 4), (40, 0, -1), 6, approach=True)]
    out = program_path(_program(moves), OPTS)
    assert list(out.moves.program_move) == [0, 1, 2, 3] and len(out.stops) == 0


# --- corner stops ------------------------------------------------------------------------


def test_a_junction_no_transition_fits_becomes_a_corner_stop(monkeypatch):
    """With one round from transitions as long as the room allows a kink between a line and
    an arc cannot be made G2 within the tolerance: the tool stops there instead of the
    program being refused."""
    import feedopt.geometry.junctions as junctions
    from feedopt.gcode import parse_gcode

    monkeypatch.setattr(junctions, "MAX_ROUNDS", 1)
    monkeypatch.setattr(junctions, "first_cut", lambda turn, jump, tol: np.full(turn.shape,
                                                                                np.inf))
    text = ("G21 G17 G90 G94\nG0 X0 Y0 Z5.\nG1 Z-1. F300.\nG1 X10. F254.\n"
            "G3 X20. Y0 I5. J-2.\nG1 X30.\nG0 Z5.\nM30\n")
    out = program_path(parse_gcode(text, "k.nc"), OPTS)
    assert out.stops.kind == ("corner", "corner") and list(out.stops.line) == [5, 6]
    assert out.junctions.treatment[1:3] == ("stop", "stop")
    assert np.allclose(out.path.evaluate(out.stops.s).position / MM, [[10, 0, -1], [20, 0, -1]],
                       atol=1e-12)
    notes = [w for w in out.warnings if "a corner stop;" in w]
    assert len(notes) == 2 and notes[0].startswith("k.nc line 5: no G2 transition within the "
                                                   "tolerance 0.01 mm fits the junction with "
                                                   "line 4")


def test_a_near_reversal_whose_transition_would_be_a_hairpin_is_a_corner_stop():
    """A 179 deg kink between two arcs at a 4 um tolerance: the transition within it would
    be about 0.1 um long (the two cut points c = 4 um back along nearly opposite directions
    are 2 c sin(0.5 deg) = 0.07 um apart), a hairpin whose end curvatures floating point
    cannot match (0.03 1/m off): a corner stop with its own note, the path G2 elsewhere."""
    from feedopt.gcode import parse_gcode
    from feedopt.geometry.continuity import continuity_report

    heading = math.radians(20.0)  # after a G3 of R19 sweeping 20 deg from heading 0
    x, y = 19.0 * math.sin(heading), 19.0 - 19.0 * math.cos(heading)
    back = heading + math.radians(179.0)  # then a G2 of R1 starting 179 deg around
    cx, cy = x + math.sin(back), y - math.cos(back)
    a1 = math.atan2(y - cy, x - cx) - math.radians(20.0)
    text = ("G21 G17 G90 G94\nG0 X0 Y0 Z5.\nG1 Z-1. F300.\n"
            f"G3 X{x:.6f} Y{y:.6f} I0 J19. F254.\n"
            f"G2 X{cx + math.cos(a1):.6f} Y{cy + math.sin(a1):.6f} I{cx - x:.6f} "
            f"J{cy - y:.6f}\nG0 Z5.\nM30\n")
    out = program_path(parse_gcode(text, "h.nc"), replace(OPTS, tolerance=0.004 * MM))
    assert out.stops.kind == ("corner",) and list(out.stops.line) == [5]
    assert np.allclose(out.path.evaluate(out.stops.s).position / MM, [[x, y, -1]], atol=1e-9)
    rep = continuity_report(out.path)
    away = ~np.isin(rep.s, out.stops.s)
    assert rep.g2[away].max(initial=0) < 1e-3  # [1/m]
    notes = [w for w in out.warnings if "cannot be built G2" in w]
    assert len(notes) == 1 and notes[0].startswith("h.nc line 5: the G2 transition within the "
                                                   "tolerance 0.004 mm at the junction with "
                                                   "line 4")


# --- sampling ----------------------------------------------------------------------------


def test_piecewise_uniform_matches_a_loop_over_the_stretches():
    rng = np.random.default_rng(7)
    for _ in range(20):
        bounds = np.sort(np.r_[0.0, rng.uniform(0, 1, rng.integers(0, 6)), 1.0])
        spacing = rng.uniform(0.003, 0.4)
        expect = [bounds[0]]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            if b > a:
                n = max(math.ceil((b - a) / spacing - 1e-9), 1)
                expect += [a + k * (b - a) / n for k in range(1, n)] + [b]
        got = piecewise_uniform(bounds, spacing)
        assert np.allclose(got, expect, atol=1e-15) and got.size == len(expect)
        assert np.all(np.isin(bounds, got))


def test_sample_without_stops_is_unchanged_and_every_stop_is_sampled():
    path = Path([Segment("line", 0.0, 1.0, -1, {"origin": np.zeros(3),
                                               "direction": np.array([1.0, 0, 0])})])
    before = path.sample(0.07).s
    assert np.array_equal(before, np.linspace(0, 1, 16))
    path.stops = StopTable(np.array([0.0, 0.123456, 0.5, 1.0]), ("dwell",) * 4, np.zeros(4),
                           np.arange(4), ("a", "b", "c", "d"))
    s = path.sample(0.07).s
    assert set(path.stops.s) <= set(s) and np.all(np.diff(s) > 0)
    assert np.diff(s).max() <= 0.07
    assert list(path.stops.sample_index(s)) == [int(np.flatnonzero(s == v)[0])
                                                 for v in path.stops.s]
    with pytest.raises(ValueError, match="do not include every stop"):
        path.stops.sample_index(before)
