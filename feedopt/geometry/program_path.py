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
   line, and the largest whose deviation from the two programmed lines is within tolerance.
5. *transitions*: every junction that is still not G2 (line-arc, arc-arc, spline ends, the
   ends of a circular blend, kinks next to arcs) gets a quintic G2 transition
   (:mod:`feedopt.geometry.transitions`) as long as the tolerance allows: its length is
   shortened until its measured deviation from the program is within tolerance; a junction
   where none fits becomes a corner stop.
6. *provenance*: every programmed move (and air-link leg) gets the arc length where it starts
   on the smoothed path (:class:`MoveTable`), so every sample knows its program line, N
   number, move category and programmed feed, and the :class:`JunctionReport` gives, per
   programmed junction, what was done, the G0/G1/G2 jumps of the result and its deviation
   from the program.

The tolerance applies to junctions next to a cutting move (a plunge ending below the stock
top counts as one); a G64 P on the move before a junction (or on the moves of a smoothed run)
replaces it there. Junctions between air moves (rapids, plunges and retracts in air) use the
larger air tolerance. Deviations are measured on every modified stretch against the
programmed geometry (lines exactly, arcs as polylines with a sag below 1e-3 of the
tolerance), at 65 samples zoomed twice around the largest (:func:`zoomed_max`: the distance
to the nearer of two moves has a kink at its maximum), all junctions at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from feedopt.errors import InputError
from feedopt.gcode.moves import SAME_POINT_MM, MoveCategory, MoveKind, Program
from feedopt.geometry import blends
from feedopt.geometry.arcs import ARC, arc_params
from feedopt.geometry.path import COLLINEAR_TOL, Path, Segment
from feedopt.geometry.registry import LINE, BlendKind, get_blend
from feedopt.geometry.smoothing import smooth_chain
from feedopt.geometry.stops import (
    StopPoint,
    StopTable,
    air_links,
    corner_stops,
    program_stop_points,
    reversal_points,
    split_runs,
    stop_junctions,
    stop_table,
)
from feedopt.geometry.transitions import TRANSITION, build_transitions
from feedopt.units import MM, MM_PER_M

