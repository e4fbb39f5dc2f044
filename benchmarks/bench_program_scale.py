"""Scaling benchmark on programs: a whole run of generated 3D raster programs by their length.

Issue 28's measurement: a program of 1k, 10k, 70k and 100k lines (``raster_program.py``: a
sum-of-sines surface machined by a zigzag raster in a CAM post's style, a 6 mm flat end mill)
planned end to end in the cell of ``real_programs_scenario.yaml`` at 0.1 mm spacing: the
stock made from the program (Z-map engagement along the path), the deflection bound, every
law, the dense replay, the exports. Each size runs in its own process: the time of every stage
and law (``feedopt run --profile``'s rows), the total, the peak memory of the process tree,
and per row the exponent b of a fit time ~ lines^b (from 1e4 lines on; target: 1).

    .venv/bin/python benchmarks/bench_program_scale.py                      # 1k .. 100k
    .venv/bin/python benchmarks/bench_program_scale.py --sizes 1000,10000   # quick
    .venv/bin/python benchmarks/bench_program_scale.py \
        --out benchmarks/results/bench_program_scale.txt
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_scale import TreePeak, table  # noqa: E402
from raster_program import write_raster  # noqa: E402

TEMPLATE = ROOT / "benchmarks" / "real_programs_scenario.yaml"
TOOL = ROOT / "tests" / "data" / "gcode" / "posts" / "tool_6mm_2flute.yaml"
LAWS = ["programmed", "topp", "convex", "jerk", "thesis"]


def scenario_for(program: Path, folder: Path, spacing_mm: float) -> Path:
    """The template made for ``program``: absolute files, the 6 mm tool, every law."""
    doc = yaml.safe_load(TEMPLATE.read_text(encoding="utf-8"))
    base = TEMPLATE.parent
    doc["robot"]["directory"] = str((base / doc["robot"]["directory"]).resolve())
    doc["material"] = str((base / doc["material"]).resolve())
    doc["tool"] = str(TOOL)
    doc["name"] = program.stem
    doc["path"]["file"] = str(program)
    doc["path"]["spacing_mm"] = spacing_mm
    doc["schedule"]["laws"] = LAWS
    out = folder / "scenario.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return out


def one_run(lines: int, spacing_mm: float) -> dict:
    """Generate a program of ``lines`` lines and run it; its profile, cycle times, verdicts."""
    from feedopt.runner import run_scenario

    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / f"raster_{lines}.nc"
        written = write_raster(lines, program)
        scen = scenario_for(program, Path(tmp), spacing_mm)
        with TreePeak() as tree:
            res = run_scenario(scen, out_dir=Path(tmp) / "out", progress=lambda _m: None)
    prof = res.profile
    return {
        "lines": written,
        "samples": written,  # the table's size column and the exponent fit: program lines
        "sample_count": prof.samples,
        "total_s": prof.total_s,
        "tree_peak_bytes": tree.peak,
        "peak_memory_bytes": prof.peak_memory_bytes,
        "child_peak_memory_bytes": prof.child_peak_memory_bytes,
        "rows": [[r.stage, r.law, r.seconds] for r in prof.rows],
        "laws": {law: {"cycle_time_s": e["cycle_time_s"], "verified": e["verified"],
                       "exported": e["exported"]}
                 for law, e in res.summary["laws"].items()},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000,70000,100000",
                    help="comma-separated program lengths in lines (default 1k,10k,70k,100k)")
    ap.add_argument("--spacing-mm", type=float, default=0.1)
    ap.add_argument("--out", help="also write the table to this file")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # child: one size, JSON out
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one_run(args.one, args.spacing_mm)))
        return 0
    runs = []
    for n in (int(x) for x in args.sizes.split(",")):
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, __file__, "--one", str(n), "--spacing-mm",
                               str(args.spacing_mm)], capture_output=True, text=True,
                              check=False)
        if done.returncode != 0:
            print(done.stderr[-3000:], file=sys.stderr)
            return 1
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"{n} lines: {time.perf_counter() - t0:.1f} s wall", file=sys.stderr, flush=True)
    text = table(runs).replace("samples:", "lines:")
    text += "\n" + "\n".join(f"{r['lines']:>8d} lines: {r['sample_count']} samples"
                             for r in runs)
    print(text)
    if args.out:
        Path(args.out).write_text(
            f"# benchmarks/bench_program_scale.py, {time.strftime('%Y-%m-%d')}, spacing "
            f"{args.spacing_mm} mm, 2-core machine (sizes = program lines)\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
