"""The ``thesis`` timing law: chapter 3 (constant feed per line, quintic blends) and
chapter 4 (key points every l along lines, quintic pieces with acceleration hand-off).

Chapter 3 (thesis 3.5): every line runs at one constant feed, the largest meeting the bound
on it (min of v_max over the line); each blend between two lines is one quintic s(t)
(Eq. 3.21) with the Eq. 3.22 conditions s, sdot = the adjacent line feeds, sddot = 0 at both
ends and ``t_f = blend length / min(sdot0, sdotf)``.

Chapter 4 (thesis 4.2-4.3), used on lines when ``problem.key_point_spacing > 0``: key points
every l (the line is split into round(length / l) equal intervals), the feed at a key point is
the minimum of v_max over its two neighbouring intervals (so the bound holds between key points),
and the pieces are quintics with ``t_f = l / min(v0, vf)``, ``sddot0[i] = sddotf[i-1]``,
``sddotf[i] = 2 abar - sddot0[i]``, ``abar = (vf - v0) / t_f``; the first piece starts with
sddot0 = 0 and, so that the line joins its neighbours C2, the last piece ends with sddotf = 0.

Because ``t_f`` comes from the smaller end feed, the average feed of a piece is that smaller
feed and the velocity dips below it in between (thesis 4.5; for a chapter-3 blend exactly
``min - 0.512 (max - min)`` at u = 0.6). Where that dip (or a hand-off overshoot) takes the feed
above v_max on a sample, the law lowers the feeds at both ends of the piece by the measured
ratio, as the thesis lowered feeds until the limit held; for a chapter-3 blend this is exact in
one step because scaling both end feeds scales the whole quintic's feed (closed form). It
iterates until no sample exceeds its bound and lists every lowering in ``notes``.

Start and end (and a junction of two constant-feed stretches without a blend between them) are
smoothstep ramps: Eq. 3.22 with zero end accelerations and ``h = (v0 + v1) T / 2``, with a
length that keeps them inside the acceleration and jerk limits for any feeds up to the
initial ones. The jerk the blends and key-point pieces reach is reported in ``stats`` (the thesis
does not limit it).

:func:`plan_thesis` runs these phases, each a function of the previous one's result: stretches
(:func:`_stretches`), initial feeds (:func:`_initial_feeds`), ramps (:func:`_place_ramps`),
the global node layout (:func:`_layout`), the quintic pieces with the hand-off
(:func:`_pieces`) and the feed lowering (:func:`_lower_feeds`); what they did is reported as
typed fields of :class:`ThesisStats` and as ``notes``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from feedopt.errors import InputError, LawNotApplicable
from feedopt.schedule.checks import check_boundary_feeds
from feedopt.schedule.polynomial import sample_piece_chunks
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.quintic import QuinticPieces, fit_length, quintic_ramp_duration
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM

_SMOOTH, _THESIS, _HANDOFF = 0, 1, 2
# Bisection steps of the largest feed whose ramp fits (exact to rounding).
_RAMP_FIT_STEPS = 80
# Pieces whose estimated max feed is below (1 - this) of their bound minimum skip the exact
# per-sample check (the estimate is far more accurate than that).
_FLAG_RTOL = 1e-3
# A lowering by less than this fraction is a rounding-level touch-up, not reported in notes.
_REPORTED_DROP = 1e-4
# Points per piece at which the acceleration and jerk extrema are taken for the stats.
_STATS_POINTS = 17


class ThesisOptions(BaseModel):
    """Tunables of the ``thesis`` law (thesis chapters 3-4)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    key_points: bool = Field(
        True, description="use the chapter-4 key points on lines when the scenario's key point "
        "spacing is > 0 (false: chapter-3 constant line feeds)")
    lower_feeds: bool = Field(
        True, description="lower the feeds where the quintic pieces would exceed v_max (false: "
        "the pure thesis construction, its violation stated in the notes)")
    max_iterations: int = Field(
        200, ge=0, description="cap on the feed-lowering passes (each re-plans all pieces)")
    ramp_room: float = Field(
        0.45, gt=0.0, lt=1.0, allow_inf_nan=False,
        description="largest share of the neighbouring node interval a start, stop or "
        "junction ramp may take (fraction)")
    lowering_margin: float = Field(
        1e-9, ge=0.0, lt=1e-3, allow_inf_nan=False,
        description="relative safety when a piece's feeds are lowered: they are lowered to "
        "(1 - margin) of the bound, so the next check stays below it")
    max_stretches: int = Field(
        2000, ge=1, description="the law holds one feed per stretch (line, blend, key-point "
        "interval) and re-plans all of them per lowering pass; a path with more stretches (a "
        "dense waypoint cloud) is declined, cheaply, before any planning")
    decline_reversal: bool = Field(
        True, description="decline the path (say why, let the other laws plan it) when a "
        "quintic piece would run backwards; false: return it, and verification fails it")
    handoff_reset_factor: float = Field(
        4.0, gt=0.0, allow_inf_nan=False,
        description="the section 4.3 hand-off is restarted with af = 0 where it would exceed "
        "this multiple of the larger mean acceleration of the two adjacent pieces")


