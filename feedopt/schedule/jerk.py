"""The ``jerk`` timing law: ruckig jerk-limited profiles that follow v_max(s) from below.

ruckig (Community edition) plans one time-optimal, jerk-limited motion between two states
with constant limits, so the path is split into sections with a constant velocity cap:

1. Sections: a greedy pass over the samples closes a section when the bound in it varies by
   more than ``tolerance`` (relative); its cap is the minimum of v_max over its samples
   (both end samples included), so where v_max is flat there are few sections and the time
   lost to the staircase is below ``tolerance``.
2. Junction feeds (acceleration 0 at every junction): at most both neighbouring caps, then a
   backward pass (every section can brake to the next junction feed within its length) and a
   forward pass (every section can reach it), using the closed-form distance of a jerk-limited
   velocity change (:func:`~feedopt.schedule.quintic.scurve_distance`) inverted exactly.
3. One ruckig call per section, from (0, v_k, 0) to (L_k, v_k+1, 0) with ``max_velocity =
   cap``, ``min_velocity = 0`` (it refuses rather than reverse), ``max_acceleration`` and
   ``max_jerk``. Its 7 constant-jerk phases (``Trajectory.profiles[0][0].t`` and ``.j``) are
   integrated in order into a piecewise-cubic s(t), so s(t) is C2 with |jerk| <= jerk_max and
   sdot <= cap <= v_max everywhere in the section.

Joint accelerations q'' = q_ss sdot^2 + q_s sddot are kept within their limits by splitting
each joint's budget: a share ``joint_acceleration_split`` goes to the velocity term (the bound
used for the sections is lowered to sqrt(share qdd_max / |q_ss|) per sample) and the rest to
the path acceleration (each section's ruckig acceleration limit is at most (1 - share)
qdd_max / max|q_s| over the section). |q_ss| and |q_s| are their bounds over the sample
intervals (:func:`feedopt.schedule.joints.interval_peaks`), not their values at the samples,
so |q''| <= qdd_max holds everywhere between the samples too, a sufficient condition (thesis
paths at cutting feeds never reach it; rapids round tight air corners and corners shorter
than a sample do). The joint velocity limits lower the bound the same way (|q_s| sdot), so
they too hold between the samples.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import ruckig
from pydantic import BaseModel, ConfigDict, Field

from feedopt.errors import InputError
from feedopt.schedule.checks import check_boundary_feeds, check_positive_bound
from feedopt.schedule.joints import IntervalPeaks, interval_peaks
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.quintic import fit_length, ppoly_from_jerk_phases
from feedopt.schedule.trajectory import LawStats, Trajectory, outcome
from feedopt.units import MM


class JerkOptions(BaseModel):
    """Tunables of the ``jerk`` law (ruckig sections)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    tolerance: float = Field(
        0.005, gt=0.0, lt=0.5, allow_inf_nan=False,
        description="largest relative variation of v_max inside one constant-cap section (the "
        "time lost to the staircase is below it)")
    joint_acceleration_split: float = Field(
        0.5, gt=0.0, lt=1.0, allow_inf_nan=False,
        description="share of each joint's acceleration limit given to the velocity term "
        "q_ss sdot^2 (the rest bounds the path acceleration term q_s sddot)")
    margin: float = Field(
        1e-9, ge=0.0, lt=1e-3, allow_inf_nan=False,
        description="relative safety applied to the section caps and to the distances of the "
        "junction passes, so ruckig is never asked for a motion at the edge of feasibility")


@dataclass(frozen=True)
class JerkStats(LawStats):
    """What the ``jerk`` law reports (``as_dict()``: its summary.json entry)."""

    n_sections: int
    tolerance: float
    time_sections_passes_s: float
    time_ruckig_s: float
    time_assemble_s: float
    length_error_m: float
    #: junction feeds the backward / forward passes lowered below both neighbouring caps
    junctions_lowered: int = outcome(0)


def _sections(v: np.ndarray, tolerance: float) -> np.ndarray:
    """Sample indices ``b_0 = 0 < b_1 < ... < b_K = n-1`` of sections whose bound varies by
    at most ``tolerance``: max(v) * (1 - tolerance) <= min(v) over ``[b_k, b_k+1]``."""
    vl = v.tolist()
    n = len(vl)
    out = [0]
    lo = hi = vl[0]
    keep = 1.0 - tolerance
    for i in range(1, n):
        x = vl[i]
        nlo = x if x < lo else lo
        nhi = x if x > hi else hi
        if nhi * keep > nlo and i - out[-1] > 1:
            # close the section at the previous sample; the new one starts there
            out.append(i - 1)
            a, b = vl[i - 1], x
            lo, hi = (a, b) if a < b else (b, a)
        else:
            lo, hi = nlo, nhi
    out.append(n - 1)
    return np.asarray(out)


