"""The ABB RAPID module (feedopt/export/rapid.py) of ROS-Industrial's IRB 2400, read back.

Every target is checked without feedopt's kinematics: the jointtarget through the URDF read
by hand (tests/robot/test_init.urdf_fk) with ABB's J2/J3 parallel-linkage coupling undone
(A3 = q3 + q2, ROS-Industrial's abb driver), the robtargets against the trajectory CSV's own
poses (KUKA A, B, C turned into a matrix here), quaternions against scipy.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from feedopt.cli import main
from feedopt.export.frames import APPROACH_MM
from feedopt.export.rapid import (
    CHORD_TOLERANCE_MM,
    confdata,
    parse_rapid_targets,
    quaternion_from_rotation,
)
from feedopt.runner import run_scenario
from tests.robot.test_init import PUBLISHED, urdf_fk


@settings(max_examples=200)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 1e-3))
def test_quaternions_are_scipy_s_scalar_first_with_q1_positive(v):
    r = Rotation.from_quat(np.asarray(v) / np.linalg.norm(v))  # x, y, z, w
    q = quaternion_from_rotation(r.as_matrix())
    assert q[0] >= 0 and abs(np.linalg.norm(q) - 1.0) < 1e-12
    want = r.as_quat()[[3, 0, 1, 2]]
    want = want if want[0] >= 0 else -want
    if abs(q[0]) < 1e-12:  # q and -q are the same rotation at w = 0
        want = want if np.dot(want, q) > 0 else -want
    np.testing.assert_allclose(q, want, atol=1e-12)


def test_confdata_is_the_quadrant_of_axes_1_4_6():
    got = confdata(np.array([[10.0, 0, 0, -10.0, 0, 190.0], [-100.0, 0, 0, 90.0, 0, -0.5]]))
    np.testing.assert_array_equal(got, [[0, -1, 2, 0], [-2, 1, -1, 0]])


def _matrix_from_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _kuka_abc(abc_deg: np.ndarray) -> np.ndarray:
    a, b, c = np.deg2rad(abc_deg)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rx = np.array([[1, 0, 0], [0, np.cos(c), -np.sin(c)], [0, np.sin(c), np.cos(c)]])
    return rz @ ry @ rx


def _irb2400(out: Path) -> None:
    """ROS-Industrial's IRB 2400 as a robot directory ``out`` for an ABB controller (A3 =
    q3 + q2: the parallel linkage's coupling)."""
    assert main(["robot", "init", str(PUBLISHED / "irb2400.urdf"), "--out", str(out),
                 "--controller", "abb"]) == 0
    doc = yaml.safe_load((out / "robot.yaml").read_text())
    doc["controller"]["axes"] = {"sign": [1] * 6, "offset_deg": [0] * 6,
                                 "coupled": [{"axis": 3, "joint": 2, "factor": 1.0}]}
    (out / "robot.yaml").write_text(yaml.safe_dump(doc))


@pytest.fixture(scope="module")
def irb2400_run(tmp_path_factory) -> Path:
    from tests.conftest import ROOT, SCENARIOS

    tmp = tmp_path_factory.mktemp("rapid")
    out = tmp / "irb2400"
    _irb2400(out)
    scen = yaml.safe_load((SCENARIOS / "linear_peripheral.yaml").read_text())
    scen["tool"] = str(SCENARIOS / scen["tool"])
    scen["material"] = str(SCENARIOS / scen["material"])
    scen["robot"]["directory"] = str(out)
    scen["robot"]["start_configuration_deg"] = [0, 20, 30, 0, 60, 0]  # A3 = q3 + q2
    scen["workpiece"]["position_mm"] = [1000.0, 0.0, 731.9]
    scen["path"]["spacing_mm"] = 1.0
    scen["schedule"]["laws"] = ["jerk"]
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(scen))
    del ROOT
    result = run_scenario(p, out_dir=tmp / "out", progress=lambda _m: None, report=False)
    assert result.summary["laws"]["jerk"]["rapid_module"] == "jerk.mod"
    return tmp / "out"


def _csv(path: Path) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


