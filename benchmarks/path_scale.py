"""Scaling of path building from a G-code program (issue 28): the work tree against git HEAD.

What ``feedopt path PROGRAM.nc --out ...`` does, by stage, on 3D raster finishing programs of
1k to 100k lines (:mod:`raster_program`: a sum-of-sines surface, CAM-post style):

- ``read``: :func:`feedopt.gcode.read_gcode` (arc tolerance 0.002 mm, as ``feedopt path``);
- ``smooth``: :func:`~feedopt.geometry.program_path.program_path` (chains smoothed, corners
  blended, transitions fitted within 0.01 mm, blend size 12.7 mm, stock top Z0);
- ``sample``: :meth:`Path.sample` at 0.1 mm.

Each program runs in its own child process, once with the work tree and once with the code at
git HEAD (``git archive HEAD`` exported to a temporary directory and put first on the
child's PYTHONPATH), back to back in the same run, so both see the same machine. Per stage
the time, per size the time per line and the child's peak memory (``ru_maxrss`` of the
child, from ``os.wait4``), and per stage the exponent b of a least-squares fit time ~ lines^b
(target: 1, linear) over the sizes from 10k lines on (fixed costs dominate below).

    .venv/bin/python benchmarks/path_scale.py                           # 1k .. 100k, both
    .venv/bin/python benchmarks/path_scale.py --sizes 1000,10000 --no-head
    .venv/bin/python benchmarks/path_scale.py --out benchmarks/results/path_scale_issue28.md
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from raster_program import write_raster  # noqa: E402

SIZES = (1000, 10000, 70000, 100000)
STAGES = ("read", "smooth", "sample")
SPACING_MM = 0.1
BLEND_MM = 12.7
TIMEOUT_S = 1800.0

# the child: imports feedopt from its PYTHONPATH, times the three stages, prints JSON
CHILD = """
import json, sys, time
t0 = time.perf_counter()
import feedopt
from feedopt.gcode import read_gcode
from feedopt.geometry.program_path import ProgramPathOptions, program_path
t1 = time.perf_counter()
program = read_gcode(sys.argv[1], arc_tolerance_mm=0.002)
t2 = time.perf_counter()
result = program_path(program, ProgramPathOptions(blend_size={blend} * 1e-3))
t3 = time.perf_counter()
pts = result.path.sample({spacing} * 1e-3)
t4 = time.perf_counter()
print(json.dumps({{"feedopt": feedopt.__file__, "import": t1 - t0, "read": t2 - t1,
                  "smooth": t3 - t2, "sample": t4 - t3, "samples": int(pts.s.size),
                  "moves": len(program.moves), "length_mm": result.path.length * 1e3,
                  "junctions": len(result.junctions), "chains": len(result.chains),
                  "worst_ratio": float((result.junctions.deviation
                                        / result.junctions.tolerance).max())}}))