SPLINE = "spline"  #: segment kind of smoothed chains (:mod:`feedopt.geometry.smoothing`)
#: curvature jumps below this [1/m] (a radius of 1 km) count as G2
G2_TOL = 1e-3
#: samples per modified stretch at which the deviation from the program is measured
DEVIATION_SAMPLES = 64
#: transition shortening rounds before a junction is refused
MAX_ROUNDS = 40
#: transitions shorter than this [m] cannot be built reliably (arc-length tables)
MIN_TRANSITION = 1e-7


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
    """

    tolerance: float = 0.01 * MM
    air_tolerance: float = 0.5 * MM
    blend: str = "varying_radius"
    blend_size: float = 5.0 * MM
    chain_max_move: float = 2.0 * MM
    chain_max_turn: float = math.radians(15.0)
    chain_min_moves: int = 4
    stock_top: float | None = 0.0


class Treatment(Enum):
    """What a programmed junction got."""

    NONE = "none"  #: already G2 (or a G2 jump below G2_TOL)
    BLEND = "blend"  #: a corner blend of the scenario's kind
    TRANSITION = "transition"  #: a quintic G2 transition
    BLEND_TRANSITIONS = "blend+transitions"  #: a G1 blend (circle) and transitions at its ends
    STOP = "stop"  #: the tool stops there: the pieces meet at the programmed point


@dataclass(frozen=True)
class MoveTable:
    """Per programmed move (program order) where it starts on the path and what it is.

    s_start : (m,) arc length where the move starts on the smoothed path [m]
    line, n_number : (m,) source line (1-based) and N number (-1: none)
    category : (m,) "cut" | "plunge" | "rapid" | "retract"
    kind : (m,) "line" | "arc" | "rapid"
    feed : (m,) programmed feed [m/s], NaN for rapids
    spindle_rpm : (m,) last S word [rev/min], NaN before any
    tool : (m,) tool number, -1 before any M6
    program_move : (m,) index into the program's moves, -1 for the legs of an air link
        (which carry the line of the move they lead to); None: one row per program move
    """

    s_start: np.ndarray
    line: np.ndarray
    n_number: np.ndarray
    category: np.ndarray
    kind: np.ndarray
    feed: np.ndarray
    spindle_rpm: np.ndarray
    tool: np.ndarray
    program_move: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.s_start.size)

    def index_at(self, s: np.ndarray) -> np.ndarray:
        """Index of the move each arc length ``s`` [m] belongs to."""
        idx = np.searchsorted(self.s_start, np.asarray(s, dtype=float), side="right") - 1
        return np.clip(idx, 0, len(self) - 1)

    def lowest_cut(self, s: np.ndarray, values: np.ndarray) -> tuple[int, int]:
        """(sample, move) where ``values`` (one per arc length ``s``) is lowest on cut moves
        (on all moves if nothing cuts): "the feed bound is lowest at line 88"."""
        move = self.index_at(s)
        cut = self.category[move] == "cut"
        k = int(np.argmin(np.where(cut, values, np.inf) if cut.any() else values))
        return k, int(move[k])

    def label(self, i: int) -> str:
        """``"line 88 (N880)"`` for move ``i``."""
        n = int(self.n_number[i])
        return f"line {int(self.line[i])}" + (f" (N{n})" if n >= 0 else "")


@dataclass(frozen=True)
class JunctionReport:
    """Per programmed junction (between moves ``before`` and ``before + 1`` that are not
    inside a smoothed chain): what it got and how far the result is from the program.

    before : (k,) index of the move before the junction (in the :class:`MoveTable`)
    s : (k,) arc length of the move boundary on the path [m]
    turn : (k,) programmed turning angle (G1 jump) [rad]
    curvature_jump : (k,) programmed |K_after - K_before| (G2 jump) [1/m]
    treatment : (k,) :class:`Treatment` values
    size : (k,) blend size used [m] (NaN without blend)
    transition_length : (k,) arc length of the transition(s) [m] (NaN without)
    deviation : (k,) largest distance of the modified stretch from the program [m]
    tolerance : (k,) the tolerance that applied [m] (a G64 P where the program set one)
    g0, g1, g2 : (k,) largest G0 [m], G1, G2 [1/m] jump of the result over the junction
    """

    before: np.ndarray
    s: np.ndarray
    turn: np.ndarray
    curvature_jump: np.ndarray
    treatment: tuple[str, ...]
    size: np.ndarray
    transition_length: np.ndarray
    deviation: np.ndarray
    tolerance: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    g2: np.ndarray
    labels: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.before.size)

    def table(self, max_rows: int | None = 40) -> str:
        """Plain-text table in mm (curvatures in 1/mm); long reports keep head and tail."""
        head = (f"{'junction':>26} {'s_mm':>10} {'turn_deg':>9} {'dK_1_mm':>9} "
                f"{'treatment':>17} {'size_mm':>8} {'trans_mm':>8} {'dev_mm':>9} "
                f"{'tol_mm':>7} {'G0_mm':>8} {'G1':>8} {'G2_1_mm':>8}")
        rows = [head]
        idx = list(range(len(self)))
        if max_rows is not None and len(idx) > max_rows:
            half = max_rows // 2
            idx = idx[:half] + [-1] + idx[-half:]
        for i in idx:
            if i < 0:
                rows.append(f"{'...':>26} ({len(self) - 2 * (max_rows // 2)} junctions omitted)")
                continue
            rows.append(
                f"{self.labels[i]:>26} {self.s[i] * MM_PER_M:>10.3f} "
                f"{math.degrees(self.turn[i]):>9.3f} {self.curvature_jump[i] * MM:>9.4g} "
                f"{self.treatment[i]:>17} {_opt(self.size[i]):>8} "
                f"{_opt(self.transition_length[i]):>8} {self.deviation[i] * MM_PER_M:>9.2e} "
                f"{self.tolerance[i] * MM_PER_M:>7.3g} {self.g0[i] * MM_PER_M:>8.1e} "
                f"{self.g1[i]:>8.1e} {self.g2[i] * MM:>8.1e}")
        if len(self):
            worst = int(np.argmax(self.deviation / self.tolerance))
            rows.append(
                f"{len(self)} junctions: largest deviation {self.deviation.max() * MM_PER_M:.3g}"
                f" mm ({self.labels[worst]}); largest jumps G0 {self.g0.max() * MM_PER_M:.2g} "
                f"mm, G1 {self.g1.max():.2g}, G2 {self.g2.max() * MM:.2g} 1/mm")
        return "\n".join(rows)


@dataclass(frozen=True)
class ChainReport:
    """A run of short G1 moves smoothed into one spline."""

    first_move: int
    moves: int
    first_line: int
    last_line: int
    length: float  # [m]
    deviation: float  # curve -> program [m]
    coverage: float  # program vertices -> curve [m]
    points: np.ndarray | None = None  # (moves + 1, 3) the programmed vertices [m]


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


def _opt(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v * MM_PER_M:.3g}"


# --- 1. check ------------------------------------------------------------------------------


def check_program(program: Program) -> None:
    """InputError for a program with nothing to plan: no move, or only air moves. (Gaps
    become air links, plunges ordinary moves: the process stage models them.)"""
    if not any(m.category is MoveCategory.CUT for m in program.moves):
        raise InputError(f"{program.source}: the program has no cutting move (G1/G2/G3 across "
                         "the tool axis); there is nothing to plan")


# --- 2. pieces -------------------------------------------------------------------------------


@dataclass
class _Piece:
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


def _pieces(program: Program, opts: ProgramPathOptions, points: list[StopPoint],
            g64_p: np.ndarray) -> list[_Piece]:
    """The pieces in order: chains (split at stops) smoothed within the smallest G64 P of
    their moves (``opts.tolerance`` without), every other move a line or an arc."""
    runs = {first: last for first, last in split_runs(_chain_runs(program, opts), points,
                                                       program, opts.chain_min_moves)}
    pieces: list[_Piece] = []
    moves = program.moves
    sag = 1e-3 * min(opts.tolerance, _run_tolerance(g64_p, opts))
    i = 0
    while i < len(moves):
        m = moves[i]
        if i in runs:
            last = runs[i]
            pts = np.vstack([program.starts[i], program.ends[i:last + 1]]) * MM
            chain = smooth_chain(pts, _run_tolerance(g64_p[i:last + 1], opts))
            seg_len = np.linalg.norm(np.diff(pts, axis=0), axis=1)
            report = ChainReport(first_move=i, moves=last - i + 1, first_line=m.line,
                                 last_line=moves[last].line, length=chain.length,
                                 deviation=chain.deviation, coverage=chain.coverage,
                                 points=pts)
            pieces.append(_Piece(SPLINE, chain.params, chain.length, i, last - i + 1,
                                 np.asarray(chain.node_s, dtype=float), pts,
                                 np.concatenate([[0.0], np.cumsum(seg_len)]), report))
            i = last + 1
            continue
        start = np.asarray(m.start) * MM
        end = np.asarray(m.end) * MM
        if m.kind is MoveKind.ARC:
            params, length = arc_params(m)
            poly, poly_s = _arc_polyline(params, length, sag)
            pieces.append(_Piece(ARC, params, length, i, 1, np.array([0.0, length]),
                                 poly, poly_s))
        else:
            length = float(np.linalg.norm(end - start))
            params = {"origin": start, "direction": (end - start) / length}
            pieces.append(_Piece(LINE, params, length, i, 1, np.array([0.0, length]),
                                 np.stack([start, end]), np.array([0.0, length])))
        i += 1
    return pieces


def _path_of(pieces: list[_Piece]) -> Path:
    """The untrimmed pieces laid end to end (for their end states)."""
    s0 = np.concatenate([[0.0], np.cumsum([p.length for p in pieces])[:-1]])
    return Path([Segment(p.kind, float(s), p.length, -1, p.params)
                 for p, s in zip(pieces, s0, strict=True)])


@dataclass(frozen=True)
class _States:
    """Position, tangent and curvature vector of pieces at local arc lengths (k, 3) each."""

    p: np.ndarray
    t: np.ndarray
    k: np.ndarray


def _states(base: Path, piece: np.ndarray, local: np.ndarray) -> _States:
    p, t, k, _ = base._eval_segments(piece, local)
    return _States(p, t, k)


# --- 3. corners ----------------------------------------------------------------------------


def _ray_distance(x: np.ndarray, d_in: np.ndarray, d_out: np.ndarray) -> np.ndarray:
    """Distance of points x (m, q, 3) to the two rays of corners at the origin: back along
    -d_in and forward along d_out (m, 3)."""
    t_in = np.maximum(-np.einsum("mqi,mi->mq", x, d_in), 0.0)
    t_out = np.maximum(np.einsum("mqi,mi->mq", x, d_out), 0.0)
    a = np.linalg.norm(x + t_in[..., None] * d_in[:, None], axis=-1)
    b = np.linalg.norm(x - t_out[..., None] * d_out[:, None], axis=-1)
    return np.minimum(a, b)


def zoomed_max(f, lo: np.ndarray, hi: np.ndarray, q: int = DEVIATION_SAMPLES + 1,
               rounds: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Largest value of ``f`` on each interval [lo_i, hi_i] and where: ``q`` samples, then
    ``rounds`` times ``q`` samples across the two sample steps around the best one.

    ``f`` takes an (m, k) array of parameters and returns (m, k) values. A distance to the
    nearer of two curves has a kink where they are equally far, so its maximum is not a smooth
    peak and a single uniform sampling misses it linearly in the step; zooming makes that error
    q^-rounds of it.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    grid = np.linspace(0.0, 1.0, q)
    t = lo[:, None] + grid[None, :] * (hi - lo)[:, None]
    best_v = np.full(lo.size, -np.inf)
    best_t = lo.copy()
    step = (hi - lo) / (q - 1)
    for _ in range(rounds + 1):
        v = f(t)
        k = np.argmax(v, axis=1)
        vk = v[np.arange(lo.size), k]
        better = vk > best_v
        best_v = np.where(better, vk, best_v)
        best_t = np.where(better, t[np.arange(lo.size), k], best_t)
        a = np.maximum(best_t - step, lo)
        b = np.minimum(best_t + step, hi)
        t = a[:, None] + grid[None, :] * (b - a)[:, None]
        step = (b - a) / (q - 1)
    return best_v, best_t


def _unit_deviation(kind: BlendKind, c: blends.Corners) -> np.ndarray:
    """Deviation from its two lines of a size-1 blend of ``kind`` at every corner (blends
    are similar under scaling, so a size-x blend deviates x times this)."""
    unit = blends.Corners(np.zeros_like(c.point), c.d_in, c.d_out, c.turn, c.normal,
                          np.full_like(c.turn, 1e9), np.full_like(c.turn, 1e9))
    built = kind.build(unit, 1.0)
    segs = [Segment(kind.name, 0.0, float(built.length[i]), -1,
                    {key: val[i] for key, val in built.params.items()})
            for i in range(len(c.turn))]
    ev = kind.evaluator(segs)
    m = len(segs)

    def distance(sl: np.ndarray) -> np.ndarray:
        j = np.repeat(np.arange(m), sl.shape[1])
        pos = ev.eval(j, sl.ravel())[0].reshape(m, sl.shape[1], 3)
        return _ray_distance(pos, c.d_in, c.d_out)

    return zoomed_max(distance, np.zeros(m), np.asarray(built.length, dtype=float))[0]


@dataclass
class _Corner:
    """Blends at the line-line corners: junction index, blend params, length, tangent
    distance on each line, size."""

    kind: str
    junction: np.ndarray
    params: list[dict]
    length: np.ndarray
    tangent: np.ndarray
    size: np.ndarray


def _corners(kind: BlendKind | None, size: float, pieces: list[_Piece], base: Path,
             corner_j: np.ndarray, tol: np.ndarray) -> _Corner:
    empty = _Corner("", corner_j[:0], [], np.zeros(0), np.zeros(0), np.zeros(0))
    if kind is None or not corner_j.size:
        return empty
    end = _states(base, corner_j, np.array([pieces[j].length for j in corner_j]))
    start = _states(base, corner_j + 1, np.zeros(corner_j.size))
    d_in, d_out = end.t, start.t
    cos = np.clip(np.einsum("ij,ij->i", d_in, d_out), -1.0, 1.0)
    perp = d_out - cos[:, None] * d_in
    sin = np.linalg.norm(perp, axis=1)
    turn = np.arctan2(sin, cos)
    len_in = np.array([pieces[j].length for j in corner_j])
    len_out = np.array([pieces[j + 1].length for j in corner_j])
    c = blends.Corners(end.p, d_in, d_out, turn, perp / sin[:, None], len_in, len_out)
    room = 0.5 * np.minimum(len_in, len_out)
    fits = kind.largest_size(turn, room) * (1.0 - 1e-9)
    within = 0.999 * tol[corner_j] / _unit_deviation(kind, c)
    sizes = np.minimum.reduce([np.full_like(turn, size), fits, within])
    params: list[dict] = [{}] * len(turn)
    length = np.zeros(len(turn))
    for value in np.unique(sizes):  # builders take one size; corners share the common ones
        rows = np.flatnonzero(sizes == value)
        sub = blends.Corners(*(np.asarray(getattr(c, f))[rows] for f in
                               ("point", "d_in", "d_out", "turn", "normal", "len_in",
                                "len_out")))
        built = kind.build(sub, float(value))
        for k, r in enumerate(rows):
            params[r] = {key: val[k] for key, val in built.params.items()}
            length[r] = built.length[k]
    tangent = np.array([kind.tangent_distance(turn[i:i + 1], sizes[i])[0]
                        for i in range(len(turn))])
    return _Corner(kind.name, corner_j, params, length, tangent, sizes)


# --- 4. transitions and assembly -----------------------------------------------------------


@dataclass
class _Stretch:
    """One segment of the result: a piece (or blend) trimmed to [offset, offset + length]."""

    kind: str
    params: dict
    offset: float
    length: float
    piece: int  # index into the pieces (-1 for blends and transitions)
    junction: int  # programmed junction a blend/transition belongs to (-1 otherwise)


def _trimmed_pieces(pieces: list[_Piece], corners: _Corner) -> list[_Stretch]:
    """Pieces shortened by the corner blends, with the blends between them."""
    cut_end = np.zeros(len(pieces))
    cut_start = np.zeros(len(pieces))
    blend_at = {}
    for k, j in enumerate(corners.junction):
        cut_end[j] = corners.tangent[k]
        cut_start[j + 1] = corners.tangent[k]
        blend_at[int(j)] = k
    out: list[_Stretch] = []
    for i, p in enumerate(pieces):
        out.append(_Stretch(p.kind, p.params, cut_start[i], p.length - cut_start[i]
                            - cut_end[i], i, -1))
        if i in blend_at:
            k = blend_at[i]
            out.append(_Stretch(corners.kind, corners.params[k], 0.0, float(corners.length[k]),
                                -1, i))
    return out


def _stretch_path(stretches: list[_Stretch]) -> Path:
    s0 = np.concatenate([[0.0], np.cumsum([x.length for x in stretches])[:-1]])
    return Path([Segment(x.kind, float(s), x.length, -1, x.params, offset=x.offset)
                 for x, s in zip(stretches, s0, strict=True)])


def _non_g2(path: Path, stretches: list[_Stretch]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Junctions between consecutive stretches that are not G2: index of the stretch before,
    turn [rad] and curvature jump [1/m] of all of them."""
    k = len(stretches)
    before = np.arange(k - 1)
    lens = np.array([x.length for x in stretches[:-1]])
    _, ta, ka, _ = path._eval_segments(before, lens)
    _, tb, kb, _ = path._eval_segments(before + 1, np.zeros(k - 1))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", ta, tb), -1.0, 1.0))
    jump = np.linalg.norm(kb - ka, axis=1)
    bad = (turn > COLLINEAR_TOL) | (jump > G2_TOL)
    return before[bad], turn, jump


