"""Per-sample upper bound on the feed, v_max(s), in closed form (no iteration over feed).

At each sample the deflection over a revolution is d(phi) = c a(phi) + b(phi)
(:mod:`feedopt.schedule.deflection`). For the norm limit |d(phi)| <= L is the quadratic
inequality |a|^2 c^2 + 2 (a.b) c + |b|^2 - L^2 <= 0 per angle, whose solution set is an
interval containing c = 0 whenever |b| <= L; the largest feasible c is its upper root,
intersected (minimum) over angles. For a directional limit |c a_n + b_n| <= L is linear in c.
The thesis reached the same feed by lowering it iteratively (section 3.5, step 6).
The feed is further bounded by the user's maximum feed, spindle torque and power
(Tc = D/2 Ft, Pc = Tc omega, Algorithm 1) and joint velocity limits.

Each bound is a constraint object in the style of toppra's constraint classes: it has a
``name`` and gives ``v_max`` per sample from a :class:`BoundInputs`; the feed bound is their
minimum and records which one is active where. :data:`CONSTRAINTS` is the registry, the one
place a new constraint (chatter, chip thickness, a force limit, ...) is registered.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from feedopt.errors import InputError
from feedopt.parallel import for_each_chunk
from feedopt.registry import add_unique
from feedopt.schedule.deflection import (
    AngleTerms,
    ChunkForces,
    DeflectionModel,
    GridExtreme,
    counting,
)
from feedopt.schedule.orientation_limits import OrientationLimit
from feedopt.schedule.roots import (
    upper_roots_norm,
    upper_roots_projected,
    upper_roots_quadratic,
)
from feedopt.schedule.surface import floor_error_constraint, wall_error_constraint
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class BoundInputs:
    """Everything a feed-bound constraint may use, SI units, one entry per path sample.

    ``cache`` lets constraints that share a computation (spindle torque and power come from
    the same force pass) do it once per bound.
    """

    model: DeflectionModel
    limit: float  # deflection limit [m]
    max_feed: float | np.ndarray  # [m/s], one value or one per sample (a program's F)
    dq_ds: np.ndarray  # (n, dof) [rad/m]
    joint_velocity_max: np.ndarray  # (dof,) [rad/s]
    torque_max: float = np.inf  # spindle [N m]
    power_max: float = np.inf  # spindle [W]
    positions: np.ndarray | None = None  # (n, 3) base frame [m], for messages
    compensation_cap: float = np.inf  # largest compensated offset (residual mode) [m]
    wall_limit: float = np.inf  # part tolerances (deflection.mode surface) [m]
    floor_limit: float = np.inf
    # five-axis paths: per sample the largest |du/ds| [1/m] and |d2u/ds2| [1/m^2] of the tool
    # vector nearby (None: three-axis), the orientation limits [rad/s, rad/s^2] and the
    # tangential acceleration limit [m/s^2] (schedule/orientation_limits.py)
    axis_rate: np.ndarray | None = None
    axis_curvature: np.ndarray | None = None
    orientation_rate_max: float = np.inf
    orientation_acceleration_max: float = np.inf
    accel_max: float = np.inf
    cache: dict = field(default_factory=dict)
    progress: Callable[[int, int], None] | None = None  # (samples done, samples): a bar

    @property
    def n(self) -> int:
        return self.model.n


class FeedConstraint(Protocol):
    """A per-sample upper bound on the path feed (toppra-style constraint object)."""

    name: str

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        """(n,) largest feed [m/s] this constraint allows at each sample (``inf``: none)."""
        ...


@dataclass(frozen=True)
class FeedBound:
    """v_max(s) and its parts, all (n,) arrays in m/s (``inf`` where a part does not bind).

    ``active`` holds, per sample, the index into ``names`` (the constraints, in order) of
    the tightest part.
    ``zero_feed_deflection`` is the deflection from edge forces alone [m].
    """

    v_max: np.ndarray
    parts: dict[str, np.ndarray]
    active: np.ndarray
    zero_feed_deflection: np.ndarray
    names: tuple[str, ...] = ()

    def active_names(self) -> np.ndarray:
        """Name of the active constraint per sample."""
        return np.asarray(self.names)[self.active]

    def active_fraction(self) -> dict[str, float]:
        """Share of samples on which each constraint is the tightest."""
        n = self.active.size
        return {name: float(np.sum(self.active == i)) / n for i, name in enumerate(self.names)}


def upper_roots(terms: AngleTerms, limit: float) -> np.ndarray:
    """Per sample and angle (k, M), the largest c with the limited deflection <= limit."""
    if terms.quadratic:
        return upper_roots_quadratic(terms.aa, terms.ab, terms.bb, limit)
    return upper_roots_projected(terms.a, terms.b, limit)


def smallest_upper_root(terms: AngleTerms, limit: float) -> GridExtreme:
    """Per sample, the angle with the smallest :func:`upper_roots` and that root, formed in
    blocks of rows that stay in cache (:meth:`GridExtreme.blocked`)."""
    return GridExtreme.blocked(lambda r: upper_roots(terms.rows(r), limit),
                               terms.angles.shape[0], "min")


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
    return np.maximum(np.min(upper_roots_norm(a, b, limit), axis=1), 0.0)


def largest_feed_per_tooth_projected(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Largest c >= 0 with max over angles of |c a + b| <= limit for scalar (k, m) a, b."""
    return np.maximum(np.min(upper_roots_projected(a, b, limit), axis=1), 0.0)


