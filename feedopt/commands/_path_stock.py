"""``feedopt path PROGRAM --tool T.yaml --stock-box ... | --stock-from-program``: the stock
checks ``feedopt run`` applies to a program (a rapid whose swept volume meets material, a
plunge deeper than the flutes), without a scenario (issue 28).

The sweep is :func:`feedopt.process.material.engagement_from_stock`, the one a run uses, so
``path`` refuses what ``run`` refuses, with the same message."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from pydantic import ValidationError

from feedopt.errors import InputError
from feedopt.units import MM


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The stock options of ``feedopt path`` (programs only)."""
    p.add_argument("--tool", metavar="TOOL.yaml", help="program: the tool file, for the stock "
                   "checks of --stock-box / --stock-from-program")
    p.add_argument("--stock-box", type=float, nargs=6, metavar=("X0", "Y0", "Z0", "X1", "Y1",
                   "Z1"), help="program: a stock box [mm] in the program's frame: check it "
                   "as feedopt run does (rapids through material, plunges) with --tool")
    p.add_argument("--stock-from-program", action="store_true",
                   help="program: the same with the box a run's stock.from_program makes "
                   "(from --stock-top down to the deepest cut)")
    p.add_argument("--stock-cell", type=float, default=0.25, metavar="MM",
                   help="program: Z-map cell of the stock checks (default 0.25)")


def check_stock_args(args: argparse.Namespace) -> bool:
    """True when stock checks were asked for; InputError for an incomplete or mixed request."""
    box, from_program = args.stock_box is not None, args.stock_from_program
    if box and from_program:
        raise InputError("give one of --stock-box and --stock-from-program, not both")
    if (box or from_program) and args.tool is None:
        raise InputError("the stock checks need the cutter: add --tool TOOL.yaml (its radius "
                         "and flute length)")
    if args.tool is not None and not (box or from_program):
        raise InputError("--tool is used by the stock checks only: add --stock-box X0 Y0 Z0 "
                         "X1 Y1 Z1 or --stock-from-program, or drop --tool")
    return box or from_program


def stock_check(args: argparse.Namespace, result, spacing: float) -> str:
    """Sweep the tool through the stock along ``result`` (a ProgramPath) as a run does; the
    line to print. InputError where a run would refuse the program."""
    from feedopt.process.material import engagement_from_stock
    from feedopt.process.program_stock import program_stock_box
    from feedopt.process.tool import load_tool
    from feedopt.scenario import StockSection

    tool = load_tool(Path(args.tool))
    samples = result.path.sample(spacing)
    moves = result.moves
    note = ""
    box = args.stock_box
    if args.stock_from_program:
        category = moves.category[moves.index_at(samples.s)]
        made = program_stock_box(samples.position, category, args.stock_top * MM,
                                 0.5 * tool.diameter, spacing)
        box, note = list(made.box_mm), f"\nnote: {made.note}"
    try:
        section = StockSection(box_mm=box, cell_mm=args.stock_cell)
    except ValidationError as exc:
        problem = "; ".join(e["msg"] for e in exc.errors())
        raise InputError(f"--stock-box / --stock-cell: {problem}") from None

    def resolve(rel: str, what: str) -> Path:  # a box names no file
        raise InputError(f"{what}: no file in a --stock-box check")

    found = engagement_from_stock(section, resolve, tool, samples, moves,
                                  source=str(args.waypoints))
    cutting = int(np.count_nonzero(found.found.engagement.exit > found.found.engagement.entry))
    return (f"stock: {found.before.shape[0]} x {found.before.shape[1]} cells of "
            f"{section.cell_mm:g} mm; {cutting} of {samples.s.size} samples cut; no rapid "
            f"meets material{note}" + "".join(f"\nnote: {w}" for w in found.warnings))
