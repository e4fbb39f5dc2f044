"""The FANUC LS program (feedopt/export/fanuc.py) of ROS-Industrial's M-20iA, read back.

Every position is checked without feedopt's kinematics: its joints (J3 from the horizontal
undone, J3 = q3 + q2: ROS-Industrial's J23_factor 1) through the URDF read by hand
(tests/robot/test_init.urdf_fk) and the robot.yaml tool, against the trajectory CSV.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.export.fanuc import parse_ls_positions
from feedopt.export.frames import APPROACH_MM
from feedopt.export.rapid import CHORD_TOLERANCE_MM
from feedopt.runner import run_scenario
from tests.robot.test_init import _rpy, expand_m20ia, urdf_fk

# URDF joints (0, 30, 0, 0, -60, 0) deg: TCP at (1393.1, 0, 708.2) mm, the tool pointing down
START_AXES = [0, 30, 30, 0, -60, 0]  # the controller's: J3 = q3 + q2


@pytest.fixture(scope="module")
def m20ia_run(tmp_path_factory) -> tuple[Path, Path, Path]:
    from tests.conftest import SCENARIOS

    tmp = tmp_path_factory.mktemp("fanuc")
    urdf = expand_m20ia(tmp)
    robot = tmp / "m20ia"
    assert main(["robot", "init", str(urdf), "--out", str(robot), "--controller",
                 "fanuc"]) == 0
    doc = yaml.safe_load((robot / "robot.yaml").read_text())
    doc["controller"]["axes"] = {"sign": [1] * 6, "offset_deg": [0] * 6,
                                 "coupled": [{"axis": 3, "joint": 2, "factor": 1.0}]}
    (robot / "robot.yaml").write_text(yaml.safe_dump(doc))
    scen = yaml.safe_load((SCENARIOS / "linear_peripheral.yaml").read_text())
    scen["tool"] = str(SCENARIOS / scen["tool"])
    scen["material"] = str(SCENARIOS / scen["material"])
    scen["robot"]["directory"] = str(robot)
    scen["robot"]["start_configuration_deg"] = START_AXES
    scen["workpiece"]["position_mm"] = [1330.6, 0.0, 708.2]
    scen["path"]["spacing_mm"] = 1.0
    scen["schedule"]["laws"] = ["jerk"]
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(scen))
    result = run_scenario(p, out_dir=tmp / "out", progress=lambda _m: None, report=False)
    assert result.summary["laws"]["jerk"]["fanuc_program"] == "jerk.ls"
    return tmp / "out", urdf, robot


def _tcp(urdf: Path, robot: Path, axes_deg: np.ndarray) -> np.ndarray:
    """TCP pose (4, 4) [m] of controller axes by the hand-read URDF and robot.yaml's tool."""
    q = np.deg2rad(np.asarray(axes_deg, dtype=float))
    q[2] -= q[1]  # undo the coupling
    tool = yaml.safe_load((robot / "robot.yaml").read_text())["tool"]
    flange = urdf_fk(urdf, yaml.safe_load((robot / "robot.yaml").read_text())["flange_frame"],
                     {f"joint_{i + 1}": float(v) for i, v in enumerate(q)})
    t = np.eye(4)
    t[:3, :3] = _rpy(*np.deg2rad(tool.get("tcp_rpy_deg", [0, 0, 0])))
    t[:3, 3] = np.asarray(tool["tcp_xyz_mm"]) * 1e-3
    return flange @ t


def _csv(path: Path) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