@dataclass(frozen=True)
class ForcePass:
    """The bounds one pass over the path's forces gives (:func:`force_pass`), (n,) each:
    ``v_deflection`` [m/s] and ``zero_feed`` [m] of the deflection limit, ``v_torque`` and
    ``v_power`` [m/s] of the spindle; None for a part not asked for."""

    v_deflection: np.ndarray | None
    zero_feed: np.ndarray | None
    v_torque: np.ndarray | None
    v_power: np.ndarray | None


def force_pass(model: DeflectionModel, limit: float | None,
               spindle: tuple[float, float] | None,
               progress: Callable[[int, int], None] | None = None) -> ForcePass:
    """The deflection bound (``limit`` [m]) and the spindle bounds (``spindle`` = (torque
    [N m], power [W])) from one evaluation of each chunk's forces: the forces on the angle
    grid and at the critical angles are what both need, and computing them is most of the
    bound's time."""
    n = model.n
    v_d, zero = (np.empty(n), np.empty(n)) if limit is not None else (None, None)
    v_t, v_p = (np.empty(n), np.empty(n)) if spindle is not None else (None, None)

    def bound(sl: slice | np.ndarray) -> int:
        forces = model.chunk_forces(sl)
        if limit is not None:
            v_d[sl], zero[sl] = _deflection_chunk(model, sl, forces, limit)
        if spindle is not None:
            v_t[sl], v_p[sl] = _spindle_chunk(model, forces, *spindle)
        return forces.grid_row.size

    for_each_chunk(bound, model.sample_chunks(model.chunk_size()),
                   on_done=counting(progress, n))
    return ForcePass(v_d, zero, v_t, v_p)


def deflection_feed_bound(model: DeflectionModel, limit: float,
                          progress: Callable[[int, int], None] | None = None
                          ) -> tuple[np.ndarray, np.ndarray]:
    """v_max from the deflection limit [m/s] and the zero-feed deflection [m], per sample.

    The largest feed per tooth is the minimum over the angle grid, every slice entry/exit
    angle (where forces jump) and a refinement around the binding angle
    (:meth:`DeflectionModel.refine`), so the bound holds between grid points too.
    """
    done = force_pass(model, limit, None, progress)
    return done.v_deflection, done.zero_feed


