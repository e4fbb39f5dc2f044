"""How much of the deflection is the tool's own bending (issue 34), measured on the bundled runs.

The default scenario (``triangle_slot.yaml``) plans with the thesis's tool file, which has no
stickout: the 19.05 mm HSS end mill is taken as rigid, as in the thesis. This script runs it
again with the same cutter clamped at stated stickouts (the thesis gives none; 2 in is a common
projection of a 3/4 in end mill in a side-lock holder) and the 2 mm carbide ball-nose raster
(``ball_raster.yaml``) with its tool rigid, as in its file (14 mm out) and further out,
and reports the tool's lateral stiffness, its share of the revolution-mean deflection at the
nominal feed (median over the cutting samples and at the largest deflection; summary.json
``scenario.tool.bending``) and the change of the convex law's cycle time.

    .venv/bin/python benchmarks/tool_share.py [--out benchmarks/results/tool_share.txt]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
#: (scenario, label, tool-file fields replaced; None: the tool file as it is)
CASES = (
    ("triangle_slot", "thesis tool rigid (its file)", None),
    ("triangle_slot", "thesis tool, 50.8 mm out (HSS)", {"stickout_mm": 50.8, "material": "hss"}),
    ("triangle_slot", "thesis tool, 76.2 mm out (HSS)", {"stickout_mm": 76.2, "material": "hss"}),
    ("ball_raster", "2 mm ball rigid", {"stickout_mm": None}),
    ("ball_raster", "2 mm ball, 14 mm out (its file)", None),
    ("ball_raster", "2 mm ball, 2 mm shank 10 mm out", {"stickout_mm": 10.0,
                                                       "shank_diameter_mm": 2.0}),
    ("ball_raster", "2 mm ball, 2 mm shank 20 mm out", {"stickout_mm": 20.0,
                                                       "shank_diameter_mm": 2.0}),
)


def _scenario_with(name: str, fields: dict | None, tmp: Path) -> Path:
    """The scenario file, its tool file's ``fields`` replaced (None values removed)."""
    src = ROOT / "scenarios" / f"{name}.yaml"
    if fields is None:
        return src
    doc = yaml.safe_load(src.read_text())
    tool = yaml.safe_load((src.parent / doc["tool"]).read_text())
    for key, value in fields.items():
        tool.pop(key, None) if value is None else tool.__setitem__(key, value)
    (tmp / "tool.yaml").write_text(yaml.safe_dump(tool))
    doc["tool"] = str(tmp / "tool.yaml")
    for key in ("directory",):
        doc["robot"][key] = str((src.parent / doc["robot"][key]).resolve())
    for key in ("material",):
        doc[key] = str((src.parent / doc[key]).resolve())
    path = doc.get("path", {})
    if "file" in path:
        path["file"] = str((src.parent / path["file"]).resolve())
    stock = doc.get("stock") or {}
    if stock.get("mesh"):
        stock["mesh"] = str((src.parent / stock["mesh"]).resolve())
    out = tmp / f"{name}.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def _row(name: str, label: str, fields: dict | None) -> str:
    from feedopt.runner import run_scenario

    with tempfile.TemporaryDirectory() as tmp:
        scenario = _scenario_with(name, fields, Path(tmp))
        res = run_scenario(scenario, out_dir=Path(tmp) / "out", report=False,
                           progress=lambda _m: None)
    bending = res.summary["scenario"]["tool"]["bending"]
    share = bending.get("share_of_mean_deflection") or {}
    k = bending.get("lateral_stiffness_n_per_um")
    law = res.summary["laws"].get("convex") or {}
    return (f"| {label} | {'rigid' if k is None else f'{k:.3g}'} | "
            f"{100 * share['median']:.1f} % | {100 * share['at_largest']:.1f} % | "
            if share else f"| {label} | rigid | 0 | 0 | ") + f"{law.get('cycle_time_s', 0):.2f} |"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, help="also write the table here")
    args = p.parse_args(argv)
    lines = ["| case | tool lateral stiffness [N/um] | tool's share of the mean deflection "
             "(median) | at the largest deflection | convex T [s] |",
             "|:--|--:|--:|--:|--:|"]
    for case in CASES:
        lines.append(_row(*case))
        print(lines[-1], file=sys.stderr)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