class StretchFeed(NamedTuple):
    """Feeds of one constant-feed stretch (a line, or a blend not between two lines)."""

    s_from_mm: float
    s_to_mm: float
    kind: str
    min_feed_mm_s: float
    max_feed_mm_s: float


class RampFit(NamedTuple):
    """A stretch feed lowered so that its start, stop or junction ramp fits."""

    s_mm: float  # start of the stretch
    feed_from_mm_s: float
    feed_to_mm_s: float


class FeedLowering(NamedTuple):
    """Feeds of a stretch lowered so that the quintic feed stays under v_max."""

    stretch: int  # segment index
    kind: str
    s_from_mm: float
    s_to_mm: float
    key_points: bool  # the feeds are chapter-4 key-point feeds
    feeds: int  # how many feeds were lowered
    max_drop: float  # largest relative lowering (fraction)
    min_feed_mm_s: float  # lowest lowered feed


@dataclass(frozen=True)
class ThesisStats(LawStats):
    """What the ``thesis`` law reports (``as_dict()``: its summary.json entry)."""

    iterations: int
    max_feed_ratio: float
    max_accel_m_s2: float
    max_jerk_m_s3: float
    stretch_feeds_mm_s: tuple[StretchFeed, ...]
    n_pieces: int
    handoff_resets: int
    #: sample where the feed is highest relative to v_max
    worst_sample: int = outcome(0)
    #: segments that are not between two lines, run at constant feed like a line
    constant_feed_segments: tuple[int, ...] = outcome(())
    #: feeds lowered so that a ramp fits
    ramp_fits: tuple[RampFit, ...] = outcome(())
    #: feeds lowered so that the quintic feed stays under v_max (drops >= 1e-4)
    lowered: tuple[FeedLowering, ...] = outcome(())
    #: a quintic piece reverses (its end feeds differ too much for t_f = l / min(v0, vf))
    reverses: bool = outcome(False)
    #: the jerk / acceleration reached exceeds jerk_max / accel_max (not limited by the law)
    exceeds_jerk_max: bool = outcome(False)
    exceeds_accel_max: bool = outcome(False)

    @property
    def exceeds_bound(self) -> bool:
        """The feed exceeds v_max on a sample (only with ``lower_feeds=False`` or when the
        iteration cap is hit)."""
        return self.max_feed_ratio > 1.0 + 1e-9


@dataclass(frozen=True)
class _Stretch:
    a: float
    b: float
    kind: str  # segment kind
    flat: bool  # constant feed (line, or blend not between two lines)
    key: bool  # chapter-4 key points
    nodes: np.ndarray | None = None  # node positions [m]
    feeds: np.ndarray | None = None  # initial node feeds [m/s]


@dataclass(frozen=True)
class _Layout:
    """All pieces of the law in path order and how their end feeds are shared.

    Node ``i`` has the feed ``group_feed[node_group[i]]``; piece ``i`` runs from node ``i``
    to node ``i + 1`` with rule ``rule[i]`` (smoothstep ramp, Eq. 3.22 blend or section 4.3
    hand-off piece of chain ``chain[i]``).
    """

    node_s: np.ndarray
    node_group: np.ndarray
    group_feed: np.ndarray  # initial feeds
    group_fixed: np.ndarray  # boundary feeds, never lowered
    group_stretch: np.ndarray  # stretch of each group (-1: boundary)
    rule: np.ndarray
    chain: np.ndarray
    n_chain: int
    h: np.ndarray  # piece lengths [m]
    piece_of: np.ndarray  # piece of each sample
    bound_min: np.ndarray  # min of v_max over each piece


