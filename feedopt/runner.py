"""The scenario runner: the only place that wires the stages together (design.md).

scenario -> geometry -> process -> robot -> schedule (bounds, laws) -> verify -> export ->
report. Outputs are written to a temporary folder beside the destination and moved into
place only when everything succeeded, so a failed run never leaves partial outputs that
look complete.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from feedopt import outdir
from feedopt.errors import InputError
from feedopt.geometry.path import Path as ToolPath
from feedopt.geometry.path import PathPoints, build_lipb_path
from feedopt.geometry.waves import square_wave, straight_line, triangle_wave
from feedopt.geometry.waypoints import read_waypoints_csv
from feedopt.process.coefficients import (
    CoefficientTable,
    feed_per_tooth_warning,
    load_coefficients,
)
from feedopt.process.engagement import (
    Engagement,
    peripheral_engagement,
    radial_depth_profile,
    slot_engagement,
)
from feedopt.process.path_radius import check_path_radius
from feedopt.process.tool import Tool, load_tool
from feedopt.robot.ik import PathIK, solve_path_ik
from feedopt.robot.model import RobotModel, load_robot
from feedopt.robot.stiffness import translational_compliance
from feedopt.scenario import Scenario, load_scenario, resolve, scenario_warnings
from feedopt.schedule.bounds import FeedBound, feed_bound
from feedopt.schedule.deflection import DeflectionModel, feed_frames
from feedopt.schedule.laws import plan_law
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM
from feedopt.verify import Verification, is_finite, verify_trajectory

# Largest number of path samples a run plans (memory: ~2 kB per sample across the stages).
MAX_SAMPLES = 2_000_000
Progress = Callable[[str], None]


def _stderr_progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


@dataclass
class Prepared:
    """Everything upstream of the timing laws, in SI units and the robot base frame."""

    scenario: Scenario
    base_dir: Path
    path: ToolPath
    samples: PathPoints  # workpiece frame
    positions: np.ndarray  # (n, 3) TCP positions in the base frame [m]
    tool_axes: np.ndarray  # (n, 3) in the base frame
    frames: np.ndarray  # (n, 3, 3) force-model frame -> base
    tool: Tool
    coefficient_table: CoefficientTable  # the material file, all calibrated speeds
    robot: RobotModel
    ik: PathIK
    compliance: np.ndarray  # (n, 3, 3) [m/N]
    model: DeflectionModel
    bound: FeedBound
    problem: ScheduleProblem
    q_of_s: CubicSpline
    limit: float
    stage_times: dict[str, float] = field(default_factory=dict)
    # What the run does that the user should know (placeholder robot data, tight radii, an
    # export that will be skipped...): printed, in summary.json and in the report.
    warnings: list[str] = field(default_factory=list)
    # Why no KRL program is written for this run (None: it is written for the KRL laws).
    krl_blocker: str | None = None


@dataclass
class LawResult:
    trajectory: Trajectory
    verification: Verification
    planning_time: float
    verification_time: float = 0.0


def workpiece_transform(position_mm: list[float], rpy_deg: list[float]) -> np.ndarray:
    """Homogeneous transform of the workpiece frame W in the base frame B (extrinsic XYZ)."""
    r, p, y = np.deg2rad(rpy_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    t = np.eye(4)
    t[:3, :3] = rz @ ry @ rx
    t[:3, 3] = np.asarray(position_mm) * MM
    return t


def waypoints_of(scenario: Scenario, base_dir: Path) -> np.ndarray:
    """Waypoints [m] in the workpiece frame from the path section."""
    p = scenario.path
    if p.generator == "triangle_wave":
        w = triangle_wave(p.length_mm * MM, p.height_mm * MM, p.waves)
    elif p.generator == "square_wave":
        w = square_wave(p.length_mm * MM, p.height_mm * MM, p.waves)
    elif p.generator == "line":
        w = straight_line(np.asarray(p.start_mm) * MM, np.asarray(p.end_mm) * MM)
    else:
        w = read_waypoints_csv(resolve(base_dir, p.file, "path.file (waypoint CSV)"))
    w = np.array(w, dtype=float)
    if p.generator in ("triangle_wave", "square_wave"):
        w[:, 2] += p.z_mm * MM
    return w


def build_path(scenario: Scenario, base_dir: Path) -> ToolPath:
    """The scenario's path; geometry errors are prefixed with the scenario section."""
    p = scenario.path
    try:
        return build_lipb_path(waypoints_of(scenario, base_dir), p.blend, p.blend_size_mm * MM,
                               drop_repeated=p.drop_repeated_waypoints)
    except InputError as exc:
        msg = str(exc).replace("or pass drop_repeated=True (CLI: --drop-repeated)",
                               "or set path.drop_repeated_waypoints: true")
        raise InputError(f"path ({p.generator}, blend {p.blend} {p.blend_size_mm:g} mm): "
                         f"{msg}") from None


