"""Quintic timing pieces (thesis Eq. 3.21-3.22) and the C2 ramps shared by the timing laws.

A piece moves the tool over ``h`` metres of path in ``T`` seconds with a 5th-order polynomial
``s(t)`` (Eq. 3.21) whose six coefficients follow from the boundary values of s, sdot and
sddot (Eq. 3.22, :func:`feedopt.schedule.polynomial.quintic_hermite`). :class:`QuinticPieces`
holds many consecutive pieces as arrays, turns them into the
:class:`~scipy.interpolate.PPoly` of a :class:`~feedopt.schedule.trajectory.Trajectory` and
evaluates the feed they command at given path positions (exact inverse of s(t)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PPoly

from feedopt.schedule.polynomial import (
    bisect_increasing,
    derivative_coefficients,
    horner,
    quintic_hermite,
)

# The s -> t inverse on the normalised piece (u in [0, 1]): bisection to 2^-14, then Newton
# steps kept inside the bracket (quadratic convergence: 2^-28, 2^-56), exact to rounding.
_BISECTION_STEPS = 14
_NEWTON_STEPS = 3
# Points per piece at which the velocity extrema are estimated before the exact check.
_DENSE = np.linspace(0.0, 1.0, 33)


def quintic_ramp_duration(
    v0: float | np.ndarray, v1: float | np.ndarray, accel_max: float, jerk_max: float
) -> np.ndarray:
    """Shortest duration of a quintic velocity change ``v0 -> v1`` with zero end accelerations.

    With ``h = (v0 + v1) T / 2`` the quintic of Eq. 3.22 reduces to the smoothstep velocity
    ``v0 + (v1 - v0)(3u^2 - 2u^3)``: peak |sddot| = 1.5 |dv| / T, peak |sdddot| = 6 |dv| / T^2
    (at the ends), so ``T = max(1.5 |dv| / A, sqrt(6 |dv| / J))``.
    """
    dv = np.abs(np.asarray(v1, dtype=float) - np.asarray(v0, dtype=float))
    t_acc = 1.5 * dv / accel_max if np.isfinite(accel_max) else np.zeros_like(dv)
    t_jerk = np.sqrt(6.0 * dv / jerk_max) if np.isfinite(jerk_max) else np.zeros_like(dv)
    return np.maximum(t_acc, t_jerk)


def scurve_times(dv: float, accel_max: float, jerk_max: float) -> tuple[float, float]:
    """Jerk-limited (third-order) velocity change of ``|dv|`` from and to zero acceleration.

    Returns ``(t_j, t_a)``: jerk phases of ``t_j`` at +-J around a constant-acceleration phase
    of ``t_a``; total duration ``2 t_j + t_a``. Needs finite limits.
    """
    dv = abs(float(dv))
    if dv * jerk_max <= accel_max**2:
        return float(np.sqrt(dv / jerk_max)), 0.0
    t_j = accel_max / jerk_max
    return t_j, dv / accel_max - t_j


def scurve_distance(v0: float, v1: float, accel_max: float, jerk_max: float) -> float:
    """Distance covered by the jerk-limited velocity change ``v0 -> v1`` (symmetric, so
    the average velocity is ``(v0 + v1) / 2``)."""
    t_j, t_a = scurve_times(v1 - v0, accel_max, jerk_max)
    return 0.5 * (v0 + v1) * (2.0 * t_j + t_a)


@dataclass(frozen=True)
class QuinticPieces:
    """Consecutive quintic pieces: piece ``i`` starts at arc length ``s0[i]`` [m], covers
    ``h[i]`` [m] in ``T[i]`` [s] with end feeds ``v0, vf`` [m/s] and end accelerations
    ``a0, af`` [m/s^2] (Eq. 3.22)."""

    s0: np.ndarray
    h: np.ndarray
    v0: np.ndarray
    vf: np.ndarray
    a0: np.ndarray
    af: np.ndarray
    T: np.ndarray

    def coefficients(self) -> np.ndarray:
        """``(6, m)`` PPoly coefficients (local time, highest power first)."""
        return quintic_hermite(self.T, self.h, self.v0, self.vf, self.a0, self.af, self.s0)

    def ppoly(self) -> PPoly:
        """s(t) of all pieces as one PPoly starting at t = 0."""
        t = np.concatenate([[0.0], np.cumsum(self.T)])
        return PPoly(self.coefficients(), t)

    def normalised(self) -> np.ndarray:
        """``(6, m)`` coefficients of P(u) with s = s0 + h P(u), t = T u (u in [0, 1])."""
        T, h = self.T, self.h
        return quintic_hermite(
            1.0, 1.0, self.v0 * T / h, self.vf * T / h, self.a0 * T**2 / h, self.af * T**2 / h
        )

    def feed_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Estimated (min, max) of sdot over each piece (33 points per piece + ends)."""
        vals = horner(derivative_coefficients(self.normalised()), _DENSE[:, None])
        vals *= self.h / self.T
        return vals.min(axis=0), vals.max(axis=0)

    def feed_at(self, s: np.ndarray, piece: np.ndarray) -> np.ndarray:
        """Feed sdot [m/s] at arc lengths ``s`` lying in pieces ``piece`` (exact inverse).

        Bisection on u of the normalised piece, then Newton steps kept inside the bracket;
        valid while the piece is monotone (sdot >= 0).
        """
        P = self.normalised()[:, piece]
        target = np.clip((s - self.s0[piece]) / self.h[piece], 0.0, 1.0)
        lo, hi = bisect_increasing(P, target, np.zeros_like(target), np.ones_like(target),
                                   _BISECTION_STEPS)
        u = 0.5 * (lo + hi)
        dP = derivative_coefficients(P)
        for _ in range(_NEWTON_STEPS):
            slope = horner(dP, u)
            step = (horner(P, u) - target) / np.where(slope > 0, slope, np.inf)
            u = np.clip(u - step, lo, hi)
        return horner(dP, u) * self.h[piece] / self.T[piece]