@dataclass(frozen=True)
class _Lowered:
    """Result of the feed lowering: the final feeds and pieces and their check."""

    feed: np.ndarray
    pieces: QuinticPieces
    handoff_resets: int
    vmin: np.ndarray  # estimated min feed per piece
    sample_ratio: np.ndarray  # sdot / v_max on the checked samples (0 elsewhere)
    iterations: int


def _interval_min(problem: ScheduleProblem, x: np.ndarray) -> np.ndarray:
    """min of v_max over the samples in each [x_k, x_k+1] and the interpolated end values."""
    s, v = problem.s, problem.v_max
    vx = np.interp(x, s, v)
    out = np.minimum(vx[:-1], vx[1:])
    i0 = np.searchsorted(s, x[:-1], side="left")
    i1 = np.searchsorted(s, x[1:], side="right")
    has = i1 > i0
    if np.any(has):
        # reduceat over [i0, i1): run on non-empty ranges only
        idx = np.stack([i0[has], i1[has]], axis=1).ravel()
        red = np.minimum.reduceat(np.append(v, np.inf), idx)[::2]
        out[has] = np.minimum(out[has], red)
    return out


def _ramp_length(v_hi: float, problem: ScheduleProblem) -> float:
    """Length of a smoothstep ramp that meets the limits for any end feeds in [0, v_hi]."""
    if v_hi <= 0:
        return 0.0
    T = float(quintic_ramp_duration(0.0, v_hi, problem.accel_max, problem.jerk_max))
    return v_hi * T


def _fit_ramp(v: float, room: float, problem: ScheduleProblem) -> float:
    """Largest feed <= v whose ramp length fits in ``room`` (bisection; length grows with v)."""
    if _ramp_length(v, problem) <= room:
        return v
    lo, hi = 0.0, v
    for _ in range(_RAMP_FIT_STEPS):
        mid = 0.5 * (lo + hi)
        if _ramp_length(mid, problem) <= room:
            lo = mid
        else:
            hi = mid
    return lo


def _check_inputs(problem: ScheduleProblem) -> None:
    """Refuse problems the law cannot plan (InputError)."""
    if problem.n < 2:
        raise InputError("thesis law: the path needs at least 2 samples")
    check_boundary_feeds("thesis", problem)
    if not (np.isfinite(problem.accel_max) or np.isfinite(problem.jerk_max)):
        raise InputError("thesis law: start/stop ramps need a finite accel_max or jerk_max")


def _stretches(problem: ScheduleProblem, key_points: bool) -> list[_Stretch]:
    """One stretch per segment: constant feed (``flat``) unless a blend between two lines;
    lines get chapter-4 key points when asked for and the spacing is positive."""
    segs = problem.segments()
    out = []
    for i, (a, b, kind) in enumerate(segs):
        between_lines = (
            kind != "line" and 0 < i < len(segs) - 1
            and segs[i - 1][2] == "line" and segs[i + 1][2] == "line"
        )
        key = kind == "line" and key_points and problem.key_point_spacing > 0
        out.append(_Stretch(a=a, b=b, kind=kind, flat=not between_lines, key=key))
    return out


def _initial_feeds(problem: ScheduleProblem, stretches: list[_Stretch]) -> list[_Stretch]:
    """Nodes and initial feeds of every constant-feed stretch: its two ends at the minimum
    of v_max over it (chapter 3), or key points every l at the minimum over their two
    neighbouring intervals (chapter 4, thesis 4.2)."""
    out = []
    for st in stretches:
        if not st.flat:
            out.append(st)
            continue
        if st.key:
            m = max(1, int(round((st.b - st.a) / problem.key_point_spacing)))
            x = np.linspace(st.a, st.b, m + 1)
            imin = _interval_min(problem, x)
            feeds = np.minimum(np.append(imin, np.inf), np.append(np.inf, imin))
        else:
            x = np.array([st.a, st.b])
            feeds = np.repeat(_interval_min(problem, x), 2)
        out.append(replace(st, nodes=x, feeds=feeds))
    return out


