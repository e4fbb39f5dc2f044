"""Corners and G2 transitions of a program path, each within its tolerance both ways.

Phases 4 and 5 of :func:`~feedopt.geometry.program_path.program_path`:

- *corners*: line-line corners get the scenario's blend (thesis 3.3), its size the smallest of
  the one asked for, the largest that fits in half of each line, and the largest whose
  two-sided deviation from the corner is within the tolerance. Blends are similar under
  scaling, so a size-x blend deviates x times a size-1 blend: both directions are measured
  once on size-1 blends (:func:`unit_deviation`), every corner at once, and all blends are
  built in one call with one size per corner.
- *transitions*: every junction that is still not G2 gets a quintic G2 transition
  (:mod:`feedopt.geometry.transitions`) cutting up to half of each neighbour; a junction whose
  modified stretch (its blend and transitions) is farther from the program than the tolerance,
  either way (:mod:`feedopt.geometry.deviation`), gets shorter transitions, by the ratio of
  tolerance to deviation (its square root where the programmed junction is tangent: the
  deviation then grows with the square of the length), until it is within the tolerance; one
  where the transition would become shorter than :data:`MIN_TRANSITION` fails (it becomes a
  corner stop). Every round builds and measures the junctions still over the tolerance, all
  of them at once, on a small path of their modified stretches only; the whole path is built
  once at the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.geometry import arclength, blends
from feedopt.geometry.blend_kinds import ARRAY_SIZES
from feedopt.geometry.deviation import (
    DEVIATION_SAMPLES,
    batches,
    curve_samples,
    nearest_on_curve,
    padded,
    polyline_points,
    segment_distance,
    zoomed_max,
)
from feedopt.geometry.path import COLLINEAR_TOL, Path, Segment
from feedopt.geometry.program_pieces import SPLINE, Piece, states
from feedopt.geometry.registry import BlendKind
from feedopt.geometry.transitions import TRANSITION, build_transitions

#: curvature jumps below this [1/m] (a radius of 1 km) count as G2
G2_TOL = 1e-3
#: a built transition whose ends still jump by more than this [1/m] (a radius of 200 m)
#: makes its junction a corner stop: floating point leaves the end curvatures of a
#: sub-micrometre hairpin at a near-reversal 1e-3 to 0.08 1/m off (measured: 0.18 um at
#: 176 deg 1.3e-3, 0.09 um at 178 deg 5e-3, 0.02 um at 179.5 deg 0.08); below it the jump is
#: kept (a normal-acceleration step of v^2 dK < 5e-5 m/s^2 at 0.1 m/s)
G2_STOP_TOL = 5e-3
#: transition shortening rounds before a junction is refused
MAX_ROUNDS = 40
#: transitions shorter than this [m] cannot be built reliably (arc-length tables): the
#: junction becomes a corner stop
MIN_TRANSITION = 1e-7
#: samples (+1) along the replaced program at which its distance to the path is maximised
PROGRAM_SAMPLES = 16
#: samples of a size-1 blend for the nearest-point search (a smooth convex curve)
UNIT_SAMPLES = 64


# --- corners ---------------------------------------------------------------------------------


def _ray_distance(x: np.ndarray, d_in: np.ndarray, d_out: np.ndarray) -> np.ndarray:
    """Distance of points x (m, q, 3) to the two rays of corners at the origin: back along
    -d_in and forward along d_out (m, 3)."""
    t_in = np.maximum(-np.einsum("mqi,mi->mq", x, d_in), 0.0)
    t_out = np.maximum(np.einsum("mqi,mi->mq", x, d_out), 0.0)
    a = np.linalg.norm(x + t_in[..., None] * d_in[:, None], axis=-1)
    b = np.linalg.norm(x - t_out[..., None] * d_out[:, None], axis=-1)
    return np.minimum(a, b)


def _segments_of(kind: str, params: dict[str, np.ndarray], length: np.ndarray,
                 offset: np.ndarray | None = None) -> list[Segment]:
    """One segment per row of built ``params`` (laid from s = 0; placed by the caller)."""
    off = np.zeros(length.size) if offset is None else offset
    return [Segment(kind, 0.0, float(length[i]), -1, {k: v[i] for k, v in params.items()},
                    offset=float(off[i])) for i in range(length.size)]


@dataclass(frozen=True)
class UnitDeviation:
    """Of a size-1 blend at every corner: its largest distance from its two lines (path ->
    program), the largest distance of the lines between its tangent points from it (program
    -> path), and the arc length from its start of its point nearest the corner [m]."""

    path: np.ndarray
    program: np.ndarray
    near: np.ndarray


def unit_deviation(kind: BlendKind, turn: np.ndarray) -> UnitDeviation:
    """:class:`UnitDeviation` of ``kind`` at corners turning by ``turn``; a size-x blend
    deviates x times as much (blends are similar under scaling). A blend's shape depends on
    its turn only, so it is measured once per distinct turn, in the xy plane, by its own
    parameter where its evaluator has one (``derivs``, ``t_end``: no arc-length inversion),
    else by arc length."""
    uniq, inv = np.unique(np.round(np.asarray(turn, dtype=float), 12), return_inverse=True)
    m = uniq.size
    zero = np.zeros(m)
    e_x = np.tile([1.0, 0.0, 0.0], (m, 1))
    d_out = np.column_stack([np.cos(uniq), np.sin(uniq), zero])
    c = blends.Corners(np.zeros((m, 3)), e_x, d_out, uniq, np.tile([0.0, 1.0, 0.0], (m, 1)),
                       np.full(m, 1e9), np.full(m, 1e9))
    built = kind.build(c, 1.0)
    length = np.asarray(built.length, dtype=float)
    ev = kind.evaluator(_segments_of(kind.name, built.params, length))
    parametric = hasattr(ev, "derivs") and hasattr(ev, "t_end")
    hi = np.asarray(ev.t_end(), dtype=float) if parametric else length

    def curve(t: np.ndarray):
        j = np.repeat(np.arange(m), t.shape[1])
        tt = np.clip(t, 0.0, hi[:, None]).ravel()
        out = ev.derivs(j, tt) if parametric else ev.eval(j, tt)
        return tuple(o.reshape(m, t.shape[1], 3) for o in out[:3])

    path = zoomed_max(lambda t: _ray_distance(curve(t)[0], e_x, d_out), zero, hi)[0]
    ts = kind.tangent_distance(uniq, 1.0)
    sampled = curve_samples(curve, zero, hi, UNIT_SAMPLES)

    def program(v: np.ndarray) -> np.ndarray:
        x = v[..., None] * np.where(v[..., None] < 0, e_x[:, None], d_out[:, None])
        return nearest_on_curve(curve, sampled, zero, hi, x)[0]

    near = nearest_on_curve(curve, sampled, zero, hi, np.zeros((m, 1, 3)))[1][:, 0]
    if parametric:
        near = arclength.arc_length(ev.speed, np.arange(m), near, ev.table)
    # the grid of 2 PROGRAM_SAMPLES + 1 points is symmetric: it holds the corner (v = 0)
    prog = zoomed_max(program, -ts, ts, q=2 * PROGRAM_SAMPLES + 1)[0]
    return UnitDeviation(path[inv], prog[inv], near[inv])


@dataclass
class Corner:
    """Blends at the line-line corners: junction index, blend params, length, tangent
    distance on each line, size, and (from :func:`unit_deviation`) both deviations [m] and
    the arc length of the point nearest the corner [m]."""

    kind: str
    junction: np.ndarray
    params: list[dict]
    length: np.ndarray
    tangent: np.ndarray
    size: np.ndarray
    path_dev: np.ndarray
    program_dev: np.ndarray
    near: np.ndarray


def _build_sized(kind: BlendKind, c: blends.Corners, sizes: np.ndarray
                 ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Params, lengths and tangent distances of ``kind`` blends with one size per corner: one
    call for the built-in kinds, one per distinct size for kinds that take one size."""
    if kind.name in ARRAY_SIZES:
        built = kind.build(c, sizes)
        return built.params, np.asarray(built.length), kind.tangent_distance(c.turn, sizes)
    rows_of = [np.flatnonzero(sizes == v) for v in np.unique(sizes)]
    parts = [kind.build(_corner_rows(c, rows), float(sizes[rows[0]])) for rows in rows_of]
    order = np.argsort(np.concatenate(rows_of))
    params = {k: np.concatenate([np.asarray(p.params[k]) for p in parts])[order]
              for k in parts[0].params}
    length = np.concatenate([np.asarray(p.length) for p in parts])[order]
    tangent = np.concatenate([kind.tangent_distance(c.turn[rows], float(sizes[rows[0]]))
                              for rows in rows_of])[order]
    return params, length, tangent


