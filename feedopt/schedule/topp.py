"""Time-optimal timing law with toppra (reachability analysis), the ``topp`` law.

The path q(s) is a quintic Hermite spline through the problem's samples (it reproduces
``q``, ``dq_ds`` and ``d2q_ds2`` exactly at every sample). toppra runs on explicit
gridpoints (a subset of the samples); the feed bound v_max and the joint velocity limits
(with |q'| over the intervals next to each sample) enter as a bound on x = sdot^2 at each
gridpoint and the tangential acceleration limit as a bound on u = sddot. The joint
accelerations u q'(s) + x(s) q''(s) are bounded on every sample interval, not only at the
gridpoints: with u constant and x linear on a grid interval they are u A(s) + x_k B(s) with
cubics A, B, and the Bernstein coefficients of A and B give one linear row each in (u, x_k)
(:func:`~feedopt.schedule.joint_rows.constant_accel_rows`, imposed by collocation). Where a
corner transition is shorter than a sample, q'' spikes inside an interval and the
Interpolation discretisation at the gridpoints alone let toppra exceed the limit there.

Between gridpoints toppra's solution has constant sddot, so sdot^2 is linear in s and lies
below the larger of its end values. Each gridpoint therefore gets the *minimum* of the
per-sample bound over its two neighbouring intervals: then sdot <= v_max holds on every fine
sample, not just on the grid. The output s(t) is piecewise quadratic (continuity 1): the
acceleration jumps at gridpoints, which is reported, not hidden.

Internally the solver works in millimetres (``MM_PER_M``: x ~ 10 mm^2/s^2 rather than
1e-5 m^2/s^2), which keeps toppra's absolute tolerances (1e-8 .. 1e-5) meaningful.

toppra is run only when the joint acceleration limits bind. Without them the problem on the
grid is: the largest x with x_k <= bound_k and |x_(k+1) - x_k| <= 2 a_max ds_k, whose
solution is the pointwise minimum that one backward and one forward pass compute exactly
(:func:`limit_acceleration`; what toppra's reachability analysis converges to, up to its
solver tolerance). So the law first computes that profile and checks the joint
accelerations on it as toppra imposes them (every sample interval, the same Bernstein
rows); when they hold, the profile is also the optimum of toppra's problem
and is the answer (about 1 ms at 1e5 samples against 2-4 s for toppra, same cycle time to
5e-10: toppra's tolerance), otherwise toppra solves it. :class:`ToppMethod` says which.

Two pitfalls of toppra used on its own that this law avoids: its default gridpoints
(``propose_gridpoints``) depend on the unit of the path parameter (161 in metres, 16,385 in
millimetres on the triangle slot), and a velocity bound imposed at gridpoints is exceeded
between them (by 1.6 % there with the metre grid); here the gridpoints are the samples (or a
subset) and the bound of each gridpoint is the minimum over its neighbouring intervals, so
sdot <= v_max holds on every sample (tests/schedule/test_topp_gridding.py).

Reference: H. Pham and Q.-C. Pham, "A new approach to time-optimal path parameterization
based on reachability analysis", IEEE Trans. Robotics 34(3), 2018 (toppra).
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.interpolate import PPoly

from feedopt.errors import InputError
from feedopt.schedule.checks import check_boundary_feeds, check_positive_bound
from feedopt.schedule.joint_rows import constant_accel_ratio, constant_accel_rows
from feedopt.schedule.joints import IntervalPeaks, interval_peaks
from feedopt.schedule.polynomial import quintic_hermite_spline
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM, MM_PER_M

# toppra's joint accelerations exceeding their limit by more than this (relative) between
# gridpoints get a note.
_JOINT_ACCELERATION_RTOL = 1e-6


class ToppOptions(BaseModel):
    """Tunables of the ``topp`` law (toppra)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    max_gridpoints: int | None = Field(
        None, ge=2,
        description="use about this many evenly spaced samples as toppra gridpoints (null: "
        "every sample; the feed bound still holds on every sample between them)",
    )
    use_accel_limit: bool = Field(
        True, description="impose the tangential acceleration limit on |sddot| (ignored when "
        "it is infinite)")
    use_joint_limits: bool = Field(
        True, description="impose the joint acceleration limits (on every sample interval, "
        "Bernstein rows); joint velocity limits are always folded into the feed bound")


