"""Where a program's path stops, and how it crosses the stretches where the tool is lost.

A program path is one :class:`~feedopt.geometry.path.Path`, but the tool stops (feed,
acceleration and jerk zero) at some of its points: where the program asks for it (G61/G9
exact stops, G4 dwells, M0/M1, M6: :attr:`~feedopt.gcode.moves.Program.stops`) and where the
geometry needs it (a move turning back, a corner no G2 transition within the tolerance fits).
At a stop the two pieces meet at the programmed point with no blend and no transition (a G1
corner is harmless at zero feed). :class:`StopTable` lists the stops by arc length.

Where the reader loses the tool's position (after M6, G28, G53: the next move is an
``approach`` or starts elsewhere), :func:`air_links` adds an air link: straight up to the
clearance height (the highest point of the program's moves), across, and down to the start of
the next move, three rapid moves the path blends like any other.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.gcode.lexer import where
from feedopt.gcode.moves import (
    SAME_POINT_MM,
    Move,
    MoveCategory,
    MoveKind,
    Plane,
    Program,
    StopKind,
    sample_move,
)
from feedopt.geometry.path import REVERSAL_TOL
from feedopt.units import MM

#: a merged stop is named by its most telling kind, in this order
KIND_ORDER = (StopKind.PROGRAM_STOP, StopKind.OPTIONAL_STOP, StopKind.TOOL_CHANGE,
              StopKind.DWELL, StopKind.REVERSAL, StopKind.CORNER, StopKind.EXACT)
#: stops in a run of short moves smoothed as one curve that are refused (the others split it)
REFUSED_IN_CHAIN = (StopKind.PROGRAM_STOP, StopKind.OPTIONAL_STOP, StopKind.DWELL)
#: stops closer than this in arc length [m] are one stop
MERGE_S = 1e-9


@dataclass(frozen=True)
class StopTable:
    """The stops of a path, by increasing arc length (several at one point merged).

    s : (k,) arc length [m], increasing; a stop at a segment boundary is where the following
        segment starts, so evaluating the path there gives the outgoing tangent (right-sided)
    kind : (k,) :class:`~feedopt.gcode.moves.StopKind` values (merged: the most telling of
        :data:`KIND_ORDER`; the label names them all)
    hold_s : (k,) time held there [s] (the dwells' sum; 0 for the others)
    line : (k,) program line of the (first) block that asked for it
    label : (k,) ``"line 12 (N120): G4 P1"``; merged stops joined with ``" + "``, each with its
        kind in brackets
    """

    s: np.ndarray
    kind: tuple[str, ...]
    hold_s: np.ndarray
    line: np.ndarray
    label: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.s.size)

    @classmethod
    def empty(cls) -> StopTable:
        """A table without stops."""
        return cls(np.zeros(0), (), np.zeros(0), np.zeros(0, dtype=np.int64), ())

    def sample_index(self, s: np.ndarray) -> np.ndarray:
        """Index of the sample at each stop in the sorted arc lengths ``s`` [m] (those of
        :meth:`~feedopt.geometry.path.Path.sample`, which samples every stop exactly);
        ``ValueError`` if a stop has no sample within 1e-9 m."""
        s = np.asarray(s, dtype=float)
        idx = np.clip(np.searchsorted(s, self.s), 0, max(s.size - 1, 0))
        left = np.maximum(idx - 1, 0)
        idx = np.where(np.abs(s[left] - self.s) < np.abs(s[idx] - self.s), left, idx)
        if s.size == 0 or np.any(np.abs(s[idx] - self.s) > MERGE_S):
            raise ValueError("the samples do not include every stop: sample the path with "
                             "Path.sample (it puts a sample at every stop)")
        return idx

    def summary(self) -> str:
        """``"3 stop(s): 2 exact stop, 1 dwell (1.5 s held)"``."""
        kinds = ", ".join(f"{self.kind.count(k)} {k}" for k in dict.fromkeys(self.kind))
        held = float(self.hold_s.sum())
        return f"{len(self)} stop(s): {kinds}" + (f" ({held:g} s held)" if held > 0 else "")


@dataclass(frozen=True)
class StopPoint:
    """One reason to stop, before merging: after move ``after_move`` of the path's move list
    (-1: at the start), with its kind, hold [s], program line and label."""

    after_move: int
    kind: StopKind
    hold_s: float
    line: int
    label: str


def move_label(m: Move) -> str:
    """``"line 12 (N120)"``."""
    return f"line {m.line}" + (f" (N{m.n_number})" if m.n_number is not None else "")


def program_stop_points(program: Program) -> list[StopPoint]:
    """The stops the program asks for (its :attr:`~Program.stops`)."""
    return [StopPoint(st.after_move, st.kind, float(st.hold_s), st.line,
                      f"line {st.line}" + (f" (N{st.n_number})" if st.n_number is not None
                                           else "") + f": {st.text.strip()}")
            for st in program.stops]


def geometric_stop(program: Program, after_move: int, kind: StopKind, why: str) -> StopPoint:
    """A stop the path adds (reversal, corner) at the end of move ``after_move``, named by the
    move that follows it."""
    m = program.moves[after_move + 1]
    return StopPoint(after_move, kind, 0.0, m.line, f"{move_label(m)}: {m.text.strip()} ({why})")


def stop_table(points: list[StopPoint], s_start: np.ndarray, length: float) -> StopTable:
    """The merged table of ``points`` on a path of ``length`` [m] whose moves start at
    ``s_start`` [m] (a stop after the last move is at the end)."""
    if not points:
        return StopTable.empty()
    after = np.array([p.after_move for p in points], dtype=np.int64)
    s_of = np.append(s_start, length)
    s = np.where(after < 0, 0.0, s_of[np.clip(after + 1, 0, s_of.size - 1)])
    order = np.argsort(s, kind="stable")
    s = s[order]
    first = np.flatnonzero(np.concatenate([[True], np.diff(s) > MERGE_S]))
    out_s, kinds, holds, lines, labels = [], [], [], [], []
    for lo, hi in zip(first.tolist(), [*first[1:].tolist(), s.size], strict=True):
        members = [points[i] for i in order[lo:hi]]
        out_s.append(float(s[lo]))
        kind = min((p.kind for p in members), key=KIND_ORDER.index)
        kinds.append(kind.value)
        holds.append(sum(p.hold_s for p in members))
        lines.append(members[0].line)
        labels.append(members[0].label if len(members) == 1 else
                      " + ".join(f"{p.label} [{p.kind.value}]" for p in members))
    return StopTable(np.array(out_s), tuple(kinds), np.array(holds),
                     np.array(lines, dtype=np.int64), tuple(labels))


def reversal_points(program: Program, last: np.ndarray, turn: np.ndarray) -> list[StopPoint]:
    """A stop at every junction between pieces (``last``: each piece's last move) where the
    path turns back by more than ``pi - REVERSAL_TOL`` (``turn`` [rad]): no blend rounds it."""
    out = []
    for j in np.flatnonzero(turn > np.pi - REVERSAL_TOL).tolist():
        before = program.moves[int(last[j])]
        out.append(geometric_stop(program, int(last[j]), StopKind.REVERSAL,
                                  f"turns back {math.degrees(turn[j]):.3f} deg from line "
                                  f"{before.line}"))
    return out


def corner_stops(program: Program, last: np.ndarray, failed: dict[int, float],
                 tol: np.ndarray) -> tuple[list[StopPoint], list[str]]:
    """A stop and a note for every junction (after piece j, ``last`` its last move) where no
    G2 transition fits the tolerance ``tol[j]`` [m] (``failed``: j -> shortest's deviation;
    nan: its transition cannot be built G2, :mod:`feedopt.geometry.junctions`)."""
    points, notes = [], []
    for j, best in sorted(failed.items()):
        before, after = program.moves[int(last[j])], program.moves[int(last[j]) + 1]
        points.append(geometric_stop(program, int(last[j]), StopKind.CORNER,
                                     f"no G2 transition within {tol[j] / MM:g} mm: corner "
                                     "stop"))
        if math.isnan(best):  # junctions: a transition too short to be built G2
            notes.append(f"{where(program.source, after.line, after.n_number)}: the G2 "
                         f"transition within the tolerance {tol[j] / MM:g} mm at the junction "
                         f"with line {before.line} cannot be built G2: it would be a fraction "
                         "of a micrometre long (a move about that short, or a near-reversal), "
                         "too short for floating point to match its end curvatures; the tool "
                         "stops there (a corner stop)")
            continue
        notes.append(f"{where(program.source, after.line, after.n_number)}: no G2 transition "
                     f"within the tolerance {tol[j] / MM:g} mm fits the junction with line "
                     f"{before.line} (the shortest tried deviates {best / MM:.3g} mm): the "
                     "tool stops there (a corner stop; a larger path.tolerance_mm would round "
                     "it)")
    return points, notes


def stop_junctions(last: np.ndarray, points: list[StopPoint]) -> np.ndarray:
    """(m - 1,) True at the junctions between pieces (``last``: each piece's last move) where
    a stop lies."""
    after = np.array([p.after_move for p in points if 0 <= p.after_move < last[-1]],
                     dtype=np.int64)
    j = np.searchsorted(last, after)
    if np.any(last[j] != after):  # split_runs cuts every run at its stops
        raise RuntimeError("a stop inside a smoothed chain")
    stop_j = np.zeros(last.size - 1, dtype=bool)
    stop_j[j] = True
    return stop_j


# --- stops and smoothed chains -----------------------------------------------------------


def split_runs(runs: list[tuple[int, int]], points: list[StopPoint], program: Program,
               min_moves: int) -> list[tuple[int, int]]:
    """The chain ``runs`` (first, last move) cut at the exact stops and tool changes inside
    them (pieces shorter than ``min_moves`` moves are not smoothed); InputError for an M0, M1
    or G4 inside a run without an exact stop at the same point: the tool cannot stop inside
    a curve smoothed as one."""
    if not points or not runs:
        return runs
    after = np.array(sorted(p.after_move for p in points))
    by_after: dict[int, list[StopPoint]] = {}
    for p in points:
        by_after.setdefault(p.after_move, []).append(p)
    out = []
    for first, last in runs:
        inside = after[np.searchsorted(after, first):np.searchsorted(after, last)]
        cuts = sorted(set(inside.tolist()))
        for a in cuts:
            kinds = {p.kind for p in by_after[a]}
            if kinds <= set(REFUSED_IN_CHAIN):  # no exact stop or tool change there as well
                _refuse_stop_in_chain(by_after[a][0], program, first, last, a)
        bounds = [first, *(a + 1 for a in cuts), last + 1]
        out += [(lo, hi - 1) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)
                if hi - lo >= min_moves]
    return out


def _refuse_stop_in_chain(p: StopPoint, program: Program, first: int, last: int,
                          a: int) -> None:
    moves = program.moves
    longer = max(moves[a].length_mm, moves[a + 1].length_mm)
    code = {StopKind.PROGRAM_STOP: "an M0", StopKind.OPTIONAL_STOP: "an M1"}.get(
        p.kind, "a G4 dwell")
    raise InputError(
        f"{where(program.source, p.line, None)}: {code} inside a run of short moves smoothed "
        f"as one curve (lines {moves[first].line}-{moves[last].line}; it would stop between "
        f"lines {moves[a].line} and {moves[a + 1].line}): the tool cannot stop inside that "
        f"curve. Make it an exact stop (G9 on line {moves[a].line}, or G61 before it and G64 "
        f"after), or set path.chain_max_move_mm below {longer:.4g} mm (the longer of the two "
        "moves there) so the moves are not smoothed, or remove the stop")


# --- air links across unknown positions ----------------------------------------------------


def clearance_mm(program: Program) -> float:
    """The highest Z [mm] of the program's moves (end points; arcs in G18/G19 sampled)."""
    z = max(float(program.starts[:, 2].max()), float(program.ends[:, 2].max()))
    for m in program.moves:
        if m.kind is MoveKind.ARC and m.plane is not Plane.XY:
            z = max(z, float(sample_move(m, 1.0)[:, 2].max()))
    return z


def _gaps(program: Program) -> np.ndarray:
    """Indices i of the moves the tool reaches from an unknown position (i >= 1): an
    ``approach`` or a start away from the previous end."""
    gap = np.linalg.norm(program.starts[1:] - program.ends[:-1], axis=1) > SAME_POINT_MM
    gap |= np.array([m.approach for m in program.moves[1:]], dtype=bool)
    return np.flatnonzero(gap) + 1


def _leg(after: Move, start: np.ndarray, end: np.ndarray, text: str) -> Move:
    """A rapid of an air link, with the provenance of the move it leads to."""
    return Move(MoveKind.RAPID, MoveCategory.RAPID, tuple(float(v) for v in start),
                tuple(float(v) for v in end), None, after.spindle_rpm,
                after.spindle_direction, after.tool, after.work_offset, after.length_offset,
                after.line, after.n_number, text)


def _link_legs(before: Move, after: Move, z_mm: float) -> list[Move]:
    """Straight up from ``before``'s end to ``z_mm``, across, down to ``after``'s start
    (legs shorter than the same-point distance left out)."""
    p, q = np.asarray(before.end), np.asarray(after.start)
    pts = [p, np.array([p[0], p[1], z_mm]), np.array([q[0], q[1], z_mm]), q]
    text = f"(air link: position unknown between lines {before.line} and {after.line})"
    return [_leg(after, a, b, text) for a, b in zip(pts[:-1], pts[1:], strict=True)
            if np.linalg.norm(b - a) > SAME_POINT_MM]


def _check_above(program: Program, gaps: np.ndarray, top_mm: float) -> None:
    """InputError where a link would start or end below the stock top, or the program's
    first move (an approach) starts below it."""
    moves = program.moves
    first = moves[0]
    if first.approach and first.start[2] < top_mm - SAME_POINT_MM:
        raise InputError(
            f"{where(program.source, first.line, first.n_number)}: the program's first move "
            f"starts at Z{first.start[2]:g} mm, below the stock top (Z{top_mm:g} mm), and the "
            "tool would come to it through the air: position the tool above the stock first "
            "(G0 X Y at a safe Z, then down at feed)")
    for i in gaps.tolist():
        before, after = moves[i - 1], moves[i]
        if before.end[2] < top_mm - SAME_POINT_MM:
            raise InputError(
                f"{where(program.source, before.line, before.n_number)}: the tool is at "
                f"Z{before.end[2]:g} mm, below the stock top (Z{top_mm:g} mm), when the "
                f"program loses its position after this move (a tool change, G28 or G53 "
                f"before line {after.line}); feedopt links such gaps straight up through the "
                "air: retract above the stock (G0 Z...) first")
        if after.start[2] < top_mm - SAME_POINT_MM:
            raise InputError(
                f"{where(program.source, after.line, after.n_number)}: after the unknown "
                f"position (a tool change, G28 or G53 after line {before.line}) this move "
                f"starts at Z{after.start[2]:g} mm, below the stock top (Z{top_mm:g} mm): the "
                "air link would come down into the material at rapid; position the tool "
                "above the stock first (G0 X Y at a safe Z, then down at feed)")


def air_links(program: Program, stock_top_mm: float | None
              ) -> tuple[Program, np.ndarray, tuple[str, ...]]:
    """The program with an air link before every move reached from an unknown position
    (its stops' ``after_move`` renumbered), the index of every new move's program move (-1
    for link legs), and a note per link saying what was assumed. InputError for links or a
    first approach below ``stock_top_mm`` (None: not checked)."""
    gaps = _gaps(program)
    if stock_top_mm is not None:
        _check_above(program, gaps, stock_top_mm)
    n = len(program.moves)
    if not gaps.size:
        return program, np.arange(n), ()
    z = clearance_mm(program)
    moves: list[Move] = []
    source: list[int] = []
    notes = []
    gap_set = set(gaps.tolist())
    for i, m in enumerate(program.moves):
        if i in gap_set:
            legs = _link_legs(program.moves[i - 1], m, z)
            moves += legs
            source += [-1] * len(legs)
            p, q = (", ".join(f"{v:g}" for v in x) for x in (program.moves[i - 1].end, m.start))
            notes.append(
                f"lines {program.moves[i - 1].line}-{m.line}: the tool position is unknown "
                f"between them (a tool change, G28 or G53); assumed an air link at rapid from "
                f"({p}) straight up to Z{z:g} mm (the program's highest point), across and "
                f"down to ({q}) mm")
        moves.append(m)
        source.append(i)
    source_arr = np.array(source, dtype=np.int64)
    new_index = np.flatnonzero(source_arr >= 0)
    stops = tuple(st if st.after_move < 0 else
                  dataclasses.replace(st, after_move=int(new_index[st.after_move]))
                  for st in program.stops)
    linked = dataclasses.replace(program, moves=tuple(moves), stops=stops)
    return linked, source_arr, tuple(notes)


__all__ = ["KIND_ORDER", "StopPoint", "StopTable", "air_links", "clearance_mm",
           "corner_stops", "geometric_stop", "move_label", "program_stop_points",
           "reversal_points", "split_runs", "stop_junctions", "stop_table"]
