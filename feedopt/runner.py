"""The scenario runner: the only place that wires the stages together (design.md).

scenario -> geometry -> cell placement -> process -> robot -> schedule (bound, laws) ->
verify -> export -> report. Each stage exposes the one function called here and does its
own work; this module only passes results along, times the stages and reports progress.
Outputs are written to a staging folder beside the destination and moved into place only
when everything succeeded (:mod:`feedopt.outdir`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import numpy as np

from feedopt import background, outdir, outputs
from feedopt.cell import fixed_x_axes, place_path
from feedopt.compensate import compensate as compensate
from feedopt.errors import InputError, LawNotApplicable
from feedopt.geometry.path import Path as ToolPath
from feedopt.geometry.path import PathPoints, check_sample_count
from feedopt.geometry.program_path import segment_labels
from feedopt.geometry.stage import path_from_section
from feedopt.outputs import write_outputs as write_outputs
from feedopt.parallel import single_threaded_blas
from feedopt.process.program import (
    apply_program,
)
from feedopt.process.program_stock import resolve_program_stock
from feedopt.process.program_tool import check_program_tool
from feedopt.process.stage import feed_range_warnings, process_along_path
from feedopt.process.tool import load_tool
from feedopt.profiling import (
    RunProfile,
    StageTiming,
    peak_memory_bytes,
    progress_bar,
)
from feedopt.profiling import stderr_progress as _stderr_progress
from feedopt.robot.ik import UnreachableError
from feedopt.robot.model import RobotModel, load_robot
from feedopt.robot.placement_search import suggest_workpiece_position
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.start import start_joints as robot_start_joints
from feedopt.run_data import Front, LawResult, Prepared, RunResult
from feedopt.scenario import (
    Scenario,
    load_scenario,
    resolve,
    scenario_input_files,
    scenario_warnings,
)
from feedopt.schedule.laws import LAWS, plan_law, planning_order
from feedopt.schedule.stage import interior_stop_indices, schedule_problem
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM, MS
from feedopt.verify import Verdict, replay_all

Progress = Callable[[str], None]


def _segment_names(path: ToolPath) -> list[str]:
    """Readable name of each path segment for messages ("line 3", "circle blend of corner 2",
    "arc at line 88 (N880)" on a program)."""
    if path.moves is not None:
        return segment_labels(path)
    return [f"line {i}" if seg.kind == "line" else
            f"{seg.kind} blend of corner {seg.corner_index}" for i, seg in enumerate(path.segments)]


def _sample(path: ToolPath, spacing: float) -> PathPoints:
    check_sample_count(path.length, spacing, "path.spacing_mm")
    return path.sample(spacing)


def prepare_front(
    scenario: Scenario,
    base_dir: Path,
    progress: Progress = _stderr_progress,
    spacing_mm: float | None = None,
) -> Front:
    """Run the geometry, cell and process stages of ``scenario``."""
    times: dict[str, float] = {}
    spacing = (spacing_mm or scenario.path.spacing_mm) * MM

    t0 = time.perf_counter()
    path = path_from_section(scenario.path, base_dir, stock_top=scenario.stock is None)
    program_notes: list[str] = []
    if path.moves is not None:
        scenario, program_notes = apply_program(scenario, path.moves, scenario.path.file)
    samples = _sample(path, spacing)
    if scenario.stock is not None and scenario.stock.from_program:
        scenario, stock_note = resolve_program_stock(
            scenario, 0.5 * load_tool(resolve(base_dir, scenario.tool, "tool file")).diameter,
            samples, path.moves, spacing)
        progress(stock_note)
    for note in scenario.fit_notes():  # a fitted input, before any result it shapes
        progress(f"fit: {note}")
    warnings = scenario_warnings(scenario) + list(path.notes) + program_notes
    if path.dropped_waypoints:
        shown = ", ".join(str(i) for i in path.dropped_waypoints[:10])
        more = len(path.dropped_waypoints) - 10
        warnings.append(f"path: dropped {len(path.dropped_waypoints)} repeated waypoint(s) "
                        f"(indices {shown}{f' and {more} more' if more > 0 else ''}), as "
                        "path.drop_repeated_waypoints asks")
    times["geometry"] = time.perf_counter() - t0
    progress(f"[1/5] geometry: {len(path.segments)} segments, {path.length / MM:.2f} mm, "
             f"{samples.s.size} samples ({times['geometry']:.2f} s)")

    t0 = time.perf_counter()
    wp = scenario.workpiece
    air = (None if path.moves is None
           else path.moves.category[path.moves.index_at(samples.s)] != "cut")
    placement = place_path(samples, wp.position_mm, wp.rpy_deg, wp.tool_axis, air=air)
    process = process_along_path(scenario, lambda rel, what: resolve(base_dir, rel, what),
                                 samples, _segment_names(path), moves=path.moves)
    warnings += check_program_tool(path, process.tool, scenario.path.file, scenario.tool)
    warnings += process.warnings
    times["process"] = time.perf_counter() - t0
    how = ("engagement from the stock" if process.material is not None
           else f"{scenario.cut.type} cut")
    progress(f"[2/5] process: tool {process.tool.name}, {how} at "
             f"{scenario.cut.spindle_rpm:g} rpm ({times['process']:.2f} s)")

    return Front(scenario=scenario, path=path, samples=samples, placement=placement,
                 process=process, warnings=warnings, times=times)


def prepare(
    scenario: Scenario,
    base_dir: Path,
    progress: Progress = _stderr_progress,
    spacing_mm: float | None = None,
) -> Prepared:
    """Run the geometry, process, robot and bound stages of ``scenario``."""
    from feedopt.export.job import early_blockers

    front = prepare_front(scenario, base_dir, progress, spacing_mm)
    scenario, path, samples = front.scenario, front.path, front.samples
    placement, process, warnings, times = (front.placement, front.process, front.warnings,
                                           front.times)

    t0 = time.perf_counter()
    robot = load_robot(resolve(base_dir, scenario.robot.directory, "robot directory"))
    _check_redundancy(robot, scenario)
    x_axes = fixed_x_axes(placement, scenario.robot.fix_tool_rotation)
    with progress_bar(progress, "[3/5] robot IK") as bar, _suggesting_position(
            robot, scenario, samples):
        tcp = TcpPath(samples.s, placement.positions, placement.tool_axes, x_axes=x_axes,
                      breaks=interior_stop_indices(path.stops, samples.s))
        along = robot_along_path(robot, tcp, start_joints(robot, scenario),
                                 scenario.robot.stiffness, progress=bar)
    warnings += along.warnings
    blockers = early_blockers(robot, path)
    times["robot"] = time.perf_counter() - t0
    progress(f"[3/5] robot: {robot.name}, IK on {samples.s.size} samples, max condition "
             f"number {along.max_condition_number:.1f} ({times['robot']:.2f} s)")

    t0 = time.perf_counter()
    with progress_bar(progress, "[4/5] deflection bound") as bar:
        schedule = schedule_problem(scenario, process, robot, along, placement, samples, path,
                                    progress=bar)
    redundancy, nearest_compliance = None, None
    if scenario.robot.redundancy == "optimise":
        times["bounds"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        redundancy = _optimise_redundancy(front, base_dir, robot, along, progress)
        nearest_compliance = along.compliance
        along, schedule = redundancy.along, redundancy.schedule
        times["redundancy"] = time.perf_counter() - t0
        progress(f"[4/5] redundancy: {redundancy.describe()}")
        t0 = time.perf_counter() - times["bounds"]
    v_max = schedule.bound.v_max
    warnings += feed_range_warnings(process.table, [
        ("the lowest feed of the bound", float(np.min(v_max[1:-1] if v_max.size > 2 else v_max)))
    ], scenario.cut.spindle_rpm, process.tool)
    outputs.check_output_size(schedule.problem.lower_bound_time(),
                              scenario.export.rsi_cycle_ms * MS)
    times["bounds"] = time.perf_counter() - t0
    warnings += [b.reason for b in blockers.values() if b.warn]
    for w in warnings:
        progress(f"warning: {w}")
    share = ", ".join(f"{k} {v:.0%}" for k, v in schedule.bound.active_fraction().items()
                      if v > 0)
    if path.moves is not None:  # where a program's bound is lowest, by its line
        share += f"; lowest at {path.moves.label(path.moves.lowest_cut(samples.s, v_max)[1])}"
    progress(f"[4/5] bounds: v_max {v_max.min() / MM:.3f}-{v_max.max() / MM:.3f} "
             f"mm/s, T* = {schedule.problem.lower_bound_time():.2f} s; active: {share} "
             f"({times['bounds']:.2f} s)")
    return Prepared(scenario=scenario, base_dir=base_dir, path=path, samples=samples,
                    placement=placement, process=process, robot=robot, along=along,
                    schedule=schedule, stage_times=times, warnings=warnings,
                    export_blockers=blockers, redundancy=redundancy,
                    nearest_compliance=nearest_compliance)


@contextmanager
def _suggesting_position(robot: RobotModel, scenario: Scenario, samples: PathPoints):
    """An unreachable sample's error, with a workpiece position that reaches the path (or
    "none found")."""
    try:
        yield
    except UnreachableError as exc:
        wp = scenario.workpiece
        hint = suggest_workpiece_position(
            robot, samples.position, wp.position_mm, wp.rpy_deg, wp.tool_axis,
            start_joints(robot, scenario),
            scenario.robot.fix_tool_rotation)
        raise InputError(f"{exc}; {hint}") from None


def _optimise_redundancy(front: Front, base_dir: Path, robot: RobotModel,
                         nearest: RobotAlongPath, progress: Progress):
    """``robot.redundancy: optimise``: the rotation about the tool axis psi(s) that lowers T*
    (:func:`feedopt.robot.redundancy.optimise_redundancy`), searched on a coarser sampling of
    the same path and confirmed on the run's."""
    from feedopt.robot.redundancy import RedundancyOptions, RedundancyTask, optimise_redundancy

    sc = front.scenario
    opts = sc.robot.redundancy_options
    coarse = prepare_front(sc, base_dir, lambda _m: None, spacing_mm=opts.search_spacing_mm)
    q_start = start_joints(robot, sc)
    coarse_nearest = robot_along_path(robot, TcpPath(coarse.samples.s,
                                                     coarse.placement.positions,
                                                     coarse.placement.tool_axes),
                                      q_start, sc.robot.stiffness)

    def task(f: Front, along: RobotAlongPath) -> RedundancyTask:
        return RedundancyTask(
            f.samples.s, f.placement.positions, f.placement.tool_axes,
            lambda a: schedule_problem(f.scenario, f.process, robot, a, f.placement,
                                       f.samples, f.path), along)

    options = RedundancyOptions(objective=opts.objective, knots=opts.knots,
                                max_evaluations=opts.max_evaluations,
                                path_acceleration=opts.path_acceleration)
    with progress_bar(progress, "[4/5] redundancy") as bar:
        if robot.dof == 7:
            from feedopt.robot.extra_axis import choose_extra_axis

            return choose_extra_axis(robot, robot.held_axis(), task(coarse, coarse_nearest),
                                     task(front, nearest), sc.robot.stiffness, options, bar)
        return optimise_redundancy(robot, task(coarse, coarse_nearest), task(front, nearest),
                                   sc.robot.stiffness, options, progress=bar)


