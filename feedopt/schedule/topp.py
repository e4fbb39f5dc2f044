"""Time-optimal timing law with toppra (reachability analysis), the ``topp`` law.

The path q(s) is a quintic Hermite spline through the problem's samples (it reproduces
``q``, ``dq_ds`` and ``d2q_ds2`` exactly at every sample). toppra runs on explicit
gridpoints (a subset of the samples) with the Interpolation discretisation of the joint
acceleration limits; the feed bound v_max and the joint velocity limits enter as a bound on
x = sdot^2 at each gridpoint and the tangential acceleration limit as a bound on u = sddot.

Between gridpoints toppra's solution has constant sddot, so sdot^2 is linear in s and lies
below the larger of its end values. Each gridpoint therefore gets the *minimum* of the
per-sample bound over its two neighbouring intervals: then sdot <= v_max holds on every fine
sample, not just on the grid. The output s(t) is piecewise quadratic (continuity 1): the
acceleration jumps at gridpoints, which is reported, not hidden.

Internally the solver works in millimetres (x ~ 10 mm^2/s^2 rather than 1e-5 m^2/s^2), which
keeps toppra's absolute tolerances (1e-8 .. 1e-5) meaningful.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.interpolate import PPoly

from feedopt.errors import InputError
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory, ppoly_from_pieces

_MM = 1e3  # metres -> millimetres


def quintic_hermite_coefficients(
    h: np.ndarray,
    p0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    p1: np.ndarray,
    v1: np.ndarray,
    a1: np.ndarray,
) -> np.ndarray:
    """Coefficients (highest power first, shape (6, m, ...)) of the quintics on [0, h]
    matching value, first and second derivative at both ends (vectorised over pieces)."""
    h = np.asarray(h, dtype=float)
    if p0.ndim > h.ndim:
        h = h.reshape(h.shape + (1,) * (p0.ndim - h.ndim))
    dp = p1 - p0
    c3 = (20 * dp - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h**2) / (2 * h**3)
    c4 = (-30 * dp + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h**2) / (2 * h**4)
    c5 = (12 * dp - 6 * (v1 + v0) * h - (a0 - a1) * h**2) / (2 * h**5)
    return np.stack([c5, c4, c3, 0.5 * a0, v0, p0])


class SampledJointPath:
    """toppra geometric path q(s): a C2 quintic Hermite spline through the samples.

    Implements toppra's ``AbstractGeometricPath`` interface (``__call__(s, order)``, ``dof``,
    ``path_interval``, ``waypoints``). ``scale`` multiplies the path parameter (1e3: s in mm);
    ``joint_scale`` (dof,) divides each joint (toppra's seidel solver needs the joint
    acceleration rows normalised to limit 1: with raw limits of 0.01 rad/s^2 it reported
    controllable instances as uncontrollable).
    """

    def __init__(
        self, problem: ScheduleProblem, scale: float = 1.0, joint_scale: np.ndarray | None = None
    ):
        js = np.ones(problem.q.shape[1]) if joint_scale is None else np.asarray(joint_scale)
        s = problem.s * scale
        q = np.asarray(problem.q, dtype=float) / js
        dq = np.asarray(problem.dq_ds, dtype=float) / scale / js
        d2q = np.asarray(problem.d2q_ds2, dtype=float) / scale**2 / js
        h = np.diff(s)
        c = quintic_hermite_coefficients(h, q[:-1], dq[:-1], d2q[:-1], q[1:], dq[1:], d2q[1:])
        self._pp = PPoly(c, s)
        self._s = s
        self._q = q

    def __call__(self, path_positions, order: int = 0) -> np.ndarray:
        pp = self._pp if order == 0 else self._pp.derivative(order)
        return pp(np.asarray(path_positions, dtype=float))

    @property
    def dof(self) -> int:
        return int(self._q.shape[1])

    @property
    def path_interval(self) -> np.ndarray:
        return np.array([self._s[0], self._s[-1]])

    @property
    def waypoints(self):
        return self._s, self._q

    # toppra's older method names
    def eval(self, ss):  # noqa: D102
        return self(ss, 0)

    def evald(self, ss):  # noqa: D102
        return self(ss, 1)

    def evaldd(self, ss):  # noqa: D102
        return self(ss, 2)


def sample_feed_bound(problem: ScheduleProblem) -> np.ndarray:
    """Per-sample bound on sdot [m/s]: v_max and every joint velocity limit |q'(s)| sdot."""
    dq = np.abs(np.asarray(problem.dq_ds, dtype=float))
    with np.errstate(divide="ignore"):
        v_joint = np.min(np.asarray(problem.joint_velocity_max)[None, :] / dq, axis=1)
    return np.minimum(np.asarray(problem.v_max, dtype=float), v_joint)


