"""The scenario runner: the only place that wires the stages together (design.md).

scenario -> geometry -> cell placement -> process -> robot (redundancy) -> schedule (bound)
-> planning (laws, verify) -> compensation -> outputs (export, report). Each stage exposes
the one function called here and does its own work; this module only passes results along,
times the stages and reports progress. Outputs are written to a staging folder beside the
destination and moved into place only when everything succeeded (:mod:`feedopt.outdir`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

from feedopt import outdir, outputs
from feedopt.cell import fixed_x_axes, place_path
from feedopt.compensate import compensate as compensate
from feedopt.errors import InputError
from feedopt.geometry.stage import (
    air_samples,
    path_from_section,
    path_warnings,
    sample_path,
    segment_names,
)
from feedopt.outputs import write_outputs as write_outputs
from feedopt.parallel import beside, single_threaded_blas
from feedopt.planning import law_workers as law_workers
from feedopt.planning import plan_and_verify as plan_and_verify
from feedopt.process.program import settings_from_program
from feedopt.process.program_stock import program_stock
from feedopt.process.stage import (
    bound_feed_warnings,
    process_along_path,
    process_warnings,
    stock_description,
)
from feedopt.process.tool import load_tool
from feedopt.profiling import Progress, progress_bar, run_profile
from feedopt.profiling import stderr_progress as _stderr_progress
from feedopt.report.worker import report_worker
from feedopt.robot.model import RobotModel, load_robot
from feedopt.robot.placement_search import suggesting_position
from feedopt.robot.redundancy_stage import check_redundancy, optimise_along_path
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes
from feedopt.robot.start import start_joints as robot_start_joints
from feedopt.run_data import Front, LawResult, Prepared, RunResult
from feedopt.scenario import (
    Scenario,
    load_scenario,
    resolve,
    scenario_input_files,
    scenario_warnings,
)
from feedopt.schedule.stage import bounds_line, interior_stop_indices, schedule_problem
from feedopt.units import MM, MS


def _quiet(_message: str) -> None:
    """No progress (the redundancy search's coarse sampling)."""


def prepare_front(
    scenario: Scenario,
    base_dir: Path,
    progress: Progress = _stderr_progress,
    spacing_mm: float | None = None,
    placed_check: Callable[[Front], None] | None = None,
) -> Front:
    """Run the geometry, cell and process stages of ``scenario``; ``placed_check`` sees the
    front before its process stage (a command refusing a path before the costly part)."""
    placed = _place(scenario, base_dir, progress, spacing_mm)
    if placed_check is not None:
        placed_check(placed)
    return _process(placed, base_dir, progress)


def _place(scenario: Scenario, base_dir: Path, progress: Progress,
           spacing_mm: float | None) -> Front:
    """The geometry and cell stages: a :class:`Front` without its process stage."""
    times: dict[str, float] = {}
    spacing = (spacing_mm or scenario.path.spacing_mm) * MM
    t0 = time.perf_counter()
    path = path_from_section(scenario.path, base_dir, stock_top=scenario.stock is None)
    scenario, program_notes = settings_from_program(scenario, path)
    samples = sample_path(path, spacing)
    scenario, stock_note = program_stock(scenario, partial(resolve, base_dir), samples,
                                         path.moves, spacing)
    if stock_note is not None:
        progress(stock_note)
    for note in scenario.fit_notes():  # a fitted input, before any result it shapes
        progress(f"fit: {note}")
    warnings = scenario_warnings(scenario) + path_warnings(path) + program_notes
    times["geometry"] = time.perf_counter() - t0
    progress(f"[1/5] geometry: {len(path.segments)} segments, {path.length / MM:.2f} mm, "
             f"{samples.s.size} samples ({times['geometry']:.2f} s)")
    t0 = time.perf_counter()
    wp = scenario.workpiece
    given_axis = wp.tool_axis if "tool_axis" in wp.model_fields_set else None
    placement = place_path(samples, wp.position_mm, wp.rpy_deg, given_axis,
                           air=air_samples(path, samples.s))
    times["process"] = time.perf_counter() - t0
    return Front(scenario=scenario, path=path, samples=samples, placement=placement,
                 process=None, warnings=warnings, times=times)


def _process(placed: Front, base_dir: Path, progress: Progress) -> Front:
    """``placed`` with its process stage (tool, material, engagement along the path)."""
    scenario, path, times = placed.scenario, placed.path, dict(placed.times)
    t0 = time.perf_counter()
    process = process_along_path(scenario, partial(resolve, base_dir), placed.samples,
                                 segment_names(path), moves=path.moves)
    times["process"] += time.perf_counter() - t0
    how = ("engagement from the stock" if process.material is not None
           else f"{scenario.cut.type} cut")
    progress(f"[2/5] process: tool {process.tool.name}, {how} at "
             f"{scenario.cut.spindle_rpm:g} rpm ({times['process']:.2f} s)")
    return replace(placed, process=process, times=times,
                   warnings=placed.warnings + process_warnings(process, path, scenario))


def _robot(placed: Front, base_dir: Path, progress: Progress
           ) -> tuple[RobotModel, RobotAlongPath, float]:
    """The robot stage of ``placed``: the robot, the IK along the path and its time [s]."""
    scenario, samples, placement = placed.scenario, placed.samples, placed.placement
    t0 = time.perf_counter()
    robot = load_robot(resolve(base_dir, scenario.robot.directory, "robot directory"))
    check_redundancy(robot, scenario.robot.redundancy)
    q_start = start_joints(robot, scenario)
    x_axes = fixed_x_axes(placement, scenario.robot.fix_tool_rotation)
    if x_axes is None:  # a five-axis path: a drift-free rotation about the turning axis
        x_axes = five_axis_x_axes(robot, q_start, placement.tool_axes)
    with progress_bar(progress, "[3/5] robot IK") as bar, suggesting_position(
            robot, samples.position, scenario.workpiece, q_start,
            scenario.robot.fix_tool_rotation, five_axis=samples.axis is not None):
        tcp = TcpPath(samples.s, placement.positions, placement.tool_axes, x_axes=x_axes,
                      breaks=interior_stop_indices(placed.path.stops, samples.s))
        along = robot_along_path(robot, tcp, q_start, scenario.robot.stiffness, progress=bar)
    return robot, along, time.perf_counter() - t0


def prepare(
    scenario: Scenario,
    base_dir: Path,
    progress: Progress = _stderr_progress,
    spacing_mm: float | None = None,
) -> Prepared:
    """Run the geometry, process, robot and bound stages of ``scenario`` (the robot's IK
    in a thread beside the process stage: both need only the placed samples)."""
    from feedopt.export.job import early_blockers

    placed = _place(scenario, base_dir, progress, spacing_mm)
    robot_stage = beside(partial(_robot, placed, base_dir, _quiet))
    front = _process(placed, base_dir, progress)
    robot, along, times_robot = robot_stage()
    scenario, path, samples = front.scenario, front.path, front.samples
    placement, process, times = front.placement, front.process, front.times
    warnings = front.warnings + list(along.warnings)
    blockers = early_blockers(robot, path)
    times["robot"] = times_robot
    progress(f"[3/5] robot: {robot.name}, IK on {samples.s.size} samples, max condition "
             f"number {along.max_condition_number:.1f} ({times['robot']:.2f} s)")

    t0 = time.perf_counter()
    with progress_bar(progress, "[4/5] deflection bound") as bar:
        schedule = schedule_problem(scenario, process, robot, along, placement, samples, path,
                                    progress=bar)
    times["bounds"] = time.perf_counter() - t0
    redundancy, nearest_compliance = None, None
    if scenario.robot.redundancy == "optimise":
        t0 = time.perf_counter()
        redundancy = _redundancy(front, base_dir, robot, along, progress)
        nearest_compliance = along.compliance
        along, schedule = redundancy.along, redundancy.schedule
        times["redundancy"] = time.perf_counter() - t0
        progress(f"[4/5] redundancy: {redundancy.describe()}")
    t0 = time.perf_counter()
    warnings += bound_feed_warnings(process, schedule.bound.v_max, scenario.cut.spindle_rpm)
    outputs.check_output_size(schedule.problem.lower_bound_time(),
                              scenario.export.rsi_cycle_ms * MS)
    times["bounds"] += time.perf_counter() - t0
    warnings += [b.reason for b in blockers.values() if b.warn]
    for w in warnings:
        progress(f"warning: {w}")
    progress(bounds_line(schedule, path.moves, samples.s, times["bounds"]))
    return Prepared(scenario=scenario, base_dir=base_dir, path=path, samples=samples,
                    placement=placement, process=process, robot=robot, along=along,
                    schedule=schedule, stage_times=times, warnings=warnings,
                    export_blockers=blockers, redundancy=redundancy,
                    nearest_compliance=nearest_compliance)


def _redundancy(front: Front, base_dir: Path, robot: RobotModel, nearest: RobotAlongPath,
                progress: Progress):
    """``robot.redundancy: optimise``: the search on the path sampled again at the search
    spacing, confirmed on the run's (:func:`optimise_along_path`)."""
    spacing_mm = front.scenario.robot.redundancy_options.search_spacing_mm
    coarse = prepare_front(front.scenario, base_dir, _quiet, spacing_mm=spacing_mm)
    with progress_bar(progress, "[4/5] redundancy") as bar:
        return optimise_along_path(robot, coarse, front, nearest, bar)


def start_joints(robot: RobotModel, scenario: Scenario) -> np.ndarray:
    """``robot.start_configuration_deg`` as the URDF's joints [rad]
    (:func:`feedopt.robot.start.start_joints`)."""
    return robot_start_joints(robot, scenario.robot.start_configuration_deg)


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
                     profile=run_profile(prepared.stage_times, results, output_times,
                                         time.perf_counter() - t_start,
                                         int(prepared.samples.s.size)))


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
    files = partial(resolve, base_dir)
    load_tool(files(scenario.tool, "tool file"))  # files in this order
    load_coefficients(files(scenario.material, "material file"))
    robot = load_robot(files(scenario.robot.directory, "robot directory"))
    check_redundancy(robot, scenario.robot.redundancy)
    start_joints(robot, scenario)  # one value per joint, within the limits, as run checks
    front = prepare_front(scenario, base_dir, _quiet)
    scenario, path, process = front.scenario, front.path, front.process
    notes = process_warnings(process, path, scenario)
    stock = stock_description(process.material, scenario.stock)
    return (f"{scenario_path}: ok — {scenario.name}: {len(path.segments)} segments, "
            f"{path.length / MM:.2f} mm, laws {', '.join(scenario.schedule.laws)}{stock}"
            + "".join(f"\nwarning: {note}" for note in notes))