def engagement_of(scenario: Scenario, tool: Tool, s: np.ndarray) -> Engagement:
    """Per-sample engagement from the cut section."""
    cut = scenario.cut
    depth = cut.axial_depth_mm * MM
    if depth > tool.flute_length:
        raise InputError(
            f"cut.axial_depth_mm = {cut.axial_depth_mm:g} mm exceeds the flute length "
            f"{tool.flute_length / MM:g} mm of tool '{tool.name}'"
        )
    if cut.type == "slot":
        return slot_engagement(s.size, depth)
    try:
        return _peripheral(cut, tool, s, depth)
    except InputError as exc:
        field = ("cut.radial_depth_profile" if cut.radial_depth_profile is not None
                 else "cut.radial_depth_mm")
        raise InputError(f"{field}: {exc}") from None


def _peripheral(cut, tool: Tool, s: np.ndarray, depth: float) -> Engagement:
    if cut.radial_depth_profile is not None:
        prof = cut.radial_depth_profile
        table_s = (np.asarray(prof.s_mm) * MM if prof.s_mm is not None
                   else np.asarray(prof.s_fraction) * s[-1])
        radial = radial_depth_profile(s, table_s, np.asarray(prof.depth_mm) * MM)
    else:
        radial = np.full(s.size, cut.radial_depth_mm * MM)
    return peripheral_engagement(radial, tool.diameter, depth, cut.milling)


def _segment_names(path: ToolPath) -> list[str]:
    """Readable name of each path segment for messages ("line 3", "circle blend of corner 2")."""
    return [f"line {i}" if seg.kind == "line" else
            f"{seg.kind} blend of corner {seg.corner_index}" for i, seg in enumerate(path.segments)]


def _krl_blocker(robot: RobotModel, path: ToolPath) -> str | None:
    """Why the run will not write a KRL program, known before any planning."""
    from feedopt.export.krl import MAX_SEGMENTS

    if robot.controller != "kuka":
        return (f"no KRL program: robot {robot.name} has controller '{robot.controller}' "
                "(robot.yaml), KRL is for KUKA controllers")
    n_segments = sum(1 if seg.kind == "line" else 2 for seg in path.segments)
    if n_segments > MAX_SEGMENTS:
        return (f"no KRL program: the path's key points make {n_segments} spline segments, "
                f"more than the {MAX_SEGMENTS} a KSS 8.x SPLINE block holds; the RSI CSVs are "
                "written as usual")
    return None


def _feed_range_warnings(table, scenario: Scenario, tool: Tool, v_max: np.ndarray) -> list[str]:
    """Feeds per tooth the run uses (nominal, max, lowest of the bound) that leave the range
    the cutting coefficients were calibrated on."""
    per_tooth = 1.0 / (scenario.cut.spindle_rpm / 60.0 * tool.teeth)  # s per tooth pass
    feed = scenario.feed
    checks = [("feed.nominal_mm_s", feed.nominal_mm_s * MM)]
    if feed.max_mm_s is not None:
        checks.append(("feed.max_mm_s", feed.max_mm_s * MM))
    interior = v_max[1:-1] if v_max.size > 2 else v_max
    checks.append(("the lowest feed of the bound", float(np.min(interior))))
    out = []
    for what, v in checks:
        text = feed_per_tooth_warning(table, v * per_tooth)
        if text:
            out.append(f"{what} ({v / MM:.4g} mm/s): {text}")
    return out


