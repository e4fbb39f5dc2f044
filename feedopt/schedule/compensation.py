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
from feedopt.schedule.roots import upper_roots_norm
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
        c = upper_roots_norm(a[:, None, :], b[:, None, :], cap)[:, 0]
        return np.maximum(c, 0.0) * model.feed_per_unit_c


@dataclass(frozen=True)
class CompensatedPath:
    """The commanded path of a compensated law and how it was found.

    Attributes
    ----------
    commanded : (n, 3) commanded TCP positions [m], base frame (nominal - mean deflection).
    offset : (n, 3) commanded minus nominal [m] (= -mean deflection at the planned feed).
    iterations : pose iterations done (IK and mean deflection at a fixed feed), in all.
    plans : times the law was planned (on the bound at the commanded pose of the time).
    change : largest change of the offset in the last pose iteration [m].
    feed_change : largest relative change of the planned feed at the last re-plan (0 when
        the last plan reproduced the one before).
    converged : the pose iteration reached its tolerance.
    plan_state, pose_state : what the last ``plan`` and ``mean_deflection`` returned besides
        the feed / mean deflection (the law and its bound; the robot along the path).
    """

    commanded: np.ndarray
    offset: np.ndarray
    iterations: int
    plans: int
    change: float
    feed_change: float
    converged: bool
    plan_state: object
    pose_state: object

    def samples(self, s: np.ndarray) -> CompensatedSamples:
        """Nominal and commanded positions at the path samples ``s``."""
        return CompensatedSamples(np.asarray(s, dtype=float), self.commanded - self.offset,
                                  self.commanded)

    def commanded_at(self, s_samples: np.ndarray):
        """``s -> (m, 3)`` commanded positions, linear between the samples ``s_samples``."""
        samples = self.samples(s_samples)
        return lambda s: samples.at(s)[1]


@dataclass(frozen=True)
class CompensatedSamples:
    """Nominal and commanded TCP positions at the path samples (n, 3) [m], base frame."""

    s: np.ndarray
    nominal: np.ndarray
    commanded: np.ndarray

    def at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(nominal, commanded) at arc lengths ``s`` (linear between samples) [m]."""
        s = np.asarray(s, dtype=float)
        return tuple(np.column_stack([np.interp(s, self.s, a[:, k]) for k in range(3)])
                     for a in (self.nominal, self.commanded))


#: Re-plans of the law at most (the feed depends on the commanded pose only through the
#: compliance, ~1e-4 per mm of offset: one re-plan normally reproduces the feed).
MAX_PLANS = 3
#: Relative change of the planned feed below which a re-plan reproduced the plan before.
FEED_TOLERANCE = 1e-9


def compensation_fixed_point(
    nominal: np.ndarray,
    plan: Callable[[np.ndarray], tuple[np.ndarray, object]],
    mean_deflection: Callable[[np.ndarray, object], tuple[np.ndarray, object]],
    tolerance: float = FIXED_POINT_TOLERANCE,
    max_iterations: int = MAX_ITERATIONS,
    max_plans: int = MAX_PLANS,
) -> CompensatedPath:
    """Solve ``commanded = nominal - mean_d(commanded, feed(commanded))``.

    ``plan(commanded)`` plans the law on the bound at that pose (IK, compliance, residual
    bound, law) and returns the feed at the samples (n,) and a state; ``mean_deflection(
    commanded, plan_state)`` returns the mean deflection (n, 3) [m] at that pose with the
    planned feed, and a state. Inner loop: the pose at a fixed feed, a contraction (a 0.3 mm
    offset moves a robot of ~2 m reach by ~1e-4 of its geometry), to ``tolerance``. Outer
    loop: re-plan at the new pose until the feed repeats to :data:`FEED_TOLERANCE` (or
    ``max_plans``; a law whose plan jumps with tiny changes of its bound keeps its last plan,
    and the pose is always solved for the feed that is exported).
    """
    nominal = np.asarray(nominal, dtype=float)
    commanded, offset = nominal.copy(), np.zeros_like(nominal)
    feed, plan_state = plan(commanded)
    plans, iterations, feed_change = 1, 0, 0.0
    while True:
        change, pose_state = np.inf, None
        for _ in range(max_iterations):
            mean_d, pose_state = mean_deflection(commanded, plan_state)
            new_offset = -np.asarray(mean_d, dtype=float)
            change = (float(np.max(np.linalg.norm(new_offset - offset, axis=1)))
                      if new_offset.size else 0.0)
            offset, commanded = new_offset, nominal + new_offset
            iterations += 1
            if change <= tolerance:
                break
        if plans >= max_plans:
            break
        new_feed, new_state = plan(commanded)
        plans += 1
        scale = np.maximum(np.abs(feed), 1e-300)
        feed_change = float(np.max(np.abs(new_feed - feed) / scale)) if feed.size else 0.0
        if feed_change <= FEED_TOLERANCE:
            break  # the plan at the solved pose is the plan the pose was solved for
        feed, plan_state = new_feed, new_state
    return CompensatedPath(commanded, offset, iterations, plans, change, feed_change,
                           bool(change <= tolerance), plan_state, pose_state)


#: The verification tolerance of ``commanded + mean d = nominal`` [m] (1e-6 mm).
IDENTITY_TOLERANCE = 1e-9


@dataclass(frozen=True)
class CompensationCheck:
    """The replay's check of a compensated law: the forward kinematics of the joints the
    controller is sent, plus the mean deflection recomputed at the replayed feed, against the
    nominal path (base frame)."""

    max_error: float  # [m]
    max_offset: float  # largest |commanded - nominal| [m]
    passed: bool

    def problem(self) -> str | None:
        """The verification problem, or None."""
        if self.passed:
            return None
        return (f"compensation: FK of the commanded joints + the predicted mean deflection "
                f"misses the nominal path by {self.max_error / MM:.3g} mm (tolerance "
                f"{IDENTITY_TOLERANCE / MM:g} mm)")


def check_compensation(commanded_fk: np.ndarray, mean_deflection: np.ndarray,
                       nominal: np.ndarray) -> CompensationCheck:
    """``|FK(q_commanded) + mean d(feed) - nominal| <= IDENTITY_TOLERANCE`` at every sample
    (all (n, 3) [m], base frame)."""
    err = np.linalg.norm(commanded_fk + mean_deflection - nominal, axis=1)
    offset = np.linalg.norm(commanded_fk - nominal, axis=1)
    max_error = float(err.max()) if err.size else 0.0
    return CompensationCheck(max_error, float(offset.max()) if offset.size else 0.0,
                             bool(max_error <= IDENTITY_TOLERANCE))
