"""Five-axis APT CL files end to end on the KR500-3 (issue 35): the generated swarf wall and the
public NX variable-axis file (CC0) are read, their tool vectors blended, planned and verified;
the exported RSI poses are checked against the CL file itself, read here with a regex."""

from __future__ import annotations

import re

import numpy as np
import pytest

from feedopt.export.rsi import read_rsi_csv
from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
GOTO = re.compile(r"^GOTO/([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+)\s*$")


def _cl_points(name: str, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    rows = [m.groups() for line in (ROOT / "scenarios" / "five_axis" / name).read_text(
        ).splitlines() if (m := GOTO.match(line.strip()))]
    a = np.array(rows, dtype=float)
    return a[:, :3] * scale, a[:, 3:] / np.linalg.norm(a[:, 3:], axis=1, keepdims=True)


def _z_of_abc(a, b, c):
    a, b, c = np.radians(a), np.radians(b), np.radians(c)
    return np.column_stack([np.cos(a) * np.sin(b) * np.cos(c) + np.sin(a) * np.sin(c),
                            np.sin(a) * np.sin(b) * np.cos(c) - np.cos(a) * np.sin(c),
                            np.cos(b) * np.cos(c)])


def _angle(a, b):
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                 np.sum(a * b, axis=-1)))


@pytest.fixture(scope="module")
def swarf(tmp_path_factory):
    out = tmp_path_factory.mktemp("swarf") / "out"
    return out, run_scenario(ROOT / "scenarios" / "five_axis_swarf.yaml", out,
                             laws=["programmed", "convex", "jerk"], progress=quiet, report=False)


def test_swarf_wall_is_verified_and_exported(swarf):
    _, result = swarf
    for law in ("programmed", "convex", "jerk"):
        assert result.summary["laws"][law]["verified"], result.summary["laws"][law]["problems"]
    assert result.summary["laws"]["jerk"]["exported"]
    o = result.summary["scenario"]["orientation"]
    assert o["tool_vectors"] > 90 and o["largest_deviation_deg"] <= 0.1
    assert o["tilt_from_workpiece_z_deg"][1] == pytest.approx(20.0, abs=0.05)


def test_swarf_poses_lie_along_the_rulings_of_the_cl_file(swarf):
    out, result = swarf
    table = read_rsi_csv(out / "jerk.csv")
    origin = np.array(result.summary["scenario"]["workpiece_position_mm"])
    tcp = np.column_stack([table.x_mm, table.y_mm, table.z_mm]) - origin
    z = _z_of_abc(table.a_deg, table.b_deg, table.c_deg)
    pts, vec = _cl_points("swarf_wall.cls")
    # the two CL points nearest each pose: its tool axis lies between their vectors (the
    # controller's great circle), within the orientation tolerance
    d = np.linalg.norm(tcp[:, None, :] - pts[None, :, :], axis=2)
    near = np.argsort(d, axis=1)[:, :2]
    on_wall = d.min(axis=1) < 2.5  # the rows along the wall (not the approach in the air)
    a, b = vec[near[:, 0]], vec[near[:, 1]]
    spread = _angle(a, b)
    got = np.minimum(_angle(z, a), _angle(z, b))
    assert on_wall.sum() > 1000
    assert np.all(got[on_wall] <= spread[on_wall] + 0.1 + 1e-6)


def test_public_nx_variable_axis_file_is_planned_and_verified(tmp_path):
    result = run_scenario(ROOT / "scenarios" / "five_axis_nx.yaml", tmp_path / "out",
                          laws=["jerk"], progress=quiet, report=False)
    row = result.summary["laws"]["jerk"]
    assert row["verified"] and row["exported"], row["problems"]
    o = result.summary["scenario"]["orientation"]
    pts, vec = _cl_points("nx_variable_axis.cls", 25.4)
    tilt = np.degrees(np.arccos(vec[:, 2]))
    assert o["tilt_from_workpiece_z_deg"][1] == pytest.approx(tilt.max(), abs=0.25)
    assert o["largest_deviation_deg"] <= 0.2


def _local(text: str) -> str:
    """A bundled scenario's text with its relative files made absolute (for tmp_path)."""
    sc = ROOT / "scenarios"
    return (text.replace("../robots", str(ROOT / "robots"))
            .replace("file: five_axis/", f"file: {sc}/five_axis/")
            .replace("tool: tools/", f"tool: {sc}/tools/")
            .replace("material: materials/", f"material: {sc}/materials/"))


def test_the_programmed_baseline_keeps_the_orientation_limits(tmp_path):
    text = _local((ROOT / "scenarios" / "five_axis_swarf.yaml").read_text()).replace(
        "orientation_rate_deg_s: 5.0", "orientation_rate_deg_s: 1.0")
    (tmp_path / "s.yaml").write_text(text)
    result = run_scenario(tmp_path / "s.yaml", tmp_path / "out", laws=["programmed"],
                          progress=quiet, report=False)
    row = result.summary["laws"]["programmed"]
    assert row["verified"], row["problems"]
    assert row["orientation"]["max_rate_deg_s"] <= 1.0 * (1 + 1e-6)
    assert row["orientation"]["max_rate_deg_s"] > 0.9  # the limit binds
