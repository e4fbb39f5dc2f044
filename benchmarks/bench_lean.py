"""The cost of the feed's lean in the force model (issue 35), back to back with the same
five-axis run without it, in one process.

Prepares a five-axis scenario (default: the tilted ball-nose surfacing, ``scenarios/
five_axis_ball.yaml``) once, then builds the deflection bound (``schedule_problem``: the
forces over the angle grid and at every critical angle of every sample) and the revolution
means (``DeflectionModel.mean_terms``, compensation's) with the engagement as the process
stage gives it (``feed_axial`` set: leaning general-cutter slices, front and back
intervals) and with the lean removed (the feed taken across the axis, as before the lean
was modelled). Best of ``--repeat`` runs each, alternated.

    .venv/bin/python benchmarks/bench_lean.py [--scenario scenarios/five_axis_ball.yaml]
        [--repeat 3] [--out benchmarks/results/lean_forces.txt]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from feedopt.runner import prepare
from feedopt.scenario import load_scenario
from feedopt.schedule.stage import schedule_problem

ROOT = Path(__file__).resolve().parent.parent


def _timed(prepared, process) -> dict[str, float]:
    """Seconds of the bound and of the revolution means, and the bound's T* [s]."""
    p = prepared
    t0 = time.perf_counter()
    inputs = schedule_problem(p.scenario, process, p.robot, p.along, p.placement, p.samples,
                              p.path)
    t1 = time.perf_counter()
    inputs.model.mean_terms(slice(0, inputs.model.n))
    t2 = time.perf_counter()
    return {"bound": t1 - t0, "means": t2 - t1,
            "t_star": float(inputs.problem.lower_bound_time())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "five_axis_ball.yaml"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "lean_forces.txt"))
    args = ap.parse_args(argv)
    scenario, base = load_scenario(args.scenario)
    prepared = prepare(scenario, base, progress=lambda _m: None)
    leaning = prepared.process
    across = replace(leaning, engagement=leaning.engagement.with_feed_axial(None))
    lean = leaning.engagement.feed_axial
    cutting = leaning.engagement.exit > leaning.engagement.entry
    best = {"lean": {}, "across": {}}
    for _ in range(args.repeat):
        for name, process in (("lean", leaning), ("across", across)):
            got = _timed(prepared, process)
            for key, value in got.items():
                keep = min if key != "t_star" else (lambda a, b: b)
                best[name][key] = keep(best[name].get(key, value), value)
    deg = np.degrees(np.arcsin(lean[cutting])) if lean is not None else np.zeros(1)
    lines = [f"bench_lean: {Path(args.scenario).name}, {prepared.samples.s.size} samples "
             f"({int(cutting.sum())} cutting, lean {deg.min():.1f}..{deg.max():.1f} deg), "
             f"best of {args.repeat} (alternated)",
             "| feed in the force model | bound [s] | revolution means [s] | T* [s] |",
             "|---|---:|---:|---:|"]
    for name, label in (("lean", "leaning (feed_axial)"), ("across", "across the axis")):
        b = best[name]
        lines.append(f"| {label} | {b['bound']:.3f} | {b['means']:.3f} | {b['t_star']:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
