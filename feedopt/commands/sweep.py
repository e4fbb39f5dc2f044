"""``feedopt sweep SCENARIO.yaml --grid FIELD=VALUES``: the pipeline over a grid, on Dask."""

from __future__ import annotations

import argparse
import signal
import sys

from feedopt.errors import InputError, Terminated

#: Exit code of a sweep stopped because its Dask scheduler (or every worker) was lost.
CLUSTER_LOST_EXIT = 3


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sweep",
        epilog="docs: docs/sweeps.md",
        help="plan a scenario over a grid of placements or other numeric fields (Dask)",
        description="Plan and verify SCENARIO.yaml at every point of a grid of numeric fields "
        "(no exports) on a local Dask cluster or a running one, and write one table row per "
        "point (T*, each law's cycle time and verdict, max deflection at the nominal feed, "
        "reachability and the reason when a point fails), a heat map per pair of swept "
        "fields and the best feasible point. An interrupted sweep resumes: run the same "
        "command again.",
    )
    p.add_argument("scenario", help="scenario YAML file (see scenarios/)")
    p.add_argument("--grid", action="append", default=[], metavar="FIELD=VALUES",
                   help="a swept field and its values, repeatable: FIELD=lo:hi:step (both ends "
                   "included), FIELD=v1;v2;..., or for a vector FIELD=x:lo:hi:step,y:...,z:v "
                   "(components x/y/z or 0..n-1). FIELD is a scenario field's dotted path "
                   "(workpiece.position_mm, cut.axial_depth_mm, deflection.limit_mm, "
                   "path.blend_size_mm, ...) or robot_yaml.<path> for robot.yaml (e.g. "
                   "robot_yaml.tool.tcp_xyz_mm for the TCP offset)")
    p.add_argument("--out", help="sweep folder (default: out/<scenario name>_sweep/): new, "
                   "empty, or an earlier sweep of the same inputs, which is resumed; never a "
                   "folder of your own files")
    p.add_argument("--restart", action="store_true",
                   help="replace an earlier sweep (or feedopt output) in --out instead of "
                   "resuming it")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786); default: a local cluster")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default and most: one per "
                   "usable core, and one per point; 0: evaluate in this process without Dask)")
    p.add_argument("--spacing-mm", "--spacing", dest="spacing_mm", type=float, metavar="MM",
                   help="override the path sample spacing (mm)")
    p.add_argument("--laws", help="comma-separated laws run at every point (default: the "
                   "scenario's)")
    p.add_argument("--objective", default="t_star",
                   help="what the best feasible point minimises: t_star (default), "
                   "cycle_time:<law>, max_deflection or mean_deflection (at the nominal feed)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (it is shown "
                   "only when stderr is a terminal anyway)")
    p.set_defaults(func=run)


def _fmt(value: str) -> str:
    try:
        return f"{float(value):.4g}"
    except ValueError:
        return value or "-"


def _stopped(exc) -> int:
    """Report a stopped sweep; its exit code: 128 + N for signal N, 3 for a lost cluster."""
    from feedopt.sweep.execute import ClusterLost

    cause = exc.cause
    keeps = (f"{exc.out / 'sweep.csv'} keeps {exc.finished} of {exc.total} points: run the "
             "same command again to resume")
    if isinstance(cause, ClusterLost):
        print(f"feedopt sweep: stopped ({cause}); {keeps} (with --scheduler: once a scheduler "
              "and workers run again, at the new address if it changed)", file=sys.stderr)
        return CLUSTER_LOST_EXIT
    name = cause.signal_name if isinstance(cause, Terminated) else "SIGINT"
    print(f"feedopt sweep: stopped ({name}); {keeps}", file=sys.stderr)
    return 128 + (cause.signal_number if isinstance(cause, Terminated) else signal.SIGINT)


def _note_workers(workers: int | None, scheduler: str | None) -> None:
    """Say so when --workers asks for more processes than there are usable cores."""
    from feedopt.sweep.execute import usable_cores

    if workers and scheduler is None and workers > usable_cores():
        print(f"feedopt sweep: --workers {workers}: this process may use {usable_cores()} "
              f"core(s); starting at most {usable_cores()} worker process(es) (each point runs "
              "on one core: more would only share the cores)", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from feedopt.commands.run import parse_laws
    from feedopt.sweep import Execution, SweepInterrupted, SweepSettings, run_sweep

    if args.spacing_mm is not None and not args.spacing_mm > 0:
        raise InputError(f"--spacing-mm must be positive, got {args.spacing_mm}")
    if args.workers is not None and args.workers >= 0:
        _note_workers(args.workers, args.scheduler)
    try:
        result = run_sweep(
            args.scenario, args.grid, out_dir=args.out,
            settings=SweepSettings(laws=parse_laws(args.laws), objective=args.objective,
                                   spacing_mm=args.spacing_mm),
            execution=Execution(scheduler=args.scheduler, workers=args.workers,
                                progress=False if args.no_progress else None),
            restart=args.restart)
    except SweepInterrupted as exc:
        return _stopped(exc)
    c = result.counts
    print(f"{result.grid.size} points ({result.evaluated} evaluated now, {result.reused} from "
          f"the earlier table): {c['ok']} planned ({c['feasible']} feasible), {c['refused']} "
          f"refused, {c['error']} internal errors")
    if result.best is None:
        print(f"no feasible point for {result.objective.name}")
    else:
        where = ", ".join(f"{a.name}={result.best[a.name]}" for a in result.grid.axes)
        laws = [k.removesuffix(".cycle_time_s") for k in result.best if
                k.endswith(".cycle_time_s")]
        times = ", ".join(f"{law} {_fmt(result.best[law + '.cycle_time_s'])} s" for law in laws)
        print(f"best ({result.objective.label}: {result.best_value:.6g}): {where}\n"
              f"  T* {_fmt(result.best['t_star_s'])} s; max deflection at the nominal feed "
              f"{_fmt(result.best['max_deflection_nominal_mm'])} mm; cycle times: {times}")
    print(f"wrote {result.out_dir} (sweep.csv, best.json, {len(result.plots)} plot(s))")
    if c["error"]:
        print(f"feedopt sweep: {c['error']} point(s) hit internal errors (status error in "
              "sweep.csv); run the same command again to retry them", file=sys.stderr)
        return 1
    return 0