def _corner_rows(c: blends.Corners, rows: np.ndarray) -> blends.Corners:
    return blends.Corners(*(np.asarray(getattr(c, f))[rows] for f in
                            ("point", "d_in", "d_out", "turn", "normal", "len_in", "len_out")))


def corners(kind: BlendKind | None, size: float, pieces: list[Piece], base: Path,
            corner_j: np.ndarray, tol: np.ndarray) -> Corner:
    """Blends at the line-line ``corner_j`` of ``kind``, each the smallest of ``size``, the
    largest that fits in half of each line and the largest within the junction's tolerance
    both ways (:func:`unit_deviation`)."""
    empty = Corner("", corner_j[:0], [], *(np.zeros(0),) * 6)
    if kind is None or not corner_j.size:
        return empty
    end = states(base, corner_j, np.array([pieces[j].length for j in corner_j]))
    start = states(base, corner_j + 1, np.zeros(corner_j.size))
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
    unit = unit_deviation(kind, turn)
    within = 0.999 * tol[corner_j] / np.maximum(unit.path, unit.program)
    sizes = np.minimum.reduce([np.full_like(turn, size), fits, within])
    params, length, tangent = _build_sized(kind, c, sizes)
    rows = [{k: v[i] for k, v in params.items()} for i in range(turn.size)]
    return Corner(kind.name, corner_j, rows, length, tangent, sizes, sizes * unit.path,
                  sizes * unit.program, sizes * unit.near)


