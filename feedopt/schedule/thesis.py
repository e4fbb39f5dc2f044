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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.quintic import QuinticPieces, fit_length, quintic_ramp_duration
from feedopt.schedule.trajectory import Trajectory

_SMOOTH, _THESIS, _HANDOFF = 0, 1, 2
# Largest share of the neighbouring interval a ramp may take.
_RAMP_ROOM = 0.45
# Safety factor applied when a piece's feeds are lowered (keeps the next check below 1).
_LOWER_MARGIN = 1.0 - 1e-9


@dataclass
class _Stretch:
    a: float
    b: float
    kind: str  # segment kind
    flat: bool  # constant feed (line, or blend not between two lines)
    key: bool  # chapter-4 key points
    nodes: np.ndarray | None = None  # node positions [m]
    feeds: np.ndarray | None = None  # initial node feeds [m/s]


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
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if _ramp_length(mid, problem) <= room:
            lo = mid
        else:
            hi = mid
    return lo


def _stretches(problem: ScheduleProblem, key_points: bool) -> tuple[list[_Stretch], list[str]]:
    segs = problem.segments()
    notes = []
    out = []
    for i, (a, b, kind) in enumerate(segs):
        between_lines = (
            kind != "line" and 0 < i < len(segs) - 1
            and segs[i - 1][2] == "line" and segs[i + 1][2] == "line"
        )
        flat = not between_lines
        if kind != "line" and flat:
            notes.append(
                f"segment {i} ({kind}, s = {a * 1e3:.3f}-{b * 1e3:.3f} mm) is not between two "
                f"lines: run at constant feed like a line"
            )
        key = kind == "line" and key_points and problem.key_point_spacing > 0
        out.append(_Stretch(a=a, b=b, kind=kind, flat=flat, key=key))
    return out, notes


