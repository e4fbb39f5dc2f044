"""Per-sample upper bound on the feed, v_max(s), in closed form (no iteration over feed).

At each sample the deflection over a revolution is d(phi) = c a(phi) + b(phi)
(:mod:`feedopt.schedule.deflection`). For the norm limit |d(phi)| <= L is the quadratic
inequality |a|^2 c^2 + 2 (a.b) c + |b|^2 - L^2 <= 0 per angle, whose solution set is an
interval containing c = 0 whenever |b| <= L; the largest feasible c is its upper root,
intersected (minimum) over angles. For a directional limit |c a_n + b_n| <= L is linear in c.
The thesis reached the same feed by lowering it iteratively (section 3.5, step 6).
The feed is further bounded by the user's maximum feed, spindle torque and power
(Tc = D/2 Ft, Pc = Tc omega, Algorithm 1) and joint velocity limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.forces import critical_angles, milling_forces_at
from feedopt.schedule.deflection import DeflectionModel

CONSTRAINTS = ("deflection", "max_feed", "spindle_torque", "spindle_power", "joint_velocity")


@dataclass(frozen=True)
class FeedBound:
    """v_max(s) and its parts, all (n,) arrays in m/s (``inf`` where a part does not bind).

    ``active`` holds, per sample, the index into :data:`CONSTRAINTS` of the tightest part.
    ``zero_feed_deflection`` is the deflection from edge forces alone [m].
    """

    v_max: np.ndarray
    parts: dict[str, np.ndarray]
    active: np.ndarray
    zero_feed_deflection: np.ndarray

    def active_names(self) -> np.ndarray:
        """Name of the active constraint per sample."""
        return np.asarray(CONSTRAINTS)[self.active]

    def active_fraction(self) -> dict[str, float]:
        """Share of samples on which each constraint is the tightest."""
        n = self.active.size
        return {name: float(np.sum(self.active == i)) / n for i, name in enumerate(CONSTRAINTS)}


def _upper_roots_norm(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Per angle, the largest c with |c a + b| <= limit (``inf`` without cutting force)."""
    qa = np.einsum("...i,...i->...", a, a)
    qb = np.einsum("...i,...i->...", a, b)
    qc = np.einsum("...i,...i->...", b, b) - limit * limit  # <= 0 where feasible at c = 0
    disc = np.sqrt(np.maximum(qb * qb - qa * qc, 0.0))
    # Upper root (-qb + disc) / qa, written without cancellation for qb > 0.
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.where(qb > 0, -qc / (qb + disc), (disc - qb) / qa)
    root = np.where(qa > 0, root, np.inf)
    return np.where(np.isnan(root), 0.0, root)