def _reach(v_end: float, length: float, A: float, J: float) -> float:
    """Largest v0 >= v_end from which a jerk-limited change to ``v_end`` (zero accelerations
    at both ends) fits in ``length``: inverse of ``scurve_distance`` in closed form."""
    if length <= 0:
        return v_end
    # Case 1, no constant-acceleration phase: D = (2 vf + x^2) x / sqrt(J), x = sqrt(dv).
    # x^3 + p x - q = 0 with p = 2 vf > 0 has one real root (hyperbolic form, stable).
    p = 2.0 * v_end
    q = length * math.sqrt(J)
    if p > 1e-6 * q ** (2.0 / 3.0):
        x = 2.0 * math.sqrt(p / 3.0) * math.sinh(
            math.asinh(1.5 * q / p * math.sqrt(3.0 / p)) / 3.0
        )
    else:  # p ~ 0: x ~ q^(1/3), the Newton steps below add the small correction
        x = q ** (1.0 / 3.0)
    for _ in range(2):
        x -= (x * x * x + p * x - q) / (3.0 * x * x + p)
    dv = x * x
    if dv * J > A * A:
        # Case 2: D = (2 vf + dv) / 2 * (dv / A + A / J)
        b = 2.0 * v_end + A * A / J
        c = 2.0 * v_end * A * A / J - 2.0 * A * length
        dv = 0.5 * (-b + math.sqrt(b * b - 4.0 * c))
    return v_end + dv


def _check_inputs(problem: ScheduleProblem) -> tuple[float, float]:
    """Refuse limits and bounds ruckig cannot plan with; returns ``(accel_max, jerk_max)``."""
    A, J = float(problem.accel_max), float(problem.jerk_max)
    if not (np.isfinite(A) and np.isfinite(J) and A > 0 and J > 0):
        raise InputError(
            f"jerk law: needs finite positive accel_max and jerk_max (got {A}, {J})"
        )
    check_positive_bound("jerk", problem, problem.v_max)
    return A, J


def _section_caps(v: np.ndarray, tolerance: float, margin: float):
    """Sections (:func:`_sections`), the minimum of v_max over each (both end samples
    included) and the cap ruckig gets, ``(1 - margin)`` of it."""
    b = _sections(v, tolerance)
    low = np.minimum.reduceat(v, b[:-1])
    # reduceat covers [b_k, b_k+1); include the closing sample of each section
    low = np.minimum(low, v[b[1:]])
    return b, low, low * (1.0 - margin)


def joint_caps(problem: ScheduleProblem, share: float, peaks: IntervalPeaks) -> np.ndarray:
    """Per sample, the feed [m/s] at which a joint reaches its velocity limit or the velocity
    term |q_ss| sdot^2 uses ``share`` of its acceleration limit (``inf`` where the joint path
    is straight), with |q_s| and |q_ss| as a per-sample bound must take them
    (:meth:`IntervalPeaks.at_samples` of ``peaks``): a feed under the caps of an interval's
    ends keeps both within on all of it."""
    dq, d2q = peaks.at_samples(problem)
    qd = np.asarray(problem.joint_velocity_max, dtype=float)
    qdd = share * np.asarray(problem.joint_acceleration_max, dtype=float)
    with np.errstate(divide="ignore"):
        return np.minimum(np.min(qd / dq, axis=1), np.sqrt(np.min(qdd / d2q, axis=1)))


def section_accelerations(problem: ScheduleProblem, b: np.ndarray, A: float,
                          share: float, peaks: IntervalPeaks) -> np.ndarray:
    """Per section, the path acceleration limit: ``A``, or less where (1 - share) of a joint's
    acceleration limit over the largest |q_s| in the section (between its samples too:
    ``peaks``) is smaller."""
    peak = np.maximum.reduceat(peaks.dq_ds, b[:-1], axis=0)
    qdd = (1.0 - share) * np.asarray(problem.joint_acceleration_max, dtype=float)
    with np.errstate(divide="ignore"):
        return np.minimum(A, np.min(qdd / peak, axis=1))


def _junction_feeds(problem: ScheduleProblem, cap: np.ndarray, L: np.ndarray, A: np.ndarray,
                    J: float, margin: float) -> list[float]:
    """Feeds at the section junctions (acceleration 0 there).

    At most both neighbouring caps; then a backward pass (every section can brake to the
    next junction feed within ``(1 - margin)`` of its length) and a forward pass (every
    section can reach it), with the exact inverse :func:`_reach` of the S-curve distance.
    ``A`` is the acceleration limit of each section.
    """
    K = cap.size
    vj = np.empty(K + 1)
    vj[1:-1] = np.minimum(cap[:-1], cap[1:])
    vj[0] = min(problem.v_start, cap[0])
    vj[-1] = min(problem.v_end, cap[-1])
    Ls = (L * (1.0 - margin)).tolist()
    vl = vj.tolist()
    for k in range(K - 1, -1, -1):  # backward: section k can brake to vj[k+1]
        r = _reach(vl[k + 1], Ls[k], A[k], J)
        if r < vl[k]:
            if k == 0:
                raise InputError(
                    f"jerk law: cannot brake from v_start = {vl[0] / MM:.4g} mm/s to "
                    f"{vl[1] / MM:.4g} mm/s within the first {Ls[0] / MM:.4g} mm"
                )
            vl[k] = r
    for k in range(K):  # forward: section k can reach vj[k+1]
        r = _reach(vl[k], Ls[k], A[k], J)
        if r < vl[k + 1]:
            if k == K - 1:
                raise InputError(
                    f"jerk law: cannot reach v_end = {vl[-1] / MM:.4g} mm/s within the "
                    f"last {Ls[-1] / MM:.4g} mm"
                )
            vl[k + 1] = r
    return vl


