"""The output stage of a run: every registered exporter's files per law, summary.json and the
report, written into the run's staging folder (:func:`write_outputs`; the runner calls it
like any other stage). The report is drawn in a forked child while the exporters write
(:mod:`feedopt.background`)."""

from __future__ import annotations

import json
import time
from functools import partial
from pathlib import Path

import numpy as np

from feedopt import background
from feedopt.errors import InputError
from feedopt.parallel import worker_threads
from feedopt.part.output import other_mode, part_stage
from feedopt.process.program import unmodelled_plunge_moves, unmodelled_plunge_note
from feedopt.profiling import Progress, progress_bar
from feedopt.report.data import engagement_series, redundancy_series
from feedopt.run_data import LawResult, Prepared
from feedopt.schedule.laws import LAWS
from feedopt.schedule.polynomial import sample_piece_chunks
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM, MS
from feedopt.verify import is_finite

# The largest number of path samples a run plans is feedopt.geometry.path.MAX_SAMPLES (shared
# with feedopt path: check_sample_count).
# Largest number of controller cycles one exported trajectory may have: 11 h at 4 ms, about
# 2.5 GB of RSI CSV (~250 bytes per row). Checked on T* before planning and per law after.
MAX_CONTROLLER_ROWS = 10_000_000
_BYTES_PER_ROW = 250

#: Above this many path samples the children started before planning are let go: a law is
#: planned here, not in its worker, and the report's child is forked when its data is ready
#: (sharing it, copy-on-write). Their own copy of the data and the solver's memory (about
#: 1 kB per sample for convex, 0.3 kB for the report) would sit next to this process's,
#: while the imports they save (~0.5 s each) are a small part of such a run.
CHILD_COPY_MAX_SAMPLES = 200_000
#: Samples from which the laws are exported in forked children side by side
#: (:func:`_run_exports`): a law's exports take seconds there, a fork milliseconds.
PARALLEL_EXPORT_MIN_SAMPLES = 50_000


def controller_rows(duration: float, cycle: float) -> float:
    """Rows of a trajectory of ``duration`` [s] sampled every ``cycle`` [s]."""
    return duration / cycle + 1


def check_output_size(lower_bound_time: float, cycle: float) -> None:
    """InputError before planning when even the fastest law would write too many rows."""
    rows = controller_rows(lower_bound_time, cycle)
    if rows > MAX_CONTROLLER_ROWS:
        raise InputError(
            f"the fastest trajectory the feed bound allows lasts {lower_bound_time:.4g} s, "
            f"{rows:.3g} RSI cycles of {cycle / MS:g} ms (about {rows * _BYTES_PER_ROW / 1e9:.3g} "
            f"GB of CSV per law); at most {MAX_CONTROLLER_ROWS:.0e} cycles are exported: split "
            "the job, or check the feed (a feed far below the nominal makes long jobs)")


def monotone_within_path(trajectory: Trajectory, length: float) -> bool:
    """s(t) stays in [0, L] (a reversing law cannot be resampled onto the path)."""
    pp = trajectory.timing
    return all(s.min() >= -1e-9 and s.max() <= length + 1e-9
               for s in map(pp, sample_piece_chunks(pp.x, 9)))


def export_notes(prepared: Prepared) -> tuple[str, ...]:
    """What every exported file's header says about the run beyond its law: plunges that
    are not deflection-limited (no plunge coefficients)."""
    moves = prepared.path.moves
    if moves is None:
        return ()
    note = unmodelled_plunge_note(
        moves, unmodelled_plunge_moves(moves, prepared.samples.s,
                                       prepared.process.unmodelled_plunge),
        prepared.scenario.feed.plunge_max_mm_s)
    return () if note is None else (note,)


def _law_entry(prepared: Prepared, law: str, res: LawResult, cycle: float,
               export_unverified: bool) -> tuple[dict, bool]:
    """summary.json's entry of ``law`` with its export verdict, and whether the trajectory
    can be sampled at the controller cycle at all (finite, on the path, not too long)."""
    from feedopt.report.summary import law_summary

    entry = law_summary(prepared, res)
    ver = res.verification
    entry["exportable"] = ver.exportable
    entry["export_blockers"] = list(ver.export_blockers)
    drawable = is_finite(res.trajectory) and monotone_within_path(res.trajectory,
                                                                  prepared.problem.length)
    rows = controller_rows(res.trajectory.duration, cycle) if drawable else 0.0
    if rows > MAX_CONTROLLER_ROWS:  # too long to sample, draw or export
        drawable = False
        entry["exportable"] = False
        entry["export_blockers"].append(
            f"{res.trajectory.duration:.4g} s is {rows:.3g} controller cycles, more than the "
            f"{MAX_CONTROLLER_ROWS:.0e} exported")
    entry["exported"] = drawable and (ver.exportable or export_unverified)
    return entry, drawable