def plan_and_verify(
    prepared: Prepared, laws: list[str], progress: Progress = _stderr_progress,
    workers: dict[str, background.Prestarted] | None = None,
) -> dict[str, LawResult]:
    """Run each timing law (registry order), then replay-verify all of them in one pass.

    A law with a child in ``workers`` (:func:`law_workers`, its slow imports done) is sent
    there and planned beside the laws planned here; its planning time is the child's own, so
    it overlaps theirs.
    """
    context: dict[str, Trajectory] = {}
    planned: dict[str, Trajectory] = {}
    planning_time: dict[str, float] = {}
    options = prepared.scenario.schedule
    sent: dict[str, background.Prestarted] = {}
    order = planning_order(laws)
    workers = dict(workers or {})
    if prepared.problem.n > outputs.CHILD_COPY_MAX_SAMPLES:  # a copy would cost more than saved
        for worker in workers.values():
            worker.join(cancel=True)
        workers = {}
    with progress_bar(progress, "[5/5] planning", " laws", False) as bar:
        done = 0
        for law in order:
            worker = workers.pop(law, None)
            if worker is not None:
                worker.submit(_plan_law_timed, law, prepared.problem,
                              {k: context[k] for k in LAWS[law].uses_context if k in context},
                              options.options_for(law))
                sent[law] = worker
                continue
            t0 = time.perf_counter()
            try:
                planned[law] = plan_law(law, prepared.problem, context,
                                        options=options.options_for(law))
            except LawNotApplicable as exc:
                prepared.declined[law] = str(exc)
                progress(f"[5/5] {law}: declined: {exc}")
            else:
                planning_time[law] = time.perf_counter() - t0
            done += 1
            if bar is not None:
                bar(done, len(order))
        for law, worker in sent.items():
            try:
                planned[law], planning_time[law] = worker.join(reraise=True)
            except LawNotApplicable as exc:
                prepared.declined[law] = str(exc)
                progress(f"[5/5] {law}: declined: {exc}")
            else:
                context[law] = planned[law]
            done += 1
            if bar is not None:
                bar(done, len(order))
    planned = {law: planned[law] for law in order if law in planned}  # registry order

    results: dict[str, LawResult] = {}
    t_star = prepared.problem.lower_bound_time()
    with progress_bar(progress, "[5/5] replay") as bar:
        replayed = replay_all(planned, prepared.problem, prepared.model, prepared.limit, bar)
    for law, (ver, dt_verify) in replayed.items():
        traj, dt = planned[law], planning_time[law]
        results[law] = LawResult(trajectory=traj, verification=ver, planning_time=dt,
                                 verification_time=dt_verify)
        status = ver.verdict.value
        if ver.verdict is Verdict.VERIFIED:
            status += ": " + "; ".join(ver.export_blockers)
        progress(f"[5/5] {law}: {traj.duration:.2f} s cycle ({traj.duration / t_star:.4f} T*), "
                 f"max deflection {ver.max_deflection / MM:.4f} mm ({ver.deflection_ratio:.4f} "
                 f"of limit), {status} ({dt:.2f} s)")
        for problem in ver.problems:
            progress(f"      ! {law}: {problem}")
    return {law: results[law] for law in laws if law in results}


