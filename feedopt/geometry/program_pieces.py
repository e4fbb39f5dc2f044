"""The pieces of a program path before corners and transitions: every programmed line and arc,
and every run of short, nearly tangent G1 cut moves smoothed into one quintic spline
(:mod:`feedopt.geometry.smoothing`, all runs of a program fitted together); the options of the
whole construction and the tolerance that applies at every junction."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.gcode.moves import SAME_POINT_MM, MoveCategory, MoveKind, Program
from feedopt.geometry.arcs import ARC, arc_params
from feedopt.geometry.path import Path, Segment
from feedopt.geometry.program_tables import ChainReport
from feedopt.geometry.registry import LINE
from feedopt.geometry.smoothing import smooth_chains
from feedopt.geometry.stops import StopPoint, split_runs
from feedopt.units import MM

SPLINE = "spline"  #: segment kind of smoothed chains (:mod:`feedopt.geometry.smoothing`)


@dataclass(frozen=True)
class ProgramPathOptions:
    """How a program becomes a path (SI units).

    tolerance : largest deviation from the program next to cutting moves [m]
    air_tolerance : the same between air moves (rapids, plunges, retracts) [m]
    blend, blend_size : corner blend kind of line-line corners and its size [m]
    chain_max_move : G1 cut moves up to this long may be smoothed as a chain [m]
    chain_max_turn : ... if consecutive ones turn by at most this [rad]
    chain_min_moves : ... and at least this many follow each other
    stock_top : height of the stock's top face in the program frame [m]: a plunge ending
        below it gets the cutting tolerance, an air link (or the first approach) below it is
        refused; None: plunges count as air moves and links are not checked
    orientation_tolerance : five-axis programs: largest angle between the smoothed tool
        vector and the programmed one [rad] (:mod:`feedopt.geometry.orientation`)
    """

    tolerance: float = 0.01 * MM
    air_tolerance: float = 0.5 * MM
    blend: str = "varying_radius"
    blend_size: float = 5.0 * MM
    chain_max_move: float = 2.0 * MM
    chain_max_turn: float = math.radians(15.0)
    chain_min_moves: int = 4
    stock_top: float | None = 0.0
    orientation_tolerance: float = math.radians(0.2)


@dataclass
class Piece:
    """A programmed line or arc, or a smoothed chain of moves, before corners and
    transitions: a segment ``kind`` with its ``params`` and ``length`` [m]."""

    kind: str
    params: dict
    length: float
    first_move: int
    n_moves: int
    node_s: np.ndarray  # (n_moves + 1,) arc length of the move boundaries on the piece [m]
    polyline: np.ndarray  # (p, 3) the programmed geometry [m]
    poly_s: np.ndarray  # (p,) programmed arc length along it [m]
    chain: ChainReport | None = None
    sag: float = 0.0  # how far the programmed geometry is from ``polyline`` at most [m]


def _arc_polyline(params: dict, length: float, sag: float) -> tuple[np.ndarray, np.ndarray]:
    r, lam = params["radius"], math.hypot(params["radius"], params["rise"])
    step = 2.0 * math.sqrt(2.0 * sag / r) if r > 0 else params["angle"]
    k = max(2, math.ceil(params["angle"] / min(step, 0.1)))
    phi = np.linspace(0.0, params["angle"], k + 1)
    pts = (params["centre"] + r * (np.cos(phi)[:, None] * params["e1"]
                                   + np.sin(phi)[:, None] * params["e2"])
           + (params["rise"] * phi)[:, None] * params["normal"])
    return pts, phi * lam


def _chain_runs(program: Program, opts: ProgramPathOptions) -> list[tuple[int, int]]:
    """(first, last) move indices of the runs of short, nearly tangent G1 cut moves with one
    feed."""
    moves = program.moves
    n = len(moves)
    vec = (program.ends - program.starts) * MM
    length = np.linalg.norm(vec, axis=1)
    ok = np.array([m.kind is MoveKind.LINE and m.category is MoveCategory.CUT for m in moves])
    ok &= length <= opts.chain_max_move
    d = vec / np.maximum(length, 1e-300)[:, None]
    cos = np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1.0, 1.0)
    feeds = program.feeds_mm_s
    link = ok[:-1] & ok[1:] & (np.arccos(cos) <= opts.chain_max_turn) & (feeds[:-1] == feeds[1:])
    runs = []
    i = 0
    while i < n:
        if not ok[i]:
            i += 1
            continue
        j = i
        while j < n - 1 and link[j]:
            j += 1
        if j - i + 1 >= opts.chain_min_moves:
            runs.append((i, j))
        i = j + 1
    return runs


def pieces_of(program: Program, opts: ProgramPathOptions, points: list[StopPoint],
              g64_p: np.ndarray) -> list[Piece]:
    """The pieces in order: chains (split at stops) smoothed within the smallest G64 P of
    their moves (``opts.tolerance`` without), all in one call, every other move a line or an
    arc."""
    runs = dict(split_runs(_chain_runs(program, opts), points, program, opts.chain_min_moves))
    firsts = sorted(runs)
    chain_pts = [np.vstack([program.starts[i], program.ends[i:runs[i] + 1]]) * MM
                 for i in firsts]
    smoothed = dict(zip(firsts, smooth_chains(
        chain_pts, [run_tolerance(g64_p[i:runs[i] + 1], opts) for i in firsts]), strict=True))
    pieces: list[Piece] = []
    moves = program.moves
    sag = 1e-3 * min(opts.tolerance, run_tolerance(g64_p, opts))
    i = 0
    while i < len(moves):
        if i in runs:
            pieces.append(_chain_piece(program, i, runs[i], smoothed[i]))
            i = runs[i] + 1
            continue
        pieces.append(_move_piece(program, i, sag))
        i += 1
    return pieces


def _chain_piece(program: Program, first: int, last: int, chain) -> Piece:
    """The piece of moves ``first..last`` smoothed into ``chain``."""
    pts = np.vstack([program.starts[first], program.ends[first:last + 1]]) * MM
    seg_len = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    report = ChainReport(first_move=first, moves=last - first + 1,
                         first_line=program.moves[first].line,
                         last_line=program.moves[last].line, length=chain.length,
                         deviation=chain.deviation, coverage=chain.coverage, points=pts)
    return Piece(SPLINE, chain.params, chain.length, first, last - first + 1,
                 np.asarray(chain.node_s, dtype=float), pts,
                 np.concatenate([[0.0], np.cumsum(seg_len)]), report)


def _move_piece(program: Program, i: int, sag: float) -> Piece:
    """Move ``i`` as a line or an arc (its programmed polyline: the arc's with ``sag``)."""
    m = program.moves[i]
    start = np.asarray(m.start) * MM
    end = np.asarray(m.end) * MM
    if m.kind is MoveKind.ARC:
        params, length = arc_params(m)
        poly, poly_s = _arc_polyline(params, length, sag)
        step = params["angle"] / max(len(poly) - 1, 1)
        return Piece(ARC, params, length, i, 1, np.array([0.0, length]), poly, poly_s,
                     sag=params["radius"] * (1.0 - math.cos(0.5 * step)))
    length = float(np.linalg.norm(end - start))
    params = {"origin": start, "direction": (end - start) / length}
    return Piece(LINE, params, length, i, 1, np.array([0.0, length]), np.stack([start, end]),
                 np.array([0.0, length]))


def path_of(pieces: list[Piece]) -> Path:
    """The untrimmed pieces laid end to end (for their end states)."""
    s0 = np.concatenate([[0.0], np.cumsum([p.length for p in pieces])[:-1]])
    return Path([Segment(p.kind, float(s), p.length, -1, p.params)
                 for p, s in zip(pieces, s0, strict=True)])


@dataclass(frozen=True)
class States:
    """Position, tangent and curvature vector of pieces at local arc lengths (k, 3) each."""

    p: np.ndarray
    t: np.ndarray
    k: np.ndarray


def states(base: Path, piece: np.ndarray, local: np.ndarray) -> States:
    p, t, k, _ = base._eval_segments(piece, local)
    return States(p, t, k)


def g64_p_of(program: Program) -> np.ndarray:
    """Per move, the G64 P active for it [m], NaN where none is."""
    return np.array([math.nan if m.blend_tolerance_mm is None else m.blend_tolerance_mm * MM
                     for m in program.moves], dtype=float)


def run_tolerance(p: np.ndarray, opts: ProgramPathOptions) -> float:
    """The tolerance of moves with G64 P ``p`` [m] (NaN: none) smoothed as one: the
    smallest P, ``opts.tolerance`` if none has one."""
    p = p[~np.isnan(p)]
    return float(p.min()) if p.size else opts.tolerance


def _cut_tolerance(p: np.ndarray, opts: ProgramPathOptions) -> np.ndarray:
    """The cutting tolerance where the G64 P ``p`` [m] applies: P, else ``opts.tolerance``."""
    return np.where(np.isnan(p), opts.tolerance, p)


def tolerances(program: Program, pieces: list[Piece], opts: ProgramPathOptions,
                g64_p: np.ndarray) -> np.ndarray:
    """Tolerance per junction between pieces: the cutting one next to a cut move or a plunge
    ending below the stock top, the air tolerance elsewhere. As in LinuxCNC a junction takes
    the smaller G64 P of its two moves (a move without one does not limit it); with none,
    ``opts.tolerance``."""
    cut = program.categories == MoveCategory.CUT.value
    if opts.stock_top is not None:
        below = program.ends[:, 2] < opts.stock_top / MM - SAME_POINT_MM
        cut = cut | ((program.categories == MoveCategory.PLUNGE.value) & below)
    last = np.array([p.first_move + p.n_moves - 1 for p in pieces])
    first = np.array([p.first_move for p in pieces])
    near_cut = cut[last[:-1]] | cut[first[1:]]
    p = np.fmin(g64_p[last[:-1]], g64_p[first[1:]])
    return np.where(near_cut, _cut_tolerance(p, opts), opts.air_tolerance)