# --- stretches ---------------------------------------------------------------------------------


@dataclass
class Stretch:
    """One segment of the result: a piece (or blend) trimmed to [offset, offset + length]."""

    kind: str
    params: dict
    offset: float
    length: float
    piece: int  # index into the pieces (-1 for blends and transitions)
    junction: int  # programmed junction a blend/transition belongs to (-1 otherwise)


def trimmed_pieces(pieces: list[Piece], corner: Corner) -> list[Stretch]:
    """Pieces shortened by the corner blends, with the blends between them."""
    cut_end = np.zeros(len(pieces))
    cut_start = np.zeros(len(pieces))
    cut_end[corner.junction] = corner.tangent
    cut_start[corner.junction + 1] = corner.tangent
    blend_at = {int(j): k for k, j in enumerate(corner.junction)}
    out: list[Stretch] = []
    for i, p in enumerate(pieces):
        out.append(Stretch(p.kind, p.params, cut_start[i], p.length - cut_start[i]
                           - cut_end[i], i, -1))
        if i in blend_at:
            k = blend_at[i]
            out.append(Stretch(corner.kind, corner.params[k], 0.0, float(corner.length[k]),
                               -1, i))
    return out


def stretch_path(stretches: list[Stretch]) -> Path:
    s0 = np.concatenate([[0.0], np.cumsum([x.length for x in stretches])[:-1]])
    return Path([Segment(x.kind, float(s), x.length, -1, x.params, offset=x.offset)
                 for x, s in zip(stretches, s0, strict=True)])


def non_g2(path: Path, stretches: list[Stretch], g2_tol: float = G2_TOL) -> np.ndarray:
    """Indices of the stretches whose junction with the next one is not G2 (a kink, or a
    curvature jump over ``g2_tol`` [1/m])."""
    k = len(stretches)
    before = np.arange(k - 1)
    lens = np.array([x.length for x in stretches[:-1]])
    _, ta, ka, _ = path._eval_segments(before, lens)
    _, tb, kb, _ = path._eval_segments(before + 1, np.zeros(k - 1))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", ta, tb), -1.0, 1.0))
    jump = np.linalg.norm(kb - ka, axis=1)
    return before[(turn > COLLINEAR_TOL) | (jump > g2_tol)]