def _with_transitions(stretches: list[_Stretch], path: Path, at: np.ndarray,
                      scale: np.ndarray, junction_of: np.ndarray) -> list[_Stretch]:
    """Insert transitions after stretches ``at``, cutting ``scale`` x the room (half of each
    neighbour, shared with a transition at its other end) from both neighbours."""
    if not at.size:
        return stretches
    length = np.array([x.length for x in stretches])
    room = 0.5 * np.minimum(length[at], length[at + 1])
    cut = room * scale
    a_state = _states(path, at, length[at] - cut)
    b_state = _states(path, at + 1, cut)
    built = build_transitions(a_state.p, a_state.t, a_state.k, b_state.p, b_state.t,
                              b_state.k)
    trim_end = np.zeros(len(stretches))
    trim_start = np.zeros(len(stretches))
    trim_end[at] = cut
    trim_start[at + 1] = cut
    insert = {int(i): k for k, i in enumerate(at)}
    out = []
    for i, x in enumerate(stretches):
        out.append(_Stretch(x.kind, x.params, x.offset + trim_start[i],
                            x.length - trim_start[i] - trim_end[i], x.piece, x.junction))
        if i in insert:
            k = insert[i]
            out.append(_Stretch(TRANSITION, {key: val[k] for key, val in built.params.items()},
                                0.0, float(built.length[k]), -1, int(junction_of[k])))
    return out