def _check_redundancy(robot: RobotModel, scenario: Scenario) -> None:
    """InputError for ``robot.redundancy: optimise`` on a robot it cannot search: a 6-axis
    arm's is the rotation about the tool axis, a 7-axis robot's its extra axis
    (:meth:`RobotModel.held_axis`), which a 7-joint arm must name."""
    if scenario.robot.redundancy != "optimise" or robot.dof == 6:
        return
    if robot.dof == 7 and robot.held_axis() is None:
        raise InputError(f"robot.redundancy: optimise holds the extra axis of a 7-axis robot; "
                         f"robot {robot.name} does not say which joint it is: add "
                         f"'extra_axis: <joint>' to its robot.yaml (one of "
                         f"{', '.join(robot.joint_names)}; a KUKA LBR: its third joint, the "
                         "controller's E1), or use redundancy: nearest")
    if robot.dof > 7:
        raise InputError(f"robot.redundancy: optimise searches one extra axis (6- and 7-axis "
                         f"robots); robot {robot.name} has {robot.dof} joints: use redundancy: "
                         "nearest (its extra axes follow the weighted nearest IK)")


def start_joints(robot: RobotModel, scenario: Scenario) -> np.ndarray:
    """``robot.start_configuration_deg`` as the URDF's joints [rad]
    (:func:`feedopt.robot.start.start_joints`)."""
    return robot_start_joints(robot, scenario.robot.start_configuration_deg)