def prepare(
    scenario: Scenario,
    base_dir: Path,
    progress: Progress = _stderr_progress,
    spacing_mm: float | None = None,
) -> Prepared:
    """Run the geometry, process, robot and bound stages of ``scenario``."""
    times: dict[str, float] = {}
    spacing = (spacing_mm or scenario.path.spacing_mm) * MM

    t0 = time.perf_counter()
    path = build_path(scenario, base_dir)
    n_samples = path.length / spacing + 1
    if n_samples > MAX_SAMPLES:
        raise InputError(
            f"path.spacing_mm = {spacing / MM:g} mm gives {n_samples:.3g} samples on the "
            f"{path.length / MM:.1f} mm path; at most {MAX_SAMPLES:.0e} are planned (use "
            f"a spacing of at least {path.length / MM / (MAX_SAMPLES - 1):.2g} mm)"
        )
    samples = path.sample(spacing)
    warnings = scenario_warnings(scenario)
    times["geometry"] = time.perf_counter() - t0
    progress(f"[1/5] geometry: {len(path.segments)} segments, {path.length / MM:.2f} mm, "
             f"{samples.s.size} samples ({times['geometry']:.2f} s)")

    t0 = time.perf_counter()
    tw = workpiece_transform(scenario.workpiece.position_mm, scenario.workpiece.rpy_deg)
    rot = tw[:3, :3]
    positions = samples.position @ rot.T + tw[:3, 3]
    axis_w = np.asarray(scenario.workpiece.tool_axis, dtype=float)
    if np.linalg.norm(axis_w) < 1e-12:
        raise InputError("workpiece.tool_axis must be a non-zero vector")
    axis = np.broadcast_to(rot @ (axis_w / np.linalg.norm(axis_w)), positions.shape).copy()
    tangents = samples.tangent @ rot.T
    along = np.abs(np.sum(tangents * axis, axis=1))
    if np.any(along > 1 - 1e-6):
        i = int(np.argmax(along))
        raise InputError(f"the path runs along the tool axis at sample {i} "
                         f"(s = {samples.s[i] / MM:.3f} mm): milling needs a feed direction "
                         "across the tool axis")
    frames = feed_frames(tangents, axis)
    tool = load_tool(resolve(base_dir, scenario.tool, "tool file"))
    table = load_coefficients(resolve(base_dir, scenario.material, "material file"))
    coeffs = table.at(scenario.cut.spindle_rpm, extrapolate=scenario.cut.extrapolate_coefficients)
    engagement = engagement_of(scenario, tool, samples.s)
    warnings += check_path_radius(samples.s, samples.curvature, samples.segment,
                                  _segment_names(path), 0.5 * tool.diameter)
    times["process"] = time.perf_counter() - t0
    progress(f"[2/5] process: tool {tool.name}, {scenario.cut.type} cut at "
             f"{scenario.cut.spindle_rpm:g} rpm ({times['process']:.2f} s)")

    t0 = time.perf_counter()
    robot = load_robot(resolve(base_dir, scenario.robot.directory, "robot directory"))
    q_start = np.deg2rad(scenario.robot.start_configuration_deg)
    x_axes = None
    if scenario.robot.fix_tool_rotation:
        x_axes = np.broadcast_to(rot[:, 0], positions.shape).copy()
    ik = solve_path_ik(robot, positions, axis, q_start, x_axes=x_axes)
    compliance = translational_compliance(robot, ik.q, scenario.robot.stiffness)
    q_of_s = CubicSpline(samples.s, ik.q, axis=0)
    warnings += [f"robot {robot.name}: {w}" for w in robot.data_warnings]
    krl_blocker = _krl_blocker(robot, path)
    times["robot"] = time.perf_counter() - t0
    progress(f"[3/5] robot: {robot.name}, IK on {samples.s.size} samples, max condition "
             f"number {np.max(ik.condition_number):.1f} ({times['robot']:.2f} s)")

    t0 = time.perf_counter()
    limits = scenario.limits
    step = np.deg2rad(scenario.schedule.angle_step_deg)
    pitch = 2.0 * np.pi / tool.teeth  # forces repeat every tooth pitch
    angles = np.arange(0.0, pitch - 1e-12, step)
    model = DeflectionModel(
        tool=tool,
        coefficients=coeffs,
        engagement=engagement,
        angles=angles,
        frames=frames,
        compliance=compliance,
        rpm=scenario.cut.spindle_rpm,
        mode=scenario.deflection.mode,
        direction=(np.asarray(scenario.deflection.direction, dtype=float)
                   if scenario.deflection.direction is not None else None),
        axial_slices=scenario.schedule.axial_slices,
    )
    limit = scenario.deflection.limit_mm * MM
    feed = scenario.feed
    max_feed = (feed.max_mm_s if feed.max_mm_s is not None else feed.nominal_mm_s) * MM
    qd_max = robot.joint_velocity_max * limits.joint_velocity_scale
    qdd_max = robot.joint_acceleration_max * limits.joint_acceleration_scale
    dq_ds = q_of_s(samples.s, 1)
    bound = feed_bound(
        model,
        limit,
        max_feed,
        dq_ds,
        qd_max,
        torque_max=limits.spindle_torque_nm,
        power_max=limits.spindle_power_w,
        positions=positions,
    )
    for name, v in (("start", feed.start_mm_s), ("end", feed.end_mm_s)):
        i = 0 if name == "start" else -1
        if v * MM > bound.v_max[i] * (1 + 1e-9):
            raise InputError(f"feed.{name}_mm_s = {v:g} mm/s exceeds the feed bound "
                             f"{bound.v_max[i] / MM:.4g} mm/s at the path {name}")
    problem = ScheduleProblem(
        s=samples.s,
        v_max=bound.v_max,
        q=ik.q,
        dq_ds=dq_ds,
        d2q_ds2=q_of_s(samples.s, 2),
        joint_velocity_max=qd_max,
        joint_acceleration_max=qdd_max,
        accel_max=limits.tangential_acceleration_mm_s2 * MM,
        jerk_max=limits.tangential_jerk_mm_s3 * MM,
        nominal_feed=feed.nominal_mm_s * MM,
        v_start=feed.start_mm_s * MM,
        v_end=feed.end_mm_s * MM,
        segment_start=path.segment_start,
        segment_kind=path.segment_kind,
        key_point_spacing=scenario.schedule.key_point_spacing_mm * MM,
    )
    times["bounds"] = time.perf_counter() - t0
    warnings += _feed_range_warnings(table, scenario, tool, bound.v_max)
    if krl_blocker is not None and robot.controller == "kuka":
        warnings.append(krl_blocker)
    for w in warnings:
        progress(f"warning: {w}")
    share = ", ".join(f"{k} {v:.0%}" for k, v in bound.active_fraction().items() if v > 0)
    progress(f"[4/5] bounds: v_max {bound.v_max.min() / MM:.3f}-{bound.v_max.max() / MM:.3f} "
             f"mm/s, T* = {problem.lower_bound_time():.2f} s; active: {share} "
             f"({times['bounds']:.2f} s)")
    return Prepared(
        scenario=scenario, base_dir=base_dir, path=path, samples=samples, positions=positions,
        tool_axes=axis, frames=frames, tool=tool, coefficient_table=table, robot=robot, ik=ik,
        compliance=compliance,
        model=model, bound=bound, problem=problem, q_of_s=q_of_s, limit=limit,
        stage_times=times, warnings=warnings, krl_blocker=krl_blocker,
    )