def test_every_position_is_on_the_path_by_the_urdf(m20ia_run):
    out, urdf, robot = m20ia_run
    text = (out / "jerk.ls").read_text()
    positions = parse_ls_positions(text)
    head, rows = _csv(out / "jerk.csv")
    xyz = rows[:, [head.index(k) for k in ("x_mm", "y_mm", "z_mm")]]
    n = max(positions)
    tcp = {k: _tcp(urdf, robot, v) for k, v in positions.items()}
    path = np.array([tcp[k][:3, 3] * 1e3 for k in range(3, n - 1)])
    np.testing.assert_allclose(path[0], xyz[0], atol=5e-3)  # 4-decimal degrees
    np.testing.assert_allclose(path[-1], xyz[-1], atol=5e-3)
    a, b = path[:-1], path[1:]
    d = b - a
    u = np.clip(np.einsum("kij,ij->ki", xyz[:, None, :] - a[None], d)
                / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    dist = np.linalg.norm(xyz[:, None, :] - (a[None] + u[..., None] * d[None]), axis=2)
    assert dist.min(axis=1).max() <= CHORD_TOLERANCE_MM + 5e-3
    for k in range(3, n - 1):  # the tool axis stays the path's (vertical here)
        np.testing.assert_allclose(tcp[k][:3, 2], [0, 0, 1], atol=1e-5)
    # P[1] is APPROACH_MM above the lead-in point P[2]; the retract above the lead-out
    np.testing.assert_allclose(tcp[1][:3, 3], tcp[2][:3, 3] + APPROACH_MM * 1e-3 *
                               tcp[2][:3, 2], atol=5e-6)
    np.testing.assert_allclose(tcp[n][:3, 3], tcp[n - 1][:3, 3] + APPROACH_MM * 1e-3 *
                               tcp[n - 1][:3, 2], atol=5e-6)


def test_the_program_s_structure_and_speeds(m20ia_run):
    out, _, _ = m20ia_run
    text = (out / "jerk.ls").read_text()
    assert text.startswith("/PROG  FO_JERK") and text.rstrip().endswith("/END")
    mn = text.split("/MN\n")[1].split("/POS")[0].splitlines()
    count = int(re.search(r"LINE_COUNT\t= (\d+);", text).group(1))
    assert count == len(mn) and [int(ln.split(":")[0]) for ln in mn] == list(
        range(1, count + 1))
    body = [ln.split(":", 1)[1].strip() for ln in mn]
    order = ["UFRAME_NUM=0 ;", "UTOOL_NUM=1 ;", "J P[1] 10% FINE ;", "PAUSE ;",
             "L P[2] R[1]mm/sec FINE ;", "L P[3] R[1]mm/sec CNT100 ;", "PAUSE ;"]
    at = -1
    for needle in order:
        at = next(i for i in range(at + 1, len(body)) if body[i] == needle)
    speeds = np.array([float(v) for v in re.findall(r"R\[1\]=([0-9.]+) ;", text)])
    head, rows = _csv(out / "jerk.csv")
    feed = rows[:, head.index("feed_mm_s")]
    assert speeds[1:-1].max() <= feed.max() * 1.001 and speeds[1:-1].min() > 0
    assert all(len(ln) <= 80 for ln in body if ln.startswith("!"))
    assert "KUKA" not in text and "$" not in text


def test_utool_is_the_tcp_in_ros_industrial_s_tool0(m20ia_run):
    """The UTOOL line against the TCP in the hand-read URDF's tool0 (ROS-Industrial's
    faceplate: the flange turned by rpy (pi, -pi/2, 0) in the M-20iA xacro)."""
    out, urdf, robot = m20ia_run
    text = (out / "jerk.ls").read_text()
    line = "".join(ln.split("!", 1)[1].rsplit(";", 1)[0].strip() for ln in
                   text.split("/MN\n")[1].splitlines()[4:6])
    got = dict(re.findall(r"([XYZWPR]) (-?[0-9.]+)", line.split("faceplate:")[1]))
    tool0 = urdf_fk(urdf, "tool0", {})
    tcp = _tcp(urdf, robot, [0, 0, 0, 0, 0, 0])
    rel = np.linalg.inv(tool0) @ tcp
    np.testing.assert_allclose([float(got[k]) for k in "XYZ"], rel[:3, 3] * 1e3, atol=1e-3)
    w, p, r = np.deg2rad([float(got[k]) for k in "WPR"])
    np.testing.assert_allclose(_rpy(w, p, r), rel[:3, :3], atol=1e-5)