def junction_of(stretches: list[Stretch], i: int) -> int:
    """The programmed junction (index of the piece before it) a non-G2 stretch junction
    belongs to: a blend's own, or the junction between the two pieces."""
    a, b = stretches[i], stretches[i + 1]
    if a.junction >= 0:
        return a.junction
    if b.junction >= 0:
        return b.junction
    return a.piece


# --- transitions -------------------------------------------------------------------------------


@dataclass
class Transitions:
    """G2 transitions after stretches ``at`` (of the stretches without transitions), their
    junctions, and per transition what the last round built: the length cut from each
    neighbour [m], the Bezier control points, the arc-length table and the length [m]."""

    at: np.ndarray
    junction: np.ndarray
    cut: np.ndarray
    control: np.ndarray
    s_nodes: np.ndarray
    sigma_nodes: np.ndarray
    length: np.ndarray

    @classmethod
    def empty(cls, at: np.ndarray, junction: np.ndarray) -> Transitions:
        n = at.size
        return cls(at, junction, np.zeros(n), np.zeros((n, 6, 3)), np.zeros((n, 0)),
                   np.zeros((n, 0)), np.zeros(n))

    def build(self, rows: np.ndarray, path0: Path, len0: np.ndarray, cut: np.ndarray) -> None:
        """(Re)build transitions ``rows`` cutting ``cut`` from both neighbours."""
        at = self.at[rows]
        a = states(path0, at, len0[at] - cut)
        b = states(path0, at + 1, cut)
        built = build_transitions(a.p, a.t, a.k, b.p, b.t, b.k)
        table = built.params["s_nodes"].shape[1]
        if self.s_nodes.shape[1] != table:
            self.s_nodes = np.zeros((self.at.size, table))
            self.sigma_nodes = np.zeros((self.at.size, table))
        self.cut[rows] = cut
        self.control[rows] = built.params["control"]
        self.s_nodes[rows] = built.params["s_nodes"]
        self.sigma_nodes[rows] = built.params["sigma_nodes"]
        self.length[rows] = built.length

    def params(self, i: int) -> dict[str, np.ndarray]:
        return {"control": self.control[i], "s_nodes": self.s_nodes[i],
                "sigma_nodes": self.sigma_nodes[i]}


@dataclass(frozen=True)
class Layout:
    """Where the junctions' modified stretches sit among the stretches without transitions:
    per programmed junction the stretch of the piece before and after it (``first``,
    ``last``), the blend stretches, and the stretches' offsets, lengths and path positions."""

    first: np.ndarray
    last: np.ndarray
    blend: np.ndarray  # stretch indices of the blends
    blend_junction: np.ndarray
    offset: np.ndarray
    length: np.ndarray
    start: np.ndarray

    @classmethod
    def of(cls, stretches: list[Stretch], path0: Path, n_pieces: int) -> Layout:
        piece = np.array([x.piece for x in stretches])
        junction = np.array([x.junction for x in stretches])
        where = np.full(n_pieces, -1)
        where[piece[piece >= 0]] = np.flatnonzero(piece >= 0)
        blend = np.flatnonzero(junction >= 0)
        return cls(where[:-1], where[1:], blend, junction[blend],
                   np.array([x.offset for x in stretches]),
                   np.array([x.length for x in stretches]), path0.segment_start)