def _plan_law_timed(law: str, problem, context: dict[str, Trajectory], options
                    ) -> tuple[Trajectory, float]:
    """:func:`plan_law` in a law worker: the trajectory and the time it took [s]."""
    t0 = time.perf_counter()
    trajectory = plan_law(law, problem, dict(context), options=options)
    return trajectory, time.perf_counter() - t0


def _import_law(law: str) -> None:
    import importlib

    for name in (*LAWS[law].slow_imports, LAWS[law].module):
        importlib.import_module(name)


def law_workers(laws: list[str]) -> dict[str, background.Prestarted]:
    """A child per requested law with slow imports (:attr:`LawSpec.slow_imports`: cvxpy for
    ``convex``), forked now so that the imports happen on the other core while this one
    prepares; :func:`plan_and_verify` sends each its law. Empty where fork is unavailable."""
    if not background.fork_available():
        return {}
    return {law: background.prestart(partial(_import_law, law), f"planning {law}")
            for law in dict.fromkeys(laws) if law in LAWS and LAWS[law].slow_imports}


def _import_report() -> None:
    import feedopt.report.html  # noqa: F401 - matplotlib and the figures, ~0.5 s
    import feedopt.report.run  # noqa: F401


def report_worker() -> background.Prestarted:
    """A forked child that imports the report's plotting libraries now and draws the report
    when :func:`write_outputs` sends it the run's data."""
    return background.prestart(_import_report, "drawing the report")