class ToppMethod(enum.Enum):
    """Which solver produced the ``topp`` profile."""

    #: the exact backward/forward pass (:func:`limit_acceleration`): the joint accelerations
    #: hold on it, so it is the optimum of toppra's problem too
    FORWARD_BACKWARD = "exact forward-backward pass"
    #: toppra's reachability analysis (seidel), for joint acceleration limits that bind
    TOPPRA = "toppra seidel"


@dataclass(frozen=True)
class ToppStats(LawStats):
    """What the ``topp`` law reports (``as_dict()``: its summary.json entry)."""

    gridpoints: int
    #: :class:`ToppMethod` value of the solver used
    solver: str
    #: time in toppra [s] (0 when the forward-backward pass was the optimum)
    toppra_time_s: float
    planning_time_s: float
    max_accel_jump_m_s2: float
    lower_bound_s: float
    #: largest joint acceleration / limit on the sample intervals (an upper bound, exact at
    #: the samples; None: joint limits not imposed)
    joint_acceleration_ratio: float | None = None
    #: toppra's ``ParameterizationReturnCode`` name (``"Ok"``; also without toppra)
    return_code: str = outcome("Ok")
    #: the solver used
    method: ToppMethod = outcome(ToppMethod.TOPPRA)

    @property
    def joint_acceleration_exceeded(self) -> bool:
        """Joint accelerations go over their limit (beyond toppra's tolerance)."""
        ratio = self.joint_acceleration_ratio
        return ratio is not None and ratio > 1 + _JOINT_ACCELERATION_RTOL


class SampledJointPath:
    """toppra geometric path q(s): a C2 quintic Hermite spline through the samples.

    The pieces are :func:`~feedopt.schedule.polynomial.quintic_hermite_spline` through
    ``(q, dq_ds, d2q_ds2)`` at the samples (the conditions of Eq. 3.22 in s instead of t).

    Implements toppra's ``AbstractGeometricPath`` interface (``__call__(s, order)``, ``dof``,
    ``path_interval``, ``waypoints``). ``scale`` multiplies the path parameter (``MM_PER_M``:
    s in mm); ``joint_scale`` (dof,) divides each joint (toppra's seidel solver needs the
    joint acceleration rows normalised to limit 1: with raw limits of 0.01 rad/s^2 it
    reported controllable instances as uncontrollable).
    """

    def __init__(
        self, problem: ScheduleProblem, scale: float = 1.0, joint_scale: np.ndarray | None = None
    ):
        js = np.ones(problem.q.shape[1]) if joint_scale is None else np.asarray(joint_scale)
        s = problem.s * scale
        q = np.asarray(problem.q, dtype=float) / js
        dq = np.asarray(problem.dq_ds, dtype=float) / scale / js
        d2q = np.asarray(problem.d2q_ds2, dtype=float) / scale**2 / js
        self._pp = PPoly(quintic_hermite_spline(np.diff(s), q, dq, d2q), s)
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


def sample_feed_bound(problem: ScheduleProblem, peaks: IntervalPeaks | None = None
                      ) -> np.ndarray:
    """Per-sample bound on sdot [m/s]: v_max and every joint velocity limit |q'(s)| sdot,
    with |q'| its bound over the one or two sample intervals next to the sample
    (:meth:`~feedopt.schedule.joints.IntervalPeaks.at_samples`; ``peaks``: those of the
    problem, :func:`~feedopt.schedule.joints.interval_peaks`), so that the smaller bound of
    an interval's ends keeps the joint velocities within their limits on all of it."""
    peaks = interval_peaks(problem) if peaks is None else peaks
    dq = peaks.at_samples(problem)[0]
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


def forward_backward_profile(
    s_grid: np.ndarray, v_node: np.ndarray, v_start: float, v_end: float, a_max: float
) -> np.ndarray:
    """x = sdot^2 [m^2/s^2] at the gridpoints: the largest profile under ``v_node`` with the
    boundary feeds and |sddot| <= ``a_max`` (constant sddot between gridpoints), computed
    exactly by the backward and forward pass of :func:`limit_acceleration`."""
    x = v_node**2
    x[0], x[-1] = v_start**2, v_end**2
    out = limit_acceleration(x, s_grid, a_max)
    for end, v in ((0, v_start), (-1, v_end)):
        if out[end] < x[end] * (1 - 1e-9):
            raise InputError(
                f"no feasible parameterisation: the {'start' if end == 0 else 'end'} feed "
                f"{v / MM:g} mm/s cannot be {'braked from' if end == 0 else 'reached'} in time "
                f"under the feed bound with the acceleration limit {a_max / MM:g} mm/s^2: "
                "the boundary feeds, the feed bound and the acceleration limits are "
                "inconsistent")
    return out