def _place_ramps(problem: ScheduleProblem, stretches: list[_Stretch], ramp_room: float
                 ) -> tuple[list[_Stretch], tuple[RampFit, ...]]:
    """Room for the start and stop ramps and the ramps between two constant-feed stretches.

    The first / last node of a stretch moves inwards by the ramp length (at most
    ``ramp_room`` of its neighbouring node interval, lowering the stretch feed if the ramp
    would not fit). Returns new stretches and the feeds lowered for a ramp.
    """
    work = [replace(st, nodes=st.nodes.copy(), feeds=st.feeds.copy()) if st.flat else st
            for st in stretches]
    fits: list[RampFit] = []

    def shift(st: _Stretch, first: bool, v_other: float) -> None:
        j, nb = (0, 1) if first else (-1, -2)
        room = ramp_room * abs(st.nodes[nb] - st.nodes[j])
        v = st.feeds[j]
        v_fit = _fit_ramp(max(v, v_other), room, problem)
        if v_fit < max(v, v_other):
            if v_fit < v_other:
                raise LawNotApplicable(
                    f"thesis law: no room for a ramp from {v_other / MM:.4g} mm/s on the "
                    f"segment at s = {st.a / MM:.3f}-{st.b / MM:.3f} mm (its quintic ramps "
                    "need segments long enough for one feed change each); convex and jerk "
                    "plan this path")
            fits.append(RampFit(st.a / MM, v / MM, v_fit / MM))
            st.feeds[j] = v_fit
            if not st.key:
                st.feeds[:] = v_fit
        h = _ramp_length(max(st.feeds[j], v_other), problem)
        st.nodes[j] += h if first else -h

    flats = [st for st in work if st.flat]
    shift(flats[0], True, problem.v_start)
    shift(flats[-1], False, problem.v_end)
    for left, right in zip(work[:-1], work[1:], strict=True):
        if left.flat and right.flat:
            if left.feeds[-1] >= right.feeds[0]:
                shift(left, False, right.feeds[0])
            else:
                shift(right, True, left.feeds[-1])
    return work, tuple(fits)


def _layout(problem: ScheduleProblem, stretches: list[_Stretch]) -> _Layout:
    """The global node list: boundary feeds, stretch feeds (one group per chapter-3 stretch,
    one per key point) and the rule of every piece between consecutive nodes."""
    node_s = [0.0]
    node_group = [0]
    group_feed = [problem.v_start]
    group_fixed = [True]
    rule = []
    chain = []  # chain id for hand-off pieces, -1 otherwise
    group_stretch = [-1]
    n_chain = 0
    for k, st in enumerate(stretches):
        if not st.flat:
            rule.append(_THESIS)  # connects the previous node to the next stretch's first
            chain.append(-1)
            continue
        if k == 0 or stretches[k - 1].flat:
            rule.append(_SMOOTH)  # start ramp or flat-flat junction ramp (else: the blend)
            chain.append(-1)
        if st.key:
            gids = list(range(len(group_feed), len(group_feed) + st.nodes.size))
            group_feed.extend(st.feeds.tolist())
            group_fixed.extend([False] * st.nodes.size)
            group_stretch.extend([k] * st.nodes.size)
            rule.extend([_HANDOFF] * (st.nodes.size - 1))
            chain.extend([n_chain] * (st.nodes.size - 1))
            n_chain += 1
        else:
            gids = [len(group_feed)] * 2
            group_feed.append(float(st.feeds[0]))
            group_fixed.append(False)
            group_stretch.append(k)
            rule.append(_SMOOTH)
            chain.append(-1)
        node_s.extend(st.nodes.tolist())
        node_group.extend(gids)
    rule.append(_SMOOTH)  # end ramp
    chain.append(-1)
    node_s.append(problem.length)
    node_group.append(len(group_feed))
    group_feed.append(problem.v_end)
    group_fixed.append(True)
    group_stretch.append(-1)

    node_s = np.asarray(node_s)
    h = np.diff(node_s)
    if np.any(h <= 0):
        raise InputError(
            "thesis law: segments too short for the ramps and key points "
            f"(a piece of length {h.min() / MM:.3g} mm)"
        )
    group_feed = np.asarray(group_feed, dtype=float)
    group_fixed = np.asarray(group_fixed)
    group_stretch = np.asarray(group_stretch)
    if np.any((group_feed <= 0) & ~group_fixed):
        g = int(np.flatnonzero((group_feed <= 0) & ~group_fixed)[0])
        raise InputError(f"thesis law: the feed bound is 0 on stretch {group_stretch[g]}")
    return _Layout(
        node_s=node_s, node_group=np.asarray(node_group), group_feed=group_feed,
        group_fixed=group_fixed, group_stretch=group_stretch, rule=np.asarray(rule),
        chain=np.asarray(chain), n_chain=n_chain, h=h,
        # samples -> pieces, and per-piece bound minimum
        piece_of=np.clip(np.searchsorted(node_s, problem.s, side="right") - 1, 0, h.size - 1),
        bound_min=_interval_min(problem, node_s),
    )