def _ruckig_phases(s_from: np.ndarray, s_to: np.ndarray, vl: list[float], cap: np.ndarray,
                   A: np.ndarray, J: float) -> tuple[np.ndarray, np.ndarray]:
    """One ruckig call per section, from ``(0, vl[k], 0)`` to ``(L_k, vl[k+1], 0)`` under
    ``cap[k]``; returns the ``(K, 7)`` durations and jerks of the constant-jerk phases."""
    L = s_to - s_from
    K = L.size
    otg = ruckig.Ruckig(1)
    traj = ruckig.Trajectory(1)
    inp = ruckig.InputParameter(1)
    inp.max_jerk = [J]
    inp.min_velocity = [0.0]
    inp.current_position = [0.0]
    inp.current_acceleration = [0.0]
    inp.target_acceleration = [0.0]
    durations = np.empty((K, 7))
    jerks = np.empty((K, 7))
    caps = cap.tolist()
    accels = A.tolist()
    for k in range(K):
        inp.max_acceleration = [accels[k]]
        inp.current_velocity = [vl[k]]
        inp.target_position = [L[k]]
        inp.target_velocity = [vl[k + 1]]
        inp.max_velocity = [caps[k]]
        res = otg.calculate(inp, traj)
        if res != ruckig.Result.Working:
            raise RuntimeError(
                f"jerk law: ruckig returned {res} on section {k} (s = {s_from[k] / MM:.4f}-"
                f"{s_to[k] / MM:.4f} mm, v {vl[k] / MM:.6g} -> {vl[k + 1] / MM:.6g} mm/s, "
                f"cap {caps[k] / MM:.6g} mm/s)"
            )
        prof = traj.profiles[0][0]
        if prof.brake.duration > 0 or prof.accel.duration > 0:
            raise RuntimeError(f"jerk law: ruckig added a brake profile on section {k}")
        durations[k] = prof.t
        jerks[k] = prof.j
    return durations, jerks


def plan_jerk(problem: ScheduleProblem, options: JerkOptions | None = None) -> Trajectory:
    """Jerk-limited timing law under v_max(s) with ruckig (see the module docstring).

    Parameters
    ----------
    problem : ScheduleProblem
        Needs finite ``accel_max`` and ``jerk_max``. Joint acceleration limits are kept by
        splitting them between the velocity and the path-acceleration terms (module
        docstring).
    options : JerkOptions, optional
        Section tolerance and safety margin (default: :class:`JerkOptions`).

    Returns
    -------
    Trajectory
        ``law="jerk"``, piecewise cubic, ``continuity=2``, :class:`JerkStats`.
    """
    options = JerkOptions() if options is None else options
    A, J = _check_inputs(problem)
    s = problem.s
    share = options.joint_acceleration_split
    peaks = interval_peaks(problem)
    v = np.minimum(problem.v_max, joint_caps(problem, share, peaks))
    t_start = time.perf_counter()

    b, low, cap = _section_caps(v, options.tolerance, options.margin)
    check_boundary_feeds("jerk", problem, low[0], low[-1])
    L = np.diff(s[b])
    accel = section_accelerations(problem, b, A, share, peaks)
    vl = _junction_feeds(problem, cap, L, accel, J, options.margin)
    t_passes = time.perf_counter()
    durations, jerks = _ruckig_phases(s[b[:-1]], s[b[1:]], vl, cap, accel, J)
    t_ruckig = time.perf_counter()

    pp = ppoly_from_jerk_phases(durations.ravel(), jerks.ravel(), v0=vl[0])
    notes = []
    end_err = float(pp(pp.x[-1])) - problem.length
    pp = fit_length(pp, problem.length)
    if abs(end_err) > 1e-9 * max(1.0, problem.length):
        notes.append(f"integrated length differs from the path by {end_err:.3g} m")
    junction_cap = np.minimum(cap[:-1], cap[1:])
    stats = JerkStats(
        n_sections=int(cap.size),
        tolerance=options.tolerance,
        time_sections_passes_s=t_passes - t_start,
        time_ruckig_s=t_ruckig - t_passes,
        time_assemble_s=time.perf_counter() - t_ruckig,
        length_error_m=end_err,
        junctions_lowered=int(np.sum(np.asarray(vl[1:-1]) < junction_cap)),
    )
    return Trajectory(law="jerk", timing=pp, continuity=2, notes=tuple(notes), stats=stats)