def joint_acceleration_ratio_on_grid(
    problem: ScheduleProblem, grid: np.ndarray, x: np.ndarray
) -> float:
    """Largest |q'' x + q' u| / limit at both ends of every grid interval (toppra's
    Interpolation discretisation of the joint acceleration constraint), u = dx/ds / 2 of the
    interval, x = sdot^2 at the gridpoints."""
    s = problem.s[grid]
    u = np.diff(x) / (2 * np.diff(s))
    limit = np.asarray(problem.joint_acceleration_max, dtype=float)
    worst = 0.0
    for end in (0, 1):  # start and end of each interval
        k = grid[end:grid.size - 1 + end]
        qdd = problem.d2q_ds2[k] * x[end:x.size - 1 + end, None] + problem.dq_ds[k] * u[:, None]
        worst = max(worst, float(np.max(np.abs(qdd) / limit, initial=0.0)))
    return worst


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
            f"s = {s[k] / MM:.3f} mm (gridpoint {k}): the bound or limits stop the motion"
        )
    dt = 2 * ds / vsum
    u = (x[1:] - x[:-1]) / (2 * ds)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    coeffs = np.stack([0.5 * u, v[:-1], s[:-1]])
    return PPoly(coeffs, t), u


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


def _constraints(problem: ScheduleProblem, grid: np.ndarray, v_node: np.ndarray,
                 a_max: float, use_joint_limits: bool) -> list:
    """toppra constraints in mm: per-gridpoint bounds on x = sdot^2 and u = sddot, and the
    joint accelerations on every sample interval (rows normalised to limit 1)."""
    xbound = np.column_stack([np.zeros(v_node.size), (v_node * MM_PER_M) ** 2])
    ubound = None
    if np.isfinite(a_max):
        ubound = np.tile([-a_max * MM_PER_M, a_max * MM_PER_M], (v_node.size, 1))
    constraints = [_feed_bound_constraint(xbound, ubound)]
    if use_joint_limits:
        constraints.append(_joint_acceleration_constraint(*constant_accel_rows(
            problem, grid, scale=MM_PER_M)))
    return constraints


def _joint_acceleration_constraint(rows_a: np.ndarray, rows_b: np.ndarray):
    """A toppra LinearConstraint ``-1 <= rows_a[k] u + rows_b[k] x <= 1`` at gridpoint k
    (collocation: u is the grid interval's constant sddot, x = sdot^2 at its start): the
    joint accelerations over the whole interval (:func:`constant_accel_rows`)."""
    from toppra.constraint import DiscretizationType, LinearConstraint

    m = rows_a.shape[1]
    f = np.vstack([np.eye(m), -np.eye(m)])
    g = np.ones(2 * m)

    class _JointAcceleration(LinearConstraint):
        def __init__(self):
            super().__init__()
            self.dof = 0
            self.identical = True
            self.discretization_type = DiscretizationType.Collocation
            self._format_string = "    joint accelerations between the gridpoints (Bernstein)\n"

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            return rows_a, rows_b, np.zeros_like(rows_a), f, g, None, None

    return _JointAcceleration()


#: Gridpoints per toppra instance: a longer grid is solved in windows of this many
#: (:func:`_solve_toppra`), so that toppra's per-gridpoint arrays (about 2.5 kB per
#: gridpoint while an instance is built) stay ~80 MB however long the path.
TOPPRA_WINDOW = 1 << 15


class _GridInterval:
    """The path toppra is given: every constraint here is given per gridpoint
    (:func:`_constraints`), so toppra only checks the gridpoints against the path's
    interval; q(s) is never evaluated (calling it is an error)."""

    def __init__(self, s_first: float, s_last: float, dof: int):
        self.path_interval = np.array([s_first, s_last])
        self.dof = dof

    def __call__(self, path_positions, order: int = 0):
        raise NotImplementedError("toppra evaluated q(s): a constraint needs the path")