def _pieces(layout: _Layout, feed: np.ndarray, reset_factor: float
            ) -> tuple[QuinticPieces, int]:
    """The quintic pieces for the group feeds ``feed`` and the number of hand-off restarts.

    Ramps (smoothstep, ``T = 2 h / (v0 + vf)``) and blends / key-point pieces
    (``t_f = h / min(v0, vf)``, Eq. 3.22 and section 4.3). Thesis 4.3: ``af[i] = 2 abar_i -
    a0[i]``, ``a0[i] = af[i-1]``, ``a0 = 0`` at the chain start. The recursion alternates and
    is undamped: where it would exceed ``reset_factor`` times the mean accelerations of the
    adjacent pieces it is restarted with ``af = 0`` (still C2, since the next piece starts
    from the same value). One loop per key point, not per sample.
    """
    h, rule, chain = layout.h, layout.rule, layout.chain
    v = feed[layout.node_group]
    v0, vf = v[:-1], v[1:]
    T = np.where(rule == _SMOOTH, 2.0 * h / np.maximum(v0 + vf, 1e-300),
                 h / np.maximum(np.minimum(v0, vf), 1e-300))
    a0 = np.zeros_like(h)
    af = np.zeros_like(h)
    resets = 0
    for c in range(layout.n_chain):
        idx = np.flatnonzero(chain == c)
        abar = (vf[idx] - v0[idx]) / T[idx]
        af_c = np.zeros(idx.size)
        prev = 0.0
        for j in range(idx.size - 1):
            a = 2.0 * abar[j] - prev
            if abs(a) > reset_factor * max(abs(abar[j]), abs(abar[j + 1])):
                a = 0.0
                resets += 1
            af_c[j] = prev = a
        af[idx] = af_c
        a0[idx[1:]] = af_c[:-1]
    pieces = QuinticPieces(s0=layout.node_s[:-1], h=h, v0=v0, vf=vf, a0=a0, af=af, T=T)
    return pieces, resets