@dataclass(frozen=True)
class Regions:
    """The modified stretches of some junctions laid end to end as one small path
    (``local``): junction row a's is [``start[a]``, ``start[a] + length[a]``] on it, made of
    segments ``seg_lo[a]..seg_hi[a]``. Beyond its ends the path continues along the pieces
    (stretches ``before``/``after`` of the path without transitions, from local arc lengths
    ``end_before``/``start_after``), up to ``ext_lo``/``ext_hi``."""

    junction: np.ndarray
    local: Path
    start: np.ndarray
    length: np.ndarray
    seg_lo: np.ndarray
    seg_hi: np.ndarray
    path0: Path
    before: np.ndarray
    after: np.ndarray
    end_before: np.ndarray
    start_after: np.ndarray
    ext_lo: np.ndarray
    ext_hi: np.ndarray

    def curve(self, rows: np.ndarray):
        """``curve(r)``: position, tangent, curvature (k, q, 3) at region parameters r (k, q)
        of junction rows ``rows`` (r < 0 and r > length continue along the pieces)."""
        def f(r: np.ndarray):
            shape = r.shape
            row = np.broadcast_to(rows[:, None], shape).ravel()
            r = r.ravel()
            out = [np.empty((r.size, 3)) for _ in range(3)]
            length = self.length[row]
            lo, hi = r < 0.0, r > length
            mid = ~(lo | hi)
            s = self.start[row[mid]] + r[mid]
            seg = np.clip(np.searchsorted(self.local._start, s, side="right") - 1,
                          self.seg_lo[row[mid]], self.seg_hi[row[mid]])
            parts = [(mid, self.local, seg, s - self.local._start[seg]),
                     (lo, self.path0, self.before[row[lo]], self.end_before[row[lo]] + r[lo]),
                     (hi, self.path0, self.after[row[hi]],
                      self.start_after[row[hi]] + r[hi] - length[hi])]
            for mask, path, seg_i, sl in parts:
                if mask.any():
                    res = path._eval_segments(seg_i, sl)
                    for o, v in zip(out, res[:3], strict=True):
                        o[mask] = v
            return tuple(o.reshape(*shape, 3) for o in out)
        return f


def regions(active: np.ndarray, lay: Layout, trans: Transitions, corner_kind: str,
            path0: Path) -> Regions:
    """The modified stretches of junctions ``active`` (sorted): transitions as built, blends
    trimmed by the transitions at their ends."""
    cut_after = np.zeros(lay.length.size)
    cut_after[trans.at] = trans.cut
    t_rows = np.flatnonzero(np.isin(trans.junction, active))
    b = lay.blend[np.isin(lay.blend_junction, active)]
    key = np.concatenate([trans.at[t_rows] + 0.5, b.astype(float)])
    order = np.argsort(key, kind="stable")
    parts = []  # (kind, length, params, offset) in path order
    for k in order.tolist():  # one segment per part: the small path's own construction
        if k < t_rows.size:
            i = int(t_rows[k])
            parts.append((TRANSITION, float(trans.length[i]), trans.params(i), 0.0))
        else:
            i = int(b[k - t_rows.size])
            parts.append((corner_kind, float(lay.length[i] - cut_after[i - 1] - cut_after[i]),
                          path0.segments[i].params, float(lay.offset[i] + cut_after[i - 1])))
    lengths = np.array([p[1] for p in parts])
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    local = Path([Segment(kind, s0, ln, -1, params, offset=off)
                  for (kind, ln, params, off), s0 in zip(parts, starts.tolist(), strict=True)])
    owner = np.concatenate([trans.junction[t_rows], lay.blend_junction[np.isin(
        lay.blend_junction, active)]])[order]
    row = np.searchsorted(active, owner)
    seg_hi = np.zeros(active.size, dtype=np.intp)
    np.maximum.at(seg_hi, row, np.arange(owner.size))
    seg_lo = np.full(active.size, owner.size, dtype=np.intp)
    np.minimum.at(seg_lo, row, np.arange(owner.size))
    length = np.bincount(row, lengths, minlength=active.size)
    f, last = lay.first[active], lay.last[active]
    end_before = lay.length[f] - cut_after[f]
    start_after = cut_after[last - 1]
    return Regions(active, local, starts[seg_lo], length, seg_lo, seg_hi, path0, f, last,
                   end_before, start_after,
                   np.clip(np.minimum(length, 0.5 * lay.length[f] - cut_after[f]), 0.0, None),
                   np.clip(np.minimum(length, 0.5 * lay.length[last] - cut_after[last - 1]),
                           0.0, None))


# --- the program near each junction, and the two deviations ------------------------------------


def _program_u(piece: Piece, s: float) -> float:
    """Programmed arc length (along the piece's polyline) at piece arc length ``s``."""
    if piece.kind == SPLINE:
        return float(np.interp(s, piece.node_s, piece.poly_s))
    return float(s)


def _point_at(piece: Piece, u: float) -> np.ndarray:
    return np.array([np.interp(u, piece.poly_s, piece.polyline[:, i]) for i in range(3)])


