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
"""

from __future__ import annotations

import math
import time

import numpy as np
import ruckig

from feedopt.errors import InputError
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.quintic import fit_length, ppoly_from_jerk_phases
from feedopt.schedule.trajectory import Trajectory

# Relative safety applied to caps and to the distances of the junction passes, so ruckig is
# never asked for a motion exactly at the edge of feasibility.
_MARGIN = 1e-9


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


def plan_jerk(
    problem: ScheduleProblem,
    *,
    tolerance: float = 0.005,
) -> Trajectory:
    """Jerk-limited timing law under v_max(s) with ruckig (see the module docstring).

    Parameters
    ----------
    problem : ScheduleProblem
        Needs finite ``accel_max`` and ``jerk_max``. Joint acceleration limits are not
        imposed (only what v_max already contains); the checks report them.
    tolerance : float
        Largest relative variation of v_max inside one constant-cap section (time lost to
        the staircase is below it).
    """
    A, J = float(problem.accel_max), float(problem.jerk_max)
    if not (np.isfinite(A) and np.isfinite(J) and A > 0 and J > 0):
        raise InputError(
            f"jerk law: needs finite positive accel_max and jerk_max (got {A}, {J})"
        )
    if not 0 < tolerance < 0.5:
        raise InputError(f"jerk law: tolerance must be in (0, 0.5), got {tolerance}")
    s, v = problem.s, problem.v_max
    if np.any(v <= 0):
        i = int(np.argmin(v))
        raise InputError(f"jerk law: v_max must be > 0 (sample {i}: {v[i]})")
    t_start = time.perf_counter()

    b = _sections(v, tolerance)
    K = b.size - 1
    cap = np.minimum.reduceat(v, b[:-1])
    # reduceat covers [b_k, b_k+1); include the closing sample of each section
    cap = np.minimum(cap, v[b[1:]]) * (1.0 - _MARGIN)
    L = np.diff(s[b])

    vj = np.empty(K + 1)
    vj[1:-1] = np.minimum(cap[:-1], cap[1:])
    vj[0], vj[-1] = problem.v_start, problem.v_end
    for name, val, c in (("v_start", problem.v_start, cap[0]), ("v_end", problem.v_end, cap[-1])):
        if val > c / (1.0 - _MARGIN) * (1 + 1e-12):
            raise InputError(
                f"jerk law: {name} = {val * 1e3:.4g} mm/s exceeds the feed bound "
                f"{c * 1e3:.4g} mm/s at that end of the path"
            )
    vj[0] = min(vj[0], cap[0])
    vj[-1] = min(vj[-1], cap[-1])
    Ls = (L * (1.0 - _MARGIN)).tolist()
    vl = vj.tolist()
    for k in range(K - 1, -1, -1):  # backward: section k can brake to vj[k+1]
        r = _reach(vl[k + 1], Ls[k], A, J)
        if r < vl[k]:
            if k == 0:
                raise InputError(
                    f"jerk law: cannot brake from v_start = {vl[0] * 1e3:.4g} mm/s to "
                    f"{vl[1] * 1e3:.4g} mm/s within the first {Ls[0] * 1e3:.4g} mm"
                )
            vl[k] = r
    for k in range(K):  # forward: section k can reach vj[k+1]
        r = _reach(vl[k], Ls[k], A, J)
        if r < vl[k + 1]:
            if k == K - 1:
                raise InputError(
                    f"jerk law: cannot reach v_end = {vl[-1] * 1e3:.4g} mm/s within the "
                    f"last {Ls[-1] * 1e3:.4g} mm"
                )
            vl[k + 1] = r
    t_passes = time.perf_counter()

    otg = ruckig.Ruckig(1)
    traj = ruckig.Trajectory(1)
    inp = ruckig.InputParameter(1)
    inp.max_acceleration = [A]
    inp.max_jerk = [J]
    inp.min_velocity = [0.0]
    inp.current_position = [0.0]
    inp.current_acceleration = [0.0]
    inp.target_acceleration = [0.0]
    durations = np.empty((K, 7))
    jerks = np.empty((K, 7))
    caps = cap.tolist()
    for k in range(K):
        inp.current_velocity = [vl[k]]
        inp.target_position = [L[k]]
        inp.target_velocity = [vl[k + 1]]
        inp.max_velocity = [caps[k]]
        res = otg.calculate(inp, traj)
        if res != ruckig.Result.Working:
            raise RuntimeError(
                f"jerk law: ruckig returned {res} on section {k} (s = {s[b[k]] * 1e3:.4f}-"
                f"{s[b[k + 1]] * 1e3:.4f} mm, v {vl[k]:.6g} -> {vl[k + 1]:.6g} m/s, cap "
                f"{caps[k]:.6g} m/s)"
            )
        prof = traj.profiles[0][0]
        if prof.brake.duration > 0 or prof.accel.duration > 0:
            raise RuntimeError(f"jerk law: ruckig added a brake profile on section {k}")
        durations[k] = prof.t
        jerks[k] = prof.j
    t_ruckig = time.perf_counter()

    pp = ppoly_from_jerk_phases(durations.ravel(), jerks.ravel(), v0=vl[0])
    notes = []
    end_err = float(pp(pp.x[-1])) - problem.length
    pp = fit_length(pp, problem.length)
    if abs(end_err) > 1e-9 * max(1.0, problem.length):
        notes.append(f"integrated length differs from the path by {end_err:.3g} m")
    stats = {
        "n_sections": int(K),
        "tolerance": tolerance,
        "time_sections_passes_s": t_passes - t_start,
        "time_ruckig_s": t_ruckig - t_passes,
        "time_assemble_s": time.perf_counter() - t_ruckig,
        "length_error_m": end_err,
    }
    return Trajectory(law="jerk", timing=pp, continuity=2, notes=tuple(notes), stats=stats)