def _profile(prepared: Prepared, results: dict[str, LawResult],
             output_times: dict[tuple[str, str], float], total: float) -> RunProfile:
    """The run's stage and per-law times in pipeline order (RunProfile)."""
    rows = [StageTiming(stage, t) for stage, t in prepared.stage_times.items()]
    for law, res in results.items():
        rows += [StageTiming("plan", res.planning_time, law),
                 StageTiming("verify", res.verification_time, law)]
        if ("export", law) in output_times:
            rows.append(StageTiming("export", output_times[("export", law)], law))
    if ("report", "") in output_times:
        rows.append(StageTiming("report", output_times[("report", "")]))
    rows.append(StageTiming("other", max(0.0, total - sum(r.seconds for r in rows))))
    return RunProfile(rows=tuple(rows), total_s=total, peak_memory_bytes=peak_memory_bytes(),
                      child_peak_memory_bytes=peak_memory_bytes(children=True),
                      samples=int(prepared.samples.s.size))


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

    t_start = time.perf_counter()
    scenario, base_dir = load_scenario(scenario_path)
    laws = list(dict.fromkeys(laws or scenario.schedule.laws))
    out = Path(out_dir) if out_dir else Path("out") / scenario.name
    inputs = [Path(scenario_path), *scenario_input_files(scenario, base_dir)]
    dest = outdir.open_destination(out, protected=[Path.cwd(), base_dir], overwrite=overwrite,
                                   inputs=inputs)
    with single_threaded_blas():  # our threads and children use the cores (feedopt.parallel)
        summary, prepared, results, output_times = _run_in(
            scenario, base_dir, dest, laws, export_unverified, spacing_mm, report, progress)
    return RunResult(out_dir=out, prepared=prepared, laws=results, summary=summary,
                     table=comparison_table([summary], [scenario.name]),
                     profile=_profile(prepared, results, output_times,
                                      time.perf_counter() - t_start))