def ppoly_from_jerk_phases(
    durations: np.ndarray, jerks: np.ndarray, v0: float = 0.0, a0: float = 0.0, s0: float = 0.0
) -> PPoly:
    """Piecewise-cubic s(t) from constant-jerk phases, integrated from ``(s0, v0, a0)``.

    The state at each phase start is accumulated exactly in order (cumulative sums), so s,
    sdot and sddot are continuous by construction (C2); phases of zero duration are dropped.
    """
    durations = np.asarray(durations, dtype=float)
    jerks = np.asarray(jerks, dtype=float)
    keep = durations > 0.0
    if not np.any(keep):
        raise ValueError("ppoly_from_jerk_phases: all phase durations are zero")
    d, j = durations[keep], jerks[keep]
    da = j * d
    a = a0 + np.concatenate([[0.0], np.cumsum(da)])[:-1]
    dv = a * d + 0.5 * j * d**2
    v = v0 + np.concatenate([[0.0], np.cumsum(dv)])[:-1]
    ds = v * d + 0.5 * a * d**2 + j * d**3 / 6.0
    s = s0 + np.concatenate([[0.0], np.cumsum(ds)])[:-1]
    t = np.concatenate([[0.0], np.cumsum(d)])
    return PPoly(np.stack([j / 6.0, 0.5 * a, v, s]), t)


def fit_length(pp: PPoly, length: float) -> PPoly:
    """Scale s(t) (all coefficients, so continuity is kept) so that it ends at ``length``
    to rounding and never beyond it, absorbing the rounding of the piecewise construction."""
    end = float(pp(pp.x[-1]))
    if end <= 0:
        return pp
    c = pp.c * (length / end)
    out = PPoly(c, pp.x)
    for _ in range(8):  # step below ``length`` by a few ulps if rounding overshot
        end = float(out(out.x[-1]))
        if end <= length:
            break
        c = c * (1.0 - 2.0**-52)
        out = PPoly(c, pp.x)
    return out
