"""``run_sweep``: check everything, evaluate the points not yet done, write the results.

Order: the scenario and its files, the laws, the objective, the grid and every one of its
values, the output folder are checked first (InputError, nothing written); then the cluster
is started (or reached) and only then the folder is created or taken over; results are
appended to the table as they finish; at the end the table is rewritten in grid order, the
best feasible point is written to best.json and the heat maps are drawn.
"""

from __future__ import annotations

import contextlib
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from feedopt import __version__
from feedopt.errors import InputError, Terminated
from feedopt.outfile import write_atomically
from feedopt.scenario import scenario_input_files
from feedopt.sweep.bundle import Bundle, build_bundle, check_axes
from feedopt.sweep.execute import ClusterLost, evaluator
from feedopt.sweep.folder import (
    BEST,
    SPEC,
    TABLE,
    FolderPlan,
    check_folder,
    open_folder,
    write_spec,
)
from feedopt.sweep.grid import Grid, parse_grid, point_key
from feedopt.sweep.objective import Objective, best, parse_objective
from feedopt.sweep.plots import objective_array, plot_names, write_plots
from feedopt.sweep.point import Metric, PointResult, PointSettings, Status, error_result
from feedopt.sweep.rowcheck import BadRow, check_row
from feedopt.sweep.table import Appender, Row, columns, done, read_table, to_row, write_table


@dataclass(frozen=True)
class SweepSettings:
    """What every point computes and what the best point minimises.

    Attributes
    ----------
    laws
        Laws run at every point (default: the scenario's).
    objective
        What the best point minimises (:mod:`feedopt.sweep.objective`).
    spacing_mm
        Sample spacing override (as ``feedopt run --spacing-mm``).
    extra
        ``(column, f(prepared, results) -> float)``: more numbers per point.
    """

    laws: Sequence[str] | None = None
    objective: str = "t_star"
    spacing_mm: float | None = None
    extra: Sequence[tuple[str, Metric]] = ()


@dataclass(frozen=True)
class Execution:
    """Where the points are evaluated and whether a progress bar shows it.

    Attributes
    ----------
    scheduler, workers
        A running Dask scheduler's address, or the local cluster's worker processes (default:
        the number of cores; 0: this process, no Dask).
    progress
        Show a progress bar (default: when stderr is a terminal).
    """

    scheduler: str | None = None
    workers: int | None = None
    progress: bool | None = None


@dataclass(frozen=True)
class SweepResult:
    """What a finished sweep wrote and found."""

    out_dir: Path
    grid: Grid
    rows: list[Row]  # one per grid point, in grid order
    evaluated: int  # points evaluated by this call
    reused: int  # points taken from the table of an earlier, interrupted sweep
    objective: Objective
    best: Row | None
    best_value: float | None
    counts: dict[str, int]  # {status: number of grid points}
    plots: list[Path]


class SweepInterrupted(BaseException):  # noqa: N818 - wraps KeyboardInterrupt / Terminated
    """The sweep was stopped (a signal, or its Dask cluster was lost:
    :class:`~feedopt.sweep.execute.ClusterLost`); its table keeps every finished point for a
    resume."""

    def __init__(self, cause: BaseException, out: Path, finished: int, total: int) -> None:
        super().__init__(str(cause))
        self.cause, self.out, self.finished, self.total = cause, out, finished, total


def _table_row(result: PointResult, axes, laws: Sequence[str], extra: Sequence[str]) -> Row:
    """The row of ``result``; an ``error`` row if it holds a number a resumed sweep would
    refuse (a non-finite T*, ...), so the table never holds a row it cannot read back."""
    row = to_row(result, axes, laws, extra)
    try:
        check_row(row, axes, laws, extra)
    except BadRow as exc:
        row = to_row(error_result(result.values, ValueError(f"unexpected result: {exc}"),
                                  result.seconds), axes, laws, extra)
    return row


def _kept(table: Path, header: list[str], grid: Grid, laws: Sequence[str],
          extra: Sequence[str]) -> int | None:
    """Points of ``grid`` the table of a stopped sweep holds finished, as the next run will
    count them (a signal may land between a row's write and its count); None if unreadable."""
    try:
        finished = done(read_table(table, header, grid.axes, laws, extra))
    except Exception:  # noqa: BLE001 - then the count kept while running is said
        return None
    return sum(point_key(p) in finished for p in grid.points())


