"""Scaling benchmark: a whole run (every law, verified, exported, reported) by sample count.

The bundled triangle slot with its sample spacing chosen for about 1e3, 1e4, 1e5 and 1e6
samples (the issue-15 table). Each size runs in its own process (so its peak memory is its
own): the time of every stage and of every law's planning, verification and export
(:class:`feedopt.profiling.RunProfile`, what ``feedopt run --profile`` prints), the total, the
peak memory, and per row the exponent b of a fit time ~ n^b over the sizes from 1e4 on
(constant costs dominate below). Cycle times are printed per size as a check that only the
sampling changes them.

    .venv/bin/python benchmarks/bench_scale.py                      # 1e3 .. 1e6
    .venv/bin/python benchmarks/bench_scale.py --sizes 1000,10000   # quick
    .venv/bin/python benchmarks/bench_scale.py --out benchmarks/results/bench_scale.txt
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


class TreePeak:
    """Largest total memory of this process and its children (the report's and the convex
    law's forks), sampled every ``period`` s: the sum of their PSS (proportional set size,
    /proc/PID/smaps_rollup), which counts a page shared by several processes once in all.
    Linux only (0 elsewhere)."""

    def __init__(self, period: float = 0.05) -> None:
        self.period, self.peak, self._stop = period, 0, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _pss(pid: int) -> int:
        try:
            for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
                if line.startswith("Pss:"):
                    return int(line.split()[1]) * 1024
        except OSError:  # the child has just ended
            pass
        return 0

    @staticmethod
    def _tree(pid: int) -> list[int]:
        out = [pid]
        for task in Path(f"/proc/{pid}/task").glob("*/children"):
            try:
                out += [q for c in task.read_text().split() for q in TreePeak._tree(int(c))]
            except OSError:
                pass
        return out

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, sum(self._pss(p) for p in self._tree(os.getpid())))
            self._stop.wait(self.period)

    def __enter__(self) -> TreePeak:
        if Path("/proc/self/smaps_rollup").exists():
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()


def one_run(scenario: Path, n: int) -> dict:
    """Run ``scenario`` with about ``n`` samples; its profile, cycle times and verdicts."""
    from feedopt.runner import prepare_front, run_scenario
    from feedopt.scenario import load_scenario

    sc, base = load_scenario(scenario)
    length_mm = prepare_front(sc, base, lambda _m: None).path.length * 1e3
    with tempfile.TemporaryDirectory() as tmp, TreePeak() as tree:
        res = run_scenario(scenario, out_dir=Path(tmp) / "out", spacing_mm=length_mm / (n - 1),
                           progress=lambda _m: None)
    prof = res.profile
    return {
        "samples": prof.samples,
        "total_s": prof.total_s,
        "tree_peak_bytes": tree.peak,
        "peak_memory_bytes": prof.peak_memory_bytes,
        "child_peak_memory_bytes": prof.child_peak_memory_bytes,
        "rows": [[r.stage, r.law, r.seconds] for r in prof.rows],
        "laws": {law: {"cycle_time_s": e["cycle_time_s"], "verified": e["verified"],
                       "exported": e["exported"]}
                 for law, e in res.summary["laws"].items()},
    }


def fitted_exponent(n: np.ndarray, t: np.ndarray) -> float:
    """Least-squares slope of log t against log n (nan with fewer than two points)."""
    ok = (n >= 1e4) & (t > 0)
    if ok.sum() < 2:
        ok = t > 0
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)[0])


def table(runs: list[dict]) -> str:
    """Time per stage and law by size, the fitted exponents, totals and peak memory."""
    keys = list(dict.fromkeys((s, law) for r in runs for s, law, _ in r["rows"]))
    n = np.array([r["samples"] for r in runs], dtype=float)
    head = f"{'stage':8s} {'law':9s}" + "".join(f"{int(v):>12d}" for v in n) + "   exponent"
    lines = [head, "-" * len(head)]
    for key in keys:
        t = np.array([next((x for s, law, x in r["rows"] if (s, law) == key), np.nan)
                      for r in runs])
        lines.append(f"{key[0]:8s} {key[1] or '-':9s}" + "".join(f"{v:11.3f}s" for v in t)
                     + f"   {fitted_exponent(n, t):8.2f}")
    total = np.array([r["total_s"] for r in runs])
    lines.append(f"{'total':18s}" + "".join(f"{v:11.3f}s" for v in total)
                 + f"   {fitted_exponent(n, total):8.2f}")
    lines.append(f"{'peak memory':18s}" + "".join(
        f"{r['peak_memory_bytes'] / 2**20:9.0f}MiB" for r in runs))
    lines.append(f"{'largest child':18s}" + "".join(
        f"{r.get('child_peak_memory_bytes', 0) / 2**20:9.0f}MiB" for r in runs)
        + "   (peak RSS of a fork, shares the parent's pages)")
    lines.append(f"{'all processes':18s}" + "".join(
        f"{r.get('tree_peak_bytes', 0) / 2**20:9.0f}MiB" for r in runs)
        + "   (peak of the summed PSS, sampled every 50 ms)")
    lines.append("")
    for r in runs:
        laws = ", ".join(f"{law} {e['cycle_time_s']:.6f} s"
                         f"{'' if e['verified'] else ' NOT verified'}"
                         f"{' exported' if e['exported'] else ''}"
                         for law, e in r["laws"].items())
        lines.append(f"{r['samples']:>8d} samples: {laws}")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000,100000,1000000",
                    help="comma-separated sample counts (default: 1e3,1e4,1e5,1e6)")
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "triangle_slot.yaml"))
    ap.add_argument("--out", help="also write the table to this file")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # child: one size, JSON out
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one_run(Path(args.scenario), args.one)))
        return 0
    runs = []
    for n in (int(x) for x in args.sizes.split(",")):
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, __file__, "--one", str(n), "--scenario",
                               args.scenario], capture_output=True, text=True, check=False)
        if done.returncode != 0:
            print(done.stderr, file=sys.stderr)
            return 1
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"{n}: {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    text = table(runs)
    print(text)
    if args.out:
        Path(args.out).write_text(
            f"# benchmarks/bench_scale.py, {time.strftime('%Y-%m-%d')}, "
            f"{Path(args.scenario).name}, 2-core machine\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
