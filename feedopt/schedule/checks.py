"""Kinematic checks of a trajectory against its problem (used by laws' tests and verify.py).

Everything is evaluated on the path samples (never only on a solver grid) and at the
polynomial breakpoints, where continuity is measured as left/right jumps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory

# Evaluation points per polynomial piece for the extrema of acceleration and jerk.
_POINTS_PER_PIECE = 9


@dataclass(frozen=True)
class TimingCheck:
    """Numbers that say whether a timing law respects the bounds it was given.

    ``feed_ratio`` is max over samples of sdot / v_max (<= 1 + rtol to pass). Jumps are the
    largest left/right differences at interior breakpoints; ``c2`` says the acceleration jump
    is at numerical-noise level.
    """

    duration: float
    lower_bound: float
    feed_ratio: float
    worst_sample: int
    max_feed: float
    min_feed_interior: float
    max_accel: float
    max_jerk: float
    velocity_jump: float
    accel_jump: float
    c2: bool
    joint_velocity_ratio: float
    joint_acceleration_ratio: float
    start_feed: float
    end_feed: float
    problems: tuple[str, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        """True when no bound is violated."""
        return not self.problems


def breakpoint_jumps(trajectory: Trajectory, order: int) -> np.ndarray:
    """|left - right| of the ``order``-th derivative of s(t) at each interior breakpoint."""
    pp = trajectory.timing
    if pp.x.size <= 2:
        return np.zeros(0)
    d = pp.derivative(order) if order > 0 else pp
    if d.c.shape[0] == 0:
        return np.zeros(pp.x.size - 2)
    h = np.diff(pp.x)[:-1]
    # left limit: end of piece i evaluated by Horner at h_i; right limit: constant term of i+1
    left = np.zeros(h.size)
    for row in d.c[:, :-1]:
        left = left * h + row
    right = d.c[-1, 1:]
    return np.abs(left - right)


def check_timing(
    trajectory: Trajectory,
    problem: ScheduleProblem,
    rtol: float = 1e-6,
    c2_tol: float | None = None,
    enforce_feed_bound: bool = True,
) -> TimingCheck:
    """Check feed bound, limits, boundary feeds and continuity of ``trajectory``.

    Parameters
    ----------
    rtol : float
        Relative tolerance on every bound (feed, acceleration, jerk, joint limits).
    enforce_feed_bound : bool
        False for the ``constant`` baseline, which by definition ignores v_max: its feed
        ratio is still measured but not counted as a problem.
    c2_tol : float, optional
        Largest acceleration jump [m/s^2] still counted as continuous; default
        ``1e-6 * max(1, max|sddot|)``, i.e. numerical noise.
    """
    pp = trajectory.timing
    problems: list[str] = []

    # Feed at the path samples (exact inverse of s(t)).
    t_samples = trajectory.time_at(problem.s)
    motion = trajectory.at(t_samples)
    ratio = motion.sdot / problem.v_max
    worst = int(np.argmax(ratio))
    if enforce_feed_bound and ratio[worst] > 1 + rtol:
        problems.append(
            f"feed {motion.sdot[worst] * 1e3:.6g} mm/s exceeds its bound "
            f"{problem.v_max[worst] * 1e3:.6g} mm/s at s = {problem.s[worst] * 1e3:.3f} mm "
            f"(sample {worst}, ratio {ratio[worst]:.6f})"
        )

    # Dense evaluation per piece for acceleration / jerk extrema.
    u = np.linspace(0.0, 1.0, _POINTS_PER_PIECE)
    t_dense = (pp.x[:-1, None] + np.diff(pp.x)[:, None] * u[None, :]).ravel()
    dense = trajectory.at(t_dense)
    max_accel = float(np.max(np.abs(dense.sddot)))
    max_jerk = float(np.max(np.abs(dense.sdddot)))
    if max_accel > problem.accel_max * (1 + rtol):
        problems.append(
            f"tangential acceleration {max_accel:.6g} m/s^2 exceeds {problem.accel_max:.6g}"
        )
    if np.isfinite(problem.jerk_max) and trajectory.continuity >= 2:
        if max_jerk > problem.jerk_max * (1 + rtol):
            problems.append(f"tangential jerk {max_jerk:.6g} m/s^3 exceeds {problem.jerk_max:.6g}")
    if np.min(dense.sdot) < -1e-9 * max(1.0, float(np.max(dense.sdot))):
        problems.append("the path velocity becomes negative (the tool would reverse)")

    v_jump = breakpoint_jumps(trajectory, 1)
    a_jump = breakpoint_jumps(trajectory, 2)
    s_jump = breakpoint_jumps(trajectory, 0)
    vj = float(v_jump.max(initial=0.0))
    aj = float(a_jump.max(initial=0.0))
    tol = c2_tol if c2_tol is not None else 1e-6 * max(1.0, max_accel)
    c2 = bool(aj <= tol and vj <= 1e-9 and s_jump.max(initial=0.0) <= 1e-12)
    if trajectory.continuity >= 2 and not c2:
        problems.append(f"claims C2 but the acceleration jumps by {aj:.3g} m/s^2")

    # Joint velocity and acceleration at the samples.
    qd = problem.dq_ds * motion.sdot[:, None]
    qdd = problem.d2q_ds2 * motion.sdot[:, None] ** 2 + problem.dq_ds * motion.sddot[:, None]
    jv = float(np.max(np.abs(qd) / problem.joint_velocity_max))
    ja = float(np.max(np.abs(qdd) / problem.joint_acceleration_max))
    if jv > 1 + rtol:
        problems.append(f"joint velocity reaches {jv:.4f} of its limit")
    if ja > 1 + rtol:
        problems.append(f"joint acceleration reaches {ja:.4f} of its limit")

    # Boundary feeds at the first and last instant (inverting a flat s(t) at rest is
    # ill-conditioned, so these are not taken from the sample inversion).
    ends = trajectory.at(np.array([pp.x[0], pp.x[-1]]))
    start, end = float(ends.sdot[0]), float(ends.sdot[1])
    for name, got, want in (("start", start, problem.v_start), ("end", end, problem.v_end)):
        if abs(got - want) > 1e-9 + rtol * abs(want):
            problems.append(f"{name} feed {got:.6g} m/s differs from the requested {want:.6g}")
    if abs(trajectory.length - problem.length) > 1e-9 + 1e-9 * problem.length:
        problems.append(
            f"covers {trajectory.length:.9g} m of a {problem.length:.9g} m path"
        )

    interior = motion.sdot[1:-1] if motion.sdot.size > 2 else motion.sdot
    return TimingCheck(
        duration=trajectory.duration,
        lower_bound=problem.lower_bound_time(),
        feed_ratio=float(ratio[worst]),
        worst_sample=worst,
        max_feed=float(np.max(dense.sdot)),
        min_feed_interior=float(np.min(interior)),
        max_accel=max_accel,
        max_jerk=max_jerk,
        velocity_jump=vj,
        accel_jump=aj,
        c2=c2,
        joint_velocity_ratio=jv,
        joint_acceleration_ratio=ja,
        start_feed=start,
        end_feed=end,
        problems=tuple(problems),
    )