def test_the_targets_are_the_trajectory_s_poses(irb2400_run):
    text = (irb2400_run / "jerk.mod").read_text()
    assert text.startswith("MODULE fo_jerk") and text.rstrip().endswith("ENDMODULE")
    assert "KUKA" not in text and "$" not in text
    targets = parse_rapid_targets(text)
    head, rows = _csv(irb2400_run / "jerk.csv")
    xyz = rows[:, [head.index(k) for k in ("x_mm", "y_mm", "z_mm")]]
    abc = rows[:, [head.index(k) for k in ("a_deg", "b_deg", "c_deg")]]
    path = sorted((int(k[4:]), v) for k, v in targets.items() if re.fullmatch(r"fo_p\d+", k))
    pos = np.array([v["pos"] for _, v in path])
    # every target on the path the CSV samples, with the CSV's orientation there
    for i, p in enumerate(pos):
        k = int(np.argmin(np.linalg.norm(xyz - p, axis=1)))
        assert np.linalg.norm(xyz[k] - p) < 0.05  # 4 ms rows: within a row's travel
        got = _matrix_from_quaternion(path[i][1]["orient"])
        np.testing.assert_allclose(got, _kuka_abc(abc[k]), atol=1e-6)
        assert np.all(np.abs(path[i][1]["conf"]) <= 4)
    np.testing.assert_allclose(pos[0], xyz[0], atol=1e-4)
    np.testing.assert_allclose(pos[-1], xyz[-1], atol=1e-4)
    # the MoveL polyline stays within the chord tolerance of every CSV point
    a, b = pos[:-1], pos[1:]
    d = b - a
    u = np.clip(np.einsum("kij,ij->ki", xyz[:, None, :] - a[None], d)
                / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    dist = np.linalg.norm(xyz[:, None, :] - (a[None] + u[..., None] * d[None]), axis=2)
    assert dist.min(axis=1).max() <= CHORD_TOLERANCE_MM + 1e-4


def test_the_approach_joints_are_above_the_lead_in_by_the_urdf(irb2400_run):
    text = (irb2400_run / "jerk.mod").read_text()
    targets = parse_rapid_targets(text)
    a = np.deg2rad(targets["fo_approach"]["axes"])
    q = a.copy()
    q[2] = a[2] - a[1]  # undo ABB's parallel-linkage coupling: A3 = q3 + q2
    flange = urdf_fk(PUBLISHED / "irb2400.urdf", "tool0",
                     {f"joint_{i + 1}": float(v) for i, v in enumerate(q)})
    tool = re.search(r"tooldata fo_tool := \[TRUE,\[\[([^\]]*)\],\[([^\]]*)\]\]", text)
    t = np.eye(4)
    t[:3, 3] = np.array([float(v) for v in tool.group(1).split(",")]) * 1e-3
    t[:3, :3] = _matrix_from_quaternion(np.array([float(v) for v in tool.group(2).split(",")]))
    tcp = flange @ t
    lead_in = targets["fo_lead_in"]
    r_in = _matrix_from_quaternion(lead_in["orient"])
    want = lead_in["pos"] + APPROACH_MM * r_in[:, 2]
    assert np.linalg.norm(tcp[:3, 3] * 1e3 - want) < 5e-3  # 4-decimal degrees
    np.testing.assert_allclose(tcp[:3, :3], r_in, atol=1e-5)


def test_speeds_are_the_law_s_feeds_and_the_program_is_whole(irb2400_run):
    text = (irb2400_run / "jerk.mod").read_text()
    moves = re.findall(r"^\s+MoveL (fo_p\d+), \[([^,\]]+),", text, re.M)
    speeds = np.array([float(v) for _, v in moves[1:]])
    head, rows = _csv(irb2400_run / "jerk.csv")
    feed = rows[:, head.index("feed_mm_s")]
    # each move's speed is the law's (steady) feed, never above what it plans anywhere
    assert speeds.min() > 0 and speeds.max() <= feed.max() * 1.001
    assert np.median(speeds) == pytest.approx(np.median(feed[feed > 0.5 * feed.max()]),
                                              rel=1e-3)
    order = ["ConfL \\Off;", "MoveAbsJ fo_approach", "Stop;", "MoveL fo_lead_in",
             "MoveL fo_p0", "MoveL fo_lead_out", "MoveL fo_retract", "Stop;", "ENDPROC"]
    at = -1
    lines = text.splitlines()
    for needle in order:
        at = next(i for i in range(at + 1, len(lines)) if needle in lines[i])
    assert "PLACEHOLDER" in text and "Not verified on a controller" in text


def test_no_rapid_for_other_controllers_or_unstated_axes(tmp_path, capsys):
    out = tmp_path / "irb"
    assert main(["robot", "init", str(PUBLISHED / "irb2400.urdf"), "--out", str(out),
                 "--controller", "abb"]) == 0
    assert "controller.axes: ABB's axis convention" in capsys.readouterr().out
    from feedopt.export.rapid import early_check
    from feedopt.robot.model import load_robot

    blocker = early_check(load_robot(out), None)
    assert blocker is not None and "no RAPID module" in blocker.reason


@pytest.fixture(scope="module")
def irb2400_five_axis(tmp_path_factory) -> Path:
    """The five-axis waypoint slot (tool vectors tilting up to 11 deg) on the IRB 2400."""
    from tests.conftest import SCENARIOS

    tmp = tmp_path_factory.mktemp("rapid5")
    out = tmp / "irb2400"
    _irb2400(out)
    scen = yaml.safe_load((SCENARIOS / "five_axis_csv.yaml").read_text())
    for key in ("tool", "material"):
        scen[key] = str(SCENARIOS / scen[key])
    scen["path"]["file"] = str(SCENARIOS / scen["path"]["file"])
    scen["path"]["spacing_mm"] = 0.5
    scen["robot"] = {"directory": str(out), "start_configuration_deg": [0, 20, 30, 0, 60, 0]}
    scen["workpiece"]["position_mm"] = [900.0, -150.0, 600.0]
    scen["schedule"]["laws"] = ["jerk"]
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(scen))
    result = run_scenario(p, out_dir=tmp / "out", progress=lambda _m: None, report=False)
    assert result.summary["laws"]["jerk"]["rapid_module"] == "jerk.mod"
    return tmp / "out"