# --- 5. deviation and provenance -----------------------------------------------------------


def _segment_distance(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points x (m, q, 3) to the nearest of the segments a -> b (m, k, 3) of
    their row (a zero-length segment is its point)."""
    ab = b - a
    den = np.maximum(np.einsum("mij,mij->mi", ab, ab), 1e-300)
    t = np.clip(np.einsum("mqij,mij->mqi", x[:, :, None, :] - a[:, None], ab)
                / den[:, None], 0.0, 1.0)
    near = a[:, None] + t[..., None] * ab[:, None]
    return np.linalg.norm(x[:, :, None, :] - near, axis=3).min(axis=2)


def _segments(polys: list[list[np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The segments of each row's polylines (a one-point polyline: a zero-length segment) as
    (m, k, 3) start and end arrays, padded with zero-length segments on a row's first point
    (which change no distance)."""
    rows = [[(p[:-1], p[1:]) if len(p) > 1 else (p, p) for p in row] for row in polys]
    k = max(sum(len(a) for a, _ in row) for row in rows)
    start = np.empty((len(rows), k, 3))
    end = np.empty((len(rows), k, 3))
    for r, row in enumerate(rows):
        a = np.concatenate([x for x, _ in row])
        b = np.concatenate([y for _, y in row])
        start[r, :len(a)], end[r, :len(a)] = a, b
        start[r, len(a):] = end[r, len(a):] = a[0]
    return start, end


def _window(piece: _Piece, reach: float, at_end: bool) -> np.ndarray:
    """The programmed polyline of ``piece`` within ``reach`` of its end (or start)."""
    s = piece.poly_s
    if at_end:
        k = max(int(np.searchsorted(s, piece.length - reach, side="right")) - 1, 0)
        return piece.polyline[k:]
    k = min(int(np.searchsorted(s, reach, side="left")) + 1, len(s))
    return piece.polyline[:k]


def _regions(stretches: list[_Stretch]) -> dict[int, tuple[int, int]]:
    """Per programmed junction, the first and last stretch index of its blend/transitions
    (transitions at the outer ends of a blend included)."""
    out: dict[int, tuple[int, int]] = {}
    for i, x in enumerate(stretches):
        if x.junction >= 0:
            lo, hi = out.get(x.junction, (i, i))
            out[x.junction] = (min(lo, i), max(hi, i))
    return out


def _batches(sizes: np.ndarray, budget: int = 1 << 21) -> list[np.ndarray]:
    """Row indices in batches of similar polyline sizes (within a factor 1.25, so padding
    to the largest costs little), each at most ``budget`` rows x samples x segments."""
    order = np.argsort(sizes, kind="stable")
    bucket = np.floor(np.log(np.maximum(sizes[order], 1)) / np.log(1.25)).astype(int)
    out = []
    for rows in np.split(order, np.flatnonzero(np.diff(bucket)) + 1):
        per = max(1, budget // ((DEVIATION_SAMPLES + 1) * int(sizes[rows].max())))
        out += [rows[lo:lo + per] for lo in range(0, rows.size, per)]
    return out


def _deviations(path: Path, stretches: list[_Stretch], regions: dict[int, tuple[int, int]],
                pieces: list[_Piece]) -> dict[int, tuple[float, float, float]]:
    """Per treated junction: (deviation [m], s of the point nearest the programmed junction
    point [m], s_lo) of its modified stretch; all junctions measured together."""
    if not regions:
        return {}
    js = np.array(list(regions), dtype=np.intp)
    bounds = np.array([regions[int(j)] for j in js])
    starts = path.segment_start
    lens = np.array([x.length for x in stretches])
    s_lo, s_hi = starts[bounds[:, 0]], starts[bounds[:, 1]] + lens[bounds[:, 1]]
    reach = 2.0 * (s_hi - s_lo) + 1e-9
    poly_a = [_window(pieces[j], r, at_end=True) for j, r in zip(js, reach, strict=True)]
    poly_b = [_window(pieces[j + 1], r, at_end=False) for j, r in zip(js, reach, strict=True)]
    corner = np.array([pieces[j + 1].polyline[0] for j in js])
    dev = np.empty(js.size)
    s_near = np.empty(js.size)
    sizes = np.array([len(a) + len(b) for a, b in zip(poly_a, poly_b, strict=True)])
    grid = np.linspace(0.0, 1.0, DEVIATION_SAMPLES + 1)
    for rows in _batches(sizes):
        seg_a, seg_b = _segments([[poly_a[r], poly_b[r]] for r in rows])

        def distance(s: np.ndarray, seg_a=seg_a, seg_b=seg_b) -> np.ndarray:
            pts = path.evaluate(s.ravel()).position.reshape(*s.shape, 3)
            return _segment_distance(pts, seg_a, seg_b)

        dev[rows] = zoomed_max(distance, s_lo[rows], s_hi[rows])[0]
        s = s_lo[rows, None] + grid[None, :] * (s_hi - s_lo)[rows, None]
        pos = path.evaluate(s.ravel()).position.reshape(*s.shape, 3)
        near = np.argmin(np.linalg.norm(pos - corner[rows, None], axis=2), axis=1)
        s_near[rows] = s[np.arange(rows.size), near]
    return {int(j): (float(dev[k]), float(s_near[k]), float(s_lo[k]))
            for k, j in enumerate(js)}


def _g64_p(program: Program) -> np.ndarray:
    """Per move, the G64 P active for it [m], NaN where none is."""
    return np.array([math.nan if m.blend_tolerance_mm is None else m.blend_tolerance_mm * MM
                     for m in program.moves], dtype=float)


def _run_tolerance(p: np.ndarray, opts: ProgramPathOptions) -> float:
    """The tolerance of moves with G64 P ``p`` [m] (NaN: none) smoothed as one: the
    smallest P, ``opts.tolerance`` if none has one."""
    p = p[~np.isnan(p)]
    return float(p.min()) if p.size else opts.tolerance


def _cut_tolerance(p: np.ndarray, opts: ProgramPathOptions) -> np.ndarray:
    """The cutting tolerance where the G64 P ``p`` [m] applies: P, else ``opts.tolerance``."""
    return np.where(np.isnan(p), opts.tolerance, p)


def _tolerances(program: Program, pieces: list[_Piece], opts: ProgramPathOptions,
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
    g64_p = _g64_p(linked)
    points = program_stop_points(linked)
    pieces = _pieces(linked, opts, points, g64_p)
    base = _path_of(pieces)
    tol = _tolerances(linked, pieces, opts, g64_p)
    turn, jump = _programmed_jumps(base, pieces)
    last = np.array([_last_move(p) for p in pieces])
    points += reversal_points(linked, last, turn)
    built = _assemble(pieces, base, kind, opts, tol, turn, stop_junctions(last, points))
    corners, corner_notes = corner_stops(linked, last, built.failed, tol)
    points += corners
    moves = _move_table(linked, pieces, built.stretches, built.path, built.dev, program_move)
    report = _junction_report(pieces, built, turn, jump, tol, moves)
    stops = stop_table(points, moves.s_start, built.path.length)
    path = Path(built.path.segments, moves=moves)
    path.stops = stops
    chains = tuple(p.chain for p in pieces if p.chain is not None)
    warnings = [*link_notes, *corner_notes]
    if chains:
        warnings.append(
            f"{len(chains)} run(s) of short G1 moves ({sum(c.moves for c in chains)} moves) "
            f"smoothed into quintic splines within {opts.tolerance / MM:g} mm"
            + ("" if np.isnan(g64_p).all() else " (or the G64 P in force)")
            + f" (largest deviation {max(c.deviation for c in chains) / MM:.3g} mm)")
    inside = (stops.s > 0.0) & (stops.s < built.path.length)
    if np.any(inside | (stops.hold_s > 0)):  # not just the ends, where the tool is at rest
        shown = "; ".join(stops.label[:5]) + (f"; ... ({len(stops) - 5} more)"
                                               if len(stops) > 5 else "")
        warnings.append(f"the tool stops on the path: {stops.summary()}: {shown}")
    return ProgramPath(path, moves, report, chains, tuple(warnings), stops)


def _last_move(piece: _Piece) -> int:
    return piece.first_move + piece.n_moves - 1


def _programmed_jumps(base: Path, pieces: list[_Piece]) -> tuple[np.ndarray, np.ndarray]:
    """Turn [rad] and curvature jump [1/m] of the programmed geometry at every junction."""
    m = len(pieces)
    j_all = np.arange(m - 1)
    end = _states(base, j_all, np.array([p.length for p in pieces[:-1]]))
    start = _states(base, j_all + 1, np.zeros(m - 1))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", end.t, start.t), -1.0, 1.0))
    return turn, np.linalg.norm(start.k - end.k, axis=1)


@dataclass
class _Built:
    """The assembled path: its stretches, the path, per treated junction its deviation
    (:func:`_deviations`), the corner blends, the junctions where the tool stops, and those
    that became corner stops (junction -> best deviation [m])."""

    stretches: list[_Stretch]
    path: Path
    dev: dict[int, tuple[float, float, float]]
    corners: _Corner
    stop_j: np.ndarray
    failed: dict[int, float]


def _assemble(pieces: list[_Piece], base: Path, kind: BlendKind, opts: ProgramPathOptions,
              tol: np.ndarray, turn: np.ndarray, stop_j: np.ndarray) -> _Built:
    """Corners and transitions everywhere but at stops; a junction where no transition fits
    the tolerance becomes a stop and the path is built again without it."""
    stop_j = stop_j.copy()
    failed: dict[int, float] = {}
    is_line = np.array([p.kind == LINE for p in pieces])
    while True:
        corner_j = np.flatnonzero(is_line[:-1] & is_line[1:] & (turn >= COLLINEAR_TOL)
                                  & ~stop_j)
        corners = _corners(kind, opts.blend_size, pieces, base, corner_j, tol)
        stretches0 = _trimmed_pieces(pieces, corners)
        path0 = _stretch_path(stretches0)
        at, _, _ = _non_g2(path0, stretches0)
        junction_of = np.array([_junction_of(stretches0, i) for i in at], dtype=int)
        keep = ~stop_j[junction_of]
        stretches, path, dev, over = _fit_transitions(
            stretches0, path0, at[keep], junction_of[keep], tol, turn, pieces)
        if not over.size or not over.any():
            return _Built(stretches, path, dev, corners, stop_j, failed)
        for j in np.unique(junction_of[keep][over]).tolist():
            failed[j] = dev[j][0]
            stop_j[j] = True


def _fit_transitions(stretches0: list[_Stretch], path0: Path, at: np.ndarray,
                     junction_of: np.ndarray, tol: np.ndarray, turn: np.ndarray,
                     pieces: list[_Piece]):
    """Transitions after stretches ``at``, shortened until each is within the tolerance of
    its junction: (stretches, path, deviations, which are still over it)."""
    scale = np.ones(at.size)
    for _round in range(MAX_ROUNDS):
        stretches = _with_transitions(stretches0, path0, at, scale, junction_of)
        path = _stretch_path(stretches)
        dev = _deviations(path, stretches, _regions(stretches), pieces)
        over = np.array([dev[j][0] > tol[j] for j in junction_of], dtype=bool)
        if not over.any():
            break
        dev_of = np.array([dev[j][0] for j in junction_of])
        ratio = tol[junction_of] / np.maximum(dev_of, 1e-300)
        smooth = turn[junction_of] < 1e-3
        factor = np.clip(0.95 * np.where(smooth, np.sqrt(ratio), ratio), 0.05, 0.9)
        scale = np.where(over, scale * factor, scale)
        length = {x.junction: x.length for x in stretches if x.kind == TRANSITION}
        if any(o and length.get(int(j), 0.0) * f < MIN_TRANSITION
               for o, j, f in zip(over, junction_of, factor, strict=True)):
            break  # too short to build reliably: the junction becomes a stop
    return stretches, path, dev, over


def segment_labels(path: Path) -> list[str]:
    """A readable name per segment of a program path: its kind and the program line of the
    move it follows ("arc at line 88 (N880)")."""
    mid = path.segment_start + 0.5 * np.array([g.length for g in path.segments])
    idx = path.moves.index_at(mid)
    return [f"{g.kind} at {path.moves.label(int(i))}" for g, i in zip(path.segments, idx,
                                                                      strict=True)]


def _junction_of(stretches: list[_Stretch], i: int) -> int:
    """The programmed junction (index of the piece before it) a non-G2 stretch junction
    belongs to: a blend's own, or the junction between the two pieces."""
    a, b = stretches[i], stretches[i + 1]
    if a.junction >= 0:
        return a.junction
    if b.junction >= 0:
        return b.junction
    return a.piece


def _move_table(program: Program, pieces: list[_Piece], stretches: list[_Stretch],
                path: Path, dev: dict, program_move: np.ndarray) -> MoveTable:
    """Where every move starts on the path: a treated junction at the point of its modified
    stretch nearest the programmed corner, any other exactly at its segment boundary."""
    starts = path.segment_start
    s_start = np.zeros(len(program.moves))
    for i, x in enumerate(stretches):
        if x.piece < 0:
            continue
        p = pieces[x.piece]
        inner = p.node_s[:-1]
        s_start[p.first_move:p.first_move + p.n_moves] = np.clip(
            starts[i] + inner - x.offset, starts[i], starts[i] + x.length)
        if x.piece > 0:
            j = x.piece - 1
            s_start[p.first_move] = dev[j][1] if j in dev else starts[i]
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


def _junction_report(pieces: list[_Piece], built: _Built, turn: np.ndarray, jump: np.ndarray,
                     tol: np.ndarray, moves: MoveTable) -> JunctionReport:
    from feedopt.geometry.continuity import continuity_report

    stretches, path, corners, dev = built.stretches, built.path, built.corners, built.dev
    m = len(pieces)
    cont = continuity_report(path) if len(path.segments) > 1 else None
    # stretch junction i lies between stretch i and i+1: map it to a programmed junction
    owner = np.full(max(len(stretches) - 1, 0), -1)
    for i in range(len(stretches) - 1):
        a, b = stretches[i], stretches[i + 1]
        owner[i] = a.junction if a.junction >= 0 else (
            b.junction if b.junction >= 0 else (a.piece if b.piece == a.piece + 1 else -1))
    g = np.zeros((3, m - 1))
    if cont is not None:
        for i, j in enumerate(owner):
            if j >= 0:
                g[:, j] = np.maximum(g[:, j], [cont.g0[i], cont.g1[i], cont.g2[i]])
    size = np.full(m - 1, np.nan)
    size[corners.junction] = corners.size
    trans_len = np.full(m - 1, np.nan)
    for x in stretches:
        if x.kind == TRANSITION:
            trans_len[x.junction] = np.nansum([trans_len[x.junction], x.length])
    treatment = []
    deviation = np.zeros(m - 1)
    s = np.zeros(m - 1)
    for j in range(m - 1):
        blend = np.isfinite(size[j])
        trans = np.isfinite(trans_len[j])
        treatment.append((Treatment.STOP if built.stop_j[j] else
                          Treatment.BLEND_TRANSITIONS if blend and trans else
                          Treatment.BLEND if blend else
                          Treatment.TRANSITION if trans else Treatment.NONE).value)
        deviation[j] = dev[j][0] if j in dev else 0.0
        s[j] = moves.s_start[pieces[j + 1].first_move]
    before = np.array([p.first_move + p.n_moves - 1 for p in pieces[:-1]], dtype=np.int64)
    labels = tuple(f"{moves.label(int(b))}->{int(moves.line[b + 1])}" for b in before)
    return JunctionReport(before=before, s=s, turn=turn, curvature_jump=jump,
                          treatment=tuple(treatment), size=size, transition_length=trans_len,
                          deviation=deviation, tolerance=tol, g0=g[0], g1=g[1], g2=g[2],
                          labels=labels)


__all__ = ["ChainReport", "JunctionReport", "MoveTable", "ProgramPath", "ProgramPathOptions",
           "StopTable", "Treatment", "check_program", "program_path"]