"""


def run_child(code_root: Path, program: Path) -> dict:
    """One child process on ``program`` with feedopt from ``code_root``: its JSON plus its
    peak resident memory [bytes] (``ru_maxrss`` from ``os.wait4``); ``{"error": ...}`` if it
    failed or ran out of time."""
    env = {**os.environ, "PYTHONPATH": str(code_root), "OMP_NUM_THREADS": "1"}
    code = CHILD.format(blend=BLEND_MM, spacing=SPACING_MM)
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen([sys.executable, "-c", code, str(program)], stdout=out,
                                stderr=err, env=env, cwd=tempfile.gettempdir())
        start = time.monotonic()
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > TIMEOUT_S:
                proc.kill()
                os.wait4(proc.pid, 0)
                return {"error": f"timeout after {TIMEOUT_S:.0f} s"}
            time.sleep(0.05)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text, errors = out.read().decode(), err.read().decode()
    if proc.returncode != 0:
        return {"error": f"exit {proc.returncode}: {errors.strip().splitlines()[-1:]}"}
    res = json.loads(text.strip().splitlines()[-1])
    res["peak_bytes"] = usage.ru_maxrss * 1024  # Linux: kilobytes
    return res


def head_tree(dest: Path) -> str:
    """Export the code at git HEAD to ``dest``; the commit."""
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                            capture_output=True, text=True).stdout.strip()
    archive = subprocess.run(["git", "archive", "HEAD", "feedopt"], cwd=ROOT, check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return commit


def exponent(lines: np.ndarray, t: np.ndarray) -> float:
    """Least-squares slope of log t against log lines over the sizes from 10k lines (all
    sizes if fewer than two); nan without two valid points."""
    ok = np.isfinite(t) & (t > 0)
    big = ok & (lines >= 1e4)
    use = big if big.sum() >= 2 else ok
    if use.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(lines[use]), np.log(t[use]), 1)[0])


def _cell(r: dict, key: str) -> str:
    return "failed" if "error" in r else f"{r[key]:.2f} s"


def table(sizes: list[int], runs: dict[str, list[dict]]) -> list[str]:
    """Markdown rows: per code version and stage the times and exponent, per size the total,
    time per line, samples and peak memory."""
    lines = np.array(sizes, dtype=float)
    out = ["| code | stage | " + " | ".join(f"{n:,} lines" for n in sizes) + " | exponent |",
           "|---|---|" + "---:|" * len(sizes) + "---:|"]
    for name, rs in runs.items():
        for stage in (*STAGES, "total"):
            t = np.array([np.nan if "error" in r else
                          (sum(r[s] for s in STAGES) if stage == "total" else r[stage])
                          for r in rs])
            cells = [("failed" if "error" in r else f"{v:.2f} s") for r, v in zip(rs, t,
                                                                                   strict=True)]
            out.append(f"| {name} | {stage} | " + " | ".join(cells)
                       + f" | {exponent(lines, t):.2f} |")
        per_line = ["-" if "error" in r else
                    f"{1e6 * sum(r[s] for s in STAGES) / n:.0f} us" for r, n in zip(rs, sizes,
                                                                                      strict=True)]
        out.append(f"| {name} | time per line | " + " | ".join(per_line) + " | |")
        mem = ["-" if "error" in r else f"{r['peak_bytes'] / 2**20:.0f} MiB" for r in rs]
        out.append(f"| {name} | peak memory | " + " | ".join(mem) + " | |")
    return out


def details(sizes: list[int], runs: dict[str, list[dict]]) -> list[str]:
    out = []
    for name, rs in runs.items():
        for n, r in zip(sizes, rs, strict=True):
            if "error" in r:
                out.append(f"- {name}, {n:,} lines: {r['error']}")
                continue
            out.append(f"- {name}, {n:,} lines: {r['moves']:,} moves, {r['length_mm']:.0f} mm, "
                       f"{r['samples']:,} samples, {r['junctions']:,} junctions, "
                       f"{r['chains']:,} smoothed chains, worst deviation "
                       f"{r['worst_ratio']:.3f} of the tolerance")
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default=",".join(map(str, SIZES)),
                   help="program sizes in lines, comma-separated")
    p.add_argument("--no-head", action="store_true", help="only the work tree")
    p.add_argument("--out", type=Path, help="write the markdown report here")
    args = p.parse_args(argv)
    sizes = [int(v) for v in args.sizes.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        programs = []
        for n in sizes:
            prog = tmp / f"raster_{n}.nc"
            write_raster(n, prog)
            programs.append(prog)
        roots = {"work tree": ROOT}
        commit = ""
        if not args.no_head:
            (tmp / "head").mkdir()
            commit = head_tree(tmp / "head")
            roots[f"HEAD {commit}"] = tmp / "head"
        runs: dict[str, list[dict]] = {name: [] for name in roots}
        for n, prog in zip(sizes, programs, strict=True):
            for name, root in roots.items():  # back to back, same program
                r = run_child(root, prog)
                runs[name].append(r)
                print(f"{name:>14} {n:>7} lines: "
                      + ("  ".join(f"{s} {_cell(r, s)}" for s in STAGES) if "error" not in r
                         else r["error"]), flush=True)
    report = ["# Path building at scale (issue 28): `benchmarks/path_scale.py`", "",
              f"{datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
              f"Python {platform.python_version()}; generated 3D raster programs "
              f"(`benchmarks/raster_program.py`), tolerance 0.01 mm, blend 12.7 mm, samples "
              f"every {SPACING_MM} mm. Exponent: slope of log time vs log lines from 10k lines.",
              "", *table(sizes, runs), "", *details(sizes, runs), ""]
    text = "\n".join(report)
    print(text)
    if args.out:
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
