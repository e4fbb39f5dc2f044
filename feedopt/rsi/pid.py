"""The thesis's discrete PID on the pose error (section 3.6.2, Eq. 3.26-3.27).

The thesis streamed Cartesian corrections from a real-time PC whose PID was fed by a laser
tracker: "proportional and integral gains of 0.05 and 0.3, respectively, for corrections in
the Cartesian directions, and a 0.02 integral gain for angular motion corrections ... the
derivative gains were set to zero" (section 3.6.2, and unchanged in chapter 4, section 4.4).
No proportional gain is given for the angles: it is 0 here. With the trapezoidal rule,

    U(z) / E(z) = Kp + Ki Ts/2 (z + 1)/(z - 1) + Kd/Ts (z - 1)/z              (Eq. 3.26)

implemented as

    u[k] = u[k-1] + a e[k] + b e[k-1] + c e[k-2]                              (Eq. 3.27)
    a = Kp + Ki Ts/2 + Kd/Ts,  b = -Kp + Ki Ts/2 - 2 Kd/Ts,  c = Kd/Ts

per channel (X, Y, Z [mm], A, B, C [deg]); Ts is the RSI cycle [s], Ki in 1/s. The velocity
form lets the output be clipped (``limit``) without integrator wind-up: the next step starts
from the clipped value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Thesis gains (section 3.6.2): Kp, Ki per channel X, Y, Z, A, B, C; Kd = 0.
THESIS_KP = (0.05, 0.05, 0.05, 0.0, 0.0, 0.0)
THESIS_KI = (0.3, 0.3, 0.3, 0.02, 0.02, 0.02)


@dataclass(frozen=True)
class PidGains:
    """Gains per channel X, Y, Z, A, B, C: ``kp`` [-], ``ki`` [1/s], ``kd`` [s], each (6,)."""

    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd"):
            arr = np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (6,)).copy()
            if not np.isfinite(arr).all():
                raise ValueError(f"PID gain {name} must be finite, got {arr}")
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    @classmethod
    def thesis(cls) -> PidGains:
        """Kp 0.05, Ki 0.3 1/s (Cartesian), Ki 0.02 1/s (angular), Kd 0 (section 3.6.2)."""
        return cls(kp=np.array(THESIS_KP), ki=np.array(THESIS_KI), kd=np.zeros(6))


@dataclass(frozen=True)
class PidCoefficients:
    """Eq. 3.27's a, b, c per channel (each (6,)) for one sampling period."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray


def pid_coefficients(gains: PidGains, ts: float) -> PidCoefficients:
    """Eq. 3.27: a = Kp + Ki Ts/2 + Kd/Ts, b = -Kp + Ki Ts/2 - 2 Kd/Ts, c = Kd/Ts."""
    if not ts > 0:
        raise ValueError(f"sampling period must be > 0, got {ts!r}")
    kp, ki, kd = gains.kp, gains.ki, gains.kd
    return PidCoefficients(a=kp + ki * ts / 2 + kd / ts,  # Eq. 3.27
                           b=-kp + ki * ts / 2 - 2 * kd / ts,  # Eq. 3.27
                           c=kd / ts)  # Eq. 3.27


@dataclass(frozen=True)
class PidState:
    """u[k-1], e[k-1], e[k-2] (each (6,)); :meth:`zero` before the first step."""

    u: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    @classmethod
    def zero(cls) -> PidState:
        return cls(np.zeros(6), np.zeros(6), np.zeros(6))


def pid_step(coeffs: PidCoefficients, state: PidState, error: np.ndarray,
             limit: np.ndarray | None = None) -> PidState:
    """One step of Eq. 3.27 for the error ``e[k]`` (6,); the new state's ``u`` is ``u[k]``,
    clipped to +-``limit`` (6,) when given."""
    e = np.asarray(error, dtype=float)
    u = state.u + coeffs.a * e + coeffs.b * state.e1 + coeffs.c * state.e2  # Eq. 3.27
    if limit is not None:
        u = np.clip(u, -limit, limit)
    return PidState(u=u, e1=e, e2=state.e1)