def _window(piece: Piece, reach: float, at_end: bool) -> np.ndarray:
    """The programmed polyline of ``piece`` within ``reach`` of its end (or start)."""
    s = piece.poly_s
    if at_end:
        k = max(int(np.searchsorted(s, s[-1] - reach, side="right")) - 1, 0)
        return piece.polyline[k:]
    k = min(int(np.searchsorted(s, reach, side="left")) + 1, len(s))
    return piece.polyline[:k]


@dataclass(frozen=True)
class Programmed:
    """Per junction row the programmed geometry near it: ``window`` (the polylines of both
    pieces within reach of the junction, for path -> program), ``replaced`` (the polyline
    the modified stretch replaces, from where it leaves the first piece to where it joins the
    second, for program -> path), the programmed junction point ``corner`` (k, 3) and how far
    the programmed geometry is from those polylines at most (``sag``, arcs; k,) [m]."""

    window: list[np.ndarray]
    replaced: list[np.ndarray]
    corner: np.ndarray
    sag: np.ndarray


def programmed(pieces: list[Piece], regs: Regions, lay: Layout) -> Programmed:
    """The programmed geometry around every junction of ``regs``."""
    window, replaced = [], []
    s_a = lay.offset[regs.before] + regs.end_before
    s_b = lay.offset[regs.after] + regs.start_after
    for k, j in enumerate(regs.junction.tolist()):  # index work on each junction's polylines
        pa, pb = pieces[j], pieces[j + 1]
        u_a, u_b = _program_u(pa, s_a[k]), _program_u(pb, s_b[k])
        reach = 2.0 * regs.length[k] + 1e-9
        window.append(np.vstack([_window(pa, reach + pa.poly_s[-1] - u_a, True),
                                 _window(pb, reach + u_b, False)[1:]]))
        replaced.append(np.vstack([_point_at(pa, u_a)[None], pa.polyline[pa.poly_s > u_a],
                                   pb.polyline[1:][pb.poly_s[1:] < u_b],
                                   _point_at(pb, u_b)[None]]))
    corner = np.array([pieces[j + 1].polyline[0] for j in regs.junction.tolist()])
    sag = np.array([max(pieces[j].sag, pieces[j + 1].sag) for j in regs.junction.tolist()])
    return Programmed(window, replaced, corner.reshape(-1, 3), sag)


@dataclass(frozen=True)
class Measured:
    """Per junction row: path -> program and program -> path deviation [m], and the region
    parameter of the path point nearest the programmed junction point [m]."""

    path: np.ndarray
    program: np.ndarray
    near: np.ndarray


def measure(regs: Regions, prog: Programmed) -> Measured:
    """Both deviations of every region from the program, in batches of similar size: those
    from and to the programmed polylines plus their sag (so bounds of those from and to the
    programmed arcs too)."""
    m = regs.junction.size
    out = Measured(np.zeros(m), np.zeros(m), np.zeros(m))
    size = np.array([max(len(w), len(r)) for w, r in zip(prog.window, prog.replaced,
                                                          strict=True)])
    for rows in batches(size, (DEVIATION_SAMPLES + 1) * 2):
        _measure_rows(regs, prog, rows, out)
    out.path[:] += prog.sag
    out.program[:] += prog.sag
    return out


def _measure_rows(regs: Regions, prog: Programmed, rows: np.ndarray, out: Measured) -> None:
    curve = regs.curve(rows)
    length = regs.length[rows]
    zero = np.zeros(rows.size)
    wp, _ = padded([prog.window[i] for i in rows.tolist()])
    wa, wb = wp[:, :-1], wp[:, 1:]
    out.path[rows] = zoomed_max(lambda r: segment_distance(curve(r)[0], wa, wb), zero,
                                length)[0]
    lo, hi = -regs.ext_lo[rows], length + regs.ext_hi[rows]
    sampled = curve_samples(curve, lo, hi)
    grid, pos = sampled
    d = np.linalg.norm(pos - prog.corner[rows, None], axis=2)
    d[(grid < 0.0) | (grid > length[:, None])] = np.inf
    out.near[rows] = grid[np.arange(rows.size), np.argmin(d, axis=1)]
    rp, rc = padded([prog.replaced[i] for i in rows.tolist()])

    def dist(u: np.ndarray) -> np.ndarray:
        return nearest_on_curve(curve, sampled, lo, hi, polyline_points(rp, rc, u))[0]

    at_vertices = nearest_on_curve(curve, sampled, lo, hi, rp)[0].max(axis=1)
    between = zoomed_max(dist, zero, rc[:, -1], q=PROGRAM_SAMPLES + 1)[0]
    out.program[rows] = np.maximum(at_vertices, between)


