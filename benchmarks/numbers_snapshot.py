"""Every number of the bundled runs, as JSON, to check that a refactor changes none of them.

    python benchmarks/numbers_snapshot.py > before.json   # on the old code
    python benchmarks/numbers_snapshot.py --compare before.json   # on the new code

Compares cycle times, T*, deflections, feeds, accelerations, jerks and the per-sample bound,
feed and deflection arrays (max relative difference) of every law of every bundled scenario.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ("triangle_slot", "square_slot", "linear_peripheral")


def snapshot(spacing_mm: float | None) -> dict:
    from feedopt.runner import run_scenario

    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in SCENARIOS:
            res = run_scenario(ROOT / "scenarios" / f"{name}.yaml", out_dir=Path(tmp) / name,
                               spacing_mm=spacing_mm, report=False, progress=lambda _m: None)
            entry = {"v_max": res.prepared.bound.v_max.tolist(), "laws": {}}
            for law, r in res.laws.items():
                s = res.summary["laws"][law]
                entry["laws"][law] = {
                    "numbers": {k: v for k, v in s.items()
                                if isinstance(v, float | int) and not isinstance(v, bool)
                                and not k.endswith("time_s") or k == "cycle_time_s"},
                    "feed": r.verification.feed.tolist(),
                    "deflection": r.verification.deflection.tolist(),
                }
            out[name] = entry
    return out


def _rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return float("inf")
    scale = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(scale > 0, np.abs(a - b) / scale, 0.0)
    return float(np.nanmax(d)) if d.size else 0.0


def compare(old: dict, new: dict) -> float:
    worst = 0.0
    for name, entry in old.items():
        rows = [("v_max", _rel(entry["v_max"], new[name]["v_max"]))]
        for law, e in entry["laws"].items():
            n = new[name]["laws"].get(law)
            if n is None:
                rows.append((f"{law} missing", float("inf")))
                continue
            for key, value in e["numbers"].items():
                if value is not None and n["numbers"].get(key) is not None:
                    rows.append((f"{law}.{key}", _rel(value, n["numbers"][key])))
            rows += [(f"{law}.feed", _rel(e["feed"], n["feed"])),
                     (f"{law}.deflection", _rel(e["deflection"], n["deflection"]))]
        for what, d in rows:
            worst = max(worst, d)
            if d > 1e-12:
                print(f"{name}: {what} differs by {d:.3g} (relative)")
    print(f"largest relative difference: {worst:.3g}")
    return worst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spacing-mm", type=float, default=None,
                    help="override the scenarios' spacing (default: their own)")
    ap.add_argument("--compare", metavar="JSON", help="compare against a stored snapshot")
    args = ap.parse_args()
    new = snapshot(args.spacing_mm)
    if args.compare:
        return 0 if compare(json.loads(Path(args.compare).read_text()), new) <= 1e-12 else 1
    json.dump(new, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
