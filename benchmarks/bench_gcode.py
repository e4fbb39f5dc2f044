"""Benchmark of reading and smoothing G-code programs (issue 11: 20,000 short G1 moves in
under 2 s).

Run: ``.venv/bin/python benchmarks/bench_gcode.py [--quick]``. Times, for the free-form chain
program of ``scenarios/gcode/write_programs.py`` (20,000 G1 moves of 0.06-0.98 mm, one
tangent-continuous chain) and for the bundled pocket and profile programs: reading the text
into moves, the program -> G2 path step (chains smoothed, corners, transitions, deviation
checks), sampling at 0.1 mm, and the peak memory of the whole.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.gcode import parse_gcode  # noqa: E402
from feedopt.geometry.program_path import ProgramPathOptions, program_path  # noqa: E402
from feedopt.units import MM  # noqa: E402


def _programs_module():
    spec = importlib.util.spec_from_file_location(
        "write_programs", ROOT / "scenarios" / "gcode" / "write_programs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def bench(name: str, text: str) -> dict[str, float]:
    """Seconds to read, to make the path and to sample it; peak memory [MB] (traced in a
    second run, since tracing slows the Python parts several times)."""
    t0 = time.perf_counter()
    program = parse_gcode(text, name)
    t1 = time.perf_counter()
    result = program_path(program, ProgramPathOptions())
    t2 = time.perf_counter()
    pts = result.path.sample(0.1 * MM)
    t3 = time.perf_counter()
    tracemalloc.start()
    program_path(parse_gcode(text, name), ProgramPathOptions()).path.sample(0.1 * MM)
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    chains = result.chains
    print(f"{name:>22}: {len(program.moves):>6} moves, {result.path.length / MM:>9.1f} mm, "
          f"{len(result.path.segments):>5} segments, {len(chains)} chain(s) "
          f"(largest deviation {max((c.deviation for c in chains), default=0) / MM:.4f} mm): "
          f"read {t1 - t0:.3f} s, path {t2 - t1:.3f} s, read+path {t2 - t0:.3f} s, "
          f"sample {pts.s.size} in {t3 - t2:.3f} s, peak {peak:.0f} MB")
    return {"read_s": t1 - t0, "path_s": t2 - t1, "sample_s": t3 - t2, "peak_mb": peak}


def main(quick: bool = False) -> None:
    mod = _programs_module()
    n = 2000 if quick else 20_000
    bench(f"free-form chain {n}", mod.freeform_chain_program(n))
    for name in ("pocket.nc", "profile.nc"):
        bench(name, (ROOT / "scenarios" / "gcode" / name).read_text())


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2,000 moves instead of 20,000")
    main(ap.parse_args().quick)
