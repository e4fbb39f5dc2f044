"""``feedopt engagement SCENARIO.yaml``: the engagement the stock gives every path sample.

Runs the geometry, cell and process stages (no robot, no planning) of a scenario with a
``stock:`` section and writes one row per path sample: ``s_mm,x_mm,y_mm,z_mm,line,entry_deg,
exit_deg,radial_depth_mm,axial_depth_mm,intervals`` (workpiece frame; ``line`` is the program
line for a G-code path, empty otherwise; angles in the force-model frame, Altintas'
convention; empty angles and zero depths in air). ``entry_deg``/``exit_deg`` are the first and
last engaged angles, ``radial_depth_mm`` the radial depth of the widest engaged interval,
``axial_depth_mm`` the largest axial depth and ``intervals`` the number of separate engaged
intervals (two at an inside corner cut with a small radial depth). ``--intervals`` writes
every piece the force model sums, one row each: ``sample,s_mm,entry_deg,exit_deg,
axial_depth_mm`` (an interval whose depth varies across the cutter is several contiguous
pieces). ``--plot`` draws the stock's top view with the path coloured by radial depth, and the
angles and depths along s.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.outfile import check_data_and_plot, check_output_file, write_files_atomically
from feedopt.units import MM, MM_PER_M

HEADER = ("s_mm,x_mm,y_mm,z_mm,line,entry_deg,exit_deg,radial_depth_mm,axial_depth_mm,"
          "intervals")
PIECES_HEADER = "sample,s_mm,entry_deg,exit_deg,axial_depth_mm"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "engagement",
        epilog="docs: docs/stock.md",
        help="engagement of every path sample from the scenario's stock (CSV, plot)",
        description="Sweep the scenario's tool along its path through its stock (Z-map) and "
        "write the engagement per sample: " + HEADER)
    p.add_argument("scenario", help="scenario YAML file with a stock: section")
    p.add_argument("--out", metavar="CSV", help="write the samples here")
    p.add_argument("--plot", metavar="PNG", help="draw the stock and the engagement here")
    p.add_argument("--intervals", metavar="CSV",
                   help="write every engaged piece (angles and axial depth) here: "
                   + PIECES_HEADER)
    p.add_argument("--spacing", type=float, metavar="MM",
                   help="sample spacing [mm] (default: the scenario's path.spacing_mm)")
    p.set_defaults(func=run)


def engagement_table(front) -> np.ndarray:
    """(n, 10) rows of the CSV (NaN for empty cells), from the report's
    :func:`~feedopt.report.data.engagement_series`."""
    from feedopt.report.data import engagement_series

    eng = engagement_series(front.samples, front.process.material)
    moves = front.path.moves
    line = (moves.line[moves.index_at(front.samples.s)].astype(float) if moves is not None
            else np.full(eng.s_mm.size, np.nan))
    return np.column_stack([eng.s_mm, front.samples.position * MM_PER_M, line, eng.entry_deg,
                            eng.exit_deg, eng.radial_mm, eng.axial_mm, eng.intervals])


def run(args: argparse.Namespace) -> int:
    from feedopt.runner import prepare_front
    from feedopt.scenario import load_scenario, scenario_input_files

    if args.spacing is not None and not (np.isfinite(args.spacing) and args.spacing > 0):
        raise InputError(f"--spacing must be a positive number of mm, got {args.spacing}")
    scenario, base_dir = load_scenario(args.scenario)
    # every output is checked before any work: none may be the scenario or a file it reads
    inputs = [args.scenario, *scenario_input_files(scenario, base_dir)]
    check_data_and_plot(args.out, args.plot, inputs, "engagement.csv", "engagement.png")
    if args.intervals is not None:
        target = check_output_file(args.intervals, "--intervals", example="intervals.csv",
                                   inputs=inputs)
        for other, what in ((args.out, "--out"), (args.plot, "--plot")):
            if other is not None and Path(other).resolve() == target:
                raise InputError(f"{what} and --intervals are the same file {args.intervals}: "
                                 "give two names (e.g. --out engagement.csv --intervals "
                                 "intervals.csv)")
    if scenario.stock is None:
        raise InputError(f"{args.scenario}: no stock: section; give stock: {{box_mm: [x0, y0, "
                         "z0, x1, y1, z1]}} (or mesh: part.stl) for the engagement from the "
                         "material")
    def three_axis(placed) -> None:
        if placed.samples.axis is not None:
            raise InputError(f"{args.scenario}: the path tilts the tool (tool vectors), so "
                             "its engagement comes from a tri-dexel stock per profile slice, "
                             "which this command's table and Z-map figure cannot show; "
                             "feedopt run gives its stock (summary.json: scenario.stock) and "
                             "the deflection along the path (report.html)")

    front = prepare_front(scenario, base_dir, progress=lambda _m: None, spacing_mm=args.spacing,
                          placed_check=three_axis)
    table = engagement_table(front)
    material = front.process.material
    found = material.found
    print(f"{args.scenario}: {table.shape[0]} samples, {np.mean(~found.in_air):.1%} cutting; "
          f"stock {material.before.shape[0]} x {material.before.shape[1]} cells of "
          f"{material.before.cell / MM:g} mm ({material.before.nbytes / 1e6:.2f} MB); removed "
          f"{material.removed_volume / MM**3:.0f} mm^3")
    for note in material.warnings:
        print(f"warning: {note}")
    files = []
    if args.out is not None:
        def write(tmp, table=table):
            cells = [np.char.mod("%.9g", table[:, k]) for k in range(table.shape[1])]
            cells = [np.where(np.isnan(table[:, k]), "", c) for k, c in enumerate(cells)]
            for k in (4, 9):
                cells[k] = np.where(np.isnan(table[:, k]), "",
                                    np.char.mod("%d", np.nan_to_num(table[:, k]).astype(int)))
            rows = cells[0]
            for c in cells[1:]:
                rows = np.char.add(np.char.add(rows, ","), c)
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(HEADER + "\n" + "\n".join(rows.tolist()) + "\n")
        files.append((args.out, write, "--out"))
    if args.intervals is not None:
        iv = found.intervals
        pieces = np.column_stack([front.samples.s[iv.sample] * MM_PER_M, np.degrees(iv.entry),
                                  np.degrees(iv.exit), iv.axial_depth * MM_PER_M])

        def write_pieces(tmp, iv=iv, pieces=pieces):
            rows = [f"{k},{s:.9g},{e:.9g},{x:.9g},{a:.9g}" for k, (s, e, x, a)
                    in zip(iv.sample.tolist(), pieces.tolist(), strict=True)]
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(PIECES_HEADER + "\n" + "".join(r + "\n" for r in rows))
        files.append((args.intervals, write_pieces, "--intervals"))
    if args.plot is not None:
        from feedopt.report.data import engagement_series
        from feedopt.report.plots import engagement_figure

        series = engagement_series(front.samples, material)
        files.append((args.plot, lambda tmp: engagement_figure(series).savefig(tmp, dpi=120),
                      "--plot"))
    write_files_atomically(files)
    for f in (args.out, args.plot, args.intervals):
        if f is not None:
            print(f"wrote {f}")
    return 0
