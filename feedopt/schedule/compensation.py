"""Deflection compensation: offset the commanded path by the mean deflection you predict.

The static deflection over one cutter revolution is ``d(phi) = c a(phi) + b(phi)``. Its mean
over the revolution, ``mean d = c a_mean + b_mean`` (closed-form average forces, Altintas [39],
thesis Eq. 3.24-3.25: :meth:`DeflectionModel.mean_terms`), is steady at a 4 ms controller
cycle; the rest oscillates at the tooth passing frequency (83 Hz at 2500 rpm with 2 teeth),
which no path offset can follow. Commanding ``nominal - mean d`` therefore leaves the
residual ``d(phi) - mean d`` and the model error (Schnoes and Zach compensate the path this
way, with the feed kept; here the feed is planned for the residual as well).

* ``deflection.mode: residual`` bounds ``max_phi |d(phi) - mean d| <= L``: still affine in c,
  so the closed form of :mod:`feedopt.schedule.bounds` applies unchanged
  (:class:`feedopt.schedule.deflection.DeflectionModel` subtracts the mean).
* ``deflection.compensation_cap_mm`` bounds the offset itself, ``|c a_mean + b_mean| <= cap``
  (:class:`CompensationCapConstraint`, one more affine-in-c condition).
* The offset is a fixed point: it depends on the feed, the feed on the residual bound, and
  that on the compliance at the *commanded* pose, which the offset moves.
  :func:`compensation_fixed_point` iterates ``commanded = nominal - mean d(commanded)`` until
  the offset changes by less than a tolerance, and says how many iterations it took.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.units import MM

#: Offsets change by less than this between iterations when the fixed point is reached [m].
FIXED_POINT_TOLERANCE = 1e-10
#: Iterations before the fixed point is declared not converged.
MAX_ITERATIONS = 8


@dataclass(frozen=True)
class CompensationCapConstraint:
    """``|mean d| = |c a_mean + b_mean| <= cap`` in residual mode (the compensated offset may
    not exceed what the cell allows); no bound in the other modes or without a cap."""

    name: str = "compensation_cap"

    def v_max(self, inputs) -> np.ndarray:
        from feedopt.schedule.bounds import _upper_roots_norm

        model, cap = inputs.model, inputs.compensation_cap
        if model.mode != "residual" or not np.isfinite(cap):
            return np.full(inputs.n, np.inf)
        a, b = model.mean_terms(slice(0, model.n))
        zero = np.linalg.norm(b, axis=1)
        bad = np.flatnonzero(zero > cap)
        if bad.size:
            i = int(bad[np.argmax(zero[bad])])
            raise InputError(
                f"deflection.compensation_cap_mm {cap / MM:.4g} mm is exceeded by the mean "
                f"deflection of the edge forces alone (zero feed) at {bad.size} samples, the "
                f"worst sample {i} with {zero[i] / MM:.4g} mm; the smallest workable cap is "
                f"above {zero.max() / MM:.4g} mm")
        c = _upper_roots_norm(a[:, None, :], b[:, None, :], cap)[:, 0]
        return np.maximum(c, 0.0) * model.feed_per_unit_c


@dataclass(frozen=True)
class CompensatedPath:
    """The commanded path of a compensated law and how it was found.

    Attributes
    ----------
    commanded : (n, 3) commanded TCP positions [m], base frame (nominal - mean deflection).
    offset : (n, 3) commanded minus nominal [m] (= -mean deflection at the planned feed).
    iterations : fixed-point iterations done.
    change : largest change of the offset in the last iteration [m].
    converged : ``change <= tolerance``.
    state : whatever the last ``evaluate`` returned besides the mean deflection (the
        planned feed, the robot along the commanded path, ...).
    """

    commanded: np.ndarray
    offset: np.ndarray
    iterations: int
    change: float
    converged: bool
    state: object


def compensation_fixed_point(
    nominal: np.ndarray,
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, object]],
    tolerance: float = FIXED_POINT_TOLERANCE,
    max_iterations: int = MAX_ITERATIONS,
) -> CompensatedPath:
    """Solve ``commanded = nominal - mean_d(commanded)`` by fixed-point iteration.

    ``evaluate(commanded)`` runs what depends on the commanded pose (IK and compliance along
    it, the residual bound, the timing law) and returns the mean deflection (n, 3) [m] at the
    planned feed and any state to keep. The map is a contraction: a 0.3 mm offset moves a
    robot of ~2 m reach by ~1e-4 of its geometry, so each iteration shrinks the change by
    about that factor and two or three iterations reach 1e-10 m.
    """
    nominal = np.asarray(nominal, dtype=float)
    commanded = nominal.copy()
    offset = np.zeros_like(nominal)
    change, state = np.inf, None
    for k in range(1, max_iterations + 1):
        mean_d, state = evaluate(commanded)
        new_offset = -np.asarray(mean_d, dtype=float)
        change = float(np.max(np.linalg.norm(new_offset - offset, axis=1))) if new_offset.size \
            else 0.0
        offset = new_offset
        commanded = nominal + offset
        if change <= tolerance:
            return CompensatedPath(commanded, offset, k, change, True, state)
    return CompensatedPath(commanded, offset, max_iterations, change, False, state)
