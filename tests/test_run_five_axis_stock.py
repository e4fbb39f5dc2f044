"""A tilted ball-nose finishing a saddle through a tri-dexel stock, end to end (issue 35): a
short version of scenarios/five_axis_ball_stock.yaml (five 20 mm passes, both files written by
benchmarks/five_axis_paths.py), planned on the KR500-3, verified and exported. The volume the
run says it removed is checked against an independent Monte Carlo estimate: points below the
stock's top (the saddle z = (x^2 - y^2) / 400 mm raised by the allowance, in closed form; the
STL's 2 mm facets are within 0.0025 mm of it) within the ball's radius of the segments
between the CL file's ball centres (tip + R * tool vector, read here with a regex)."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest

from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
GOTO = re.compile(r"^GOTO/([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+)\s*$")
R_MM = 5.0
ALLOWANCE_MM = 0.5


@pytest.fixture(scope="module")
def saddle(tmp_path_factory):
    d = tmp_path_factory.mktemp("saddle")
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / "five_axis_paths.py"), "--kind",
                    "ball", "--lead-deg", "10", "--tilt-deg", "3", "--width-mm", "20",
                    "--length-mm", "4", "--out", str(d / "p.cls"), "--stock-out",
                    str(d / "stock.stl"), "--stock-allowance-mm", str(ALLOWANCE_MM)],
                   check=True, capture_output=True)
    sc = ROOT / "scenarios"
    text = ((sc / "five_axis_ball_stock.yaml").read_text()
            .replace("../robots", str(ROOT / "robots"))
            .replace("file: five_axis/ball_saddle.cls", f"file: {d / 'p.cls'}")
            .replace("mesh: five_axis/saddle_stock.stl", f"mesh: {d / 'stock.stl'}")
            .replace("tool: tools/", f"tool: {sc}/tools/")
            .replace("material: materials/", f"material: {sc}/materials/"))
    (d / "s.yaml").write_text(text)
    result = run_scenario(d / "s.yaml", d / "out", laws=["programmed", "convex", "jerk"],
                          progress=quiet, report=False)
    return d, result


def test_the_stock_run_is_verified_and_exported(saddle):
    _, result = saddle
    for law in ("programmed", "convex", "jerk"):
        row = result.summary["laws"][law]
        assert row["verified"], row["problems"]
    for law in ("convex", "jerk"):
        assert result.summary["laws"][law]["exported"]
    stock = result.summary["scenario"]["stock"]
    assert stock["model"] == "tri-dexel"
    assert 0.2 < stock["cutting_fraction"] < 1.0
    # the allowance is 0.5 mm along z; the tilted ball's deepest edge above its tip reaches
    # the top at most a few tenths of a millimetre higher
    assert 0.4 < stock["max_axial_depth_mm"] < 1.5


def _centres(path) -> np.ndarray:
    rows = [m.groups() for line in path.read_text().splitlines()
            if (m := GOTO.match(line.strip()))]
    a = np.array(rows, dtype=float)
    k = a[:, 3:] / np.linalg.norm(a[:, 3:], axis=1, keepdims=True)
    return a[:, :3] + R_MM * k


def _near_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray, r: float) -> np.ndarray:
    """Whether each point lies within ``r`` of any segment a_i b_i (chunks of points)."""
    out = np.zeros(points.shape[0], dtype=bool)
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-30)
    for start in range(0, points.shape[0], 2000):
        p = points[start:start + 2000, None, :]
        t = np.clip(np.einsum("pij,ij->pi", p - a, d) / dd, 0.0, 1.0)
        q = a + t[..., None] * d
        out[start:start + 2000] = np.any(np.sum((p - q) ** 2, axis=2) < r * r, axis=1)
    return out


def test_removed_volume_matches_the_swept_balls(saddle):
    """The stock the balls along the CL path sweep through (the shank stays above the
    allowance: its lowest point is 4.1 mm above the ball's lowest), by Monte Carlo over the
    box the balls reach: within 5 % (the estimate's own error is about 1.5 %)."""
    d, result = saddle
    centres = _centres(d / "p.cls")
    low = centres[:, 2] - R_MM < 3.0  # the feed moves and the plunges, not the rapids' tops
    a, b = centres[:-1], centres[1:]
    keep = low[:-1] | low[1:]
    a, b = a[keep], b[keep]
    lo = np.minimum(a, b).min(axis=0) - R_MM
    hi = np.maximum(a, b).max(axis=0) + R_MM
    hi[2] = min(hi[2], (hi[0] ** 2 + lo[0] ** 2) / 400.0 + ALLOWANCE_MM)  # above any top
    rng = np.random.default_rng(7)
    pts = lo + rng.random((120_000, 3)) * (hi - lo)
    inside = pts[:, 2] < (pts[:, 0] ** 2 - pts[:, 1] ** 2) / 400.0 + ALLOWANCE_MM
    swept = np.zeros(pts.shape[0], dtype=bool)
    swept[inside] = _near_segments(pts[inside], a, b, R_MM)
    estimate = swept.mean() * float(np.prod(hi - lo))
    removed = result.summary["scenario"]["stock"]["removed_mm3"]
    assert removed == pytest.approx(estimate, rel=0.05)


def test_a_flat_end_mill_slotting_through_a_stock_with_a_fixed_tool_vector(tmp_path):
    """Tool vectors that do not turn (a CSV with i, j, k = 0, 0, 1) and a flat end mill: the
    engagement is found per slice in the tri-dexel (the wall/floor model of a flat end mill
    along z is not used with it: it crashed there), planned, verified and exported; the slot
    removes its cross-section (19.05 mm x 1.5 mm x the 60 mm box) within 1 %."""
    sc = ROOT / "scenarios"
    (tmp_path / "line.csv").write_text("x_mm,y_mm,z_mm,i,j,k\n-20,0,0,0,0,1\n80,0,0,0,0,1\n")
    (tmp_path / "s.yaml").write_text(f"""\
name: flat_tri_dexel
robot:
  directory: {ROOT / 'robots' / 'kuka_kr500_3'}
  stiffness: dpp
  start_configuration_deg: [9.728, -64.745, 107.062, 0.0, 47.682, 0.0]
workpiece:
  position_mm: [1750.0, -300.0, 800.0]
path:
  generator: csv
  file: {tmp_path / 'line.csv'}
  spacing_mm: 0.5
tool: {sc / 'tools' / 'hss_2flute_19mm.yaml'}
material: {sc / 'materials' / '6061-T6511.yaml'}
stock:
  box_mm: [0, -20, -10, 60, 20, 1.5]
  cell_mm: 0.25
cut:
  spindle_rpm: 2500
feed:
  nominal_mm_s: 4.23
deflection:
  limit_mm: 0.29
schedule:
  laws: [jerk]
""")
    result = run_scenario(tmp_path / "s.yaml", tmp_path / "out", laws=["jerk"], progress=quiet,
                          report=False)
    row = result.summary["laws"]["jerk"]
    assert row["verified"] and row["exported"], row["problems"]
    stock = result.summary["scenario"]["stock"]
    assert stock["model"] == "tri-dexel"
    assert stock["removed_mm3"] == pytest.approx(19.05 * 1.5 * 60, rel=0.01)
