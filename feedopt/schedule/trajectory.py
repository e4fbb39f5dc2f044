"""The common output of every timing law: arc length as a piecewise polynomial of time.

A timing law is ``s(t)``; everything else (feed, tangential acceleration and jerk, pose and
joint values) follows from it and the path. Every law in :mod:`feedopt.schedule` returns a
:class:`Trajectory`, so the verifier, the RSI resampler and the report treat them alike.
Resampling at the RSI cycle evaluates the polynomial itself, so a C2 law stays C2. What a law
reports about itself is a typed :class:`LawStats` (each law's ``<Law>Stats``), whose
:meth:`LawStats.as_dict` is its summary.json entry.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from scipy.interpolate import PPoly

from feedopt.schedule.polynomial import derivative_coefficients, horner

# Inverting s(t) (Trajectory.time_at): Newton steps from the secant guess on every target
# (enough on pieces that move: the last one is then below an ulp), at most _MAX_STEPS
# safeguarded Newton / bisection steps on the few others (bisection alone needs ~60 for a
# double's resolution; it takes over on dwells), then at most _ULP_MOVES one-ulp moves down
# to the earliest float reaching the target.
_NEWTON_STEPS = 3
_MAX_STEPS = 80
_ULP_MOVES = 4


def outcome(default: Any = None, **kwargs) -> Any:
    """A :class:`LawStats` field that is typed data for code, not a summary.json entry."""
    if "default_factory" in kwargs:
        return field(metadata={"summary": False}, **kwargs)
    return field(default=default, metadata={"summary": False}, **kwargs)


def _plain(value: Any) -> Any:
    """A summary value as it was before stats were typed (records -> dicts / tuples)."""
    if isinstance(value, enum.Enum):
        return value.value
    if hasattr(value, "as_dict"):
        return value.as_dict()
    if isinstance(value, tuple) and hasattr(value, "_fields"):  # a NamedTuple row
        return tuple(_plain(v) for v in value)
    if isinstance(value, tuple) and value and all(
        hasattr(v, "as_dict") or hasattr(v, "_fields") for v in value
    ):
        return [_plain(v) for v in value]  # a table of records: a list, as before
    return value


@dataclass(frozen=True)
class LawStats(Mapping):
    """Typed numbers a law reports about itself; the base of every law's ``<Law>Stats``.

    Fields are read as attributes (``traj.stats.gap_to_topp``). :meth:`as_dict` is what
    summary.json gets (``law_summary``): every field in declaration order, except fields
    declared with :func:`outcome` (typed outcomes for code: what was lowered, violated, ...)
    and optional fields that are ``None`` (e.g. no topp run to compare with). The mapping
    interface (``stats["key"]``, ``.items()``) reads the same dictionary.
    """

    def as_dict(self) -> dict[str, Any]:
        """The summary entries: ``{name: value}`` as summary.json writes them."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.metadata.get("summary", True) and value is not None:
                out[f.name] = _plain(value)
        return out

    def __getitem__(self, key: str) -> Any:
        return self.as_dict()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.as_dict())

    def __len__(self) -> int:
        return len(self.as_dict())


@dataclass(frozen=True)
class Motion:
    """Samples of a timing law: time [s], arc length [m] and its first three derivatives."""

    t: np.ndarray
    s: np.ndarray
    sdot: np.ndarray
    sddot: np.ndarray
    sdddot: np.ndarray