def _export_job(prepared: Prepared, law: str, res: LawResult, samples, cycle: float,
                notes: tuple[str, ...]):
    """The :class:`feedopt.export.job.ExportJob` of one law (its compensated path when it
    has one)."""
    from feedopt.export.job import ExportJob

    sc, problem, comp = prepared.scenario, prepared.problem, res.compensation
    spec = LAWS.get(law)

    def nominal_in_base(s: np.ndarray) -> np.ndarray:
        if s.shape == problem.s.shape and np.array_equal(s, prepared.samples.s):
            # the samples: placed already (cell.place_path, the same product), not
            # evaluated again (a path's evaluation inverts its splines' arc length)
            return prepared.placement.positions.copy()
        return prepared.placement.to_base(prepared.path.evaluate(s).position)

    return ExportJob(
        law=law, scenario_name=sc.name, trajectory=res.trajectory,
        verification=res.verification, problem=problem, robot=prepared.robot,
        q_of_s=prepared.q_of_s if comp is None else comp.along.q_of_s,
        path_in_base=(nominal_in_base if comp is None else comp.path.commanded_at(problem.s)),
        compensation=None if comp is None else comp.path.samples(problem.s),
        samples=samples, cycle=cycle, limit_mm=sc.deflection.limit_mm,
        unverified_on_request=not res.verification.exportable,
        native_program=bool(spec is not None and spec.native_program),
        blockers=prepared.export_blockers, tool_axes=prepared.placement.tool_axes,
        notes=notes,
    )


def _part_series(prepared: Prepared, parts: dict, drawn: dict):
    """The report's :class:`feedopt.report.data.PartSeries` of the drawn laws (None: no
    part); the floor map of the fastest verified non-baseline law (else the first)."""
    from feedopt.part.output import floor_points, row_means
    from feedopt.report.data import PartSeries
    from feedopt.verify import is_baseline

    laws = [law for law in drawn if law in parts]
    if not laws:
        return None
    mm = 1.0 / MM
    candidates = [law for law in laws if not is_baseline(law)] or laws
    chosen = min(candidates, key=lambda law: drawn[law].duration)
    part = parts[chosen]
    xy = floor_points(part, prepared.positions, prepared.model.frames,
                      prepared.tool.diameter / 2.0)[:, :2] * mm

    def mean(values):
        return row_means(values) * mm

    return PartSeries(
        laws=tuple(laws), s_mm=tuple(parts[law].s * mm for law in laws),
        left_mm=tuple(mean(parts[law].wall[:, 0]) for law in laws),
        right_mm=tuple(mean(parts[law].wall[:, 1]) for law in laws),
        floor_mm=tuple(mean(parts[law].floor) for law in laws), map_law=chosen,
        map_xy_mm=xy, map_floor_mm=part.floor.reshape(-1) * mm)


def _start_report(prepared: Prepared, out_dir: Path, summary: dict, series: list,
                  drawing: background.Prestarted | None,
                  trajectories: dict[str, Trajectory], part=None) -> background.Prestarted:
    """The report drawn in a child: the prestarted one (its plotting imports done) for a
    short path, else a fork now that shares the data instead of sending a copy.
    ``trajectories``: the drawn laws' (their time at each sample is found in the child)."""
    from feedopt.report.run import ExtraFigures, ReportPath, SampleSources, write_run_report

    sc, problem = prepared.scenario, prepared.problem
    material = prepared.process.material
    engagement = None if material is None else engagement_series(prepared.samples, material)
    red = (None if prepared.redundancy is None
           else redundancy_series(prepared.redundancy, prepared.nearest_compliance,
                                  prepared.placement))
    sources = SampleSources(prepared.bound.active, prepared.bound.names, prepared.path.moves,
                            trajectories)
    path = ReportPath(prepared.positions, prepared.samples.segment, problem,
                      prepared.robot.axis_convention.unit, sources)
    draw = partial(write_run_report, out_dir, sc.name, summary, path, series,
                   sc.deflection.limit_mm, ExtraFigures(engagement, red, part))
    if drawing is not None and problem.n <= CHILD_COPY_MAX_SAMPLES:
        drawing.submit(draw.func, *draw.args)  # the child has imported matplotlib
        return drawing
    if drawing is not None:
        drawing.join(cancel=True)
    return background.start(draw, "drawing the report")


def _export_law(job, out_dir: Path) -> tuple[dict, float]:
    """Every exporter of one law (:func:`feedopt.export.job.run_exporters`): its summary
    entries and the time it took [s]."""
    from feedopt.export.job import run_exporters

    t0 = time.perf_counter()
    entry = run_exporters(job, out_dir)
    return entry, time.perf_counter() - t0