def _run_in(scenario: Scenario, base_dir: Path, dest: outdir.Destination, laws: list[str],
            export_unverified: bool, spacing_mm: float | None, report: bool,
            progress: Progress) -> tuple[dict, Prepared, dict[str, LawResult], dict]:
    """The stages of :func:`run_scenario` into ``dest``'s staging folder, committed at the
    end (discarded on failure): the summary, the prepared stages, the laws' results and the
    output stage's times."""
    # children that import matplotlib (the report) and cvxpy (convex) on the other core
    # while this one prepares; convex is then planned there beside the other laws
    drawing = report_worker() if report else None
    workers = law_workers(laws)
    try:
        prepared = prepare(scenario, base_dir, progress, spacing_mm=spacing_mm)
        results = plan_and_verify(prepared, laws, progress, workers)
        if scenario.deflection.mode == "residual":
            results = compensate(prepared, results, progress)
        if not results:
            raise InputError("no timing law planned this path: " + "; ".join(
                prepared.declined.values()) + " — add convex or jerk to schedule.laws / --laws")
        output_times: dict[tuple[str, str], float] = {}
        summary = write_outputs(prepared, results, dest.staging, export_unverified, report,
                                output_times, drawing, progress)
        outdir.commit(dest)
    finally:
        for worker in workers.values():  # not sent a law (a failed run): the child leaves
            worker.join(cancel=True)
        if drawing is not None:  # a run that failed before its report: the child leaves
            drawing.join(cancel=True)
        if dest.staging.exists():
            outdir.discard(dest)
    return summary, prepared, results, output_times


def validate_scenario(scenario_path: str | Path) -> str:
    """Check a scenario without planning: schema, files, robot, tool, material, path, and the
    process stage a run does (the stock sweep with its crash and plunge checks, the program's
    tool comment, the engagement), so that what ``run`` refuses ``validate`` refuses too."""
    from feedopt.process.coefficients import load_coefficients

    scenario, base_dir = load_scenario(scenario_path)
    tool = load_tool(resolve(base_dir, scenario.tool, "tool file"))  # files in this order
    load_coefficients(resolve(base_dir, scenario.material, "material file"))
    robot = load_robot(resolve(base_dir, scenario.robot.directory, "robot directory"))
    _check_redundancy(robot, scenario)
    start_joints(robot, scenario)  # one value per joint, within the limits, as run checks
    path = path_from_section(scenario.path, base_dir, stock_top=scenario.stock is None)
    if path.moves is not None:
        scenario, _ = apply_program(scenario, path.moves, scenario.path.file)
    spacing = scenario.path.spacing_mm * MM
    samples = _sample(path, spacing)
    if scenario.stock is not None and scenario.stock.from_program:
        scenario, _ = resolve_program_stock(scenario, 0.5 * tool.diameter, samples,
                                            path.moves, spacing)
    process = process_along_path(scenario, lambda rel, what: resolve(base_dir, rel, what),
                                 samples, _segment_names(path), moves=path.moves)
    notes = check_program_tool(path, process.tool, scenario.path.file, scenario.tool)
    notes += process.warnings
    stock = ""
    if process.material is not None:
        zmap = process.material.before
        units = (f", mesh read in {scenario.stock.units or 'mm'}" if scenario.stock.mesh
                 else "")
        stock = (f"; stock {zmap.shape[0]} x {zmap.shape[1]} cells of {zmap.cell / MM:g} mm"
                 f"{units}")
    return (f"{scenario_path}: ok — {scenario.name}: {len(path.segments)} segments, "
            f"{path.length / MM:.2f} mm, laws {', '.join(scenario.schedule.laws)}{stock}"
            + "".join(f"\nwarning: {note}" for note in notes))