# --- fitting the transitions -------------------------------------------------------------------


@dataclass
class Fitted:
    """The stretches with their transitions, the path, per treated junction (path ->
    program deviation, program -> path deviation, s of the point nearest the programmed
    junction point) and the junctions where no transition fits (-> best deviation [m])."""

    stretches: list[Stretch]
    path: Path
    dev: dict[int, tuple[float, float, float]]
    failed: dict[int, float]


def _local_jumps(path0: Path, lay: Layout, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Turn [rad] and curvature jump [1/m] where each transition goes (stretch ``at`` meets
    ``at + 1``): a programmed kink, or a blend's end."""
    _, ta, ka, _ = path0._eval_segments(at, lay.length[at])
    _, tb, kb, _ = path0._eval_segments(at + 1, np.zeros(at.size))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", ta, tb), -1.0, 1.0))
    return turn, np.linalg.norm(kb - ka, axis=1)


def first_cut(turn: np.ndarray, jump: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """The cut [m] from each neighbour at which a transition is expected to deviate about
    0.9 ``tol``: a quintic G2 transition cutting c from two lines meeting at a turn theta
    deviates about g(theta) c, g = sin(theta/2) (0.375 + 0.6 (theta/pi)^2) (within 10 % from
    1 to 178 deg, both ways, measured), and one cutting c from a tangent line and arc about
    0.011 dK c^2 (dK the curvature jump); the root of their sum. Only the start of the search:
    the measured deviation decides."""
    target = 0.9 * tol
    g = np.sin(0.5 * turn) * (0.375 + 0.6 * (turn / np.pi) ** 2)
    a = 0.011 * jump
    with np.errstate(divide="ignore", invalid="ignore"):
        quad = 2.0 * target / (g + np.sqrt(g * g + 4.0 * a * target))
    return np.where(g + a > 0, quad, np.inf)


def _next_scale(scale: np.ndarray, worst: np.ndarray, tol: np.ndarray, smooth: np.ndarray,
                grown: np.ndarray, room_left: np.ndarray) -> np.ndarray:
    """The next scale of transitions whose junction deviates ``worst`` (tolerance ``tol``):
    over it, shorter by 0.95 times the ratio (its square root where the junction is tangent:
    the deviation then grows with the square of the length), 0.05 to 0.9 of it; far below it
    (< 0.8 tol) and never grown before, once longer the same way, at most to the room."""
    ratio = tol / np.maximum(worst, 1e-300)
    step = 0.95 * np.where(smooth, np.sqrt(ratio), ratio)
    shrink = np.clip(step, 0.05, 0.9)
    grow = np.minimum(step, room_left)
    return scale * np.where(worst > tol, shrink, np.where(~grown & (worst < 0.8 * tol),
                                                           np.maximum(grow, 1.0), 1.0))


def fit_transitions(stretches0: list[Stretch], path0: Path, at: np.ndarray,
                    junction: np.ndarray, tol: np.ndarray,
                    pieces: list[Piece], corner: Corner) -> Fitted:
    """Transitions after stretches ``at`` (of junctions ``junction``), sized so that every
    treated junction is within its tolerance both ways: from the expected size
    (:func:`first_cut`), shortened while over the tolerance, lengthened once if far below;
    rounds on the junctions still to settle. A junction with a blend and no transition
    deviates as its blend was sized to (:class:`Corner`) and is not measured again."""
    lay = Layout.of(stretches0, path0, len(pieces))
    trans = Transitions.empty(at, junction)
    treated = np.unique(junction).astype(np.intp)
    room = 0.5 * np.minimum(lay.length[at], lay.length[at + 1])
    turn_t, jump_t = _local_jumps(path0, lay, at)
    scale = np.minimum(1.0, first_cut(turn_t, jump_t, tol[junction]) / np.maximum(room, 1e-300))
    grown = scale >= 1.0
    n_j = len(pieces) - 1
    dev = np.zeros((3, n_j))  # path -> program, program -> path, near
    failed: dict[int, float] = {}
    active = treated
    for _ in range(MAX_ROUNDS):
        if not active.size:
            break
        rows = np.flatnonzero(np.isin(trans.junction, active))
        if rows.size:
            trans.build(rows, path0, lay.length, room[rows] * scale[rows])
        regs = regions(active, lay, trans, corner.kind, path0)
        got = measure(regs, programmed(pieces, regs, lay))
        dev[:, active] = got.path, got.program, got.near
        worst = np.maximum(dev[0], dev[1])
        t_act = np.flatnonzero(np.isin(trans.junction, active))
        j = trans.junction[t_act]
        new = _next_scale(scale[t_act], worst[j], tol[j], turn_t[t_act] < 1e-3,
                          grown[t_act], 1.0 / scale[t_act])
        grown[t_act] |= new > scale[t_act]
        short = np.unique(j[(new < scale[t_act])
                            & (trans.length[t_act] * new / scale[t_act] < MIN_TRANSITION)])
        failed.update({int(g): float(worst[g]) for g in short})
        changed = np.unique(j[new != scale[t_act]])
        scale[t_act] = new
        active = np.setdiff1d(changed, short)
    else:
        over = active[np.maximum(dev[0], dev[1])[active] > tol[active]]
        failed.update({int(g): float(np.maximum(dev[0], dev[1])[g]) for g in over})
    # built that short from the start (a near-reversal): a stop, deviation unknown (nan)
    hairpin = np.unique(trans.junction[trans.length < MIN_TRANSITION])
    failed.update({int(g): math.nan for g in hairpin if int(g) not in failed})
    alone = ~np.isin(corner.junction, treated)  # blends without transitions
    blend_j = corner.junction[alone]
    dev[:, blend_j] = corner.path_dev[alone], corner.program_dev[alone], corner.near[alone]
    stretches, first = _with_transitions(stretches0, trans)
    path = stretch_path(stretches)
    failed.update(_not_built_g2(path, stretches, treated, failed))
    s_lo = path.segment_start
    return Fitted(stretches, path, {int(j): (float(dev[0, j]), float(dev[1, j]),
                                             float(s_lo[first[int(j)]] + dev[2, j]))
                                    for j in np.concatenate([treated, blend_j]).tolist()},
                  failed)


def _not_built_g2(path: Path, stretches: list[Stretch], treated: np.ndarray,
                  failed: dict[int, float]) -> dict[int, float]:
    """The treated junctions (not yet failed) whose transition's ends are still not G2 as
    built (a curvature jump over :data:`G2_STOP_TOL`), each with nan: at a near-reversal the
    transition is a hairpin of a fraction of a micrometre turning by about pi, whose end
    curvatures floating point cannot match; such a junction becomes a corner stop (the tool
    all but stops there anyway)."""
    bad = {junction_of(stretches, int(i))
           for i in non_g2(path, stretches, G2_STOP_TOL).tolist()}
    mine = bad.intersection(treated.tolist()).difference(failed)
    return {j: math.nan for j in sorted(mine)}


def _with_transitions(stretches0: list[Stretch], trans: Transitions
                      ) -> tuple[list[Stretch], dict[int, int]]:
    """The stretches trimmed by the transitions' cuts with the transitions inserted, and per
    junction the index of the first stretch of its modified stretch."""
    cut_after = np.zeros(len(stretches0) + 1)
    cut_after[trans.at] = trans.cut
    insert = {int(i): k for k, i in enumerate(trans.at.tolist())}
    out: list[Stretch] = []
    first: dict[int, int] = {}
    for i, x in enumerate(stretches0):  # one pass building the result's segment list
        cs, ce = cut_after[i - 1] if i > 0 else 0.0, cut_after[i]
        out.append(Stretch(x.kind, x.params, x.offset + cs, x.length - cs - ce, x.piece,
                           x.junction))
        if x.junction >= 0:
            first.setdefault(x.junction, len(out) - 1)
        if i in insert:
            k = insert[i]
            j = int(trans.junction[k])
            out.append(Stretch(TRANSITION, trans.params(k), 0.0, float(trans.length[k]), -1, j))
            first.setdefault(j, len(out) - 1)
    return out, first