def grid_bounds(v_sample: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interval and gridpoint bounds on sdot from a per-sample bound.

    Parameters
    ----------
    v_sample : (n,) array
        Bound at every sample.
    grid : (N+1,) int array
        Sample indices of the gridpoints (increasing, first 0, last n-1).

    Returns
    -------
    interval : (N,) array
        Minimum of ``v_sample`` over the samples of each grid interval (both ends included).
    node : (N+1,) array
        Minimum of ``interval`` over the (one or two) intervals next to each gridpoint.
    """
    inner = np.minimum.reduceat(v_sample, grid[:-1])  # samples g_k .. g_{k+1}-1
    interval = np.minimum(inner, v_sample[grid[1:]])
    node = np.empty(grid.size)
    node[0], node[-1] = interval[0], interval[-1]
    node[1:-1] = np.minimum(interval[:-1], interval[1:])
    return interval, node


def uniform_grid(n: int, max_gridpoints: int | None) -> np.ndarray:
    """Sample indices of at most ``max_gridpoints`` (about) evenly spaced gridpoints."""
    if max_gridpoints is None or n <= max_gridpoints:
        return np.arange(n)
    if max_gridpoints < 2:
        raise InputError(f"max_gridpoints must be >= 2, got {max_gridpoints}")
    return np.unique(np.round(np.linspace(0, n - 1, max_gridpoints)).astype(int))


def limit_acceleration(x: np.ndarray, s: np.ndarray, a_max: float) -> np.ndarray:
    """Largest x' <= x with |x'_{k+1} - x'_k| <= 2 a_max (s_{k+1} - s_k) (vectorised).

    A backward pass (x_k - x_{k+1} <= 2 a ds, via a reversed cumulative minimum of
    x + 2 a s) then a forward pass (cumulative minimum of x - 2 a s); the forward pass keeps
    the backward property. Used to remove toppra's rounding-level acceleration excess.
    """
    if not np.isfinite(a_max):
        return x
    y = np.minimum.accumulate((x + 2 * a_max * s)[::-1])[::-1] - 2 * a_max * s
    return np.minimum.accumulate(y - 2 * a_max * s) + 2 * a_max * s


def piecewise_quadratic_timing(s: np.ndarray, x: np.ndarray) -> tuple[PPoly, np.ndarray]:
    """s(t) with constant sddot between gridpoints from sdot^2 = ``x`` at gridpoints ``s``.

    Returns the PPoly (degree 2) and the per-interval accelerations [m/s^2]."""
    v = np.sqrt(np.maximum(x, 0.0))
    ds = np.diff(s)
    vsum = v[:-1] + v[1:]
    if np.any(vsum <= 0):
        k = int(np.argmax(vsum <= 0))
        raise InputError(
            f"the feed is zero at both ends of the grid interval starting at "
            f"s = {s[k] * 1e3:.3f} mm (gridpoint {k}): the bound or limits stop the motion"
        )
    dt = 2 * ds / vsum
    u = (x[1:] - x[:-1]) / (2 * ds)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    coeffs = np.stack([0.5 * u, v[:-1], s[:-1]])
    return ppoly_from_pieces(t, coeffs), u


def _feed_bound_constraint(xbound: np.ndarray, ubound: np.ndarray | None):
    """A toppra LinearConstraint with only per-gridpoint bounds on x = sdot^2 and u."""
    from toppra.constraint import DiscretizationType, LinearConstraint

    class _Bounds(LinearConstraint):
        def __init__(self):
            super().__init__()
            self.dof = 0
            self.discretization_type = DiscretizationType.Interpolation
            self._format_string = "    per-gridpoint bounds on sdot^2 and sddot\n"

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            return None, None, None, None, None, ubound, xbound

    return _Bounds()


def plan_topp(
    problem: ScheduleProblem,
    *,
    max_gridpoints: int | None = None,
    use_accel_limit: bool = True,
    use_joint_limits: bool = True,
) -> Trajectory:
    """Time-optimal timing law by toppra (TOPP-RA, seidel solver).

    Parameters
    ----------
    problem : ScheduleProblem
        Path samples, feed bound and limits.
    max_gridpoints : int, optional
        Use about this many evenly spaced samples as gridpoints (default: every sample).
    use_accel_limit : bool
        Impose ``problem.accel_max`` on |sddot| (ignored when it is infinite).
    use_joint_limits : bool
        Impose the joint acceleration limits (Interpolation discretisation on q(s)).
        Joint velocity limits are always folded into the per-sample feed bound.

    Returns
    -------
    Trajectory
        ``law="topp"``, piecewise quadratic s(t), ``continuity=1``.
    """
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    t_start = time.perf_counter()
    v_sample = sample_feed_bound(problem)
    if np.any(~(v_sample > 0)):
        k = int(np.argmax(~(v_sample > 0)))
        raise InputError(
            f"feed bound is {v_sample[k]} m/s at sample {k} (s = {problem.s[k] * 1e3:.3f} mm); "
            "every sample needs a positive bound"
        )
    for name, v in (("v_start", problem.v_start), ("v_end", problem.v_end)):
        k = 0 if name == "v_start" else problem.n - 1
        if v < 0 or v > v_sample[k] * (1 + 1e-12):
            raise InputError(
                f"{name} = {v * 1e3:.6g} mm/s is outside [0, {v_sample[k] * 1e3:.6g}] mm/s, "
                f"the feed bound at sample {k}"
            )

    grid = uniform_grid(problem.n, max_gridpoints)
    _, v_node = grid_bounds(v_sample, grid)
    s_grid = problem.s[grid]
    s_mm = s_grid * _MM
    xbound = np.column_stack([np.zeros(grid.size), (v_node * _MM) ** 2])
    a_max = float(problem.accel_max) if use_accel_limit else np.inf
    ubound = None
    if np.isfinite(a_max):
        ubound = np.tile([-a_max * _MM, a_max * _MM], (grid.size, 1))
    constraints = [_feed_bound_constraint(xbound, ubound)]
    if use_joint_limits:
        constraints.append(
            constraint.JointAccelerationConstraint(
                np.ones(problem.q.shape[1]),  # rows normalised by the limits (see the path)
                discretization_scheme=constraint.DiscretizationType.Interpolation,
            )
        )
    path = SampledJointPath(
        problem, scale=_MM, joint_scale=np.asarray(problem.joint_acceleration_max, dtype=float)
    )
    instance = algo.TOPPRA(
        constraints, path, gridpoints=s_mm, solver_wrapper="seidel",
        parametrizer="ParametrizeConstAccel",
    )
    t_solve = time.perf_counter()
    _, sd_vec, _ = instance.compute_parameterization(
        problem.v_start * _MM, problem.v_end * _MM
    )
    t_solve = time.perf_counter() - t_solve
    if sd_vec is None or np.any(np.isnan(sd_vec)):
        raise InputError(
            f"toppra found no feasible parameterisation ({instance.problem_data.return_code}): "
            "the boundary feeds, the feed bound and the acceleration limits are inconsistent"
        )

    # Back to SI, clip rounding-level excess over the gridpoint bound and the acceleration.
    x = (np.asarray(sd_vec, dtype=float) / _MM) ** 2
    x = np.minimum(x, v_node**2)
    x[0], x[-1] = problem.v_start**2, problem.v_end**2
    x = limit_acceleration(x, s_grid, a_max)
    timing, u = piecewise_quadratic_timing(s_grid, x)

    notes = [
        "toppra (TOPP-RA, seidel) on "
        f"{grid.size} gridpoints; s(t) is piecewise quadratic (constant sddot between "
        "gridpoints), so it is C1 only: the tangential acceleration jumps at gridpoints.",
        "feed bound imposed per gridpoint as the minimum of v_max over the neighbouring "
        "intervals, so it also holds on every fine sample between gridpoints.",
    ]
    jumps = np.abs(np.diff(u)) if u.size > 1 else np.zeros(0)
    stats = {
        "gridpoints": int(grid.size),
        "solver": "toppra seidel",
        "toppra_time_s": t_solve,
        "planning_time_s": time.perf_counter() - t_start,
        "max_accel_jump_m_s2": float(jumps.max(initial=0.0)),
        "lower_bound_s": problem.lower_bound_time(),
    }
    if use_joint_limits:
        ja = _joint_acceleration_ratio(problem, timing)
        stats["joint_acceleration_ratio"] = ja
        if ja > 1 + 1e-6:
            notes.append(
                f"joint acceleration reaches {ja:.4f} of its limit between gridpoints "
                "(toppra imposes it at gridpoints only)"
            )
    return Trajectory(law="topp", timing=timing, continuity=1, notes=tuple(notes), stats=stats)


def _joint_acceleration_ratio(problem: ScheduleProblem, timing: PPoly) -> float:
    """Largest |q'' sdot^2 + q' sddot| / limit over the samples (sddot of the piece that
    starts at or before the sample)."""
    s_break = timing(timing.x)
    piece = np.clip(np.searchsorted(s_break, problem.s, side="right") - 1, 0, timing.x.size - 2)
    u = 2 * timing.c[0, piece]
    v2_left = timing.c[1, piece] ** 2
    x = v2_left + 2 * u * (problem.s - s_break[piece])
    qdd = problem.d2q_ds2 * x[:, None] + problem.dq_ds * u[:, None]
    return float(np.max(np.abs(qdd) / np.asarray(problem.joint_acceleration_max)))