def _feed_ratios(problem: ScheduleProblem, layout: _Layout, pieces: QuinticPieces
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-piece max of sdot / v_max on the samples, per-piece min feed, per-sample ratio.

    Only the samples of pieces whose estimated max feed comes near their bound minimum are
    inverted exactly (the others cannot exceed it); their ratio is 0.
    """
    vmin, vmax = pieces.feed_range()
    flagged = vmax > layout.bound_min * (1.0 - _FLAG_RTOL)
    sel = np.flatnonzero(flagged[layout.piece_of])
    r = np.zeros(layout.h.size)
    sample_ratio = np.zeros(problem.n)
    if sel.size:
        f = pieces.feed_at(problem.s[sel], layout.piece_of[sel])
        sample_ratio[sel] = f / problem.v_max[sel]
        np.maximum.at(r, layout.piece_of[sel], sample_ratio[sel])
    return r, vmin, sample_ratio


def _lower_feeds(problem: ScheduleProblem, layout: _Layout, options: ThesisOptions) -> _Lowered:
    """Lower the feeds at both ends of every piece that exceeds v_max by its measured ratio
    (with the lowering margin) until none does, as the thesis lowered feeds until the limit
    held (at most ``max_iterations`` passes; none with ``lower_feeds=False``)."""
    keep = 1.0 - options.lowering_margin
    feed = layout.group_feed
    pieces, resets = _pieces(layout, feed, options.handoff_reset_factor)
    r, vmin, sample_ratio = _feed_ratios(problem, layout, pieces)
    iterations = 0
    while options.lower_feeds and r.max() > 1.0 and iterations < options.max_iterations:
        iterations += 1
        bad = np.flatnonzero(r > 1.0)
        factor = keep / r[bad]
        new = feed.copy()
        for end in (bad, bad + 1):
            g = layout.node_group[end]
            np.minimum.at(new, g, feed[g] * factor)
        new[layout.group_fixed] = feed[layout.group_fixed]
        if np.array_equal(new, feed):
            break  # only the fixed boundary feeds are involved
        feed = new
        pieces, resets = _pieces(layout, feed, options.handoff_reset_factor)
        r, vmin, sample_ratio = _feed_ratios(problem, layout, pieces)
    return _Lowered(feed=feed, pieces=pieces, handoff_resets=resets, vmin=vmin,
                    sample_ratio=sample_ratio, iterations=iterations)


def _lowerings(stretches: list[_Stretch], layout: _Layout, feed: np.ndarray
               ) -> tuple[FeedLowering, ...]:
    """The stretches whose feeds the lowering reduced by at least :data:`_REPORTED_DROP`."""
    initial = layout.group_feed
    lowered = np.flatnonzero(feed < initial * (1.0 - 1e-12))
    out = []
    for k in sorted({int(layout.group_stretch[g]) for g in lowered}):
        gs = lowered[layout.group_stretch[lowered] == k]
        st = stretches[k]
        drop = 1.0 - feed[gs] / initial[gs]
        if drop.max() < _REPORTED_DROP:
            continue  # a rounding-level touch-up of the bound, not a thesis-style lowering
        out.append(FeedLowering(k, st.kind, st.a / MM, st.b / MM, st.key, len(gs),
                                float(drop.max()), float(feed[gs].min() / MM)))
    return tuple(out)


def _notes(problem: ScheduleProblem, stretches: list[_Stretch], stats: ThesisStats,
           options: ThesisOptions, min_feed: float) -> list[str]:
    """What the law tells the user, from its typed outcomes (in this order: constant-feed
    blends, ramp fits, bound exceeded, reversal, lowerings, hand-off restarts, limits)."""
    notes = []
    for i in stats.constant_feed_segments:
        st = stretches[i]
        notes.append(
            f"segment {i} ({st.kind}, s = {st.a / MM:.3f}-{st.b / MM:.3f} mm) is not between "
            f"two lines: run at constant feed like a line"
        )
    for fit in stats.ramp_fits:
        notes.append(
            f"segment at s = {fit.s_mm:.3f} mm: feed lowered from {fit.feed_from_mm_s:.4g} to "
            f"{fit.feed_to_mm_s:.4g} mm/s so that its ramp fits"
        )
    if stats.exceeds_bound:
        worst = stats.worst_sample
        notes.append(
            f"feed exceeds v_max: {stats.max_feed_ratio:.6f} x the bound at s = "
            f"{problem.s[worst] / MM:.3f} mm (sample {worst})"
            + ("" if options.lower_feeds else " (feed lowering disabled: pure thesis construction)")
        )
    if stats.reverses:
        notes.append(
            f"a quintic piece reverses (min feed {min_feed / MM:.4g} mm/s): its end feeds "
            "differ too much for t_f = l / min(v0, vf)"
        )
    for low in stats.lowered:
        what = f"{low.feeds} key-point feeds" if low.key_points else "feed"
        notes.append(
            f"{low.kind} at s = {low.s_from_mm:.3f}-{low.s_to_mm:.3f} mm: {what} lowered by up "
            f"to {low.max_drop * 100:.2f} % (to {low.min_feed_mm_s:.4g} mm/s) so the "
            "quintic feed stays under v_max"
        )
    if stats.handoff_resets:
        notes.append(
            f"section 4.3 acceleration hand-off restarted (af = 0) at {stats.handoff_resets} "
            f"key points where its undamped alternation exceeded "
            f"{options.handoff_reset_factor:g} times the adjacent mean accelerations"
        )
    if stats.exceeds_jerk_max:
        notes.append(
            f"jerk reaches {stats.max_jerk_m_s3:.4g} m/s^3 > jerk_max "
            f"{problem.jerk_max:.4g} (the thesis law does not limit jerk)"
        )
    if stats.exceeds_accel_max:
        notes.append(
            f"tangential acceleration reaches {stats.max_accel_m_s2:.4g} m/s^2 > accel_max "
            f"{problem.accel_max:.4g}"
        )
    return notes


def plan_thesis(problem: ScheduleProblem, options: ThesisOptions | None = None) -> Trajectory:
    """Chapter-3/4 thesis timing law (see the module docstring).

    Parameters
    ----------
    problem : ScheduleProblem
        Path samples with their segments, feed bound, limits and key-point spacing.
    options : ThesisOptions, optional
        Key points, feed lowering and its margins (default: :class:`ThesisOptions`).

    Returns
    -------
    Trajectory
        ``law="thesis"``, quintic pieces (Eq. 3.21-3.22), ``continuity=2``,
        :class:`ThesisStats`.
    """
    options = ThesisOptions() if options is None else options
    _check_inputs(problem)
    raw = _stretches(problem, options.key_points)
    if len(raw) > options.max_stretches:
        raise LawNotApplicable(
            f"thesis law: the path has {len(raw)} stretches (lines, blends, key-point "
            f"intervals), more than the {options.max_stretches} it plans "
            "(schedule.law_options.thesis.max_stretches): it holds one feed per stretch, made "
            "for the thesis's key-point paths, not dense waypoint clouds; convex and jerk plan "
            "this path")
    stretches = _initial_feeds(problem, raw)
    stretches, ramp_fits = _place_ramps(problem, stretches, options.ramp_room)
    layout = _layout(problem, stretches)
    result = _lower_feeds(problem, layout, options)

    pp = fit_length(result.pieces.ppoly(), problem.length)
    d2, d3 = pp.derivative(2), pp.derivative(3)
    max_accel = max_jerk = 0.0
    for t_dense in sample_piece_chunks(pp.x, _STATS_POINTS):  # np.maximum keeps a NaN
        max_accel = float(np.maximum(max_accel, np.max(np.abs(d2(t_dense)))))
        max_jerk = float(np.maximum(max_jerk, np.max(np.abs(d3(t_dense)))))
    feed = result.feed
    worst = int(np.argmax(result.sample_ratio))
    stats = ThesisStats(
        iterations=result.iterations,
        max_feed_ratio=float(result.sample_ratio[worst]),
        max_accel_m_s2=max_accel,
        max_jerk_m_s3=max_jerk,
        stretch_feeds_mm_s=tuple(
            StretchFeed(st.a / MM, st.b / MM, st.kind,
                        float(feed[layout.group_stretch == k].min() / MM),
                        float(feed[layout.group_stretch == k].max() / MM))
            for k, st in enumerate(stretches) if st.flat
        ),
        n_pieces=int(layout.h.size),
        handoff_resets=int(result.handoff_resets),
        worst_sample=worst,
        constant_feed_segments=tuple(
            i for i, st in enumerate(stretches) if st.flat and st.kind != "line"),
        ramp_fits=ramp_fits,
        lowered=_lowerings(stretches, layout, feed),
        reverses=bool(np.any(result.vmin < -1e-12)),
        exceeds_jerk_max=bool(np.isfinite(problem.jerk_max)
                              and max_jerk > problem.jerk_max * (1 + 1e-6)),
        exceeds_accel_max=bool(np.isfinite(problem.accel_max)
                               and max_accel > problem.accel_max * (1 + 1e-6)),
    )
    if stats.reverses and options.decline_reversal:
        k = int(np.argmin(result.vmin))
        raise LawNotApplicable(
            f"thesis law: its quintic piece {k} would run backwards (feed down to "
            f"{float(result.vmin.min()) / MM:.4g} mm/s): the bound changes faster than one feed "
            "per stretch with quintic blends (Eq. 3.21-3.22) can follow; convex and jerk plan "
            "this path")
    notes = _notes(problem, stretches, stats, options, float(result.vmin.min()))
    return Trajectory(law="thesis", timing=pp, continuity=2, notes=tuple(notes), stats=stats)