def _windows(n_grid: int, window: int) -> list[tuple[int, int]]:
    """Gridpoint ranges ``(a, b)`` (both included) of at most ``window + 1`` gridpoints that
    cover ``0 .. n_grid - 1``, neighbours sharing their boundary gridpoint."""
    cuts = list(range(0, n_grid - 1, window)) + [n_grid - 1]
    return list(zip(cuts[:-1], cuts[1:], strict=True))


def _instance(problem: ScheduleProblem, grid: np.ndarray, v_node: np.ndarray, a_max: float):
    """A TOPP-RA (seidel) instance on the gridpoints ``grid`` (sample indices) in mm."""
    import toppra.algorithm as algo

    s_mm = problem.s[grid] * MM_PER_M
    return algo.TOPPRA(
        _constraints(problem, grid, v_node, a_max, use_joint_limits=True),
        _GridInterval(s_mm[0], s_mm[-1], problem.q.shape[1]), gridpoints=s_mm,
        solver_wrapper="seidel", parametrizer="ParametrizeConstAccel")


def _solve_toppra(problem: ScheduleProblem, grid: np.ndarray, v_node: np.ndarray,
                  a_max: float, window: int = TOPPRA_WINDOW):
    """TOPP-RA (seidel) on the gridpoints ``grid`` (sample indices), ``v_node`` [m/s] their
    feed bounds.

    A grid longer than ``window`` is solved in windows with toppra's own two passes: the
    controllable sets from the last window to the first (each window's final set is the
    first set of the window after it), then the forward pass window by window (each starts
    where the previous ended), given the controllable sets found. That is Algorithm 1 of
    Pham & Pham (2018) unchanged, K_i depends on K_(i+1) and x_(i+1) on x_i only, so the
    profile is the whole grid's (up to the rounding of sdot = sqrt(x) at the window
    boundaries), in a fraction of the memory.

    Returns ``(sdot [mm/s] at the gridpoints, return code name, solve time [s])``; raises
    InputError when toppra finds no parameterisation.
    """
    spans = _windows(grid.size, window)
    sd_end = problem.v_end * MM_PER_M
    t_solve, k_sets = 0.0, [None] * len(spans)
    if len(spans) > 1:  # the controllable sets, last window first
        k_end = np.array([sd_end, sd_end])
        for w in range(len(spans) - 1, -1, -1):
            a, b = spans[w]
            inst = _instance(problem, grid[a:b + 1], v_node[a:b + 1], a_max)
            t0 = time.perf_counter()
            k_sets[w] = inst.compute_controllable_sets(*k_end)
            t_solve += time.perf_counter() - t0
            _check_toppra(k_sets[w], "FailUncontrollable")
            k_end = np.sqrt(np.maximum(k_sets[w][0], 0.0))
    sd = np.empty(grid.size)
    sd_start, code = problem.v_start * MM_PER_M, "Ok"
    for w, (a, b) in enumerate(spans):
        inst = _instance(problem, grid[a:b + 1], v_node[a:b + 1], a_max)
        if k_sets[w] is not None:  # toppra's forward pass into the sets found above
            inst.compute_controllable_sets = lambda _lo, _hi, k=k_sets[w]: k
        t0 = time.perf_counter()
        _, sd_w, _ = inst.compute_parameterization(sd_start, sd_end)
        t_solve += time.perf_counter() - t0
        code = inst.problem_data.return_code
        _check_toppra(sd_w, code)
        sd[a:b + 1] = sd_w
        sd_start = float(sd_w[-1])
    return sd, getattr(code, "name", str(code)), t_solve


def _check_toppra(values: np.ndarray | None, code) -> None:
    """InputError when toppra found no parameterisation (``values`` None or NaN)."""
    if values is None or np.any(np.isnan(values)):
        raise InputError(
            f"toppra found no feasible parameterisation ({code}): "
            "the boundary feeds, the feed bound and the acceleration limits are inconsistent"
        )


