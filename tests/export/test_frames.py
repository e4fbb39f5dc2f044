"""Frames: FK of the exported joints with the stated TOOL_DATA reproduces the exported pose.

The forward kinematics here are written independently of the URDFs and of pinocchio: the
KR500-3 as a product of exponentials from the dimensions in shared/data/kr500_3_kinematics.md
with KUKA's joint senses and its $FLANGE (+Z out of the flange: ROS-Industrial tool0), the
UR10 from Universal Robots' published standard DH parameters. Orientations use scipy.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from feedopt.errors import InputError
from feedopt.export.frames import (
    cell_frames,
    controller_flange,
    frames_header_lines,
    frames_summary,
)
from feedopt.export.krl import parse_krl_dat, parse_krl_spline
from feedopt.export.rsi import read_rsi_csv
from feedopt.robot.model import load_robot
from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731

# KR500-3 [mm]: A2 axis 1045 above the floor, a1 = 500, a2 = 1300, forearm axis 55 below the A3
# axis, A3 -> wrist centre 1025, wrist centre -> flange 290 (kr500_3_kinematics.md).
_KUKA_AXES = [  # (axis direction, a point on it) in $ROBROOT at A1..A6 = 0 (arm stretched)
    ((0, 0, -1), (0, 0, 0)),
    ((0, 1, 0), (500, 0, 1045)),
    ((0, 1, 0), (1800, 0, 1045)),
    ((-1, 0, 0), (1800, 0, 990)),
    ((0, 1, 0), (2825, 0, 990)),
    ((-1, 0, 0), (3115, 0, 990)),
]
# $FLANGE at A1..A6 = 0: at the flange centre, +Z out of the flange (base +x), +X down.
_KUKA_FLANGE_HOME = (np.array([3115.0, 0.0, 990.0]), Rotation.from_euler("y", 90, degrees=True))


def kuka_flange_fk(q_deg: np.ndarray) -> tuple[np.ndarray, Rotation]:
    """$FLANGE position [mm] and rotation in $ROBROOT for KUKA joint angles A1..A6 [deg]
    (product of exponentials: each joint turns everything after it about its axis)."""
    pos, rot = _KUKA_FLANGE_HOME
    for (axis, point), q in reversed(list(zip(_KUKA_AXES, np.deg2rad(q_deg), strict=True))):
        r = Rotation.from_rotvec(np.asarray(axis, float) * q)
        pos = r.apply(pos - np.asarray(point, float)) + np.asarray(point, float)
        rot = r * rot
    return pos, rot


def ur10_flange_fk(q_rad: np.ndarray) -> tuple[np.ndarray, Rotation]:
    """UR10 (CB3) tool flange position [mm] and rotation from the standard DH parameters."""
    d = [127.3, 0, 0, 163.941, 115.7, 92.2]
    a = [0, -612.0, -572.3, 0, 0, 0]
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    t = np.eye(4)
    for i, q in enumerate(q_rad):
        ct, st, ca, sa = np.cos(q), np.sin(q), np.cos(alpha[i]), np.sin(alpha[i])
        t = t @ np.array([[ct, -st * ca, st * sa, a[i] * ct], [st, ct * ca, -ct * sa, a[i] * st],
                          [0, sa, ca, d[i]], [0, 0, 0, 1]])
    return t[:3, 3], Rotation.from_matrix(t[:3, :3])


def _frame(xyzabc) -> tuple[np.ndarray, Rotation]:
    """A KUKA frame X, Y, Z [mm], A, B, C [deg]: R = Rz(A) Ry(B) Rx(C)."""
    v = np.asarray(xyzabc, float)
    return v[:3], Rotation.from_euler("ZYX", v[3:], degrees=True)


def _compose(a, b):
    return a[0] + a[1].apply(b[0]), a[1] * b[1]


def _angle_deg(r1: Rotation, r2: Rotation) -> np.ndarray:
    return np.rad2deg((r1.inv() * r2).magnitude())


def test_kuka_fk_home_pose_is_the_documented_flange_pose() -> None:
    # HOME {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}: upper arm vertical, forearm horizontal;
    # flange at x = 500 + 1025 + 290, z = 1045 + 1300 - 55, facing +x: $FLANGE A 0, B 90, C 0.
    pos, rot = kuka_flange_fk(np.array([0, -90, 90, 0, 0, 0]))
    np.testing.assert_allclose(pos, [1815, 0, 2290], atol=1e-9)
    assert _angle_deg(rot, _frame([0, 0, 0, 0, 90, 0])[1]) < 1e-9


@pytest.fixture(scope="module")
def kuka_run(thesis_triangle_run):
    return thesis_triangle_run.out_dir


def test_exported_q_with_the_stated_tool_data_gives_the_exported_pose(kuka_run) -> None:
    table = read_rsi_csv(kuka_run / "thesis.csv")
    dat = parse_krl_dat((kuka_run / "thesis.dat").read_text())
    tool = _frame([dat["FO_TOOL"][k] for k in "XYZABC"])
    assert dat["FO_TOOL"]["type"] == "FRAME"
    rows = np.linspace(0, len(table) - 1, 60).astype(int)
    for i in rows:
        flange = kuka_flange_fk(table.q_deg[i])
        pos, rot = _compose(flange, tool)
        exported = _frame([table.x_mm[i], table.y_mm[i], table.z_mm[i],
                           table.a_deg[i], table.b_deg[i], table.c_deg[i]])
        np.testing.assert_allclose(pos, exported[0], atol=1e-6)
        assert _angle_deg(rot, exported[1]) < 1e-6
        # the TCP +z (tool axis into the spindle) points back to the flange along $FLANGE -Z
        np.testing.assert_allclose(rot.apply([0, 0, 1]), -flange[1].apply([0, 0, 1]),
                                   atol=1e-12)
    # The old reading of the robot.yaml comment (the URDF flange, +x out, taken as $FLANGE)
    # puts the tool 400 mm off: the test can tell the conventions apart.
    urdf_flange = (kuka_flange_fk(table.q_deg[0])[0],
                   kuka_flange_fk(table.q_deg[0])[1] * Rotation.from_euler("y", -90, degrees=True))
    wrong = _compose(urdf_flange, tool)[0]
    assert np.linalg.norm(wrong - [table.x_mm[0], table.y_mm[0], table.z_mm[0]]) > 100


def test_krl_approach_joints_are_above_the_lead_in_point(kuka_run) -> None:
    dat = parse_krl_dat((kuka_run / "thesis.dat").read_text())
    tool = _frame([dat["FO_TOOL"][k] for k in "XYZABC"])
    q = np.array([dat["FO_APPROACH"][f"A{i}"] for i in range(1, 7)])
    pos, rot = _compose(kuka_flange_fk(q), tool)
    segs = parse_krl_spline((kuka_run / "thesis.src").read_text())
    start = np.array([segs[0][k] for k in "XYZ"])  # the lead-in ends at the path start
    src = (kuka_run / "thesis.src").read_text()
    down = next(line for line in src.splitlines() if line.startswith("SLIN {"))
    lead_in = np.array([parse_krl_spline(f"SPLINE\n{down}\nENDSPLINE")[0][k] for k in "XYZ"])
    first = np.array([segs[1][k] for k in "XYZ"])
    tangent = (first - start) / np.linalg.norm(first - start)  # the first line's direction
    np.testing.assert_allclose(lead_in, start - 10.0 * tangent, atol=2e-3)
    np.testing.assert_allclose(pos, lead_in + 50.0 * rot.apply([0, 0, 1]), atol=2e-3)
    assert rot.apply([0, 0, 1])[2] > 0.999  # up: the tool is vertical in this scenario


def test_ur_tcp_pose_with_the_published_dh_gives_the_exported_pose(tmp_path,
                                                                    quick_scenario) -> None:
    p = quick_scenario(
        "linear_peripheral", robot__directory=str(ROOT / "robots" / "ur10"),
        robot__start_configuration_deg=[0, -90, 90, -90, -90, 0],
        workpiece__position_mm=[-688.0, -163.941, 447.1], workpiece__rpy_deg=[0.0, 0.0, 90.0],
        path__end_mm=[40.0, -1.0, 0.0], path__spacing_mm=1.0, deflection__limit_mm=5.0,
        schedule__laws=["jerk"])
    run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
    table = read_rsi_csv(tmp_path / "out" / "jerk.csv")
    tcp = cell_frames(load_robot(ROOT / "robots" / "ur10")).tcp_pose_ur
    tool = (np.asarray(tcp[:3]) * 1e3, Rotation.from_rotvec(tcp[3:]))
    for i in np.linspace(0, len(table) - 1, 30).astype(int):
        pos, rot = _compose(ur10_flange_fk(np.deg2rad(table.q_deg[i])), tool)
        exported = _frame([table.x_mm[i], table.y_mm[i], table.z_mm[i],
                           table.a_deg[i], table.b_deg[i], table.c_deg[i]])
        np.testing.assert_allclose(pos, exported[0], atol=1e-6)
        assert _angle_deg(rot, exported[1]) < 1e-6
    script = (tmp_path / "out" / "jerk.script").read_text()
    assert f"set_tcp(p[{tcp[0]:.6f}, {tcp[1]:.6f}, {tcp[2]:.6f}," in script


def test_header_lines_and_summary_state_the_frames() -> None:
    kuka = load_robot(ROOT / "robots" / "kuka_kr500_3")
    lines = frames_header_lines(kuka)
    text = "\n".join(lines)
    assert "TOOL_DATA = {X 0.0,Y 0.0,Z 400.0,A 180.0,B 0.0,C 180.0}" in text
    assert "BASE_DATA = {X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}" in text
    assert "$ROBROOT = $WORLD" in text and "PLACEHOLDER" in text and "M -1.0" in text
    assert "+Z out of the flange" in text
    summary = frames_summary(kuka)
    assert json.loads(json.dumps(summary)) == summary
    assert summary["tool_data"] == {"X": 0.0, "Y": 0.0, "Z": 400.0, "A": 180.0, "B": 0.0,
                                    "C": 180.0}
    assert summary["load_data"]["placeholder"] is True
    assert summary["urdf_flange_out_of_flange_axis"] == "+x"
    assert summary["flange_in_urdf_flange_rpy_deg"] == [0.0, 90.0, 0.0]
    ur = frames_summary(load_robot(ROOT / "robots" / "ur10"))
    assert ur["urdf_flange_out_of_flange_axis"] == "+z"
    np.testing.assert_allclose(ur["ur_tcp_pose"], [0, 0, 0.2, np.pi, 0, 0], atol=1e-6)


def test_a_flange_frame_of_unknown_convention_is_refused() -> None:
    kuka = load_robot(ROOT / "robots" / "kuka_kr500_3")
    # Claim the TCP sits on a flange frame turned by 90 deg about its z: then "out of the
    # flange" is that frame's -y, neither convention; the tool data would be a guess.
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    odd = dataclasses.replace(kuka, tcp_offset=np.linalg.inv(turn) @ kuka.tcp_offset)
    with pytest.raises(InputError, match="neither \\+x"):
        controller_flange(odd)
    rot, axis = controller_flange(kuka)
    assert axis == "+x"
    np.testing.assert_allclose(rot[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-12)


def test_headers_of_a_generic_robot_carry_no_kuka_data(tmp_path):
    """An ABB, FANUC or any robot without a KUKA or UR controller: no TOOL_DATA, BASE_DATA,
    LOAD_DATA or $ROBROOT in its export headers (issue 29), the TCP stated in the flange."""
    import shutil

    from feedopt.export.frames import frames_header_lines

    d = tmp_path / "robot"
    shutil.copytree(ROOT / "robots" / "kuka_kr500_3", d)
    text = (d / "robot.yaml").read_text().replace("  type: kuka\n", "  type: generic\n", 1)
    (d / "robot.yaml").write_text(text)
    lines = "\n".join(frames_header_lines(load_robot(d)))
    for kuka in ("TOOL_DATA", "BASE_DATA", "LOAD_DATA", "$ROBROOT"):
        assert kuka not in lines
    assert "TCP at 0, 0, 400 mm from the flange centre" in lines
    ur = "\n".join(frames_header_lines(load_robot(ROOT / "robots" / "ur10")))
    assert "turned 180 deg about z" in ur and "TOOL_DATA" not in ur