def _run_exports(pending: list, out_dir: Path, times: dict, progress: Progress | None,
                 drawing: background.Prestarted | None) -> float:
    """Every exporter of each pending law, timed; the drawing child is cancelled if one
    fails. On a long path (:data:`PARALLEL_EXPORT_MIN_SAMPLES`) with a core for each, each
    law is exported in a forked child of its own (the laws' files are their own, the data
    shared copy on write), side by side; the report's child counts as one (on 2 cores with a
    report the laws go one after the other here: a third process would only share the cores
    and add its memory). Returns the wall time spent [s]."""
    t_start = time.perf_counter()
    forking = (len(pending) > 1 and background.fork_available()
               and pending[0][2].problem.n >= PARALLEL_EXPORT_MIN_SAMPLES
               and len(pending) + (drawing is not None) <= worker_threads())
    children: list[background.Background] = []
    try:
        with progress_bar(progress, "[5/5] export", " laws", False) as bar:
            if forking:
                children = [background.start(partial(_export_law, job, out_dir),
                                             f"exporting {law}") for law, _, job in pending]
            for done, (law, entry, job) in enumerate(pending, start=1):
                got, seconds = (children[done - 1].join(reraise=True) if forking
                                else _export_law(job, out_dir))
                entry.update(got)
                times[("export", law)] += seconds
                if bar is not None:
                    bar(done, len(pending))
    except BaseException:
        for child in children:  # those not joined yet: killed (joined ones return at once)
            child.join(cancel=True)
        if drawing is not None:
            drawing.join(cancel=True)
        raise
    return time.perf_counter() - t_start


def write_outputs(
    prepared: Prepared,
    results: dict[str, LawResult],
    out_dir: Path,
    export_unverified: bool = False,
    report: bool = True,
    times: dict[tuple[str, str], float] | None = None,
    drawing: background.Prestarted | None = None,
    progress: Progress | None = None,
) -> dict:
    """Every registered exporter's files, summary.json and the report into ``out_dir``.

    ``times`` (optional) receives the wall time [s] of ``("export", law)`` (controller
    samples and every exporter of the law) and ``("report", "")`` (the report is drawn in a
    forked child while the exporters write: its row is the wait after them). ``drawing``: a
    child started with :func:`feedopt.report.worker.report_worker` before planning, which has
    imported the plotting libraries meanwhile (else one is forked here). ``progress``: the
    run's progress (a bar over the exported laws on a terminal).
    """
    from feedopt.export.job import controller_samples
    from feedopt.report.run import law_series
    from feedopt.report.summary import scenario_summary

    times = {} if times is None else times
    problem = prepared.problem
    cycle = prepared.scenario.export.rsi_cycle_ms * MS
    summary = {"scenario": scenario_summary(prepared),
               "warnings": list(prepared.warnings) + [f"law {law} declined: {why}" for law, why
                                                      in prepared.declined.items()],
               "declined_laws": dict(prepared.declined), "laws": {}}
    series, pending, trajectories = [], [], {}
    notes = export_notes(prepared)
    for law, res in results.items():
        entry, drawable = _law_entry(prepared, law, res, cycle, export_unverified)
        summary["laws"][law] = entry
        if not drawable:
            continue
        t0 = time.perf_counter()
        q_of_s = prepared.q_of_s if res.compensation is None else res.compensation.along.q_of_s
        samples = controller_samples(res.trajectory, cycle, q_of_s, problem.length)
        if entry["exported"]:
            pending.append((law, entry, _export_job(prepared, law, res, samples, cycle, notes)))
        times[("export", law)] = time.perf_counter() - t0
        if report:
            series.append(law_series(law, problem.s, res.verification, samples,
                                     prepared.robot.axis_convention.unit))
            trajectories[law] = res.trajectory
    t0 = time.perf_counter()
    summary["part"], parts = part_stage(prepared, results, out_dir)
    if summary["part"] is not None:
        from feedopt.report.verdict import program_law

        law = program_law(summary)
        summary["part"]["other_mode"] = other_mode(prepared, law, results.get(law))
    times[("part", "")] = time.perf_counter() - t0
    t_report = time.perf_counter()
    if report:  # drawn in a forked child while the exporters write (feedopt.background)
        drawing = _start_report(prepared, out_dir, summary, series, drawing, trajectories,
                                _part_series(prepared, parts, trajectories))
    exporting = _run_exports(pending, out_dir, times, progress, drawing)
    if drawing is not None:
        drawing.join()
        if report:  # drawn before the exporters named their files: the verdict again
            from feedopt.report.verdict import refresh_report_verdict

            refresh_report_verdict(out_dir, summary)
        # the part of the drawing the exports did not hide (rows add up to the wall time)
        times[("report", "")] = time.perf_counter() - t_report - exporting
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    return summary
