"""CAMotics' ball-nose examples planned end to end (issue 34), on a folder of their programs.

CAMotics (github.com/CauldronDevelopmentLLC/CAMotics, GPL-2.0: not committed here) ships 3D
examples cut with ball-nose mills; their ``.camotics`` projects give the tool and the workpiece:

* ``examples/bear/bear.nc``: 1/8 in ball-nose, 1 in long; workpiece 80 x 80 x 20 mm; S15000,
  F6000 (mm/min): a single-depth raster up to 17.4 mm deep;
* ``examples/cameo/cameo.nc``: 2 mm ball-nose, 10 mm long; workpiece 167.2 x 207.9 x 7 mm;
  no S word (10000 rpm assumed here), F300: a 0.25 mm step-over raster to 6 mm deep.

Each runs on the KR500-3 with the 6061 coefficients extrapolated to its speed (stated by the
run), a box stock of the project's workpiece, the ball as a tool file (teeth 2, helix 30 deg,
carbide, stickout and shank assumed: written in the table) and a 3 mm deflection limit (these
are full-depth single-pass rasters: a robot deflects by millimetres on them; the point is that
they plan and verify end to end, and what the tool's share is).

    .venv/bin/python benchmarks/camotics_ball.py /path/to/camotics/examples_folder
        [--out benchmarks/results/camotics_ball.txt]

The folder holds ``bear.nc`` and ``cameo.nc`` (e.g. ``git show HEAD:examples/bear/bear.nc``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
#: program: (tool fields, stock box [mm], spindle rpm if the program has none, path spacing)
JOBS = {
    "bear.nc": ({"diameter_mm": 3.175, "flute_length_mm": 25.4, "stickout_mm": 30.0,
                 "shank_diameter_mm": 3.175, "overall_length_mm": 50.8},
                [0, 0, -20, 80, 80, 0], None, 0.25),
    "cameo.nc": ({"diameter_mm": 2.0, "flute_length_mm": 10.0, "stickout_mm": 16.0,
                  "shank_diameter_mm": 4.0, "overall_length_mm": 50.0},
                 [-83.6, -104.153, -7, 83.6, 103.747, 0], 10000.0, 0.5),
}


def scenario(program: Path, tmp: Path) -> Path:
    """A scenario file for one of :data:`JOBS` in ``tmp``."""
    fields, box, rpm, spacing = JOBS[program.name]
    tool = {"name": f"{fields['diameter_mm']:g} mm ball-nose (CAMotics project)",
            "source": "CAMotics .camotics project (diameter, length); the rest assumed",
            "shape": "ball", "material": "carbide", "teeth": 2, "helix_deg": 30.0, **fields}
    (tmp / "tool.yaml").write_text(yaml.safe_dump(tool))
    cut = {"extrapolate_coefficients": True} | ({"spindle_rpm": rpm} if rpm else {})
    doc = {"name": program.stem, "description": f"CAMotics examples {program.name}",
           "robot": {"directory": str(ROOT / "robots" / "kuka_kr500_3"), "stiffness": "dpp",
                     "start_configuration_deg": [9.728, -64.745, 107.062, 0.0, 47.682, 0.0]},
           "workpiece": {"position_mm": [1750.0, -300.0, 800.0], "rpy_deg": [0.0, 0.0, 0.0]},
           "path": {"generator": "gcode", "file": str(program.resolve()), "tolerance_mm": 0.01,
                    "air_tolerance_mm": 0.5, "spacing_mm": spacing},
           "tool": str(tmp / "tool.yaml"),
           "material": str(ROOT / "scenarios" / "materials" / "6061-T6511.yaml"),
           "cut": cut, "stock": {"box_mm": box, "cell_mm": 0.1},
           "feed": {"rapid_mm_s": 500}, "deflection": {"limit_mm": 3.0, "mode": "norm"},
           "limits": {"tangential_acceleration_mm_s2": 500, "tangential_jerk_mm_s3": 5000},
           "schedule": {"laws": ["programmed", "convex", "jerk"], "angle_step_deg": 2},
           "export": {"rsi_cycle_ms": 4}}
    out = tmp / f"{program.stem}.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def row(program: Path) -> str:
    """One table row: samples, run time, per law cycle time / verified, the tool's share."""
    from feedopt.runner import run_scenario

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_scenario(scenario(program, Path(tmp)), out_dir=Path(tmp) / "out",
                           report=False, progress=lambda _m: None)
        seconds = time.perf_counter() - t0
    s = res.summary
    laws = ", ".join(f"{law} {r['cycle_time_s']:.0f} s "
                     f"{'verified' if r['verified'] else 'NOT verified'}"
                     f"{', exported' if r['exported'] else ''}"
                     for law, r in s["laws"].items())
    bending = s["scenario"]["tool"]["bending"]
    share = bending["share_of_mean_deflection"]["median"]
    return (f"| {program.name} | {s['scenario']['samples']} | {seconds:.0f} s | {laws} | "
            f"{bending['lateral_stiffness_n_per_um']:.3g} N/um, {100 * share:.0f} % |")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder", type=Path, help="folder holding bear.nc and cameo.nc")
    p.add_argument("--out", type=Path, help="also write the table here")
    args = p.parse_args(argv)
    lines = ["| program | samples | run | laws (cycle time, verdict) | tool stiffness, share |",
             "|:--|--:|--:|:--|:--|"]
    for name in JOBS:
        if (args.folder / name).is_file():
            lines.append(row(args.folder / name))
            print(lines[-1], file=sys.stderr)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