def plan_and_verify(
    prepared: Prepared, laws: list[str], progress: Progress = _stderr_progress
) -> dict[str, LawResult]:
    """Run each timing law, then replay-verify all of them in one pass over the forces."""
    context: dict = {}
    planned: dict[str, tuple[Trajectory, float]] = {}
    # topp first: convex reports its optimality gap to it.
    for law in sorted(laws, key=lambda law: 0 if law == "topp" else 1):
        t0 = time.perf_counter()
        planned[law] = (plan_law(law, prepared.problem, context), time.perf_counter() - t0)

    t0 = time.perf_counter()
    replayable = [law for law, (traj, _) in planned.items() if is_finite(traj)]
    replay = {}
    if replayable:
        feeds = np.stack([np.maximum(planned[law][0].feed_at(prepared.problem.s), 0.0)
                          for law in replayable])
        replay = dict(zip(replayable, prepared.model.deflection(feeds), strict=True))
    shared = (time.perf_counter() - t0) / max(len(replayable), 1)

    results: dict[str, LawResult] = {}
    for law, (traj, dt) in planned.items():
        t1 = time.perf_counter()
        ver = verify_trajectory(traj, prepared.problem, prepared.model, prepared.limit,
                                deflection=replay.get(law))
        results[law] = LawResult(trajectory=traj, verification=ver, planning_time=dt,
                                 verification_time=shared + time.perf_counter() - t1)
        if not ver.verified:
            status = "FAILED VERIFICATION"
        elif ver.exportable:
            status = "verified, exportable"
        else:
            status = "verified, not exportable: " + "; ".join(ver.export_blockers)
        progress(f"[5/5] {law}: {traj.duration:.2f} s cycle "
                 f"({traj.duration / prepared.problem.lower_bound_time():.4f} T*), max "
                 f"deflection {ver.max_deflection / MM:.4f} mm ({ver.deflection_ratio:.4f} of "
                 f"limit), {status} ({dt:.2f} s)")
        for problem in ver.problems:
            progress(f"      ! {law}: {problem}")
    return {law: results[law] for law in laws}