def _deflection_chunk(model: DeflectionModel, sl: slice | np.ndarray, forces: ChunkForces,
                      limit: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`deflection_feed_bound` on the samples ``sl`` of one chunk, from its forces."""
    terms = model.angle_terms(sl, forces)

    def window(s_: slice | np.ndarray, w: np.ndarray) -> AngleTerms:
        return AngleTerms.from_vectors(w, *model.at_angles(s_, w))

    zero = model.refine(sl, terms.angles, terms.largest_zero_feed(), "max",
                        lambda s_, w: window(s_, w).zero_feed())
    c_max = model.refine(sl, terms.angles, smallest_upper_root(terms, limit), "min",
                         lambda s_, w: upper_roots(window(s_, w), limit))
    return np.maximum(c_max, 0.0) * model.feed_per_unit_c, zero


def spindle_feed_bounds(
    model: DeflectionModel, torque_max: float, power_max: float
) -> tuple[np.ndarray, np.ndarray]:
    """Feed bounds [m/s] from the spindle's torque [N m] and power [W] over a revolution
    (instantaneous torque D/2 Ft of Algorithm 1 on the grid and at every slice entry/exit)."""
    done = force_pass(model, None, (torque_max, power_max))
    return done.v_torque, done.v_power


def _spindle_chunk(model: DeflectionModel, f: ChunkForces, torque_max: float,
                   power_max: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`spindle_feed_bounds` of one chunk from its forces: per distinct force row (a
    slot has one), then per sample (the same numbers as per sample, without repeating them)."""
    omega = model.rpm * 2.0 * np.pi / 60.0

    def smallest(tc: np.ndarray, te: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per row, the largest c within the torque and the power limits over the angles."""
        with np.errstate(divide="ignore", invalid="ignore"):
            ct = np.where(tc > 0, (torque_max - te) / tc, np.inf).min(axis=1)
            cp = np.where(tc > 0, (power_max / omega - te) / tc, np.inf).min(axis=1)
        return ct, cp

    grid_t, grid_p = smallest(f.grid.cutting_torque, f.grid.edge_torque)
    crit_t, crit_p = smallest(f.at_critical.cutting_torque, f.at_critical.edge_torque)
    return (np.minimum(grid_t[f.grid_row], crit_t[f.critical_row]) * model.feed_per_unit_c,
            np.minimum(grid_p[f.grid_row], crit_p[f.critical_row]) * model.feed_per_unit_c)


def joint_velocity_feed_bound(dq_ds: np.ndarray, joint_velocity_max: np.ndarray) -> np.ndarray:
    """Largest path velocity [m/s] with |dq/ds * sdot| <= qdot_max for every joint."""
    with np.errstate(divide="ignore", over="ignore"):  # a joint that does not move: inf
        return np.min(joint_velocity_max / np.abs(dq_ds), axis=1)


def _pass(inputs: BoundInputs) -> ForcePass:
    """:func:`force_pass` with the deflection and the spindle limits, once per bound."""
    if "force_pass" not in inputs.cache:
        spindle = ((inputs.torque_max, inputs.power_max)
                   if np.isfinite(inputs.torque_max) or np.isfinite(inputs.power_max) else None)
        inputs.cache["force_pass"] = force_pass(inputs.model, inputs.limit, spindle,
                                                inputs.progress)
    return inputs.cache["force_pass"]


def _spindle(inputs: BoundInputs) -> tuple[np.ndarray, np.ndarray]:
    done = _pass(inputs)
    if done.v_torque is None:  # no spindle limit
        return np.full(inputs.n, np.inf), np.full(inputs.n, np.inf)
    if np.any(done.v_torque <= 0) or np.any(done.v_power <= 0):
        raise InputError(
            "the spindle cannot take this cut even at zero feed: edge-force torque or power "
            f"exceeds the spindle's {inputs.torque_max:g} N m / {inputs.power_max:g} W"
        )
    return done.v_torque, done.v_power


@dataclass(frozen=True)
class DeflectionConstraint:
    """The user's deflection limit, in closed form (module docstring)."""

    name: str = "deflection"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        """InputError if the edge forces alone (zero feed) exceed the limit somewhere, naming
        the worst sample, its position, the zero-feed deflection and the smallest workable
        limit."""
        limit = inputs.limit
        done = _pass(inputs)
        v_defl, zero = done.v_deflection, done.zero_feed
        inputs.cache["zero_feed_deflection"] = zero
        bad = np.flatnonzero(zero > limit)
        if bad.size:
            i = int(bad[np.argmax(zero[bad])])
            where = (f" at ({', '.join(f'{x / MM:.3f}' for x in inputs.positions[i])}) mm"
                     if inputs.positions is not None else "")
            raise InputError(
                f"deflection limit {limit / MM:.4g} mm is exceeded by the edge forces alone "
                f"(zero feed) at {bad.size} samples; the worst is sample {i}{where} with "
                f"{zero[i] / MM:.4g} mm at zero feed ({(zero[i] - limit) / MM:.3g} mm over). "
                f"The smallest limit that allows any feed is above {zero.max() / MM:.4g} mm."
                + _tool_note(inputs.model.tool)
            )
        return v_defl


def _tool_note(tool) -> str:
    """The tool's own stiffness, for a message about deflection, when the tool bends."""
    if not getattr(tool, "bends", False):
        return ""
    lateral, _ = tool.tip_compliance()
    return (f" The tool's own bending is part of it: {tool.name!r} is {1e-6 / lateral:.3g} "
            "N/um at its tip (tool file stickout_mm / tip_stiffness_n_per_um).")


@dataclass(frozen=True)
class MaxFeedConstraint:
    """The largest feed the user allows (``feed.max_mm_s``, default the nominal feed; for a
    G-code program per sample: its move's F, or the rapid limit on rapids)."""

    name: str = "max_feed"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        return np.broadcast_to(np.asarray(inputs.max_feed, dtype=float), (inputs.n,)).copy()


@dataclass(frozen=True)
class SpindleTorqueConstraint:
    """Spindle torque: instantaneous Tc = D/2 Ft over a revolution (Algorithm 1)."""

    name: str = "spindle_torque"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        return _spindle(inputs)[0]


@dataclass(frozen=True)
class SpindlePowerConstraint:
    """Spindle power: Pc = Tc omega over a revolution (Algorithm 1)."""

    name: str = "spindle_power"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        return _spindle(inputs)[1]


@dataclass(frozen=True)
class JointVelocityConstraint:
    """|dq/ds| sdot <= qdot_max for every joint."""

    name: str = "joint_velocity"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        return joint_velocity_feed_bound(inputs.dq_ds, inputs.joint_velocity_max)


#: The registry: constraint name -> factory of the constraint object. The bound is the
#: minimum of all of them; their order is the order of the active-constraint record.
CONSTRAINTS: dict[str, Callable[[], FeedConstraint]] = {}


def register_constraint(name: str, factory: Callable[[], FeedConstraint]) -> None:
    """Add a feed-bound constraint (ValueError for a name already registered)."""
    add_unique(CONSTRAINTS, name, factory, "feed-bound constraint")


for _cls in (DeflectionConstraint, MaxFeedConstraint, SpindleTorqueConstraint,
             SpindlePowerConstraint, JointVelocityConstraint):
    register_constraint(_cls.name, _cls)


def _compensation_cap() -> FeedConstraint:
    from feedopt.schedule.compensation import CompensationCapConstraint

    return CompensationCapConstraint()


register_constraint("compensation_cap", _compensation_cap)
register_constraint("wall_error", wall_error_constraint)
register_constraint("floor_error", floor_error_constraint)
register_constraint(OrientationLimit.name, OrientationLimit)


def feed_bound(inputs: BoundInputs,
               constraints: list[FeedConstraint] | None = None) -> FeedBound:
    """v_max(s): the minimum over ``constraints`` (default: every registered one).

    Raises
    ------
    InputError
        From a constraint that leaves no feed at all (the deflection limit below the
        zero-feed deflection, a spindle that cannot take the cut).
    """
    if constraints is None:
        constraints = [factory() for factory in CONSTRAINTS.values()]
    parts = {c.name: np.asarray(c.v_max(inputs), dtype=float) for c in constraints}
    names = tuple(parts)
    stack = np.stack([parts[name] for name in names], axis=0)
    active = np.argmin(stack, axis=0)
    v_max = stack[active, np.arange(inputs.n)]
    zero = inputs.cache.get("zero_feed_deflection", np.zeros(inputs.n))
    return FeedBound(v_max=v_max, parts=parts, active=active, zero_feed_deflection=zero,
                     names=names)