def _slerp_axes(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Unit vectors an even fraction ``u`` of the way from ``a`` to ``b`` (great circle)."""
    w = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
    s = np.where(w > 1e-12, np.sin(w), 1.0)
    out = (np.where(w > 1e-12, np.sin((1 - u) * w) / s, 1 - u)[:, None] * a
           + np.where(w > 1e-12, np.sin(u * w) / s, u)[:, None] * b)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def test_a_five_axis_module_states_its_orientation_gap(irb2400_five_axis):
    """The module's targets' tool axes (their quaternions' z columns) turned evenly along each
    MoveL against the trajectory CSV's planned axes (KUKA A, B, C turned into a matrix here):
    the largest angle is the summary's ``rapid_orientation_gap_deg`` (which interpolates by
    arc length, here by the row's place along the chord) and the header states it."""
    import json

    summary = json.loads((irb2400_five_axis / "summary.json").read_text())
    gap = summary["laws"]["jerk"]["rapid_orientation_gap_deg"]
    text = (irb2400_five_axis / "jerk.mod").read_text()
    assert f"up to {gap:.3g} deg from the planned tool axis" in text
    targets = parse_rapid_targets(text)
    path = sorted((int(k[4:]), v) for k, v in targets.items() if re.fullmatch(r"fo_p\d+", k))
    pos = np.array([v["pos"] for _, v in path])
    axes = np.array([_matrix_from_quaternion(v["orient"])[:, 2] for _, v in path])
    head, rows = _csv(irb2400_five_axis / "jerk.csv")
    xyz = rows[:, [head.index(k) for k in ("x_mm", "y_mm", "z_mm")]]
    abc = rows[:, [head.index(k) for k in ("a_deg", "b_deg", "c_deg")]]
    planned = np.array([_kuka_abc(v)[:, 2] for v in abc])
    a, b = pos[:-1], pos[1:]
    d = b - a
    u = np.clip(np.einsum("kij,ij->ki", xyz[:, None, :] - a[None], d)
                / np.maximum(np.einsum("ij,ij->i", d, d), 1e-30), 0.0, 1.0)
    seg = np.argmin(np.linalg.norm(xyz[:, None, :] - (a[None] + u[..., None] * d[None]),
                                   axis=2), axis=1)
    even = _slerp_axes(axes[seg], axes[seg + 1], u[np.arange(seg.size), seg])
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", even, planned), -1.0, 1.0)))
    assert gap > 0.0
    assert angle.max() == pytest.approx(gap, rel=0.05, abs=2e-3)