def _upper_roots_projected(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Per angle, the largest c with |c a + b| <= limit for scalar a, b."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a > 0, (limit - b) / a, np.where(a < 0, (-limit - b) / a, np.inf))


def largest_feed_per_tooth_norm(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Largest c >= 0 with max over angles of |c a + b| <= limit (norm mode).

    Parameters
    ----------
    a, b : (k, m, 3) arrays
        Deflection per unit feed per tooth and at zero feed, per sample and angle.
    limit : float
        Deflection limit L [m]; |b| <= L must hold (checked by the caller).

    Returns
    -------
    (k,) array of c_max [m]; ``inf`` where no angle has a cutting contribution.
    """
    return np.maximum(np.min(_upper_roots_norm(a, b, limit), axis=1), 0.0)


def largest_feed_per_tooth_projected(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Largest c >= 0 with max over angles of |c a + b| <= limit for scalar (k, m) a, b."""
    return np.maximum(np.min(_upper_roots_projected(a, b, limit), axis=1), 0.0)


def deflection_feed_bound(model: DeflectionModel, limit: float) -> tuple[np.ndarray, np.ndarray]:
    """v_max from the deflection limit [m/s] and the zero-feed deflection [m], per sample.

    The largest feed per tooth is the minimum over the angle grid, every slice entry/exit
    angle (where forces jump) and a refinement around the binding angle
    (:meth:`DeflectionModel.refine`), so the bound holds between grid points too.
    """
    c_max = np.empty(model.n)
    zero = np.empty(model.n)

    def root(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Per-angle largest c (before the minimum over angles), shape (k, M)."""
        if b.ndim == 3:
            return _upper_roots_norm(a, b, limit)
        return _upper_roots_projected(a, b, limit)

    def zero_feed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.linalg.norm(b, axis=-1) if b.ndim == 3 else np.abs(b)

    for sl, angles, a, b in model.chunks():
        zero[sl] = model.refine(sl, angles, zero_feed(a, b), "max",
                                lambda s_, w: zero_feed(*model.at_angles(s_, w)))
        c_max[sl] = model.refine(sl, angles, root(a, b), "min",
                                 lambda s_, w: root(*model.at_angles(s_, w)))
    return np.maximum(c_max, 0.0) * model.feed_per_unit_c, zero


def spindle_feed_bounds(
    model: DeflectionModel, torque_max: float, power_max: float
) -> tuple[np.ndarray, np.ndarray]:
    """Feed bounds [m/s] from the spindle's torque [N m] and power [W] over a revolution
    (instantaneous torque D/2 Ft of Algorithm 1 on the grid and at every slice entry/exit)."""
    omega = model.rpm * 2.0 * np.pi / 60.0
    v_t = np.empty(model.n)
    v_p = np.empty(model.n)
    step = 8192
    for start in range(0, model.n, step):
        sl = slice(start, min(start + step, model.n))
        idx = np.arange(sl.start, sl.stop)
        split, row = model.forces(idx)
        crit = critical_angles(model.tool, model._engagement(sl), model.axial_slices)
        at = milling_forces_at(model.tool, model.coefficients, model._engagement(sl), crit,
                               axial_slices=model.axial_slices)
        tc = np.concatenate([split.cutting_torque[row], at.cutting_torque], axis=1)
        te = np.concatenate([split.edge_torque[row], at.edge_torque], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            ct = np.where(tc > 0, (torque_max - te) / tc, np.inf).min(axis=1)
            cp = np.where(tc > 0, (power_max / omega - te) / tc, np.inf).min(axis=1)
        v_t[sl] = ct * model.feed_per_unit_c
        v_p[sl] = cp * model.feed_per_unit_c
    return v_t, v_p


def joint_velocity_feed_bound(dq_ds: np.ndarray, joint_velocity_max: np.ndarray) -> np.ndarray:
    """Largest path velocity [m/s] with |dq/ds * sdot| <= qdot_max for every joint."""
    with np.errstate(divide="ignore"):
        return np.min(joint_velocity_max / np.abs(dq_ds), axis=1)


def feed_bound(
    model: DeflectionModel,
    limit: float,
    max_feed: float,
    dq_ds: np.ndarray,
    joint_velocity_max: np.ndarray,
    torque_max: float = np.inf,
    power_max: float = np.inf,
    positions: np.ndarray | None = None,
) -> FeedBound:
    """Combine every feed bound into v_max(s).

    Raises
    ------
    InputError
        If the edge forces alone (zero feed) deflect the robot beyond ``limit`` somewhere,
        naming the first such sample, its position, the zero-feed deflection and the
        smallest limit that leaves room for any feed; or if the spindle cannot cut at all.
    """
    v_defl, zero = deflection_feed_bound(model, limit)
    bad = np.flatnonzero(zero > limit)
    if bad.size:
        i = int(bad[np.argmax(zero[bad])])
        where = (
            f" at ({', '.join(f'{x * 1e3:.3f}' for x in positions[i])}) mm"
            if positions is not None
            else ""
        )
        raise InputError(
            f"deflection limit {limit * 1e3:.4g} mm is exceeded by the edge forces alone "
            f"(zero feed) at {bad.size} samples; the worst is sample {i}{where} with "
            f"{zero[i] * 1e3:.4g} mm at zero feed ({(zero[i] - limit) * 1e3:.3g} mm over). "
            f"The smallest limit that allows any feed is above {zero.max() * 1e3:.4g} mm."
        )
    v_t, v_p = spindle_feed_bounds(model, torque_max, power_max)
    if np.any(v_t <= 0) or np.any(v_p <= 0):
        raise InputError(
            "the spindle cannot take this cut even at zero feed: edge-force torque or power "
            f"exceeds the spindle's {torque_max:g} N m / {power_max:g} W"
        )
    parts = {
        "deflection": v_defl,
        "max_feed": np.full(model.n, float(max_feed)),
        "spindle_torque": v_t,
        "spindle_power": v_p,
        "joint_velocity": joint_velocity_feed_bound(dq_ds, joint_velocity_max),
    }
    stack = np.stack([parts[name] for name in CONSTRAINTS], axis=0)
    active = np.argmin(stack, axis=0)
    v_max = stack[active, np.arange(model.n)]
    return FeedBound(v_max=v_max, parts=parts, active=active, zero_feed_deflection=zero)
