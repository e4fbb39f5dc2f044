"""Paths parameterised by arc length: lines and corner blends (thesis 3.3, appendix B.1).

A :class:`Path` is a sequence of :class:`Segment` (lines and blends) laid end to end in arc
length s [m]. :meth:`Path.evaluate` returns, for any array of s, the position, the unit
tangent dp/ds, the curvature vector d2p/ds2 and its derivative d3p/ds3, vectorised: samples are
grouped by segment kind and each kind is evaluated on its whole array at once, by the
evaluator its blend kind registered (:mod:`feedopt.geometry.registry`; lines here).

Parametric blends (Bezier, varying radius) are evaluated by arc length through a numerical
s(t) table and its inverse t(s) (:mod:`feedopt.geometry.arclength`, thesis Eq. 3.23); the
derivatives w.r.t. s follow from those w.r.t. t by the chain rule (:func:`arc_length_derivatives`).

:func:`build_lipb_path` builds the linear-interpolation-with-polynomial-blends path from
waypoints with one blend per interior corner, of any registered kind (circle, bezier4,
bezier5, varying_radius, ...) or none, in named phases: check the blend, validate the
waypoints, find the corners, fit the blends, trim the lines, build the blends, assemble the
segments.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from feedopt.errors import InputError
from feedopt.geometry import blend_kinds as _builtin_kinds  # noqa: F401 - registers them
from feedopt.geometry import blends
from feedopt.geometry.arclength import arc_length_derivatives as arc_length_derivatives
from feedopt.geometry.registry import (
    LINE,
    BlendKind,
    SegmentEvaluator,
    blend_kinds,
    get_blend,
    segment_kinds,
)
from feedopt.geometry.segment import Segment as Segment
from feedopt.parallel import for_each_chunk
from feedopt.units import MM, MM_PER_M

REPEAT_TOL = 1e-9  # consecutive waypoints closer than this [m] are "repeated"
COLLINEAR_TOL = 1e-7  # corners turning less than this [rad] get no blend
# corners turning more than pi - REVERSAL_TOL [rad] are refused: no circle fits them and the
# Bezier blends of Eq. 3.3-3.8 degenerate towards cusps (alpha -> 0)
REVERSAL_TOL = 1e-3
#: what the repeated-waypoint message suggests unless the caller passes its own ``repeat_hint``
DEFAULT_REPEAT_HINT = "pass drop_repeated=True (CLI: --drop-repeated)"
_CHUNK = 1 << 16
#: largest number of samples a path is planned or written with (memory: ~2 kB per sample
#: across the stages of a run); ``feedopt run`` and ``feedopt path`` refuse more
MAX_SAMPLES = 2_000_000


def check_sample_count(length: float, spacing: float, option: str) -> None:
    """InputError when sampling a path ``length`` [m] long every ``spacing`` [m] gives more
    than :data:`MAX_SAMPLES` samples, naming ``option`` and the spacing that would do."""
    n_samples = length / spacing + 1
    if n_samples > MAX_SAMPLES:
        raise InputError(
            f"{option} = {spacing / MM:g} mm gives {n_samples:.3g} samples on the "
            f"{length / MM:.1f} mm path; at most {MAX_SAMPLES:.0e} are planned (use "
            f"a spacing of at least {length / MM / (MAX_SAMPLES - 1):.2g} mm)")


@dataclass(frozen=True)
class PathPoints:
    """Evaluation of a path at arc lengths ``s`` (all arrays share the leading axis n).

    s : (n,) arc length [m]; position (n, 3) [m]; tangent (n, 3) unit dp/ds;
    curvature (n, 3) curvature vector d2p/ds2 [1/m]; dcurvature (n, 3) d3p/ds3 [1/m^2];
    segment (n,) index into ``Path.segments``; five-axis paths (``Path.orientation``): the
    unit tool vector ``axis`` (n, 3) and its derivatives ``axis_d1`` [1/m], ``axis_d2``
    [1/m^2] by arc length (None on three-axis paths, whose tool axis is the workpiece's).
    """

    s: np.ndarray
    position: np.ndarray
    tangent: np.ndarray
    curvature: np.ndarray
    dcurvature: np.ndarray
    segment: np.ndarray
    axis: np.ndarray | None = None
    axis_d1: np.ndarray | None = None
    axis_d2: np.ndarray | None = None


class LineEvaluator:
    """Straight lines p(s) = origin + s direction: zero curvature and derivative."""

    def __init__(self, segs: Sequence[Segment]):
        self.origin = np.array([g.params["origin"] for g in segs]).reshape(-1, 3)
        self.direction = np.array([g.params["direction"] for g in segs]).reshape(-1, 3)

    def eval(self, j, sl):
        d = self.direction[j]
        z = np.zeros_like(d)
        return self.origin[j] + sl[:, None] * d, d, z, z.copy()


def segment_evaluator(kind: str, segs: Sequence[Segment]) -> SegmentEvaluator:
    """The evaluator of all segments ``segs`` of ``kind``: lines, or the registered blend's
    or segment kind's (:func:`~feedopt.geometry.registry.register_segment_kind`).

    Raises ``ValueError`` for a kind that is none of these.
    """
    if kind == LINE:
        return LineEvaluator(segs)
    known = (*blend_kinds(), *segment_kinds())
    found = next((b for b in known if b.name == kind), None)
    if found is None:
        raise ValueError(f"unknown segment kind {kind!r}: neither {LINE!r} nor a registered "
                         f"blend or segment kind ({', '.join(b.name for b in known)})")
    return found.evaluator(segs)


class Path:
    """A sequence of segments parameterised by arc length s in [0, length] [m].

    Segments must be contiguous: ``segments[i].s_start == sum of earlier lengths``.
    ``dropped_waypoints`` are the indices (in the caller's array) of the repeated waypoints
    the build dropped (``build_lipb_path(..., drop_repeated=True)``); empty otherwise.
    ``moves`` is the program provenance of a path made from a G-code program (None else).
    """

    def __init__(self, segments: tuple[Segment, ...] | list[Segment], *,
                 dropped_waypoints: Sequence[int] = (), moves: Any = None):
        segs = tuple(segments)
        if not segs:
            raise InputError("a path needs at least one segment")
        self.segments: tuple[Segment, ...] = segs
        self.dropped_waypoints: tuple[int, ...] = tuple(int(i) for i in dropped_waypoints)
        #: where each programmed move starts (a
        #: :class:`~feedopt.geometry.program_path.MoveTable`), for paths made from a program
        self.moves = moves
        #: what building the path recorded for the user (program reader, smoothing)
        self.notes: tuple[str, ...] = ()
        #: per programmed junction, what it got and its deviation from the program (a
        #: :class:`~feedopt.geometry.program_path.JunctionReport`), for program paths
        self.junctions = None
        #: the program's tool comments (:class:`~feedopt.gcode.moves.ToolHeader`), checked
        #: against the scenario's tool file by the process stage; () for other paths
        self.tool_headers: tuple = ()
        #: where the tool stops (a :class:`~feedopt.geometry.stops.StopTable`, or anything
        #: with an increasing array ``s`` [m]); :meth:`sample` samples every stop exactly
        self.stops = None
        #: five-axis paths: the tool's orientation u(s)
        #: (:class:`~feedopt.geometry.orientation.ToolOrientation`); None: three-axis
        self.orientation = None
        self._start = np.array([g.s_start for g in segs], dtype=float)
        self._len = np.array([g.length for g in segs], dtype=float)
        self._offset = np.array([g.offset for g in segs], dtype=float)
        self.length: float = float(self._start[-1] + self._len[-1])
        self._kind = tuple(g.kind for g in segs)
        present = {kind: code for code, kind in enumerate(dict.fromkeys(self._kind))}
        self._code = np.array([present[k] for k in self._kind], dtype=np.intp)
        self._local = np.zeros(len(segs), dtype=np.intp)
        self._eval: dict[int, SegmentEvaluator] = {}
        for kind, code in present.items():
            idx = np.flatnonzero(self._code == code)
            self._local[idx] = np.arange(idx.size)
            self._eval[code] = segment_evaluator(kind, [segs[i] for i in idx])

    @property
    def segment_start(self) -> np.ndarray:
        """(k,) arc length at which each segment starts [m]."""
        return self._start.copy()

    @property
    def segment_kind(self) -> tuple[str, ...]:
        """Kind of each segment ("line" or the blend kind)."""
        return self._kind

    def evaluate(self, s: ArrayLike) -> PathPoints:
        """Position, unit tangent, curvature vector and its derivative at arc lengths ``s``.

        A junction belongs to the segment that starts there (except s = length). Values
        outside [0, length] beyond 1e-9 of the length raise ``ValueError``.
        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        tol = 1e-9 * max(self.length, 1e-12)
        if s.size and (np.nanmin(s) < -tol or np.nanmax(s) > self.length + tol
                       or not np.all(np.isfinite(s))):
            raise ValueError(f"arc lengths must lie in [0, {self.length}] m")
        s = np.clip(s, 0.0, self.length)
        seg = np.clip(np.searchsorted(self._start, s, side="right") - 1, 0, len(self._start) - 1)
        pos, tan, curv, dcurv = self._eval_segments(seg, s - self._start[seg])
        axis = None if self.orientation is None else self.orientation.evaluate(s)
        return PathPoints(s=s, position=pos, tangent=tan, curvature=curv, dcurvature=dcurv,
                          segment=seg, axis=None if axis is None else axis.axis,
                          axis_d1=None if axis is None else axis.d1,
                          axis_d2=None if axis is None else axis.d2)

    @property
    def stop_s(self) -> np.ndarray:
        """(k,) arc lengths of the stops strictly inside (0, length) [m] (empty without)."""
        if self.stops is None:
            return np.zeros(0)
        s = np.asarray(self.stops.s, dtype=float)
        return s[(s > 1e-12 * self.length) & (s < self.length * (1.0 - 1e-12))]

    def sample(self, spacing: float) -> PathPoints:
        """Samples in s, both ends included, no further apart than ``spacing``.

        Without stops they are uniform: n = ceil(length / spacing) + 1. With stops
        (:attr:`stops`) a sample lies exactly at every stop and the samples are uniform
        between consecutive stops (each stretch in ceil(stretch / spacing) equal steps). A stop
        between two segments is where the following one starts, so its sample evaluates as
        that segment's start (right-sided: the tangent and curvature after the stop).
        """
        if not (np.isfinite(spacing) and spacing > 0):
            raise InputError(
                f"sample spacing must be a positive, finite number of mm, got {spacing / MM:g} mm")
        inner = self.stop_s
        if not inner.size and self.orientation is None:
            n = int(np.ceil(self.length / spacing - 1e-9)) + 1
            return self.evaluate(np.linspace(0.0, self.length, max(n, 2)))
        bounds = np.concatenate([[0.0], inner, [self.length]])
        if self.orientation is None:
            return self.evaluate(piecewise_uniform(bounds, spacing))
        bounds, spacings = self.orientation.sample_spacing(bounds, spacing)
        return self.evaluate(piecewise_uniform(bounds, spacings))

    def _eval_segments(self, seg: np.ndarray, sl: np.ndarray):
        """Evaluate segments ``seg`` at local arc lengths ``sl`` (clipped to the segment),
        in chunks of one kind each; many chunks (a long path's samples) go to the cores
        (:func:`feedopt.parallel.for_each_chunk`: each writes its own rows)."""
        seg = np.asarray(seg, dtype=np.intp)
        sl = np.clip(np.asarray(sl, dtype=float), 0.0, self._len[seg]) + self._offset[seg]
        n = seg.size
        out = [np.empty((n, 3)) for _ in range(4)]
        code = self._code[seg]
        parts = []
        for c in self._eval:
            idx = np.flatnonzero(code == c)
            parts += [(c, idx[lo:lo + _CHUNK]) for lo in range(0, idx.size, _CHUNK)]

        def run(part: tuple[Any, np.ndarray]) -> None:
            c, rows = part
            res = self._eval[c].eval(self._local[seg[rows]], sl[rows])
            for o, r in zip(out, res, strict=True):
                o[rows] = r

        for_each_chunk(run, parts, threads=None if len(parts) > 1 else 1)
        return tuple(out)


def piecewise_uniform(bounds: np.ndarray, spacing: float | np.ndarray) -> np.ndarray:
    """Arc lengths from ``bounds[0]`` to ``bounds[-1]`` including every bound exactly, each
    stretch between consecutive (increasing) bounds in ceil(stretch / spacing) equal steps
    (``spacing`` one for all or one per stretch)."""
    if np.ndim(spacing) == 0:
        bounds = np.unique(bounds)
    width = np.diff(bounds)
    steps = np.maximum(np.ceil(width / spacing - 1e-9).astype(np.int64), 1)
    first = np.concatenate([[0], np.cumsum(steps)[:-1]])
    k = np.arange(int(steps.sum())) - np.repeat(first, steps)
    s = np.repeat(bounds[:-1], steps) + k * np.repeat(width / steps, steps)
    return np.append(s, bounds[-1])


# --- LIPB construction ----------------------------------------------------------------------


def build_lipb_path(waypoints: np.ndarray, blend: str, size: float, *,
                    drop_repeated: bool = False, repeat_hint: str = DEFAULT_REPEAT_HINT) -> Path:
    """Lines through ``waypoints`` with one blend per interior corner (LIPB, thesis 3.3).

    Parameters
    ----------
    waypoints : (n, 3) array [m] ((n, 2) is taken as z = 0)
    blend : a registered blend kind (:func:`~feedopt.geometry.registry.blend_names`:
        "circle", "bezier4", "bezier5", "varying_radius", ...) or "none"
    size : the kind's size parameter [m]: radius r for circle / varying_radius, tolerance
        delta (distance from the corner along each line to where the blend starts, Eq. 3.1)
        for bezier4 / bezier5; ignored for "none".
    drop_repeated : drop consecutive repeated waypoints instead of refusing them; the path's
        ``dropped_waypoints`` lists them.
    repeat_hint : how the refusal of repeated waypoints tells the caller to drop them
        ("... remove them or <repeat_hint>").

    Returns
    -------
    Path
        with ``dropped_waypoints`` (indices into ``waypoints``) set.

    Corners turning less than ``COLLINEAR_TOL`` get no blend (their two lines meet with a
    G1 jump below that angle); a corner turning back on itself (within ``REVERSAL_TOL`` = 1e-3
    rad of pi) is refused, and so is a corner turning more than its kind's ``max_turn``
    (bezier4: pi - 0.1 rad, where its Eq. 3.3 blend degenerates to a near-cusp). A blend may
    use at most half of each adjoining line, so neighbouring blends never overlap; otherwise
    ``InputError`` names the corner and the largest size that fits there.

    Blends (each in its corner's own plane, see :mod:`feedopt.geometry.blends`):
    circle (appendix B.1): G1, curvature jumps 0 -> 1/r at both ends.
    bezier4 / bezier5 (Eq. 3.1-3.8): G2.
    varying_radius (Eq. 3.13-3.17, 3.23): polar curve r(theta) about the circle blend's
    centre, theta measured from the ray centre -> first tangent point P_t1 towards P_t2, over
    theta_f = turning angle (the circle's swept angle; the thesis's theta_1 of B.1 is this
    ray's angle). Then r(0) = r0 and r'(0) = 0 put the start on P_t1 with dp/dtheta = r0 d_in
    (tangent to the line), and r''(0) = r0 makes the curvature (r^2 + 2r'^2 - r r'')/
    (r^2 + r'^2)^1.5 zero, so the thesis formula meets the lines with G0, G1 and G2 as written
    (symmetrically at theta_f). Its curvature peaks at mid-corner at 1/r_mid + r0/(2 r_mid^2)
    ~ 1.5/r0, i.e. the tightest radius of curvature is about r0/1.5, not r0.
    """
    kind = _check_blend(blend, size)
    w, index, dropped = _validate_waypoints(waypoints, drop_repeated, repeat_hint)
    corners = _find_corners(w, index, kind)
    tangent, has_blend = _fit_blends(corners, kind, size, w, index)
    lines = _trim_lines(w, tangent)
    built = _build_blends(kind, corners, has_blend, size)
    segs = _assemble_segments(lines, built, has_blend, index, blend)
    return Path(segs, dropped_waypoints=dropped)


def _check_blend(blend: str, size: float) -> BlendKind | None:
    """The registered kind (None for "none"); InputError for an unknown kind or a size that
    is not a positive finite number."""
    kind = get_blend(blend)
    if kind is not None and not (np.isfinite(size) and size > 0):
        raise InputError(
            f"blend {blend} needs a positive, finite {kind.size.name} in mm, got "
            f"{size / MM:g} mm (e.g. 12.7 mm)")
    return kind


def _validate_waypoints(waypoints: ArrayLike, drop_repeated: bool,
                        repeat_hint: str = DEFAULT_REPEAT_HINT
                        ) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Check waypoints; returns (points (n,3) m, original indices, dropped indices)."""
    try:
        w = np.asarray(waypoints, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"waypoints must be an (n, 3) array of numbers: {exc}") from None
    if w.ndim != 2 or w.shape[1] not in (2, 3):
        raise InputError(f"waypoints must be an (n, 3) array (x, y, z), got shape {w.shape}")
    if w.shape[1] == 2:
        w = np.column_stack([w, np.zeros(len(w))])
    bad = np.flatnonzero(~np.all(np.isfinite(w), axis=1))
    if bad.size:
        raise InputError(
            f"waypoint {bad[0]} is not finite: {_mm(w[bad[0]])}; "
            f"{bad.size} waypoint(s) contain NaN or inf")
    if len(w) < 2:
        raise InputError(f"a path needs at least two distinct waypoints, got {len(w)}")
    step = np.linalg.norm(np.diff(w, axis=0), axis=1)
    rep = np.flatnonzero(step <= REPEAT_TOL) + 1
    index = np.arange(len(w))
    if rep.size:
        if not drop_repeated:
            shown = ", ".join(str(i) for i in rep[:10]) + (" ..." if rep.size > 10 else "")
            raise InputError(
                f"{rep.size} waypoint(s) repeat the previous one (indices {shown}); remove them "
                f"or {repeat_hint}")
        keep = np.ones(len(w), dtype=bool)
        keep[rep] = False
        w, index = w[keep], index[keep]
    if len(w) < 2:
        raise InputError("a path needs at least two distinct waypoints, all of them coincide")
    return w, index, rep.tolist()


def _find_corners(w: np.ndarray, index: np.ndarray, kind: BlendKind | None
                  ) -> blends.Corners | None:
    """Corner geometry of the interior waypoints (None for a single line); refuses corners
    that reverse the direction of travel and corners beyond the kind's ``max_turn``."""
    if len(w) <= 2:
        return None
    c = blends.corner_geometry(w)
    rev = np.flatnonzero(c.turn > np.pi - REVERSAL_TOL)
    if rev.size:
        i = rev[0] + 1
        raise InputError(
            f"corner at waypoint {index[i]} ({_mm(w[i])}) reverses the direction of travel "
            f"(turns {np.degrees(c.turn[rev[0]]):.4f} deg, within "
            f"{np.degrees(REVERSAL_TOL):.3g} deg of 180); no blend can round it: "
            "insert a waypoint beside it to make two "
            f"gentler corners, or split the path there ({rev.size} such corner(s))")
    if kind is not None and kind.max_turn < np.pi:
        sharp = np.flatnonzero(c.turn > kind.max_turn)
        if sharp.size:
            i = sharp[0] + 1
            others = _kinds_for_turn(kind, float(np.max(c.turn[sharp])))
            raise InputError(
                f"{kind.name} blend degenerates at the corner at waypoint {index[i]} "
                f"({_mm(w[i])}), which turns {np.degrees(c.turn[sharp[0]]):.3f} deg (more "
                f"than {np.degrees(kind.max_turn):.2f} deg): {kind.max_turn_reason}; "
                + (f"use {others}, or add a waypoint" if others else "add a waypoint")
                + f" ({sharp.size} such corner(s))")
    return c


def _kinds_for_turn(kind: BlendKind, turn: float) -> str:
    """The other registered kinds that can round a corner turning by ``turn``, those with the
    same size parameter first ("a, b or c")."""
    names = [k.name for k in sorted(blend_kinds(), key=lambda k: k.size != kind.size)
             if k.name != kind.name and k.max_turn >= turn]
    return " or ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def _fit_blends(c: blends.Corners | None, kind: BlendKind | None, size: float,
                w: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent distance (n,) [m] at every waypoint (0 at the ends, skipped corners and for
    "none") and which waypoints get a blend (n,) bool; refuses blends that need more than
    half of an adjoining line, naming the corner and the largest size that fits."""
    n = len(w)
    ls = np.zeros(n)
    has_blend = np.zeros(n, dtype=bool)
    if c is None or kind is None:
        return ls, has_blend
    active = c.turn >= COLLINEAR_TOL
    has_blend[1:-1] = active
    need = np.where(active, kind.tangent_distance(c.turn, size), 0.0)
    room = 0.5 * np.minimum(c.len_in, c.len_out)
    bad = np.flatnonzero(need > room * (1.0 + 1e-12))
    if bad.size:
        fits = kind.largest_size(c.turn, room)
        b = bad[0]
        what = kind.size.name
        raise InputError(
            f"{kind.name} blend does not fit at the corner at waypoint {index[b + 1]} "
            f"({_mm(w[b + 1])}): {what} {size * MM_PER_M:.6g} mm needs {need[b] * MM_PER_M:.6g}"
            f" mm of each adjoining line but a blend may use at most half of them "
            f"({c.len_in[b] * MM_PER_M:.6g} mm and {c.len_out[b] * MM_PER_M:.6g} mm long); the "
            f"largest {what} that fits there is {fits[b] * MM_PER_M:.6g} mm "
            f"({bad.size} corner(s) too tight; the largest {what} that fits all corners"
            f" is {np.min(fits[active]) * MM_PER_M:.6g} mm)")
    ls[1:-1] = need
    return ls, has_blend


@dataclass(frozen=True)
class _Lines:
    """The n-1 lines between consecutive waypoints, shortened by the blends at both ends."""

    start: np.ndarray  # (n-1, 3) [m]
    direction: np.ndarray  # (n-1, 3) unit
    length: np.ndarray  # (n-1,) [m]
    keep: np.ndarray  # (n-1,) bool: longer than 1e-12 of the waypoint distance


def _trim_lines(w: np.ndarray, ls: np.ndarray) -> _Lines:
    seg_vec = np.diff(w, axis=0)
    seg_len = np.linalg.norm(seg_vec, axis=1)
    seg_dir = seg_vec / seg_len[:, None]
    l_len = seg_len - ls[:-1] - ls[1:]
    return _Lines(start=w[:-1] + ls[:-1, None] * seg_dir, direction=seg_dir, length=l_len,
                  keep=l_len > 1e-12 * seg_len)


def _build_blends(kind: BlendKind | None, c: blends.Corners | None, has_blend: np.ndarray,
                  size: float) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Parameter arrays (one row per blended corner, in waypoint order) and the blend length
    (n,) at every waypoint (0 where there is none), from the kind's builder."""
    blend_len = np.zeros(len(has_blend))
    corner_ids = np.flatnonzero(has_blend)  # waypoint indices with a blend
    if not corner_ids.size:
        return {}, blend_len
    sub = blends.Corners(*(np.asarray(getattr(c, f))[corner_ids - 1] for f in
                           ("point", "d_in", "d_out", "turn", "normal", "len_in", "len_out")))
    built = kind.build(sub, size)
    blend_len[corner_ids] = built.length
    return built.params, blend_len


def _assemble_segments(lines: _Lines, built: tuple[dict[str, np.ndarray], np.ndarray],
                       has_blend: np.ndarray, index: np.ndarray, blend: str
                       ) -> tuple[Segment, ...]:
    """Segments in path order (line 0, blend 1, line 1, blend 2, ..., line n-2), laid end to
    end in s; dropped (zero-length) lines are skipped."""
    blend_data, blend_len = built
    kinds: list[str] = []
    lengths: list[float] = []
    refs: list[int] = []  # line index or corner position
    for i in range(len(has_blend) - 1):
        if i > 0 and has_blend[i]:
            kinds.append(blend)
            lengths.append(blend_len[i])
            refs.append(i)
        if lines.keep[i]:
            kinds.append(LINE)
            lengths.append(lines.length[i])
            refs.append(i)
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    pos_of_corner = {int(ci): k for k, ci in enumerate(np.flatnonzero(has_blend))}
    segs = []
    for kind, s0, ln, ref in zip(kinds, starts.tolist(), lengths, refs, strict=True):
        if kind == LINE:
            params = {"origin": lines.start[ref], "direction": lines.direction[ref]}
            segs.append(Segment(LINE, s0, float(ln), -1, params))
        else:
            k = pos_of_corner[ref]
            params = {key: val[k] for key, val in blend_data.items()}
            segs.append(Segment(kind, s0, float(ln), int(index[ref]), params))
    return tuple(segs)


def _mm(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v * MM_PER_M:.6g}" for v in p) + ") mm"