@dataclass
class RunResult:
    out_dir: Path
    prepared: Prepared
    laws: dict[str, LawResult]
    summary: dict
    table: str


def _time_series(prepared: Prepared, result: LawResult, cycle: float):
    """The timing law itself sampled at the RSI cycle, with joint velocities.

    For a law that is only C1 (toppra) the jerk is the finite difference of the sampled
    acceleration, i.e. what a controller stepping at this cycle would see, not the zero
    inside the polynomial pieces.
    """
    motion = result.trajectory.sample_uniform(cycle)
    jerk = motion.sdddot
    if result.trajectory.continuity < 2:
        jerk = np.gradient(motion.sddot, motion.t) if motion.t.size > 1 else motion.sdddot
    s = np.clip(motion.s, 0.0, prepared.problem.length)
    qd = prepared.q_of_s(s, 1) * motion.sdot[:, None]
    return motion, jerk, qd


def _rsi_rows(prepared: Prepared, motion):
    """Joint values and pose at the RSI samples: q interpolated along s, pose = FK(q)."""
    from feedopt.robot.model import forward_kinematics

    q = prepared.q_of_s(motion.s)
    pose = forward_kinematics(prepared.robot, q)
    # How far FK of the interpolated joints is from the exact path point (for the record).
    tw = workpiece_transform(prepared.scenario.workpiece.position_mm,
                             prepared.scenario.workpiece.rpy_deg)
    exact = prepared.path.evaluate(motion.s).position @ tw[:3, :3].T + tw[:3, 3]
    interp_error = float(np.max(np.linalg.norm(pose[:, :3, 3] - exact, axis=1)))
    return q, pose, interp_error