def plan_topp(problem: ScheduleProblem, options: ToppOptions | None = None) -> Trajectory:
    """Time-optimal timing law by toppra (TOPP-RA, seidel solver; Pham & Pham 2018).

    Parameters
    ----------
    problem : ScheduleProblem
        Path samples, feed bound and limits.
    options : ToppOptions, optional
        Gridpoints and which limits toppra imposes (default: every sample, all limits).

    Returns
    -------
    Trajectory
        ``law="topp"``, piecewise quadratic s(t), ``continuity=1``, :class:`ToppStats`.
    """
    options = ToppOptions() if options is None else options
    t_start = time.perf_counter()
    v_sample = sample_feed_bound(problem)
    check_positive_bound("topp", problem, v_sample)
    check_boundary_feeds("topp", problem, v_sample[0], v_sample[-1])

    grid = uniform_grid(problem.n, options.max_gridpoints)
    _, v_node = grid_bounds(v_sample, grid)
    s_grid = problem.s[grid]
    a_max = float(problem.accel_max) if options.use_accel_limit else np.inf
    x = forward_backward_profile(s_grid, v_node, problem.v_start, problem.v_end, a_max)
    method, return_code, t_solve = ToppMethod.FORWARD_BACKWARD, "Ok", 0.0
    joint_ratio = _joint_ratio(problem, grid, x) if options.use_joint_limits else None
    if joint_ratio is not None and joint_ratio > 1.0:
        method = ToppMethod.TOPPRA
        x, return_code, t_solve = _toppra_profile(problem, grid, v_node, a_max)
        joint_ratio = _joint_ratio(problem, grid, x)
    timing, u = piecewise_quadratic_timing(s_grid, x)

    solver = ("toppra (TOPP-RA, seidel)" if method is ToppMethod.TOPPRA else
              "the exact forward-backward pass (the joint accelerations hold on it, so it is "
              "toppra's optimum too)")
    notes = [
        f"{solver} on {grid.size} gridpoints; s(t) is piecewise quadratic (constant sddot "
        "between gridpoints), so it is C1 only: the tangential acceleration jumps at "
        "gridpoints.",
        "feed bound imposed per gridpoint as the minimum of v_max over the neighbouring "
        "intervals, so it also holds on every fine sample between gridpoints.",
    ]
    jumps = np.abs(np.diff(u)) if u.size > 1 else np.zeros(0)
    stats = ToppStats(
        gridpoints=int(grid.size),
        solver=method.value,
        toppra_time_s=t_solve,
        planning_time_s=time.perf_counter() - t_start,
        max_accel_jump_m_s2=float(jumps.max(initial=0.0)),
        lower_bound_s=problem.lower_bound_time(),
        joint_acceleration_ratio=joint_ratio,
        return_code=return_code,
        method=method,
    )
    if stats.joint_acceleration_exceeded:
        notes.append(
            f"joint acceleration reaches {stats.joint_acceleration_ratio:.4f} of its limit "
            "(toppra's tolerance)"
        )
    return Trajectory(law="topp", timing=timing, continuity=1, notes=tuple(notes), stats=stats)


def _toppra_profile(
    problem: ScheduleProblem, grid: np.ndarray, v_node: np.ndarray, a_max: float
) -> tuple[np.ndarray, str, float]:
    """x = sdot^2 [m^2/s^2] at the gridpoints by toppra with the joint acceleration limits,
    its return code name and solve time [s]. The rounding-level excess of toppra's output
    over the gridpoint bound and the acceleration limit is clipped."""
    s_grid = problem.s[grid]
    sd_mm, return_code, t_solve = _solve_toppra(problem, grid, v_node, a_max)
    x = (sd_mm / MM_PER_M) ** 2
    x = np.minimum(x, v_node**2)
    x[0], x[-1] = problem.v_start**2, problem.v_end**2
    return limit_acceleration(x, s_grid, a_max), return_code, t_solve


def _joint_ratio(problem: ScheduleProblem, grid: np.ndarray, x: np.ndarray) -> float:
    """Largest |q'' sdot^2 + q' sddot| / limit of the constant-sddot profile through
    x = sdot^2 at the gridpoints, on every sample interval, not only at the gridpoints
    (:func:`~feedopt.schedule.joint_rows.constant_accel_ratio`)."""
    u = np.diff(x) / (2 * np.diff(problem.s[grid]))
    return constant_accel_ratio(problem, grid, x, u)