def _point_dict(grid: Grid, row: Row) -> dict[str, float]:
    return {a.name: float(row[a.name]) for a in grid.axes}


@dataclass(frozen=True)
class _Checked:
    """A sweep checked before anything is written: its inputs, table and folder plan."""

    bundle: Bundle
    grid: Grid
    laws: list[str]
    extra_names: list[str]
    goal: Objective
    header: list[str]
    spec: dict
    plan: FolderPlan
    point_settings: PointSettings


def _check_options(grid: Grid, settings: SweepSettings, execution: Execution) -> None:
    """InputError for options that contradict each other or the grid."""
    if settings.spacing_mm is not None and any(a.field == "path.spacing_mm" for a in grid.axes):
        raise InputError("--spacing-mm and --grid path.spacing_mm both set the spacing: give "
                         "one of them")
    workers, scheduler = execution.workers, execution.scheduler
    if workers is not None and (workers < 0 or (scheduler is not None and workers)):
        raise InputError(f"--workers {workers}: give a number of local worker processes >= 0 "
                         "(0: this process), and none with --scheduler (the cluster has its "
                         "own)")


def _check(scenario_path: str | Path, grid_specs: Sequence[str], out_dir: str | Path | None,
           settings: SweepSettings, execution: Execution, restart: bool) -> _Checked:
    """Check the scenario, laws, objective, grid, options and folder (nothing written)."""
    bundle, scenario = build_bundle(scenario_path)
    laws = list(dict.fromkeys(settings.laws or scenario.schedule.laws))
    goal = parse_objective(settings.objective, laws)
    grid = parse_grid(grid_specs, bundle.raw, bundle.robot_doc)
    _check_options(grid, settings, execution)
    check_axes(bundle, grid.axes)
    extra_names = [name for name, _ in settings.extra]
    header = columns(grid.axes, laws, extra_names)
    if len(set(header)) != len(header):
        raise InputError(f"extra metrics {extra_names} repeat a column name of the table")
    spec = {"feedopt": __version__, "scenario": str(scenario_path), "digest": bundle.digest,
            "laws": laws, "spacing_mm": settings.spacing_mm, "columns": header,
            "grid": [{"name": a.name, "values": list(a.values)} for a in grid.axes],
            "objective": goal.name}
    out = Path(out_dir) if out_dir else Path("out") / f"{scenario.name}_sweep"
    base_dir = Path(scenario_path).resolve().parent
    plan = check_folder(out, [Path.cwd(), base_dir], spec,
                        [TABLE, SPEC, BEST] + [name for name, _ in plot_names(grid)], restart,
                        inputs=scenario_input_files(scenario, base_dir))
    return _Checked(bundle, grid, laws, extra_names, goal, header, spec, plan,
                    PointSettings(tuple(laws), settings.spacing_mm, tuple(settings.extra)))


def _evaluate(checked: _Checked, rows: dict, todo: list, evaluate, show: bool,
              evaluated: list) -> None:
    """Evaluate ``todo`` and append each row to the folder's table as it finishes (and to
    ``rows``, its point's key to ``evaluated``, so a stopped sweep knows what it did)."""
    from tqdm import tqdm

    grid, header = checked.grid, checked.header
    appender = Appender(checked.plan.out / TABLE, header)
    try:
        with tqdm(total=len(todo), disable=not show, unit="point", desc="sweep",
                  file=sys.stderr) as bar:
            for result in (evaluate(todo) if todo else ()):
                row = _table_row(result, grid.axes, checked.laws, checked.extra_names)
                appender.append(row)
                rows[point_key(result.values)] = row
                evaluated.append(point_key(result.values))
                bar.update(1)
    finally:
        appender.close()


def _stopped(checked: _Checked, exc: BaseException, reused: int,
             count: int) -> SweepInterrupted:
    """The :class:`SweepInterrupted` of a sweep stopped after its folder was opened."""
    out, grid = checked.plan.out, checked.grid
    kept = _kept(out / TABLE, checked.header, grid, checked.laws, checked.extra_names)
    return SweepInterrupted(exc, out, reused + count if kept is None else kept, grid.size)


