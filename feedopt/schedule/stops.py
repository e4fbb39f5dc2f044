"""Planning through stops: every timing law plans a path with stops piece by piece.

A program stops inside the path (G61/G9 exact stops, G4 dwells, M0/M1, tool changes,
reversals, corners the tolerance cannot blend; :class:`~feedopt.schedule.problem.StopSamples`).
:func:`plan_through_stops` splits the :class:`~feedopt.schedule.problem.ScheduleProblem` at the
stop samples into sub-problems that start and end at rest (the problem's own ``v_start`` /
``v_end`` at the path's ends), plans each with the law, and stitches the pieces' s(t) into one
:class:`~feedopt.schedule.trajectory.Trajectory`, inserting a hold (s constant for ``hold_s``)
where a stop holds. The pieces' own polynomials are kept (shifted in time and arc length), so
at a stop the feed is the law's end feed, 0, and a C2 law's acceleration its end
acceleration, 0.

The stitched trajectory's stats (:class:`StitchedStats`) read as those of the piece that
takes longest and carry, typed, the pieces' time windows and stats, so that a law planned
later (``convex`` after ``topp``) gets the matching window of an earlier stitched trajectory
as its context.

This module does not import :mod:`feedopt.schedule.laws` (which routes here): the law's
planning function comes in as ``planner``.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any, NamedTuple

import numpy as np
from scipy.interpolate import PPoly

from feedopt.errors import InputError, LawNotApplicable
from feedopt.schedule.checks import Ramp, find_ramps
from feedopt.schedule.joints import one_sided_end
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM

#: ``planner(name, problem, context, options)``: plans one stop-free problem with a law.
Planner = Callable[[str, ScheduleProblem, dict[str, Trajectory], Any], Trajectory]

# Stop labels written into the "planned in k pieces" note before "and N more".
_LABELS_IN_NOTE = 4
# Segment starts within this distance [m] of a piece end belong to the neighbouring piece.
_SEGMENT_TOL_M = 1e-9
# Samples inserted into a piece of one sample interval (see _refined).
_ONE_INTERVAL_INSERTS = 7
# A law's message or note that names a position (a sample, an arc length) of its piece.
_HAS_POSITION = re.compile(r"sample|\bs = ")


class PieceWindow(NamedTuple):
    """Where one planned piece lies in a stitched trajectory."""

    first_sample: int  # its first and last path sample (stops, or the path ends)
    last_sample: int
    t_from: float  # its time window [s] (breakpoints of the stitched s(t))
    t_to: float
    s_from: float  # arc length at its start [m]


class HoldWindow(NamedTuple):
    """A hold of a stitched trajectory: s constant at ``sample`` from ``t_from`` to ``t_to``."""

    sample: int
    t_from: float
    t_to: float
    label: str


@dataclass(frozen=True)
class StitchedStats(LawStats):
    """Stats of a trajectory planned piece by piece between stops.

    Read as the stats of the piece that takes longest (``longest``): its fields are this
    object's attributes (``stats.gap_to_topp``) and its summary entries lead :meth:`as_dict`,
    followed by the stitching's own (pieces, stops, holds). Sample numbers and positions
    inside ``longest`` count from that piece's start (``longest_piece_samples[0]``).
    """

    stitched_pieces: int
    stitched_stops: int
    hold_total_s: float
    longest_piece_samples: tuple[int, int]
    #: the stats of the piece that takes longest (what this object reads as)
    longest: LawStats = outcome(None)
    #: every piece's time window and stats, in path order
    windows: tuple[PieceWindow, ...] = outcome(())
    piece_stats: tuple[LawStats, ...] = outcome(())
    #: wall time the law took on each piece [s]
    piece_planning_s: tuple[float, ...] = outcome(())
    holds: tuple[HoldWindow, ...] = outcome(())

    def as_dict(self) -> dict[str, Any]:
        """The longest piece's summary entries, then the stitching's."""
        own = {f.name: getattr(self, f.name) for f in fields(self)
               if f.metadata.get("summary", True)}
        own["longest_piece_samples"] = list(self.longest_piece_samples)
        base = self.longest.as_dict() if self.longest is not None else {}
        return {**base, **own}

    def __getattr__(self, name: str) -> Any:
        # only reached for names that are not fields: forward them to the longest piece
        longest = self.__dict__.get("longest")
        if name.startswith("_") or longest is None:
            raise AttributeError(name)
        return getattr(longest, name)


def needs_stitching(problem: ScheduleProblem) -> bool:
    """True when ``problem.stops`` has an interior stop or a hold (else laws plan it whole)."""
    stops = problem.stops
    if stops is None or len(stops) == 0:
        return False
    idx = np.asarray(stops.index)
    interior = (idx > 0) & (idx < problem.n - 1)
    return bool(np.any(interior) or np.any(np.asarray(stops.hold_s) > 0))


def _check_stops(problem: ScheduleProblem) -> tuple[np.ndarray, np.ndarray]:
    """The stop indices and holds, validated (ValueError: built wrong; InputError: a stop at
    a path end where the scenario asks to start or end moving)."""
    stops = problem.stops
    idx = np.asarray(stops.index)
    hold = np.asarray(stops.hold_s, dtype=float)
    k = idx.size
    if (idx.ndim != 1 or hold.shape != (k,) or len(stops.kind) != k or len(stops.label) != k
            or not np.issubdtype(idx.dtype, np.integer)):
        raise ValueError("StopSamples: index, hold_s, kind and label must be (k,) sequences "
                         "of one length, index integers")
    if k and (idx[0] < 0 or idx[-1] > problem.n - 1 or np.any(np.diff(idx) <= 0)):
        raise ValueError(f"StopSamples.index must be increasing in [0, {problem.n - 1}], got "
                         f"{idx.tolist()[:10]}")
    if not np.all(np.isfinite(hold) & (hold >= 0)):
        raise ValueError("StopSamples.hold_s must be finite and >= 0")
    for at, v, name in ((0, problem.v_start, "v_start"), (problem.n - 1, problem.v_end, "v_end")):
        hit = np.flatnonzero(idx == at)
        if hit.size and v != 0:
            raise InputError(
                f"{stops.label[hit[0]]}: the path {'starts' if at == 0 else 'ends'} with a stop "
                f"({stops.kind[hit[0]]}) but {name} = {v / MM:.6g} mm/s; set {name} to 0 or "
                "remove the stop")
    return idx.astype(np.int64), hold


def _piece_segments(problem: ScheduleProblem, s_a: float, s_b: float):
    """``(segment_start, segment_kind)`` of the path between ``s_a`` and ``s_b``, from 0."""
    seg = problem.segment_start
    if seg is None or len(problem.segment_kind) == 0:
        return None, ()
    first = max(int(np.searchsorted(seg, s_a + _SEGMENT_TOL_M, side="right")) - 1, 0)
    last = max(int(np.searchsorted(seg, s_b - _SEGMENT_TOL_M, side="left")) - 1, first)
    starts = seg[first:last + 1] - s_a
    starts[0] = 0.0
    return starts, problem.segment_kind[first:last + 1]


def piece_problem(problem: ScheduleProblem, i0: int, i1: int, v_start: float,
                  v_end: float) -> ScheduleProblem:
    """The stop-free sub-problem over samples ``i0..i1`` (inclusive), s from 0.

    Arrays are views of the problem's where they are used as they are. When ``i1`` is an
    interior stop, its row of ``dq_ds`` / ``d2q_ds2`` (the following segment's) is replaced by
    :func:`one_sided_end` of this piece's own samples, and ``v_max`` / ``programmed_feed``
    there by the smaller of the stop's and the sample before's (the feed there is 0; the
    bound of the last interval must not come from the other side). A piece of one sample
    interval gets samples inserted (:func:`_refined`).
    """
    sl = slice(i0, i1 + 1)
    s = problem.s[sl] - problem.s[i0]
    dq, d2q, v_max, prog = (problem.dq_ds[sl], problem.d2q_ds2[sl], problem.v_max[sl],
                            None if problem.programmed_feed is None else
                            problem.programmed_feed[sl])
    if i1 < problem.n - 1 and i1 > i0:
        dq, d2q, v_max = dq.copy(), d2q.copy(), v_max.copy()
        dq[-1] = one_sided_end(dq, s)
        d2q[-1] = one_sided_end(d2q, s)
        v_max[-1] = min(v_max[-1], v_max[-2])
        if prog is not None:
            prog = prog.copy()
            prog[-1] = min(prog[-1], prog[-2])
    starts, kinds = _piece_segments(problem, float(problem.s[i0]), float(problem.s[i1]))
    sub = replace(problem, s=s, v_max=v_max, q=problem.q[sl], dq_ds=dq, d2q_ds2=d2q,
                  v_start=v_start, v_end=v_end, segment_start=starts, segment_kind=kinds,
                  programmed_feed=prog, stops=None)
    return _refined(sub) if sub.n == 2 else sub


def _refined(sub: ScheduleProblem) -> ScheduleProblem:
    """A one-interval piece (two stops one sample apart) with :data:`_ONE_INTERVAL_INSERTS`
    samples inserted: the grid laws (topp, convex) cannot go from rest to rest over a single
    interval. The bound there is the smaller of the ends' (as topp takes it between samples),
    q is the cubic Hermite of the ends' q and dq/ds, dq/ds and d2q/ds2 linear."""
    u = np.linspace(0.0, 1.0, _ONE_INTERVAL_INSERTS + 2)
    h = float(sub.s[1])
    q0, q1 = sub.q[0], sub.q[1]
    m0, m1 = sub.dq_ds[0] * h, sub.dq_ds[1] * h
    uu = u[:, None]
    q = ((2 * uu**3 - 3 * uu**2 + 1) * q0 + (uu**3 - 2 * uu**2 + uu) * m0
         + (-2 * uu**3 + 3 * uu**2) * q1 + (uu**3 - uu**2) * m1)

    def lerp(a: np.ndarray) -> np.ndarray:
        return (1 - uu) * a[0] + uu * a[1]

    def low(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.concatenate([a[:1], np.full(u.size - 2, a.min()),
                                                      a[1:]])

    s = u * h
    s[-1] = h  # the piece's length to the bit
    return replace(sub, s=s, v_max=low(sub.v_max), q=q, dq_ds=lerp(sub.dq_ds),
                   d2q_ds2=lerp(sub.d2q_ds2), programmed_feed=low(sub.programmed_feed))


def _stitched_alike(context: dict[str, Trajectory], uses: tuple[str, ...],
                    ranges: list[tuple[int, int]]) -> dict[str, Trajectory]:
    """The context trajectories the law uses that were stitched over the same pieces (the
    others cannot be cut into pieces: the law plans without them)."""
    out = {}
    for name in uses:
        traj = context.get(name)
        stats = None if traj is None else traj.stats
        if isinstance(stats, StitchedStats) and [
                (w.first_sample, w.last_sample) for w in stats.windows] == ranges:
            out[name] = traj
    return out


def _piece_context(sources: dict[str, Trajectory], k: int) -> dict[str, Trajectory]:
    """Each of ``sources`` (:func:`_stitched_alike`) cut to piece ``k``'s window, in the
    piece's own time and arc length, with the piece's stats."""
    out: dict[str, Trajectory] = {}
    for name, traj in sources.items():
        stats = traj.stats
        w = stats.windows[k]
        pp = traj.timing
        b0, b1 = np.searchsorted(pp.x, [w.t_from, w.t_to])
        c = pp.c[:, b0:b1].copy()
        c[-1] -= w.s_from
        out[name] = Trajectory(law=traj.law, timing=PPoly(c, pp.x[b0:b1 + 1] - w.t_from),
                               continuity=traj.continuity, stats=stats.piece_stats[k])
    return out


def _piece_ranges(n: int, idx: np.ndarray) -> list[tuple[int, int]]:
    """Sample ranges ``(i0, i1)`` between consecutive interior stops and the path ends."""
    cuts = [0, *[int(i) for i in idx if 0 < i < n - 1], n - 1]
    return list(zip(cuts[:-1], cuts[1:], strict=True))


def _plan_pieces(name: str, problem: ScheduleProblem, context: dict[str, Trajectory],
                 options: Any, planner: Planner, uses_context: tuple[str, ...]):
    """Each piece's trajectory and planning time; a piece the law declines (or cannot plan)
    makes it decline (or fail) as a whole, naming the piece."""
    ranges = _piece_ranges(problem.n, np.asarray(problem.stops.index))
    sources = _stitched_alike(context, uses_context, ranges)
    trajs, seconds = [], []
    for k, (i0, i1) in enumerate(ranges):
        sub = piece_problem(problem, i0, i1, problem.v_start if i0 == 0 else 0.0,
                            problem.v_end if i1 == problem.n - 1 else 0.0)
        t0 = time.perf_counter()
        try:
            trajs.append(planner(name, sub, _piece_context(sources, k), options))
        except (LawNotApplicable, InputError) as exc:
            local = ("; positions below count from the piece start"
                     if _HAS_POSITION.search(str(exc)) else "")
            where = (f"{name} law, piece {k + 1} of {len(ranges)} between stops (samples "
                     f"{i0}-{i1}, s = {problem.s[i0] / MM:.3f}-{problem.s[i1] / MM:.3f} mm"
                     f"{local})")
            raise type(exc)(f"{where}: {exc}") from exc
        seconds.append(time.perf_counter() - t0)
    return ranges, trajs, seconds


def _stitch(blocks: list[tuple[np.ndarray, np.ndarray]]) -> tuple[PPoly, list[float]]:
    """One PPoly from ``(c, widths)`` blocks placed end to end in time (the blocks' constant
    terms already shifted in s); returns it and the start time of each block.

    Lower degrees are padded with leading zeros; intervals that round to zero width at their
    place in time are dropped (they add nothing)."""
    degree = max(c.shape[0] for c, _ in blocks)
    cs, xs, starts = [], [np.zeros(1)], []
    t = 0.0
    for c, x_local in blocks:
        starts.append(t)
        pad = np.zeros((degree - c.shape[0], c.shape[1]))
        cs.append(np.vstack([pad, c]))
        x = x_local[1:] - x_local[0] + t
        xs.append(x)
        t = float(x[-1])
    starts.append(t)
    x = np.concatenate(xs)
    c = np.hstack(cs)
    keep = np.diff(x) > 0
    if not np.all(keep):
        c, x = c[:, keep], np.concatenate([x[:1], x[1:][keep]])
    return PPoly(c, x), starts


def _hold_block(s_m: float, hold_s: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([[s_m]]), np.array([0.0, hold_s])


def _blocks(problem: ScheduleProblem, ranges, trajs, idx, hold):
    """Pieces and holds in path order, as ``(c, x)`` blocks; which block is which."""
    hold_at = {int(i): float(h) for i, h in zip(idx, hold, strict=True) if h > 0}
    blocks, what = [], []
    if 0 in hold_at:
        blocks.append(_hold_block(0.0, hold_at[0]))
        what.append(("hold", 0))
    for k, ((i0, i1), tr) in enumerate(zip(ranges, trajs, strict=True)):
        c = tr.timing.c.copy()
        c[-1] += problem.s[i0]
        blocks.append((c, tr.timing.x))
        what.append(("piece", k))
        if i1 in hold_at:
            blocks.append(_hold_block(float(problem.s[i1]), hold_at[i1]))
            what.append(("hold", i1))
    return blocks, what


def merge_notes(trajs: list[Trajectory], ranges: list[tuple[int, int]]) -> list[str]:
    """The pieces' notes, deduplicated.

    Notes are grouped by their text with the numbers masked, in order of first appearance; a
    note every piece has word for word is kept as it is, others are prefixed with how many
    pieces have it and the first one's sample range (its numbers are that piece's)."""
    groups: dict[str, list[tuple[int, str]]] = {}
    for k, tr in enumerate(trajs):
        for note in dict.fromkeys(tr.notes):
            groups.setdefault(re.sub(r"\d+(\.\d+)?([eE][-+]?\d+)?", "#", note), []).append(
                (k, note))
    out = []
    for members in groups.values():
        k, note = members[0]
        same = all(text == note for _, text in members)
        if same and len(members) == len(trajs):
            out.append(note)
            continue
        i0, i1 = ranges[k]
        local = " (positions from its start)" if _HAS_POSITION.search(note) else ""
        many = f"in {len(members)} of {len(trajs)} pieces, e.g. " if len(members) > 1 else ""
        out.append(f"{many}piece {k + 1} (samples {i0}-{i1}){local}: {note}")
    return out


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _stitch_note(problem: ScheduleProblem, idx: np.ndarray, hold: np.ndarray, pieces: int):
    labels = problem.stops.label
    interior = [k for k, i in enumerate(idx) if 0 < i < problem.n - 1]
    held = [k for k, h in enumerate(hold) if h > 0]

    def listed(ks: list[int]) -> str:
        shown = "; ".join(labels[k] for k in ks[:_LABELS_IN_NOTE])
        more = len(ks) - _LABELS_IN_NOTE
        return shown + (f"; and {more} more" if more > 0 else "")

    parts = []
    if interior:
        parts.append(f"planned in {pieces} pieces between {_count(len(interior), 'stop')} "
                     f"({listed(interior)}), each from and to rest")
    if held:  # the holds' places, unless they are the stops just listed
        where = "" if held == interior else f" ({listed(held)})"
        parts.append(f"held {float(hold.sum()):.6g} s in {_count(len(held), 'hold')}{where}")
    return "; ".join(parts)


def plan_through_stops(name: str, problem: ScheduleProblem,
                       context: dict[str, Trajectory] | None, options: Any, *,
                       planner: Planner, uses_context: tuple[str, ...] = ()) -> Trajectory:
    """Plan ``problem`` with the law ``name`` piece by piece between its stops.

    Parameters
    ----------
    name, options : the law and its options model (passed on to ``planner``).
    problem : ScheduleProblem
        With ``stops`` (see :func:`needs_stitching`).
    context : earlier laws' trajectories; those in ``uses_context`` that were themselves
        stitched over the same pieces are cut to each piece's window, others are not passed.
    planner : plans one stop-free problem (:func:`feedopt.schedule.laws.plan_law`'s own).

    Returns
    -------
    Trajectory
        s(t) of the pieces end to end (their polynomials shifted in time and s), a hold
        (s constant) of ``hold_s`` wherever a stop holds, also at the path's ends;
        ``continuity`` the smallest of the pieces'; notes merged (:func:`merge_notes`) plus
        one on the stitching; :class:`StitchedStats`.

    Raises
    ------
    LawNotApplicable, InputError
        When the law declines, or cannot plan, a piece: the message names the piece.
    """
    idx, hold = _check_stops(problem)
    ranges, trajs, seconds = _plan_pieces(name, problem, context or {}, options, planner,
                                          uses_context)
    blocks, what = _blocks(problem, ranges, trajs, idx, hold)
    timing, starts = _stitch(blocks)
    windows, holds = [], []
    labels = dict(zip((int(i) for i in idx), problem.stops.label, strict=True))
    for (kind, k), t0, t1 in zip(what, starts[:-1], starts[1:], strict=True):
        if kind == "piece":
            i0, i1 = ranges[k]
            windows.append(PieceWindow(i0, i1, t0, t1, float(problem.s[i0])))
        else:
            holds.append(HoldWindow(k, t0, t1, labels[k]))
    longest = int(np.argmax([w.t_to - w.t_from for w in windows]))
    stats = StitchedStats(
        stitched_pieces=len(trajs), stitched_stops=len(ranges) - 1,
        hold_total_s=float(hold.sum()), longest_piece_samples=ranges[longest],
        longest=trajs[longest].stats, windows=tuple(windows),
        piece_stats=tuple(tr.stats for tr in trajs), piece_planning_s=tuple(seconds),
        holds=tuple(holds))
    notes = [*merge_notes(trajs, ranges), _stitch_note(problem, idx, hold, len(trajs))]
    return Trajectory(law=name, timing=timing, continuity=min(tr.continuity for tr in trajs),
                      notes=tuple(notes), stats=stats)


def piece_trajectories(trajectory: Trajectory) -> list[Trajectory] | None:
    """The pieces of a stitched trajectory, holds left out, in its own time and arc length
    (views of its coefficients); None if it was not stitched (:class:`StitchedStats`)."""
    stats = trajectory.stats
    if not isinstance(stats, StitchedStats):
        return None
    pp = trajectory.timing
    out = []
    for w in stats.windows:
        b0, b1 = np.searchsorted(pp.x, [w.t_from, w.t_to])
        out.append(replace(trajectory, timing=PPoly(pp.c[:, b0:b1], pp.x[b0:b1 + 1])))
    return out


def stitched_ramps(trajectory: Trajectory, problem: ScheduleProblem,
                   follow_bound: bool = True) -> tuple[Ramp, Ramp, float] | None:
    """:func:`~feedopt.schedule.checks.find_ramps` of a stitched trajectory: the first
    piece's start ramp, the last piece's stop ramp (holds at the path's ends are not ramps)
    and the smallest cutting feed of any piece between its own ramps (the ramps into and out
    of every stop are ramps too); None if it was not stitched."""
    pieces = piece_trajectories(trajectory)
    if pieces is None:
        return None
    found = [find_ramps(p, problem, follow_bound) for p in pieces]
    return found[0][0], found[-1][1], float(min(f[2] for f in found))
