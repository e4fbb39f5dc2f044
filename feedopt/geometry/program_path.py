"""A G-code program as one G2-continuous path, within a stated tolerance of the program.

:func:`program_path` turns a :class:`~feedopt.gcode.moves.Program` into a
:class:`~feedopt.geometry.path.Path` in six named phases:

1. *check and link*: at least one cutting move; where the reader lost the tool's position
   (after M6, G28, G53) an air link straight up to the program's highest point, across and
   down (:func:`~feedopt.geometry.stops.air_links`); plunges are ordinary moves.
2. *pieces*: every line (G0/G1) and arc (G2/G3, :mod:`feedopt.geometry.arcs`) becomes a piece;
   runs of short, nearly tangent G1 cut moves (CAM output of free-form curves) become one
   quintic smoothing spline within the tolerance (:mod:`feedopt.geometry.smoothing`) instead
   of a chain of tiny blends with curvature spikes. A run never spans a stop: exact stops and
   tool changes split it, an M0/M1/G4 inside it is refused.
3. *stops*: the program's stops (G61/G9, G4, M0, M1, M6) and the junctions where a move turns
   back get no blend and no transition: the pieces meet at the programmed point, where the
   tool stops (:class:`~feedopt.geometry.stops.StopTable`).
4. *corners*: line-line corners get the scenario's corner blend (any registered kind, thesis
   3.3), its size the smallest of the one asked for, the largest that fits in half of each
   line, and the largest whose deviation from the corner is within tolerance both ways
   (:mod:`feedopt.geometry.junctions`).
5. *transitions*: every junction that is still not G2 (line-arc, arc-arc, spline ends, the
   ends of a circular blend, kinks next to arcs) gets a quintic G2 transition
   (:mod:`feedopt.geometry.transitions`) as long as the tolerance allows: its length starts
   at the one expected to deviate 0.9 of the tolerance and is adjusted until its measured
   deviation from the program is within tolerance both ways; a junction where none fits
   becomes a corner stop. Every round treats all junctions still to settle at once.
6. *provenance*: every programmed move (and air-link leg) gets the arc length where it starts
   on the smoothed path (:class:`MoveTable`), so every sample knows its program line, N
   number, move category and programmed feed, and the :class:`JunctionReport` gives, per
   programmed junction, what was done, the G0/G1/G2 jumps of the result and its deviation
   from the program.

The tolerance applies to junctions next to a cutting move (a plunge ending below the stock
top counts as one); a G64 P on the move before a junction (or on the moves of a smoothed run)
replaces it there. Junctions between air moves (rapids, plunges and retracts in air) use the
larger air tolerance. The deviation of a junction is the two-sided (Hausdorff) distance
between its modified stretch and the programmed geometry it replaces
(:mod:`feedopt.geometry.deviation`): from the path to the program (how far the tool leaves
it) and from the program to the path (how much of a programmed corner is cut short, the
larger one at sharp corners), against the programmed geometry (lines exactly, arcs as
polylines with a sag below 1e-3 of the tolerance, added to the distances), all junctions at
once.

The work is split by phase: :mod:`feedopt.geometry.program_pieces` (options, pieces,
tolerances), :mod:`feedopt.geometry.junctions` (corners, transitions and their fit),
:mod:`feedopt.geometry.deviation` (the distances), :mod:`feedopt.geometry.program_tables`
(what is reported); this module wires them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from feedopt.errors import InputError
from feedopt.gcode.moves import MoveCategory, Program
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.deviation import zoomed_max
from feedopt.geometry.junctions import (
    G2_TOL,
    MAX_ROUNDS,
    MIN_TRANSITION,
    Corner,
    Stretch,
    corners,
    fit_transitions,
    junction_of,
    non_g2,
    stretch_path,
    trimmed_pieces,
)
from feedopt.geometry.orientation import blend_orientation
from feedopt.geometry.orientation_knots import program_knots
from feedopt.geometry.path import COLLINEAR_TOL, Path
from feedopt.geometry.program_pieces import (
    SPLINE,
    Piece,
    ProgramPathOptions,
    g64_p_of,
    path_of,
    pieces_of,
    states,
    tolerances,
)
from feedopt.geometry.program_tables import ChainReport, JunctionReport, MoveTable, Treatment
from feedopt.geometry.registry import LINE, BlendKind, get_blend
from feedopt.geometry.stops import (
    StopTable,
    air_links,
    corner_stops,
    program_stop_points,
    reversal_points,
    stop_junctions,
    stop_table,
)
from feedopt.geometry.transitions import TRANSITION
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class ProgramPath:
    """The path of a program and how it was made: ``stops`` lists where the tool stops
    (also set as ``path.stops``, which :meth:`Path.sample` samples exactly)."""

    path: Path
    moves: MoveTable
    junctions: JunctionReport
    chains: tuple[ChainReport, ...]
    warnings: tuple[str, ...] = ()
    stops: StopTable = field(default_factory=StopTable.empty)


def check_program(program: Program) -> None:
    """InputError for a program with nothing to plan: no move, or only air moves. (Gaps
    become air links, plunges ordinary moves: the process stage models them.)"""
    if not any(m.category is MoveCategory.CUT for m in program.moves):
        raise InputError(f"{program.source}: the program has no cutting move (G1/G2/G3 across "
                         "the tool axis); there is nothing to plan")


def program_path(program: Program, opts: ProgramPathOptions) -> ProgramPath:
    """The G2 path of ``program`` (moves in mm, program frame) within ``opts`` tolerances,
    the tool stopping where the program asks, where a move turns back and where no G2
    transition fits (:attr:`ProgramPath.stops`).

    Raises InputError for programs with nothing to cut (:func:`check_program`), an air link
    below the stock top, an M0/M1/G4 inside a smoothed run and a scenario blend of "none" (a
    program path needs G2 corners).
    """
    check_program(program)
    kind = get_blend(opts.blend)
    if kind is None:
        raise InputError("path.blend: a program path is made G2 at every corner; choose a "
                         "blend kind (varying_radius, bezier5, ...), not none")
    top = None if opts.stock_top is None else opts.stock_top / MM
    linked, program_move, link_notes = air_links(program, top)
    g64_p = g64_p_of(linked)
    points = program_stop_points(linked)
    pieces = pieces_of(linked, opts, points, g64_p)
    base = path_of(pieces)
    tol = tolerances(linked, pieces, opts, g64_p)
    turn, jump = _programmed_jumps(base, pieces)
    last = np.array([_last_move(p) for p in pieces])
    points += reversal_points(linked, last, turn)
    built = _assemble(pieces, base, kind, opts, tol, turn, stop_junctions(last, points))
    corner_points, corner_notes = corner_stops(linked, last, built.failed, tol)
    points += corner_points
    moves = _move_table(linked, pieces, built.stretches, built.path, built.dev, program_move)
    report = _junction_report(pieces, built, turn, jump, tol, moves)
    stops = stop_table(points, moves.s_start, built.path.length)
    path = Path(built.path.segments, moves=moves)
    path.stops = stops
    path.tool_headers = tuple(program.tool_headers)
    axis_notes = _orient(path, linked, program_move, opts) if program.five_axis else []
    chains = tuple(p.chain for p in pieces if p.chain is not None)
    return ProgramPath(path, moves, report, chains,
                       tuple(_notes(link_notes, corner_notes, chains, opts, g64_p, stops,
                                    built.path.length) + axis_notes), stops)


def _orient(path: Path, linked: Program, program_move: np.ndarray,
            opts: ProgramPathOptions) -> list[str]:
    """Give a five-axis program's path its G2 orientation (``path.orientation``) within the
    angle tolerance; the notes say what was done."""
    tol = opts.orientation_tolerance
    knots, notes, merged = program_knots(linked, path.moves.s_start, program_move,
                                         path.stop_s, path.length, merge=0.5 * tol)
    path.orientation = blend_orientation(knots, tol - merged)
    dev = path.orientation.deviation()
    blended = int(np.count_nonzero(path.orientation.half_window))
    notes.append(f"tool vectors: {knots.s.size} on the path, {blended} turn(s) of their "
                 f"great circles blended G2 within {math.degrees(opts.orientation_tolerance):g}"
                 f" deg (largest {math.degrees(dev.max(initial=0.0)):.3g} deg)")
    return notes


def _notes(link_notes, corner_notes, chains, opts: ProgramPathOptions, g64_p: np.ndarray,
           stops: StopTable, length: float) -> list[str]:
    """What building the path tells the user: air links, corner stops, smoothed runs and
    where the tool stops."""
    warnings = [*link_notes, *corner_notes]
    if chains:
        warnings.append(
            f"{len(chains)} run(s) of short G1 moves ({sum(c.moves for c in chains)} moves) "
            f"smoothed into quintic splines within {opts.tolerance / MM:g} mm"
            + ("" if np.isnan(g64_p).all() else " (or the G64 P in force)")
            + f" (largest deviation {max(c.deviation for c in chains) / MM:.3g} mm)")
    inside = (stops.s > 0.0) & (stops.s < length)
    if np.any(inside | (stops.hold_s > 0)):  # not just the ends, where the tool is at rest
        shown = "; ".join(stops.label[:5]) + (f"; ... ({len(stops) - 5} more)"
                                               if len(stops) > 5 else "")
        warnings.append(f"the tool stops on the path: {stops.summary()}: {shown}")
    return warnings


def _last_move(piece: Piece) -> int:
    return piece.first_move + piece.n_moves - 1


def _programmed_jumps(base: Path, pieces: list[Piece]) -> tuple[np.ndarray, np.ndarray]:
    """Turn [rad] and curvature jump [1/m] of the programmed geometry at every junction."""
    m = len(pieces)
    j_all = np.arange(m - 1)
    end = states(base, j_all, np.array([p.length for p in pieces[:-1]]))
    start = states(base, j_all + 1, np.zeros(m - 1))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", end.t, start.t), -1.0, 1.0))
    return turn, np.linalg.norm(start.k - end.k, axis=1)


@dataclass
class _Built:
    """The assembled path: its stretches, the path, per treated junction its deviations
    (path -> program, program -> path) and the s nearest the programmed junction point, the
    corner blends, the junctions where the tool stops, and those that became corner stops
    (junction -> best deviation [m])."""

    stretches: list[Stretch]
    path: Path
    dev: dict[int, tuple[float, float, float]]
    corners: Corner
    stop_j: np.ndarray
    failed: dict[int, float]


def _assemble(pieces: list[Piece], base: Path, kind: BlendKind, opts: ProgramPathOptions,
              tol: np.ndarray, turn: np.ndarray, stop_j: np.ndarray) -> _Built:
    """Corners and transitions everywhere but at stops; a junction where no transition fits
    the tolerance becomes a stop and the path is built again without it."""
    stop_j = stop_j.copy()
    failed: dict[int, float] = {}
    is_line = np.array([p.kind == LINE for p in pieces])
    while True:
        corner_j = np.flatnonzero(is_line[:-1] & is_line[1:] & (turn >= COLLINEAR_TOL)
                                  & ~stop_j)
        corner = corners(kind, opts.blend_size, pieces, base, corner_j, tol)
        stretches0 = trimmed_pieces(pieces, corner)
        path0 = stretch_path(stretches0)
        at = non_g2(path0, stretches0)
        owner = np.array([junction_of(stretches0, i) for i in at.tolist()], dtype=np.intp)
        keep = ~stop_j[owner]
        fit = fit_transitions(stretches0, path0, at[keep], owner[keep], tol, pieces, corner)
        if not fit.failed:
            return _Built(fit.stretches, fit.path, fit.dev, corner, stop_j, failed)
        for j, d in fit.failed.items():
            failed[j] = d
            stop_j[j] = True


def segment_labels(path: Path) -> list[str]:
    """A readable name per segment of a program path: its kind and the program line of the
    move it follows ("arc at line 88 (N880)")."""
    mid = path.segment_start + 0.5 * np.array([g.length for g in path.segments])
    idx = path.moves.index_at(mid)
    return [f"{g.kind} at {path.moves.label(int(i))}" for g, i in zip(path.segments, idx,
                                                                      strict=True)]


def _move_table(program: Program, pieces: list[Piece], stretches: list[Stretch],
                path: Path, dev: dict, program_move: np.ndarray) -> MoveTable:
    """Where every move starts on the path: a treated junction at the point of its modified
    stretch nearest the programmed corner, any other exactly at its segment boundary."""
    starts = path.segment_start
    piece = np.array([x.piece for x in stretches])
    at = np.flatnonzero(piece >= 0)  # the stretch of every piece, in piece order
    offset = np.array([stretches[i].offset for i in at.tolist()])
    length = np.array([stretches[i].length for i in at.tolist()])
    n_moves = np.array([p.n_moves for p in pieces])
    inner = np.concatenate([p.node_s[:-1] for p in pieces])
    rep = np.repeat(np.arange(len(pieces)), n_moves)
    s_start = np.clip(starts[at][rep] + inner - offset[rep], starts[at][rep],
                      starts[at][rep] + length[rep])
    first = np.cumsum(n_moves) - n_moves
    near = np.array([dev[j][2] if j in dev else math.nan for j in range(len(pieces) - 1)])
    treated = np.isfinite(near)
    s_start[first[1:][treated]] = near[treated]
    s_start[first[1:][~treated]] = starts[at[1:]][~treated]
    s_start[0] = 0.0
    s_start = np.maximum.accumulate(s_start)
    mv = program.moves
    return MoveTable(
        s_start=s_start,
        line=np.array([m.line for m in mv], dtype=np.int64),
        n_number=np.array([-1 if m.n_number is None else m.n_number for m in mv],
                          dtype=np.int64),
        category=program.categories.copy(),
        kind=program.kinds.copy(),
        feed=program.feeds_mm_s * MM,
        spindle_rpm=np.array([math.nan if m.spindle_rpm is None else m.spindle_rpm
                              for m in mv], dtype=float),
        tool=np.array([-1 if m.tool is None else m.tool for m in mv], dtype=np.int64),
        program_move=program_move,
    )


def _junction_jumps(stretches: list[Stretch], path: Path, m: int) -> np.ndarray:
    """(3, m-1) largest G0 [m], G1, G2 [1/m] jump of the path over every programmed junction
    (a stretch junction belongs to its blend's or transition's programmed junction, or to the
    junction between consecutive pieces)."""
    g = np.zeros((3, m - 1))
    if len(path.segments) < 2:
        return g
    cont = continuity_report(path)
    junction = np.array([x.junction for x in stretches])
    piece = np.array([x.piece for x in stretches])
    a_j, b_j, a_p, b_p = junction[:-1], junction[1:], piece[:-1], piece[1:]
    owner = np.where(a_j >= 0, a_j, np.where(b_j >= 0, b_j,
                                             np.where(b_p == a_p + 1, a_p, -1)))
    ok = owner >= 0
    for k, v in enumerate((cont.g0, cont.g1, cont.g2)):
        np.maximum.at(g[k], owner[ok], np.asarray(v)[ok])
    return g


def _junction_report(pieces: list[Piece], built: _Built, turn: np.ndarray, jump: np.ndarray,
                     tol: np.ndarray, moves: MoveTable) -> JunctionReport:
    m = len(pieces)
    stretches, corner, dev = built.stretches, built.corners, built.dev
    g = _junction_jumps(stretches, built.path, m)
    size = np.full(m - 1, np.nan)
    size[corner.junction] = corner.size
    kinds = np.array([x.kind for x in stretches])
    junction = np.array([x.junction for x in stretches])
    is_t = kinds == TRANSITION
    trans_len = np.zeros(m - 1)
    np.add.at(trans_len, junction[is_t], np.array([x.length for x in stretches])[is_t])
    has_t = np.zeros(m - 1, dtype=bool)
    has_t[junction[is_t]] = True
    trans_len[~has_t] = np.nan
    blend = np.isfinite(size)
    treatment = np.select(
        [built.stop_j, blend & has_t, blend, has_t],
        [Treatment.STOP.value, Treatment.BLEND_TRANSITIONS.value, Treatment.BLEND.value,
         Treatment.TRANSITION.value], Treatment.NONE.value)
    path_dev = np.zeros(m - 1)
    prog_dev = np.zeros(m - 1)
    for j, (a, b, _) in dev.items():
        path_dev[j], prog_dev[j] = a, b
    before = np.array([_last_move(p) for p in pieces[:-1]], dtype=np.int64)
    labels = tuple(f"{moves.label(int(b))}->{int(moves.line[b + 1])}" for b in before)
    first = np.array([p.first_move for p in pieces[1:]], dtype=np.int64)
    return JunctionReport(before=before, s=moves.s_start[first], turn=turn,
                          curvature_jump=jump, treatment=tuple(treatment.tolist()), size=size,
                          transition_length=trans_len, deviation=np.maximum(path_dev, prog_dev),
                          tolerance=tol, g0=g[0], g1=g[1], g2=g[2], labels=labels,
                          path_deviation=path_dev, program_deviation=prog_dev)


__all__ = ["ChainReport", "JunctionReport", "MoveTable", "ProgramPath", "ProgramPathOptions",
           "SPLINE", "StopTable", "Treatment", "check_program", "program_path",
           "segment_labels", "zoomed_max", "G2_TOL", "MAX_ROUNDS", "MIN_TRANSITION"]
