"""Tool vectors of five-axis programs and waypoint files on the smoothed path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.gcode.moves import Move, MoveCategory, MoveKind, Program, Stop, StopKind
from feedopt.geometry.orientation_knots import waypoint_arc_lengths
from feedopt.geometry.path import build_lipb_path
from feedopt.geometry.program_path import program_path
from feedopt.geometry.program_pieces import ProgramPathOptions


def _unit(v):
    v = np.asarray(v, dtype=float)
    return tuple(v / np.linalg.norm(v))


def _program(points, axes, categories=None, stops=()):
    moves = []
    for i in range(len(points) - 1):
        cat = MoveCategory.CUT if categories is None else categories[i]
        kind = MoveKind.RAPID if cat is MoveCategory.RAPID else MoveKind.LINE
        moves.append(Move(kind, cat, points[i], points[i + 1],
                          None if kind is MoveKind.RAPID else 10.0, 10000.0, 1, 1, None, None,
                          i + 1, None, "G1", axis_start=_unit(axes[i][0]),
                          axis_end=_unit(axes[i][1])))
    return Program(tuple(moves), "mm", (), (1,), (), "five.nc", stops=tuple(stops))


POINTS = [(0, 0, -1), (20, 0, -1), (40, 10, -1), (60, 0, -1)]
AXES = [((0, 0, 1), (0.2, 0, 1)), ((0.2, 0, 1), (0.2, 0.3, 1)), ((0.2, 0.3, 1), (0, 0, 1))]


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def test_program_vectors_sit_where_their_moves_start_and_end():
    r = program_path(_program(POINTS, AXES), ProgramPathOptions(stock_top=None))
    o = r.path.orientation
    assert o is not None and "tool vectors: 4 on the path" in r.warnings[-1]
    # each move's end vector where the next starts (the move table), within the tolerance
    s = np.append(r.moves.s_start[1:], r.path.length)
    want = np.array([_unit(a[1]) for a in AXES])
    assert np.all(_angle(o.evaluate(s).axis, want) <= math.radians(0.2) + 1e-12)
    # half way along the first move (outside any window) the great circle's midpoint exactly
    mid = 0.5 * (r.moves.s_start[0] + r.moves.s_start[1])
    half = np.add(_unit(AXES[0][0]), _unit(AXES[0][1]))
    assert _angle(o.evaluate([mid]).axis[0], half / np.linalg.norm(half)) < 1e-3


def test_turn_without_motion_before_a_cut_is_refused_before_air_is_moved():
    axes = [((0, 0, 1), (0, 0, 1)), ((0.3, 0, 1), (0.3, 0, 1)), ((0.3, 0, 1), (0.3, 0, 1))]
    with pytest.raises(InputError, match="line 2: the tool vector turns 16.7 deg before this "
                                         "cutting move"):
        program_path(_program(POINTS, axes), ProgramPathOptions(stock_top=None))
    cats = [MoveCategory.CUT, MoveCategory.RAPID, MoveCategory.CUT]
    r = program_path(_program(POINTS, [axes[0], ((0.3, 0, 1), (0.3, 0, 1)), axes[2]], cats),
                     ProgramPathOptions(stock_top=None))
    assert any("during the air move" in w for w in r.warnings)
    o = r.path.orientation
    # the rapid (move 2) turns from +z to the new vector along its length
    s0, s1 = r.moves.s_start[1], r.moves.s_start[2]
    got = o.evaluate(np.linspace(s0, s1, 5)).axis
    turn = _angle(got[1:], got[:-1])
    assert turn.sum() == pytest.approx(math.atan(0.3), rel=0.02)


def test_a_stop_keeps_its_kink():
    stop = Stop(after_move=0, kind=StopKind.EXACT, hold_s=0.0, line=1, n_number=None, text="G9")
    r = program_path(_program(POINTS, AXES, stops=[stop]), ProgramPathOptions(stock_top=None))
    o = r.path.orientation
    k = int(np.argmin(np.abs(o.knots.s - r.moves.s_start[1])))
    assert o.knots.stop[k] and o.half_window[k] == 0.0
    assert o.half_window[k + 1] > 0.0


def test_waypoints_sit_mid_blend():
    w = np.array([[0, 0, 0], [0.05, 0, 0], [0.05, 0.05, 0], [0.1, 0.05, 0.0]])
    path = build_lipb_path(w, "circle", 0.005)
    s = waypoint_arc_lengths(path, w)
    # a circle blend of radius r at a right angle: mid-blend is r (sqrt(2) - 1) from the corner
    p = path.evaluate(s[1:3]).position
    assert np.linalg.norm(p - w[1:3], axis=1) == pytest.approx(0.005 * (math.sqrt(2) - 1),
                                                               rel=1e-6)
    assert s[0] == 0.0 and s[-1] == path.length


def test_sampling_is_finer_where_the_tool_turns_fast():
    # the tool turns 30 deg over a 1 mm move between two 20 mm moves
    points = [(0, 0, -1), (20, 0, -1), (21, 0, -1), (41, 0, -1)]
    axes = [((0, 0, 1), (0, 0, 1)), ((0, 0, 1), (math.sin(math.radians(30)), 0,
                                                 math.cos(math.radians(30)))),
            ((math.sin(math.radians(30)), 0, math.cos(math.radians(30))),) * 2]
    r = program_path(_program(points, axes), ProgramPathOptions(stock_top=None))
    p = r.path.sample(0.0002)
    turn = np.degrees(_angle(p.axis[1:], p.axis[:-1]))
    assert turn.max() <= 0.5 + 1e-9
    step = np.diff(p.s)
    assert 0.00019 < step.max() <= 0.0002  # coarse where it does not turn
    assert p.s.size < 0.042 / 0.0002 + 150


def test_vectors_of_moves_smoothed_to_nothing_are_merged_within_half_the_tolerance():
    from feedopt.geometry.orientation_knots import program_knots

    axes = [((0, 0, 1), (0, 0, 1)), ((0, 0, 1), (0.001, 0, 1)), ((0.001, 0, 1),) * 2]
    prog = _program(POINTS, axes)
    s_start = np.array([0.0, 0.02, 0.02])  # the second move shortened to nothing
    with pytest.raises(InputError, match="line 2: two tool vectors at one point of the path"):
        program_knots(prog, s_start, np.arange(3), np.zeros(0), 0.05, merge=0.0)
    knots, notes, merged = program_knots(prog, s_start, np.arange(3), np.zeros(0), 0.05,
                                         merge=math.radians(0.1))
    assert merged == pytest.approx(math.atan(0.001), rel=1e-6)
    assert "merged with their neighbour" in notes[0]
    assert np.all(np.diff(knots.s) > 0)


def test_misnamed_vector_columns_and_a_repeated_point_that_turns_are_refused(tmp_path):
    import types

    from feedopt.geometry.stage import path_from_section
    from feedopt.geometry.waypoints import read_tool_vectors_csv

    for header in ("I,J,K", "i_mm,j_mm,k_mm", "tool_i,tool_j,tool_k"):
        f = tmp_path / "w.csv"
        f.write_text(f"x_mm,y_mm,z_mm,{header}\n0,0,0,0,0,1\n50,0,0,0,0,1\n")
        with pytest.raises(InputError, match="look like a tool vector"):
            read_tool_vectors_csv(f)
    f = tmp_path / "r.csv"
    f.write_text("x_mm,y_mm,z_mm,i,j,k\n0,0,0,0,0,1\n50,0,0,0,0,1\n50,0,0,0,0.2,1\n"
                 "50,50,0,0,0,1\n")
    section = types.SimpleNamespace(generator="csv", file="r.csv", blend="circle",
                                    blend_size_mm=5.0, drop_repeated_waypoints=True,
                                    orientation_tolerance_deg=0.2)
    with pytest.raises(InputError, match="waypoint 3 repeats the one before with a tool "
                                         "vector 11.3 deg away"):
        path_from_section(section, tmp_path)
