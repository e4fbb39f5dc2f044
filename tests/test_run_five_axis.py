"""A five-axis waypoint path end to end (issue 35): the tool tilts along the triangle-wave slot,
every law verified by replay, and the exported RSI CSV checked independently: its poses' tool
axes (KUKA A, B, C written out, turned back into a rotation here by hand) follow the programmed
tool vectors within the orientation tolerance, and the axis turns within the orientation rate
and acceleration limits by finite differences of those poses."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.export.rsi import read_rsi_csv
from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
SCENARIO = ROOT / "scenarios" / "five_axis_csv.yaml"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("five") / "out"
    return out, run_scenario(SCENARIO, out, laws=["topp", "convex", "jerk"], progress=quiet,
                             report=False)


def _z_of_abc(a, b, c):
    """Third column of Rz(a) Ry(b) Rx(c) (written out, not feedopt's)."""
    a, b, c = np.radians(a), np.radians(b), np.radians(c)
    return np.column_stack([np.cos(a) * np.sin(b) * np.cos(c) + np.sin(a) * np.sin(c),
                            np.sin(a) * np.sin(b) * np.cos(c) - np.cos(a) * np.sin(c),
                            np.cos(b) * np.cos(c)])


def _programmed_axes():
    """The waypoint file's tool vectors, normalised."""
    rows = np.loadtxt(ROOT / "scenarios" / "waypoints" / "five_axis_tilted.csv", delimiter=",",
                      skiprows=4)
    u = rows[:, 3:] / np.linalg.norm(rows[:, 3:], axis=1, keepdims=True)
    return u


def test_every_law_verified_and_the_smooth_ones_exported(run):
    _, result = run
    for law in ("topp", "convex", "jerk"):
        row = result.summary["laws"][law]
        assert row["verified"], (law, row.get("problems"))
    assert result.summary["laws"]["convex"]["exported"]
    assert result.summary["laws"]["jerk"]["exported"]
    assert result.summary["scenario"]["active_constraints"]["orientation"] > 0


def test_exported_poses_follow_the_tool_vectors_and_the_orientation_limits(run):
    out, _ = run
    table = read_rsi_csv(out / "convex.csv")
    z = _z_of_abc(table.a_deg, table.b_deg, table.c_deg)
    # the workpiece frame is the base frame turned by nothing (rpy 0): the tool vectors are the
    # base frame's; at the waypoints' tilts the axis leaves +z by up to 11.3 deg
    tilt = np.degrees(np.arccos(np.clip(z[:, 2], -1, 1)))
    u = _programmed_axes()
    assert tilt.max() == pytest.approx(np.degrees(np.arccos(u[:, 2].min())), abs=0.25)
    # orientation rate and acceleration by finite differences of the exported poses
    dt = np.diff(table.t_s)
    turn = np.arctan2(np.linalg.norm(np.cross(z[1:], z[:-1]), axis=1),
                      np.einsum("ij,ij->i", z[1:], z[:-1]))
    rate = np.degrees(turn / dt)
    assert rate.max() <= 1.0 * (1 + 2e-3)
    assert rate.max() > 0.9  # the limit binds somewhere
    zd = np.diff(z, axis=0) / dt[:, None]
    acc = np.degrees(np.linalg.norm(np.diff(zd, axis=0), axis=1) / dt[1:])
    assert acc.max() <= 300.0 * 1.01


def test_a_tool_axis_with_tool_vectors_is_refused(tmp_path):
    text = SCENARIO.read_text().replace("rpy_deg: [0.0, 0.0, 0.0]",
                                        "rpy_deg: [0.0, 0.0, 0.0]\n  tool_axis: [0, 0.1, 1]")
    (tmp_path / "s.yaml").write_text(text.replace("../robots", str(ROOT / "robots")).replace(
        "waypoints/", str(ROOT / "scenarios" / "waypoints") + "/").replace(
        "tools/", str(ROOT / "scenarios" / "tools") + "/").replace(
        "materials/", str(ROOT / "scenarios" / "materials") + "/"))
    with pytest.raises(InputError, match="workpiece.tool_axis is for three-axis paths"):
        run_scenario(tmp_path / "s.yaml", tmp_path / "out", laws=["jerk"], progress=quiet,
                     report=False)


def test_the_feed_lean_in_the_summary_is_that_of_the_exported_poses(run):
    """summary.json's feed_lean_deg (the force model's feed along the tool axis) against the
    exported poses: the angle between the TCP's direction of motion (finite differences of
    X, Y, Z) and the plane across the tool axis (A, B, C turned into z by hand)."""
    out, result = run
    table = read_rsi_csv(out / "convex.csv")
    xyz = np.column_stack([table.x_mm, table.y_mm, table.z_mm])
    step = np.diff(xyz, axis=0)
    moving = np.linalg.norm(step, axis=1) > 1e-4  # [mm]: away from the ends' rest
    z = _z_of_abc(table.a_deg, table.b_deg, table.c_deg)
    zm = 0.5 * (z[1:] + z[:-1])
    t = step[moving] / np.linalg.norm(step[moving], axis=1, keepdims=True)
    lean = np.degrees(np.arcsin(np.einsum("ij,ij->i", t, zm[moving])))
    got = result.summary["scenario"]["orientation"]["feed_lean_deg"]
    assert got[0] < -5.0 and got[1] > 5.0  # the tilt leans the feed out of that plane
    assert got[0] == pytest.approx(lean.min(), abs=0.1)
    assert got[1] == pytest.approx(lean.max(), abs=0.1)
