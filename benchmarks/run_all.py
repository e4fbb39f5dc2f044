"""End-to-end benchmark: planning time per stage and cycle time per law.

For the bundled triangle slot and for a random polyline path (same robot, tool and cut),
at about 1e3, 1e4 and 1e5 path samples, prints the time of each stage (geometry, process,
robot, bounds), of each timing law (planning + replay verification) and each law's cycle
time divided by the lower bound T* = integral ds / v_max(s).

    .venv/bin/python benchmarks/run_all.py            # 1e3, 1e4, 1e5 samples
    .venv/bin/python benchmarks/run_all.py --quick    # 1e3, 1e4 samples
    .venv/bin/python benchmarks/run_all.py --laws topp,jerk --sizes 1000,100000
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from feedopt.runner import plan_and_verify, prepare  # noqa: E402
from feedopt.scenario import LAWS, load_scenario  # noqa: E402


def _random_polyline_csv(folder: Path, seed: int = 7) -> Path:
    """A random 2D polyline (12 corners, 40-80 mm legs, turns up to 120 deg) as a CSV.

    With 12.7 mm varying-radius blends every path radius stays above half the cutter radius
    (the runner refuses tighter ones, feedopt.process.path_radius)."""
    rng = np.random.default_rng(seed)
    heading, p, pts = 0.0, np.zeros(3), [np.zeros(3)]
    for _ in range(13):
        heading += np.deg2rad(rng.uniform(-120, 120))
        heading = np.clip(heading, -np.pi / 2, np.pi / 2)  # keep going roughly +x
        p = p + rng.uniform(40, 80) * np.array([np.cos(heading), np.sin(heading), 0.0])
        pts.append(p)
    f = folder / "random_polyline.csv"
    np.savetxt(f, np.array(pts), delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    return f


def bench(case: str, scenario, base: Path, n: int, laws: list[str]) -> list[str]:
    rows = []
    quiet = lambda _msg: None  # noqa: E731
    # Length first (cheap), then the spacing that gives about n samples.
    length_mm = prepare(scenario, base, quiet, spacing_mm=1.0).problem.length * 1e3
    spacing = length_mm / (n - 1)
    t0 = time.perf_counter()
    prepared = prepare(scenario, base, quiet, spacing_mm=spacing)
    total = time.perf_counter() - t0
    st = prepared.stage_times
    rows.append(f"{case:<10} {prepared.problem.n:>7} stages: geometry {st['geometry']:.3f} s, "
                f"process {st['process']:.3f} s, robot {st['robot']:.3f} s, bounds "
                f"{st['bounds']:.3f} s (total {total:.2f} s); T* = "
                f"{prepared.problem.lower_bound_time():.3f} s")
    results = plan_and_verify(prepared, laws, quiet)
    for law, r in results.items():
        ratio = r.trajectory.duration / prepared.problem.lower_bound_time()
        rows.append(f"{'':<10} {'':>7} {law:<9} plan {r.planning_time:7.3f} s  verify "
                    f"{r.verification_time:6.3f} s  cycle "
                    f"{r.trajectory.duration:8.3f} s  = {ratio:.4f} T*  verified "
                    f"{r.verification.verified}")
    return rows


def main(quick: bool = False, sizes: list[int] | None = None, laws: list[str] | None = None):
    sizes = sizes or ([1000, 10000] if quick else [1000, 10000, 100000])
    laws = laws or list(LAWS)
    scenario, base = load_scenario(ROOT / "scenarios" / "triangle_slot.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        csv = _random_polyline_csv(Path(tmp))
        random_sc = scenario.model_copy(update={"path": scenario.path.model_copy(
            update={"generator": "csv", "file": str(csv), "blend_size_mm": 12.7})})
        for n in sizes:
            for case, sc in (("triangle", scenario), ("random", random_sc)):
                for row in bench(case, sc, base, n, laws):
                    print(row, flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--sizes", help="comma-separated sample counts")
    ap.add_argument("--laws", help="comma-separated laws")
    a = ap.parse_args()
    main(a.quick, [int(x) for x in a.sizes.split(",")] if a.sizes else None,
         a.laws.split(",") if a.laws else None)