def plan_thesis(
    problem: ScheduleProblem,
    *,
    key_points: bool = True,
    lower_feeds: bool = True,
    max_iterations: int = 200,
) -> Trajectory:
    """Chapter-3/4 thesis timing law (see the module docstring).

    Parameters
    ----------
    problem : ScheduleProblem
    key_points : bool
        Use the chapter-4 key points on lines when ``problem.key_point_spacing > 0``.
    lower_feeds : bool
        Lower the feeds where the quintic pieces would exceed v_max (default). With False the
        pure thesis construction is returned and its violation is stated in ``notes``.
    max_iterations : int
        Cap on the lowering passes (each pass re-plans all pieces).
    """
    if problem.n < 2:
        raise InputError("thesis law: the path needs at least 2 samples")
    if problem.v_start > problem.v_max[0] * (1 + 1e-12) or problem.v_end > problem.v_max[-1] * (
        1 + 1e-12
    ):
        raise InputError(
            f"thesis law: boundary feeds v_start={problem.v_start * 1e3:.4g}, "
            f"v_end={problem.v_end * 1e3:.4g} mm/s exceed the feed bound at the path ends "
            f"({problem.v_max[0] * 1e3:.4g}, {problem.v_max[-1] * 1e3:.4g} mm/s)"
        )
    if not (np.isfinite(problem.accel_max) or np.isfinite(problem.jerk_max)):
        raise InputError("thesis law: start/stop ramps need a finite accel_max or jerk_max")
    stretches, notes = _stretches(problem, key_points)
    l = problem.key_point_spacing

    # --- nodes and initial feeds of every constant-feed stretch --------------------------
    for st in stretches:
        if not st.flat:
            continue
        if st.key:
            m = max(1, int(round((st.b - st.a) / l)))
            x = np.linspace(st.a, st.b, m + 1)
            imin = _interval_min(problem, x)
            feeds = np.minimum(np.append(imin, np.inf), np.append(np.inf, imin))
        else:
            x = np.array([st.a, st.b])
            feeds = np.repeat(_interval_min(problem, x), 2)
        st.nodes, st.feeds = x, feeds

    # --- ramps at the ends and between constant-feed stretches ---------------------------
    flats = [st for st in stretches if st.flat]

    def shift(st: _Stretch, first: bool, v_other: float) -> None:
        """Move the first/last node of ``st`` inwards by a ramp length, lowering if needed."""
        j, nb = (0, 1) if first else (-1, -2)
        room = _RAMP_ROOM * abs(st.nodes[nb] - st.nodes[j])
        v = st.feeds[j]
        v_fit = _fit_ramp(max(v, v_other), room, problem)
        if v_fit < max(v, v_other):
            if v_fit < v_other:
                raise InputError(
                    f"thesis law: no room for a ramp from {v_other * 1e3:.4g} mm/s on the "
                    f"segment at s = {st.a * 1e3:.3f}-{st.b * 1e3:.3f} mm"
                )
            notes.append(
                f"segment at s = {st.a * 1e3:.3f} mm: feed lowered from {v * 1e3:.4g} to "
                f"{v_fit * 1e3:.4g} mm/s so that its ramp fits"
            )
            st.feeds[j] = v_fit
            if not st.key:
                st.feeds[:] = v_fit
        h = _ramp_length(max(st.feeds[j], v_other), problem)
        st.nodes[j] += h if first else -h

    shift(flats[0], True, problem.v_start)
    shift(flats[-1], False, problem.v_end)
    for left, right in zip(stretches[:-1], stretches[1:], strict=True):
        if left.flat and right.flat:
            if left.feeds[-1] >= right.feeds[0]:
                shift(left, False, right.feeds[0])
            else:
                shift(right, True, left.feeds[-1])

    # --- global node list, groups and piece rules ----------------------------------------
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
    node_group = np.asarray(node_group)
    group_feed = np.asarray(group_feed, dtype=float)
    group_initial = group_feed.copy()
    group_fixed = np.asarray(group_fixed)
    rule = np.asarray(rule)
    chain = np.asarray(chain)
    h = np.diff(node_s)
    if np.any(h <= 0):
        raise InputError(
            "thesis law: segments too short for the ramps and key points "
            f"(a piece of length {h.min() * 1e3:.3g} mm)"
        )

    # samples -> pieces, and per-piece bound minimum
    piece_of = np.clip(np.searchsorted(node_s, problem.s, side="right") - 1, 0, h.size - 1)
    bound_min = _interval_min(problem, node_s)

    handoff_resets = [0]

    def build(feed: np.ndarray) -> QuinticPieces:
        v = feed[node_group]
        v0, vf = v[:-1], v[1:]
        T = np.where(rule == _SMOOTH, 2.0 * h / np.maximum(v0 + vf, 1e-300),
                     h / np.maximum(np.minimum(v0, vf), 1e-300))
        a0 = np.zeros_like(h)
        af = np.zeros_like(h)
        resets = 0
        for c in range(n_chain):
            idx = np.flatnonzero(chain == c)
            abar = (vf[idx] - v0[idx]) / T[idx]
            # Thesis 4.3: af[i] = 2 abar_i - a0[i], a0[i] = af[i-1], a0 = 0 at the chain
            # start. The recursion alternates and is undamped: where it would exceed four times
            # the mean accelerations of the adjacent pieces it is restarted with af = 0
            # (still C2, since the next piece starts from the same value). One loop per key
            # point, not per sample.
            af_c = np.zeros(idx.size)
            prev = 0.0
            for j in range(idx.size - 1):
                a = 2.0 * abar[j] - prev
                if abs(a) > 4.0 * max(abs(abar[j]), abs(abar[j + 1])):
                    a = 0.0
                    resets += 1
                af_c[j] = prev = a
            af[idx] = af_c
            a0[idx[1:]] = af_c[:-1]
        handoff_resets[0] = resets
        return QuinticPieces(s0=node_s[:-1], h=h, v0=v0, vf=vf, a0=a0, af=af, T=T)

    def ratios(pieces: QuinticPieces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-piece max of sdot / v_max on the samples, and per-piece min feed."""
        vmin, vmax = pieces.feed_range()
        flagged = vmax > bound_min * (1.0 - 1e-3)
        sel = np.flatnonzero(flagged[piece_of])
        r = np.zeros(h.size)
        sample_ratio = np.zeros(problem.n)
        if sel.size:
            f = pieces.feed_at(problem.s[sel], piece_of[sel])
            sample_ratio[sel] = f / problem.v_max[sel]
            np.maximum.at(r, piece_of[sel], sample_ratio[sel])
        return r, vmin, sample_ratio

    if np.any((group_feed <= 0) & ~group_fixed):
        g = int(np.flatnonzero((group_feed <= 0) & ~group_fixed)[0])
        raise InputError(f"thesis law: the feed bound is 0 on stretch {group_stretch[g]}")

    iterations = 0
    pieces = build(group_feed)
    r, vmin, sample_ratio = ratios(pieces)
    while lower_feeds and r.max() > 1.0 and iterations < max_iterations:
        iterations += 1
        bad = np.flatnonzero(r > 1.0)
        factor = _LOWER_MARGIN / r[bad]
        new = group_feed.copy()
        for end in (bad, bad + 1):
            g = node_group[end]
            np.minimum.at(new, g, group_feed[g] * factor)
        new[group_fixed] = group_feed[group_fixed]
        if np.array_equal(new, group_feed):
            break  # only the fixed boundary feeds are involved
        group_feed = new
        pieces = build(group_feed)
        r, vmin, sample_ratio = ratios(pieces)

    worst = int(np.argmax(sample_ratio))
    if sample_ratio[worst] > 1.0 + 1e-9:
        notes.append(
            f"feed exceeds v_max: {sample_ratio[worst]:.6f} x the bound at s = "
            f"{problem.s[worst] * 1e3:.3f} mm (sample {worst})"
            + ("" if lower_feeds else " (feed lowering disabled: pure thesis construction)")
        )
    if np.any(vmin < -1e-12):
        notes.append(
            f"a quintic piece reverses (min feed {vmin.min() * 1e3:.4g} mm/s): its end feeds "
            "differ too much for t_f = l / min(v0, vf)"
        )
    lowered = np.flatnonzero(group_feed < group_initial * (1.0 - 1e-12))
    for k in sorted({int(group_stretch[g]) for g in lowered}):
        gs = lowered[np.asarray(group_stretch)[lowered] == k]
        st = stretches[k]
        drop = 1.0 - group_feed[gs] / group_initial[gs]
        if drop.max() < 1e-4:
            continue  # a rounding-level touch-up of the bound, not a thesis-style lowering
        what = f"{len(gs)} key-point feeds" if st.key else "feed"
        notes.append(
            f"{st.kind} at s = {st.a * 1e3:.3f}-{st.b * 1e3:.3f} mm: {what} lowered by up to "
            f"{drop.max() * 100:.2f} % (to {group_feed[gs].min() * 1e3:.4g} mm/s) so the "
            "quintic feed stays under v_max"
        )

    pp = fit_length(pieces.ppoly(), problem.length)
    d = pp.derivative
    t_dense = (pp.x[:-1, None] + np.diff(pp.x)[:, None] * np.linspace(0, 1, 17)).ravel()
    stats = {
        "iterations": iterations,
        "max_feed_ratio": float(sample_ratio[worst]),
        "max_accel_m_s2": float(np.max(np.abs(d(2)(t_dense)))),
        "max_jerk_m_s3": float(np.max(np.abs(d(3)(t_dense)))),
        "stretch_feeds_mm_s": [
            (st.a * 1e3, st.b * 1e3, st.kind,
             float(group_feed[np.asarray(group_stretch) == k].min() * 1e3),
             float(group_feed[np.asarray(group_stretch) == k].max() * 1e3))
            for k, st in enumerate(stretches) if st.flat
        ],
        "n_pieces": int(h.size),
        "handoff_resets": int(handoff_resets[0]),
    }
    if handoff_resets[0]:
        notes.append(
            f"section 4.3 acceleration hand-off restarted (af = 0) at {handoff_resets[0]} key "
            "points where its undamped alternation exceeded four times the adjacent mean "
            "accelerations"
        )
    if np.isfinite(problem.jerk_max) and stats["max_jerk_m_s3"] > problem.jerk_max * (1 + 1e-6):
        notes.append(
            f"jerk reaches {stats['max_jerk_m_s3']:.4g} m/s^3 > jerk_max "
            f"{problem.jerk_max:.4g} (the thesis law does not limit jerk)"
        )
    if np.isfinite(problem.accel_max) and stats["max_accel_m_s2"] > problem.accel_max * (1 + 1e-6):
        notes.append(
            f"tangential acceleration reaches {stats['max_accel_m_s2']:.4g} m/s^2 > accel_max "
            f"{problem.accel_max:.4g}"
        )
    return Trajectory(law="thesis", timing=pp, continuity=2, notes=tuple(notes), stats=stats)