def _monotone_within_path(result: LawResult, length: float) -> bool:
    """s(t) stays in [0, L] (a reversing law cannot be resampled onto the path)."""
    pp = result.trajectory.timing
    t = (pp.x[:-1, None] + np.diff(pp.x)[:, None] * np.linspace(0, 1, 9)).ravel()
    s = pp(t)
    return bool(s.min() >= -1e-9 and s.max() <= length + 1e-9)


def _krl_points(prepared: Prepared, result: LawResult):
    """Key points for the native-controller program: segment ends (thesis section 3.7)."""
    from feedopt.robot.kuka import abc_from_rotation
    from feedopt.robot.model import forward_kinematics

    problem = prepared.problem
    s_pts, motions, vels = [0.0], [], []
    feed_at = result.trajectory.feed_at
    for a, b, kind in problem.segments():
        if kind == "line":
            s_pts.append(b)
            motions.append("SLIN")
            vels.append(float(feed_at(np.array([0.5 * (a + b)]))[0]))
        else:  # blends: the controller's spline through the blend middle and end
            v = float(np.min(feed_at(np.linspace(a, b, 9))))
            s_pts += [0.5 * (a + b), b]
            motions += ["SPL", "SPL"]
            vels += [v, v]
    s_pts = np.asarray(s_pts)
    q = prepared.q_of_s(s_pts)
    pose = forward_kinematics(prepared.robot, q)
    points = np.column_stack([pose[:, :3, 3] / MM, abc_from_rotation(pose[:, :3, :3])])
    return points, motions, np.maximum(np.asarray(vels), 1e-6), np.rad2deg(q[0])


def write_outputs(
    prepared: Prepared,
    results: dict[str, LawResult],
    out_dir: Path,
    export_unverified: bool = False,
    report: bool = True,
) -> dict:
    """Write RSI CSVs, KRL programs, summary.json and the report into ``out_dir``."""
    from feedopt.export.krl import write_krl_program
    from feedopt.export.rsi import rsi_table_from_si, write_rsi_csv

    sc = prepared.scenario
    cycle = sc.export.rsi_cycle_ms * 1e-3
    from feedopt.report.summary import law_summary, scenario_summary

    summary = {"scenario": scenario_summary(prepared), "warnings": list(prepared.warnings),
               "laws": {}}
    series = []
    for law, res in results.items():
        entry = law_summary(prepared, res)
        ver = res.verification
        entry["exportable"] = ver.exportable
        entry["export_blockers"] = list(ver.export_blockers)
        drawable = is_finite(res.trajectory) and _monotone_within_path(
            res, prepared.problem.length)
        exported = drawable and (ver.exportable or export_unverified)
        entry["exported"] = exported
        summary["laws"][law] = entry
        if not drawable:
            continue
        motion, jerk, qd = _time_series(prepared, res, cycle)
        if exported:
            q, pose, interp_error = _rsi_rows(prepared, motion)
            entry["fk_vs_path_error_mm"] = interp_error / MM
            deflection = np.interp(motion.s, prepared.problem.s, ver.deflection)
            table = rsi_table_from_si(motion.t, pose[:, :3, 3], pose[:, :3, :3], q, motion.s,
                                      motion.sdot, motion.sddot, jerk, deflection)
            status = ("VERIFIED" if ver.exportable
                      else "NOT EXPORTABLE, written on request (--export-unverified): "
                      + "; ".join(ver.export_blockers + ver.problems))
            write_rsi_csv(out_dir / f"{law}.csv", table, comments=[
                f"feedopt {law} trajectory for scenario {sc.name}: {status}",
                f"cycle time {res.trajectory.duration:.4f} s, max predicted deflection "
                f"{ver.max_deflection / MM:.4f} mm (limit {sc.deflection.limit_mm} mm)",
                "pose: TCP in the robot base frame, A,B,C = KUKA Z-Y'-X'' (deg); q from IK; "
                "deflection = predicted static deflection at the commanded feed",
            ])
            entry["rsi_csv"] = f"{law}.csv"
            if law in ("thesis", "constant") and prepared.krl_blocker is not None:
                entry["krl_program"] = None
                entry["krl_not_written"] = prepared.krl_blocker
            elif law in ("thesis", "constant"):
                pts, motions, vels, q0 = _krl_points(prepared, res)
                write_krl_program(out_dir / f"{law}.src", None, pts, motions, vels, q0, comments=[
                    f"feedopt scenario {sc.name}, law {law}: key points of the path with the "
                    "law's segment feeds as $VEL.CP",
                    *([] if ver.exportable else [f"NOT EXPORTABLE: {b}"
                                                 for b in ver.export_blockers]),
                ])
                entry["krl_program"] = f"{law}.src"
        if report:
            from feedopt.report.data import law_series_from_si

            series.append(law_series_from_si(
                law, prepared.problem.s, ver.feed, ver.deflection, motion.t, motion.sdot,
                motion.sddot, jerk, qd, verified=ver.verified,
                notes=list(ver.problems) + [f"not exported: {b}" for b in ver.export_blockers]
                + list(ver.warnings),
            ))
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if report:
        from feedopt.report.data import ReportData
        from feedopt.report.html import write_report

        kinds = np.asarray(prepared.problem.segment_kind or ("line",))
        seg = np.asarray(prepared.samples.segment)
        data = ReportData(
            scenario=sc.name,
            summary=summary,
            path_xyz_mm=prepared.positions / MM,
            segment_kind=kinds[seg] if kinds.size > 1 else np.full(seg.size, kinds[0]),
            laws=tuple(series),
            joint_velocity_limit_deg_s=np.rad2deg(prepared.problem.joint_velocity_max),
            deflection_limit_mm=sc.deflection.limit_mm,
        )
        write_report(out_dir, data)
    return summary