def run_sweep(
    scenario_path: str | Path,
    grid_specs: Sequence[str],
    out_dir: str | Path | None = None,
    settings: SweepSettings | None = None,
    execution: Execution | None = None,
    restart: bool = False,
) -> SweepResult:
    """Evaluate every point of the grid of ``scenario_path`` and write the sweep's folder.

    Parameters
    ----------
    scenario_path
        The scenario every point starts from.
    grid_specs
        ``--grid`` texts (:mod:`feedopt.sweep.grid`).
    out_dir
        The sweep's folder (default ``out/<scenario name>_sweep``); an earlier sweep of the
        same inputs there is resumed (:mod:`feedopt.sweep.folder`).
    settings
        The laws, objective, spacing and extra metrics (:class:`SweepSettings`; default: the
        scenario's laws, T*).
    execution
        The Dask scheduler or local workers, and the progress bar (:class:`Execution`;
        default: a local cluster of one worker per core).
    restart
        Replace an earlier sweep (or feedopt output) in ``out_dir`` instead of resuming it.

    Raises
    ------
    InputError
        Bad input of any kind, before anything is written.
    SweepInterrupted
        Ctrl-C, SIGTERM or SIGHUP while points were evaluated, or the Dask cluster was lost
        (:class:`~feedopt.sweep.execute.ClusterLost`); the table keeps the finished points.
    """
    settings = SweepSettings() if settings is None else settings
    execution = Execution() if execution is None else execution
    checked = _check(scenario_path, grid_specs, out_dir, settings, execution, restart)
    grid, plan = checked.grid, checked.plan
    rows = {} if plan.fresh else read_table(plan.out / TABLE, checked.header, grid.axes,
                                            checked.laws, checked.extra_names)
    finished = done(rows)
    todo = [p for p in grid.points() if point_key(p) not in finished]
    reused = grid.size - len(todo)
    show = sys.stderr.isatty() if execution.progress is None else execution.progress
    context = (evaluator(checked.bundle, grid.axes, checked.point_settings,
                         execution.scheduler, execution.workers, len(todo)) if todo
               else contextlib.nullcontext(None))
    folder = None
    evaluated: list[tuple[float, ...]] = []
    try:
        with context as evaluate:
            folder = open_folder(plan, checked.spec)
            _evaluate(checked, rows, todo, evaluate, show, evaluated)
        return _finish(plan.out, grid, rows, checked.header, checked.goal, checked.spec,
                       len(evaluated), reused)
    except (KeyboardInterrupt, Terminated, ClusterLost) as exc:
        if folder is None and isinstance(exc, ClusterLost):
            raise InputError(f"{exc} before any point was evaluated; nothing was written: "
                             "run the same command again once the scheduler and its workers "
                             "run") from None
        if folder is None:  # stopped before anything was written
            raise
        raise _stopped(checked, exc, reused, len(evaluated)) from exc
    finally:
        if folder is not None:
            folder.close()


def _finish(out: Path, grid: Grid, rows: dict, header: list[str], goal: Objective, spec: dict,
            evaluated: int, reused: int) -> SweepResult:
    """Rewrite the table in grid order, find the best point, write best.json and the plots."""
    keys = [point_key(p) for p in grid.points()]
    in_grid = [rows[k] for k in keys]
    current = set(keys)
    others = [r for k, r in rows.items() if k not in current]  # from an earlier grid: kept
    write_table(out / TABLE, header, in_grid + others)
    found = best(in_grid, goal)
    counts = {s.value: sum(r["status"] == s.value for r in in_grid) for s in Status}
    counts["feasible"] = sum(r["feasible"] == "yes" for r in in_grid)
    summary = {"points": grid.size, **counts, "objective": goal.name,
               "best": None if found is None else _point_dict(grid, found[0]),
               "best_value": None if found is None else found[1]}
    best_doc = {"objective": goal.name, "label": goal.label, "value": summary["best_value"],
                "point": summary["best"], "row": None if found is None else found[0]}
    write_atomically(out / BEST, json.dumps(best_doc, indent=1, allow_nan=False) + "\n")
    best_index = None
    if found is not None:
        best_index = tuple(a.values.index(_as_value(a, found[0][a.name])) for a in grid.axes)
    written = write_plots(out, grid, objective_array(grid, rows, goal), goal, best_index)
    write_spec(out, {**spec, "summary": summary})
    return SweepResult(out_dir=out, grid=grid, rows=in_grid, evaluated=evaluated,
                       reused=reused, objective=goal, best=None if found is None else found[0],
                       best_value=None if found is None else found[1], counts=counts,
                       plots=written)


def _as_value(axis, text: str):
    v = float(text)
    return next(x for x in axis.values if float(x) == v)
