"""Joint limits between the samples: corners shorter than a sample (issue 28).

A corner blend shorter than the sample spacing makes the joint spline q(s) through the samples
turn within one sample interval: q'' spikes at a sample and the joint acceleration
q' sddot + q'' sdot^2 peaks between samples. Every law is planned on such paths and replayed
here independently of feedopt's checks: q(s) is a scipy CubicSpline built here through the
joint positions of a closed-form planar 2R arm (or, end to end, the run's own joint spline),
s(t) is evaluated on a uniform time grid fine enough for 24+ instants per sample interval,
and the joint velocities and accelerations are central finite differences of q(s(t)) in
time. Tolerance 1e-3 of the limit: the finite differences' error (step^2 / 12 times the
fourth time derivative, about 1e-4 of the limit here), not a slack on the laws.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import yaml
from scipy.interpolate import CubicSpline, PPoly

from feedopt.errors import LawNotApplicable
from feedopt.geometry.path import build_lipb_path
from feedopt.schedule.checks import Violation, check_timing
from feedopt.schedule.convex import ConvexOptions, plan_convex
from feedopt.schedule.joint_rows import NodeGrid, node_model_rows
from feedopt.schedule.joints import dense_joint_extrema, interval_peaks
from feedopt.schedule.laws import law_names, plan_law
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM
from tests.conftest import ROOT

#: Finite-difference tolerance on |joint rate| / limit (see the module docstring).
FD_RTOL = 1e-3
SPACING = 0.25 * MM
LINKS = (0.5, 0.45)  # [m]
BASE = np.array([0.55, 0.25])  # where the path's origin lies in the arm's plane [m]


def two_link_ik(xy: np.ndarray) -> np.ndarray:
    """Closed-form inverse kinematics of a planar 2R arm (elbow down): (n, 2) -> (n, 2) rad."""
    a, b = LINKS
    x, y = xy[:, 0], xy[:, 1]
    c2 = (x * x + y * y - a * a - b * b) / (2 * a * b)
    q2 = np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(y, x) - np.arctan2(b * np.sin(q2), a + b * np.cos(q2))
    return np.column_stack([q1, q2])


def zigzag_problem(blend_mm: float = 0.03, programmed: bool = False) -> tuple[
        ScheduleProblem, CubicSpline]:
    """A zigzag of 8 mm lines with 90 deg corners blended with ``blend_mm`` (varying radius,
    far shorter than the 0.25 mm samples), q(s) from the 2R arm's IK at the samples through
    a CubicSpline built here. Feeds up to 40 mm/s, joint accelerations limited to 2 rad/s^2:
    at a corner q'' ~ 6000 rad/m^2, so the limit binds there (the feed must drop to ~18 mm/s).
    """
    pts = [(0.0, 0.0)]
    for k in range(6):
        x = 8.0 if k % 2 == 0 else 0.0
        pts += [(x, pts[-1][1]), (x, pts[-1][1] + 1.0)]
    way = np.array(pts[:-1]) * MM
    path = build_lipb_path(np.column_stack([way, np.zeros(len(way))]), "varying_radius",
                           blend_mm * MM)
    n = int(np.ceil(path.length / SPACING)) + 1
    s = np.linspace(0.0, path.length, n)
    q = two_link_ik(path.evaluate(s).position[:, :2] + BASE)
    spline = CubicSpline(s, q, axis=0)
    v = np.full(n, 40.0 * MM)
    problem = ScheduleProblem(
        s=s, v_max=v, q=q, dq_ds=spline(s, 1), d2q_ds2=spline(s, 2),
        joint_velocity_max=np.array([1.0, 1.0]), joint_acceleration_max=np.array([2.0, 2.0]),
        accel_max=0.5, jerk_max=5.0, nominal_feed=8.0 * MM,
        segment_start=path.segment_start, segment_kind=path.segment_kind,
        programmed_feed=v.copy() if programmed else None)
    return problem, spline


def replayed_joint_ratios(trajectory: Trajectory, s_of: np.ndarray, q_of_s: CubicSpline,
                          qd_max: np.ndarray, qdd_max: np.ndarray, length: float,
                          points: int = 24) -> tuple[float, float]:
    """Largest |q_dot| / limit and |q_ddot| / limit of q(s(t)) by central finite differences
    on a uniform time grid with at least ``points`` instants per sample interval (the feed
    never exceeds ``max feed``, so a sample interval lasts at least spacing / max feed)."""
    pp = trajectory.timing
    v_top = float(np.max(pp.derivative(1)(np.linspace(pp.x[0], pp.x[-1], 20001))))
    dt = float(np.min(np.diff(s_of))) / (1.05 * v_top) / points
    t = np.arange(pp.x[0] + dt, pp.x[-1] - dt, dt)
    q = q_of_s(np.clip(pp(np.concatenate([t - dt, t, t + dt])), 0.0, length))
    before, now, after = np.split(q, 3)
    qd = (after - before) / (2 * dt)
    qdd = (after - 2 * now + before) / (dt * dt)
    return float(np.max(np.abs(qd) / qd_max)), float(np.max(np.abs(qdd) / qdd_max))


def _plan(law: str, problem: ScheduleProblem) -> Trajectory:
    try:
        return plan_law(law, problem)
    except LawNotApplicable as exc:
        pytest.skip(f"{law} declines this path: {exc}")


@pytest.mark.parametrize("law", law_names())
def test_every_law_keeps_the_joint_limits_between_samples(law: str) -> None:
    problem, q_of_s = zigzag_problem(programmed=law == "programmed")
    traj = _plan(law, problem)
    vel, acc = replayed_joint_ratios(traj, problem.s, q_of_s, problem.joint_velocity_max,
                                     problem.joint_acceleration_max, problem.length)
    check = check_timing(traj, problem, enforce_feed_bound=law != "constant")
    joint_flags = Violation.JOINT_VELOCITY | Violation.JOINT_ACCELERATION
    if law == "thesis":  # holds one feed per line, ignoring the joints: verification says so
        assert acc <= 1 + FD_RTOL or Violation.JOINT_ACCELERATION in check.violations
        return
    assert acc <= 1 + FD_RTOL, (law, acc)
    assert vel <= 1 + FD_RTOL, (law, vel)
    assert not (check.violations & joint_flags), check.problems
    # the verifier's dense replay sees at least what the finite differences see (more where
    # the peak is on a sample, at the kink of q'' the uniform time grid steps over)
    assert check.joint_acceleration_ratio >= acc - FD_RTOL


def test_the_limit_binds_at_the_sub_sample_corners() -> None:
    """The test path is the hard case: at the feed bound the corners need 3x the joint
    acceleration limit, and the convex law slows there to meet it (not everywhere)."""
    problem, q_of_s = zigzag_problem()
    peak = np.max(np.abs(q_of_s(problem.s, 2)), axis=0)
    assert np.max(peak * (40 * MM) ** 2 / problem.joint_acceleration_max) > 3.0
    traj = plan_convex(problem, ConvexOptions(compare_topp=False))
    _, acc = replayed_joint_ratios(traj, problem.s, q_of_s, problem.joint_velocity_max,
                                   problem.joint_acceleration_max, problem.length)
    assert 0.98 < acc <= 1 + FD_RTOL
    assert np.max(traj.feed_at(problem.s)) > 39.9 * MM  # full feed on the lines


def test_a_coarse_solver_grid_still_keeps_them() -> None:
    """With fewer gridpoints than samples the SOCP's variables are not at the corner samples:
    the grid is refined there and the rows cover every sample interval."""
    problem, q_of_s = zigzag_problem()
    traj = plan_convex(problem, ConvexOptions(max_gridpoints=150, compare_topp=False))
    assert traj.stats.joint_refined_gridpoints > 0
    assert traj.stats.gridpoints < problem.n
    _, acc = replayed_joint_ratios(traj, problem.s, q_of_s, problem.joint_velocity_max,
                                   problem.joint_acceleration_max, problem.length)
    assert acc <= 1 + FD_RTOL


def test_the_dense_replay_finds_an_excess_between_samples() -> None:
    """Slow (5 mm/s) through a corner sample, then full acceleration: q'' falls linearly over
    the next interval while sdot^2 grows, so q'' sdot^2 + q' sddot peaks inside the interval,
    several times its value at the samples. The verifier's replay finds that peak (matching
    the finite differences of the independent spline) and a check at the samples would not."""
    whole, q_of_s = zigzag_problem()
    k = int(np.argmax(np.abs(q_of_s(whole.s, 2)[:, 1])[: whole.n // 2]))
    end = k + 4  # the path up to a little after that corner
    problem = replace(whole, s=whole.s[:end], v_max=whole.v_max[:end], q=whole.q[:end],
                      dq_ds=whole.dq_ds[:end], d2q_ds2=whole.d2q_ds2[:end])
    v0, u, sk = 5 * MM, 0.5, float(problem.s[k])
    t1 = sk / v0
    t2 = t1 + (np.sqrt(v0 * v0 + 2 * u * (problem.length - sk)) - v0) / u
    c = np.array([[0.0, u / 2], [v0, v0], [0.0, sk]])  # s = v0 t, then + u t^2 / 2
    traj = Trajectory("hand", PPoly(c, [0.0, t1, t2]), continuity=1)
    dense = dense_joint_extrema(traj, problem, traj.time_at(problem.s))
    _, acc = replayed_joint_ratios(traj, problem.s, q_of_s, problem.joint_velocity_max,
                                   problem.joint_acceleration_max, problem.length, points=400)
    assert dense.acceleration.ratio == pytest.approx(acc, rel=2e-3)
    assert dense.acceleration.interval == k and dense.acceleration.sample is None
    m = traj.at(traj.time_at(problem.s[k:k + 2]))
    qdd = (q_of_s(problem.s[k:k + 2], 2) * m.sdot[:, None] ** 2
           + q_of_s(problem.s[k:k + 2], 1) * m.sddot[:, None])
    at_ends = np.max(np.abs(qdd) / problem.joint_acceleration_max)
    assert dense.acceleration.ratio > 2 * at_ends


def test_interval_peaks_are_the_spline_maxima_between_samples() -> None:
    """|q'| and |q''| per sample interval against the spline evaluated at 400 points of each
    interval: never below (a bound), and equal to rounding (the exact extrema are taken)."""
    problem, q_of_s = zigzag_problem()
    peaks = interval_peaks(problem)
    u = np.linspace(0.0, 1.0, 400)
    s = problem.s[:-1, None] + np.diff(problem.s)[:, None] * u
    for k, got in ((1, peaks.dq_ds), (2, peaks.d2q_ds2)):
        dense = np.max(np.abs(q_of_s(s.ravel(), k)).reshape(s.shape + (2,)), axis=1)
        scale = np.max(dense, axis=0)
        assert np.all(got >= dense - 1e-12 * scale)
        assert np.all(got <= dense + 1e-4 * scale)  # the 400 points miss the peak by < 1e-4


@pytest.mark.parametrize(("first", "last", "seed"), [(40, 41, 0), (38, 44, 1), (100, 112, 2)])
def test_node_model_rows_hold_the_joint_acceleration_of_each_cell(first, last, seed) -> None:
    """One joint, one grid interval from 0.3 of sample interval ``first`` to 0.8 of ``last``
    (cut at the samples into cells), random node values: on every cell the node model's
    joint acceleration (computed here from the spline and the model's closed form) lies
    within the range of that cell's rows, and the rows at the cell ends are its values there
    (the shared end of two cells appears once)."""
    whole, q_of_s = zigzag_problem()
    problem = replace(whole, q=whole.q[:, 1:], dq_ds=whole.dq_ds[:, 1:],
                      d2q_ds2=whole.d2q_ds2[:, 1:], joint_velocity_max=np.ones(1),
                      joint_acceleration_max=np.full(1, 1e-9))
    s = problem.s
    g0 = s[first] + 0.3 * (s[first + 1] - s[first])
    g1 = s[last] + 0.8 * (s[last + 1] - s[last])
    rng = np.random.default_rng(seed)
    a0, a1 = rng.uniform(-0.5, 0.5, 2)
    b0 = rng.uniform(1e-4, 2e-3)
    grid = NodeGrid(s=np.array([g0, g1]), b_int=np.array([1.0]), a_cap=1.0,
                    qdd_max=np.full(1, 1e-9), rest_start=False, rest_end=False)
    rows = node_model_rows(problem, grid, interval_peaks(problem))
    b = np.array([b0, b0 + (a0 + a1) * (g1 - g0)])
    a = np.array([a0, a1])
    value = (rows.ca * a[rows.ia] + rows.ca1 * a[rows.ia1] + rows.cb * b[rows.ib]) * 1e-9
    cells = last - first + 1
    assert value.size == 4 * cells + 1
    bern = np.vstack([value[:4 * cells].reshape(4, cells),
                      np.append(value[1:cells], value[-1])[None, :]])  # (5, cells)
    edges = np.concatenate([[g0], s[first + 1:last + 1], [g1]])
    for c in range(cells):
        x = np.linspace(edges[c], edges[c + 1], 201)
        d, u = g1 - g0, x - g0
        acc = a0 + (a1 - a0) * u / d
        sdot2 = b0 + 2 * a0 * u + (a1 - a0) * u * u / d
        f = q_of_s(x, 1)[:, 1] * acc + q_of_s(x, 2)[:, 1] * sdot2
        span = np.max(np.abs(bern[:, c]))
        assert np.all(f >= bern[:, c].min() - 1e-9 * span)
        assert np.all(f <= bern[:, c].max() + 1e-9 * span)
        assert f[0] == pytest.approx(bern[0, c], abs=1e-9 * span)
        assert f[-1] == pytest.approx(bern[4, c], abs=1e-9 * span)


PROGRAM = """%
O2001 (ZIGZAG FACE, SUB-SAMPLE CORNERS)
(T1 D=6 CR=0 - ZMIN=-0.2 - flat end mill)
G21 G90 G94 G17
T1 M6
S12000 M3
G0 X0 Y0 Z5
G1 Z1 F1000
Z-0.2 F300
{passes}
G1 Z5 F1000
M5
M30
%
"""


def _zigzag_program(passes: int = 8, width_mm: float = 12.0, step_mm: float = 0.9) -> str:
    out, y = [], 0.0
    for k in range(passes):
        x = width_mm if k % 2 == 0 else 0.0
        out.append(f"G1 X{x:g} F1800" if k == 0 else f"X{x:g}")
        y += step_mm
        out.append(f"Y{y:g}")
    return PROGRAM.format(passes="\n".join(out))


def test_end_to_end_no_exported_law_exceeds_a_joint_limit(tmp_path) -> None:
    """A shallow zigzag face at F1800 (30 mm/s) with the KR500-3: the 0.9 mm step-overs are
    blended within 0.01 mm, far shorter than the 0.25 mm samples, and the joint acceleration
    limits bind there. Every exported law, replayed on the run's own joint spline, keeps them
    (before the fix convex and programmed broke them 5.4x and were not exported)."""
    from feedopt.runner import run_scenario

    program = tmp_path / "zigzag.nc"
    program.write_text(_zigzag_program())
    doc = yaml.safe_load((ROOT / "scenarios" / "pocket.yaml").read_text())
    doc.update(name="zigzag", tool=str(ROOT / "tests/data/gcode/posts/tool_6mm_2flute.yaml"),
               material=str(ROOT / "scenarios/materials/6061-T6511.yaml"),
               stock={"box_mm": [-10, -10, -5, 25, 20, 0], "cell_mm": 0.25},
               cut={"extrapolate_coefficients": True})
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["path"].update(file=str(program), spacing_mm=0.25)
    doc["schedule"]["laws"] = ["programmed", "topp", "convex", "jerk"]
    # a solver grid coarser than the samples, as on any program of more than 3000 samples
    # (0.75 m at this spacing), where the corner samples are not gridpoints
    doc["schedule"]["law_options"] = {law: {"max_gridpoints": 150}
                                      for law in ("convex", "programmed")}
    scen = tmp_path / "zigzag.yaml"
    scen.write_text(yaml.safe_dump(doc))
    res = run_scenario(scen, tmp_path / "out", progress=lambda _m: None, report=False)
    p = res.prepared
    problem = p.problem
    binding = 0.0
    exported = [law for law, entry in res.summary["laws"].items() if entry["exported"]]
    assert {"convex", "jerk"} <= set(exported)
    for law in exported:
        vel, acc = replayed_joint_ratios(res.laws[law].trajectory, problem.s, p.q_of_s,
                                         problem.joint_velocity_max,
                                         problem.joint_acceleration_max, problem.length)
        assert acc <= 1 + FD_RTOL and vel <= 1 + FD_RTOL, (law, vel, acc)
        binding = max(binding, acc)
    assert binding > 0.95  # the limits bind: the check is not vacuous
