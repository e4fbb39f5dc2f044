"""The common output of every timing law: arc length as a piecewise polynomial of time.

A timing law is ``s(t)``; everything else (feed, tangential acceleration and jerk, pose and
joint values) follows from it and the path. Every law in :mod:`feedopt.schedule` returns a
:class:`Trajectory`, so the verifier, the RSI resampler and the report treat them alike.
Resampling at the RSI cycle evaluates the polynomial itself, so a C2 law stays C2.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PPoly

# Number of bisection steps when inverting s(t); 2^-60 of a piece's duration is far below
# floating-point resolution of t, so the inverse is exact to rounding.
_BISECTION_STEPS = 60


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
    stats : dict
        Law-specific numbers for the report (solver status, iterations, optimality gap, ...).
    """

    law: str
    timing: PPoly
    continuity: int = 2
    notes: tuple[str, ...] = ()
    stats: dict = field(default_factory=dict)

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
        t = np.clip(np.asarray(t, dtype=float), self.timing.x[0], self.timing.x[-1])
        pp = self.timing
        d1 = pp.derivative(1)
        d2 = pp.derivative(2)
        d3 = pp.derivative(3) if pp.c.shape[0] > 3 else None
        sdddot = d3(t) if d3 is not None else np.zeros_like(t)
        return Motion(t=t, s=pp(t), sdot=d1(t), sddot=d2(t), sdddot=sdddot)

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

        Finds the polynomial piece by ``searchsorted`` on the breakpoint values and then
        bisects within the piece, so the result is exact to rounding for any degree.
        """
        pp = self.timing
        s = np.asarray(s, dtype=float)
        s_break = pp(pp.x)
        s_break = np.maximum.accumulate(s_break)  # guard against -0 rounding noise
        s_clipped = np.clip(s, s_break[0], s_break[-1])
        piece = np.clip(np.searchsorted(s_break, s_clipped, side="left") - 1, 0, len(pp.x) - 2)
        lo = pp.x[piece].copy()
        hi = pp.x[piece + 1].copy()
        coeffs = pp.c[:, piece]  # (k+1, m), highest power first
        for _ in range(_BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            dt = mid - pp.x[piece]
            val = np.zeros_like(mid)
            for row in coeffs:  # Horner over the (small) polynomial degree, vectorised over s
                val = val * dt + row
            below = val < s_clipped
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        return hi

    def feed_at(self, s: np.ndarray) -> np.ndarray:
        """Commanded path velocity sdot [m/s] when the tool is at arc length ``s`` [m]."""
        return self.timing.derivative(1)(self.time_at(s))


def ppoly_from_pieces(t_breaks: np.ndarray, coefficients: np.ndarray) -> PPoly:
    """Build ``s(t)`` from per-piece polynomial coefficients.

    Parameters
    ----------
    t_breaks : (m+1,) array
        Increasing breakpoints [s].
    coefficients : (k+1, m) array
        Coefficients of each piece in the local variable ``t - t_breaks[i]``, highest power
        first (scipy's PPoly convention).
    """
    return PPoly(np.asarray(coefficients, dtype=float), np.asarray(t_breaks, dtype=float))