@dataclass(frozen=True)
class Trajectory:
    """A timing law ``s(t)`` on ``[0, duration]``.

    Attributes
    ----------
    law : str
        Name of the law that produced it (``constant``, ``thesis``, ``topp``, ...).
    timing : scipy.interpolate.PPoly
        ``s(t)`` in metres, breakpoints in seconds, degree <= 5. Must be non-decreasing.
    continuity : int
        Order of parametric continuity the law guarantees for ``s(t)``: 2 means s, sdot and
        sddot are continuous (C2); 1 means the acceleration may jump (toppra's output).
    notes : tuple of str
        Honest remarks from the law (a bound it could not meet, an approximation it made).
    stats : LawStats
        Law-specific typed numbers and outcomes (solver status, iterations, optimality gap,
        lowered feeds, ...); ``stats.as_dict()`` is the summary.json entry.
    """

    law: str
    timing: PPoly
    continuity: int = 2
    notes: tuple[str, ...] = ()
    stats: LawStats = field(default_factory=LawStats)

    @property
    def duration(self) -> float:
        """Cycle time [s]."""
        return float(self.timing.x[-1] - self.timing.x[0])

    @property
    def length(self) -> float:
        """Arc length covered [m]."""
        return float(self.timing(self.timing.x[-1]) - self.timing(self.timing.x[0]))

    def at(self, t: np.ndarray) -> Motion:
        """Evaluate s and its first three time derivatives at times ``t`` [s]."""
        return next(self.at_each([t]))

    def at_each(self, times: Iterable[np.ndarray]) -> Iterator[Motion]:
        """:meth:`at` of each array of times in turn, the derivative polynomials formed once
        (a long job evaluated chunk by chunk)."""
        pp = self.timing
        d1 = pp.derivative(1)
        d2 = pp.derivative(2)
        d3 = pp.derivative(3) if pp.c.shape[0] > 3 else None
        for t in times:
            t = np.clip(np.asarray(t, dtype=float), pp.x[0], pp.x[-1])
            sdddot = d3(t) if d3 is not None else np.zeros_like(t)
            yield Motion(t=t, s=pp(t), sdot=d1(t), sddot=d2(t), sdddot=sdddot)

    def sample_uniform(self, dt: float) -> Motion:
        """Evaluate at the uniform times ``k dt`` (the RSI cycle) up to the first one at or
        after the end; a last partial cycle holds the final state, so the grid stays uniform.
        """
        n = int(np.ceil(self.duration / dt - 1e-9)) + 1
        t = self.timing.x[0] + dt * np.arange(n)
        m = self.at(t)
        return Motion(t=t, s=m.s, sdot=m.sdot, sddot=m.sddot, sdddot=m.sdddot)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Earliest time at which the arc length ``s`` [m] is reached (vectorised inverse).

        Finds the polynomial piece by ``searchsorted`` on the breakpoint values, then the
        earliest time in it by :func:`earliest_crossing` (safeguarded Newton), so the result
        is exact to rounding for any degree.
        """
        pp = self.timing
        s = np.asarray(s, dtype=float)
        s_break = pp(pp.x)
        s_break = np.maximum.accumulate(s_break)  # guard against -0 rounding noise
        s_clipped = np.clip(s, s_break[0], s_break[-1])
        piece = np.clip(np.searchsorted(s_break, s_clipped, side="left") - 1, 0, len(pp.x) - 2)
        return earliest_crossing(pp.c[:, piece], s_clipped, pp.x[piece], pp.x[piece + 1])

    def feed_at(self, s: np.ndarray) -> np.ndarray:
        """Commanded path velocity sdot [m/s] when the tool is at arc length ``s`` [m]."""
        return self.timing.derivative(1)(self.time_at(s))



def earliest_crossing(
    c: np.ndarray, target: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Earliest ``t`` in ``[lo, hi]`` with ``p(t) >= target`` for non-decreasing polynomials.

    Parameters
    ----------
    c : (k+1, n) array
        One polynomial per target, highest power first, in the local variable ``t - lo``
        (a PPoly piece starting at ``lo``).
    target : (n,) array
        Values to reach, with ``p(lo) <= target <= p(hi)`` (clipped into it otherwise).
    lo, hi : (n,) arrays
        The pieces' ends.

    Returns
    -------
    (n,) array
        ``lo`` where ``p(lo) >= target``; elsewhere Newton's method from the secant guess
        (:data:`_NEWTON_STEPS` steps on every target; targets whose last step is still above
        2 ulp continue with Newton kept inside the bracket ``p(lo) < target <= p(hi)``,
        bisecting when a step would leave it, which also finds the start of a dwell), then
        moved ulp by ulp to the earliest float with ``p(t) >= target``. Exact to rounding,
        like a 60-step bisection, in about a tenth of its polynomial evaluations.
    """
    c = np.asarray(c, dtype=float)
    target = np.asarray(target, dtype=float)
    x0 = np.array(lo, dtype=float)
    out = x0.copy()
    todo = np.flatnonzero(c[-1] < target)  # else: reached at the start of the piece
    if not todo.size:
        return out
    c, x0, target = c[:, todo], x0[todo], target[todo]
    dc = derivative_coefficients(c)
    width = np.asarray(hi, dtype=float)[todo] - x0
    rise = horner(c, width) - c[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = width * np.clip((target - c[-1]) / rise, 0.0, 1.0)
        tau = np.where(np.isfinite(tau), tau, 0.5 * width)
        for _ in range(_NEWTON_STEPS):
            step = (horner(c, tau) - target) / horner(dc, tau)
            tau = np.clip(tau - np.where(np.isfinite(step), step, 0.0), 0.0, width)
    t = x0 + tau
    slow = np.flatnonzero(~(np.abs(step) <= 2 * np.spacing(np.abs(t))))
    if slow.size:
        t[slow] = _bracketed_newton(c[:, slow], dc[:, slow], target[slow], x0[slow],
                                    width[slow], t[slow])
    out[todo] = _earliest_float(c, x0, target, t, x0 + width)
    return out


def _bracketed_newton(c, dc, target, x0, width, t) -> np.ndarray:
    """Newton from ``t`` kept inside ``p(lo) < target <= p(hi)`` (bisecting when a step would
    leave it) until a step or the bracket is below 2 ulp; absolute times, local polynomials."""
    lo, hi = x0.copy(), x0 + width
    result = hi.copy()
    active = np.arange(t.size)
    for _ in range(_MAX_STEPS):
        ci, dci, x0i = c[:, active], dc[:, active], x0[active]
        ti, tg = t[active], target[active]
        f = horner(ci, ti - x0i) - tg
        below = f < 0
        lo[active] = np.where(below, ti, lo[active])
        hi[active] = np.where(below, hi[active], ti)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_new = ti - f / horner(dci, ti - x0i)
        li, hi_a = lo[active], hi[active]
        collapsed = hi_a - li <= 2 * np.spacing(np.abs(hi_a))
        done = (np.abs(t_new - ti) <= 2 * np.spacing(np.abs(ti))) | collapsed
        # converged: the Newton iterate (moved onto the target below), or the bracket's end
        result[active[done]] = np.where(collapsed[done], hi_a[done], ti[done])
        inside = (t_new > li) & (t_new < hi_a)
        t[active] = np.where(inside, t_new, 0.5 * (li + hi_a))
        active = active[~done]
        if not active.size:
            break
    result[active] = hi[active]
    return result


def _earliest_float(c, x0, target, t, reaching) -> np.ndarray:
    """Move ``t`` up until ``p(t) >= target`` (steps of 1, 2, 4, ... ulp, never past
    ``reaching``, a time known to reach it), then down while the float below still reaches it
    (at most ``_ULP_MOVES`` ulps; never below the piece start ``x0``)."""
    t = t.copy()
    idx = np.flatnonzero(horner(c, t - x0) < target)
    step = np.spacing(np.abs(t[idx]))
    for _ in range(64):
        if not idx.size:
            break
        t[idx] = np.minimum(t[idx] + step, reaching[idx])
        short = horner(c[:, idx], t[idx] - x0[idx]) < target[idx]
        idx, step = idx[short], 2 * step[short]
    idx = np.arange(t.size)
    for _ in range(_ULP_MOVES):
        down = np.maximum(np.nextafter(t[idx], -np.inf), x0[idx])
        earlier = (down < t[idx]) & (horner(c[:, idx], down - x0[idx]) >= target[idx])
        idx = idx[earlier]
        if not idx.size:
            break
        t[idx] = down[earlier]
    return t
