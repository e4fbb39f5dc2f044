"""Orientation rate and acceleration limits of the tool on five-axis paths.

The tool vector u(s) (:mod:`feedopt.geometry.orientation`) turns at the angular rate
|du/dt| = |u'| sdot and with the angular acceleration |d2u/dt2| = |u'' sdot^2 + u' sddot|
(the primes by arc length). Every law keeps |sddot| <= a_max (verified), so
|d2u/dt2| <= |u''| sdot^2 + |u'| a_max, and the feed bound

    sdot <= rate_max / |u'|,     sdot <= sqrt((acc_max - |u'| a_max) / |u''|)

(with the largest |u'|, |u''| of each sample's neighbouring intervals) keeps both limits for
every law, between the samples too. Where |u'| a_max >= acc_max no feed can guarantee it:
the scenario is refused, naming both limits. The replay (:func:`dense_orientation_extrema`)
checks the trajectory itself, densely in time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.units import MM

#: points per sample interval (in time) of the replay, on top of the samples themselves
REPLAY_POINTS = 16


class OrientationLimit:
    """The feed bound of the orientation limits (module docstring); ``inf`` on three-axis
    paths and without limits."""

    name = "orientation"

    def v_max(self, inputs) -> np.ndarray:
        rate, curv = inputs.axis_rate, inputs.axis_curvature
        out = np.full(inputs.n, np.inf)
        if rate is None:
            return out
        with np.errstate(divide="ignore"):
            if np.isfinite(inputs.orientation_rate_max):
                out = np.minimum(out, inputs.orientation_rate_max / rate)
            acc = inputs.orientation_acceleration_max
            if np.isfinite(acc):
                room = acc - rate * inputs.accel_max
                _check_room(room, rate, inputs)
                out = np.minimum(out, np.sqrt(room / curv))
        return out


def _check_room(room: np.ndarray, rate: np.ndarray, inputs) -> None:
    """InputError where the tangential acceleration alone may exceed the orientation
    acceleration limit."""
    if np.all(room > 0):
        return
    k = int(np.argmin(room))
    raise InputError(
        f"limits.orientation_acceleration_deg_s2 = "
        f"{math.degrees(inputs.orientation_acceleration_max):g}: at sample {k} the tool turns "
        f"{math.degrees(rate[k]) * MM:.4g} deg/mm, so the tangential acceleration limit "
        f"(limits.tangential_acceleration_mm_s2 = {inputs.accel_max / MM:g}) alone may turn "
        f"it at {math.degrees(rate[k] * inputs.accel_max):.4g} deg/s^2: raise the orientation "
        "limit or lower the tangential acceleration")


@dataclass(frozen=True)
class OrientationExtrema:
    """The largest orientation rate [rad/s] and acceleration [rad/s^2] of a replay, their
    ratios to the limits (nan without limits) and where (arc length [m])."""

    rate: float
    acceleration: float
    rate_ratio: float
    acceleration_ratio: float
    rate_s: float
    acceleration_s: float


def dense_orientation_extrema(trajectory, problem, sample_times: np.ndarray
                              ) -> OrientationExtrema | None:
    """Replay |du/dt| and |d2u/dt2| of ``trajectory`` at the samples, ``REPLAY_POINTS``
    instants between each two and the instants it passes the windows' points, where the
    rates peak (None on a three-axis path)."""
    orientation = problem.orientation
    if orientation is None:
        return None
    t = np.asarray(sample_times, dtype=float)
    frac = np.arange(REPLAY_POINTS) / REPLAY_POINTS
    dense = np.append((t[:-1, None] + np.diff(t)[:, None] * frac).ravel(), t[-1])
    windows = orientation.window_points()
    windows = windows[(windows >= problem.s[0]) & (windows <= problem.s[-1])]
    if windows.size:
        dense = np.concatenate([dense, trajectory.time_at(windows)])
    m = trajectory.at(dense)
    s = np.clip(m.s, 0.0, problem.length)
    u = orientation.evaluate(s)
    rate = np.linalg.norm(u.d1, axis=1) * np.abs(m.sdot)
    acc = np.linalg.norm(u.d2 * (m.sdot**2)[:, None] + u.d1 * m.sddot[:, None], axis=1)
    i, j = int(np.argmax(rate)), int(np.argmax(acc))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = (rate[i] / problem.orientation_rate_max,
                  acc[j] / problem.orientation_acceleration_max)
    return OrientationExtrema(float(rate[i]), float(acc[j]),
                              *(float(r) if r > 0 else math.nan for r in ratios),
                              float(s[i]), float(s[j]))