def run_scenario(
    scenario_path: str | Path,
    out_dir: str | Path | None = None,
    laws: list[str] | None = None,
    export_unverified: bool = False,
    spacing_mm: float | None = None,
    report: bool = True,
    progress: Progress = _stderr_progress,
    overwrite: bool = False,
) -> RunResult:
    """Run a scenario end to end and write its outputs (atomically) to ``out_dir``.

    The destination is checked and its staging folder created before any planning
    (:mod:`feedopt.outdir`): a folder of the user's own files is never replaced, and a
    failed or interrupted run leaves nothing behind.
    """
    from feedopt.report.tables import comparison_table

    scenario, base_dir = load_scenario(scenario_path)
    laws = list(dict.fromkeys(laws or scenario.schedule.laws))
    out = Path(out_dir) if out_dir else Path("out") / scenario.name
    dest = outdir.open_destination(out, protected=[Path.cwd(), base_dir], overwrite=overwrite)
    try:
        prepared = prepare(scenario, base_dir, progress, spacing_mm=spacing_mm)
        results = plan_and_verify(prepared, laws, progress)
        summary = write_outputs(prepared, results, dest.staging, export_unverified, report)
        outdir.commit(dest)
    finally:
        if dest.staging.exists():
            outdir.discard(dest)
    return RunResult(out_dir=out, prepared=prepared, laws=results, summary=summary,
                     table=comparison_table([summary], [scenario.name]))


def validate_scenario(scenario_path: str | Path) -> str:
    """Check a scenario without planning: schema, files, robot, tool, material, path."""
    scenario, base_dir = load_scenario(scenario_path)
    load_tool(resolve(base_dir, scenario.tool, "tool file"))
    table = load_coefficients(resolve(base_dir, scenario.material, "material file"))
    table.at(scenario.cut.spindle_rpm, extrapolate=scenario.cut.extrapolate_coefficients)
    load_robot(resolve(base_dir, scenario.robot.directory, "robot directory"))
    path = build_path(scenario, base_dir)
    return (f"{scenario_path}: ok — {scenario.name}: {len(path.segments)} segments, "
            f"{path.length / MM:.2f} mm, laws {', '.join(scenario.schedule.laws)}")
