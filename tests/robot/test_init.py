"""``feedopt robot init`` on published URDFs (issue 29), checked with an independent FK.

The reference FK reads the URDF's XML here (joint origins, axes, types) and multiplies the
homogeneous transforms along the chain with numpy: no pinocchio. It is compared with the FK
feedopt computes from the written robot directory (pinocchio, TCP added on the flange), at
random joint values within the limits. The TCP must sit on the last joint's axis, out of the
flange, with its +z pointing back into the spindle.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.runner import run_scenario

ROOT = Path(__file__).resolve().parents[2]
PUBLISHED = ROOT / "tests" / "data" / "robots" / "published"
URDFS = {  # file -> (joints, flange, CAD offset of the flange [mm], joints locked)
    PUBLISHED / "irb2400.urdf": (6, "tool0", 0.0, ()),
    PUBLISHED / "irb6640_185_280.urdf": (6, "tool0", 0.0, ("joint_cylinder", "joint_piston")),
    PUBLISHED / "kr120r2500pro.urdf": (6, "tool0", 0.0, ()),
    PUBLISHED / "lbr_iiwa_14_r820.urdf": (7, "tool0", 0.0, ()),
    ROOT / "tests" / "data" / "robots" / "kuka_kr210" / "kr210l150.urdf": (6, "tool0", 0.239,
                                                                           ()),
}


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def urdf_fk(urdf: Path, link: str, q_by_joint: dict[str, float]) -> np.ndarray:
    """Pose (4, 4) of ``link`` in the root link: the URDF read and multiplied by hand."""
    joints = {j.find("child").get("link"): j for j in ET.parse(urdf).getroot().iter("joint")}
    pose = np.eye(4)
    while link in joints:
        j = joints[link]
        origin = j.find("origin")
        xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None
                                  else "0 0 0").split()]
        rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None
                                  else "0 0 0").split()]
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = _rpy(*rpy), xyz
        if j.get("type") in ("revolute", "continuous"):
            axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
            m = np.eye(4)
            m[:3, :3] = _axis_angle(axis, q_by_joint.get(j.get("name"), 0.0))
            t = t @ m
        pose = t @ pose
        link = j.find("parent").get("link")
    return pose


@pytest.mark.parametrize("urdf", list(URDFS), ids=lambda p: p.stem)
def test_init_writes_a_robot_whose_fk_matches_the_urdf(tmp_path, capsys, urdf):
    _check_init(tmp_path, capsys, urdf, *URDFS[urdf])


def test_init_on_a_fanuc_expanded_from_its_xacro(tmp_path, capsys):
    """ROS-Industrial's FANUC M-20iA ships xacro only: expanded with the xacro package (its
    ``$(find package)`` paths pointed at the committed folders), then as any URDF."""

    _check_init(tmp_path, capsys, expand_m20ia(tmp_path), 6, "flange", 0.0, ())


def expand_m20ia(tmp_path: Path) -> Path:
    """The M-20iA URDF expanded from the committed xacro (skips without xacro)."""
    import re

    xacro = pytest.importorskip("xacro")
    source = ROOT / "tests" / "data" / "robots" / "xacro"
    work = tmp_path / "xacro"
    for f in source.rglob("*.xacro"):
        out = work / f.relative_to(source)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(re.sub(r"\$\(find ([\w-]+)\)", lambda m: str(work / m.group(1)),
                              f.read_text()))
    urdf = tmp_path / "m20ia.urdf"
    urdf.write_text(xacro.process_file(str(work / "fanuc_m20ia_support" / "urdf" /
                                           "m20ia.xacro")).toprettyxml(indent="  "))
    return urdf


def _check_init(tmp_path, capsys, urdf, dof, flange, off_mm, locked):
    out = tmp_path / "robot"
    assert main(["robot", "init", str(urdf), "--out", str(out), "--tool-length-mm", "250"]) == 0
    printed = capsys.readouterr().out
    assert f"flange '{flange}'" in printed and f"origin {off_mm:.3f} mm off" in printed
    assert "still to fill in robot.yaml" in printed and "joint_stiffness" in printed
    for name in locked:
        assert name in printed
    assert sorted(p.name for p in out.iterdir()) == sorted([urdf.name, "robot.yaml"])
    assert "PLACEHOLDER" in (out / "robot.yaml").read_text()
    robot = load_robot(out)
    assert robot.dof == dof and any("PLACEHOLDER" in w for w in robot.data_warnings)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.uniform(robot.q_lower, robot.q_upper)
        tcp = forward_kinematics(robot, q)
        flange_pose = urdf_fk(urdf, flange,  # ROS-I frames are links
                              dict(zip(robot.joint_names, q, strict=True)))
        np.testing.assert_allclose(tcp, flange_pose @ robot.tcp_offset, atol=1e-9)
        # the tool: 250 mm out along the last joint's axis, TCP +z back into the spindle
        last = urdf_fk(urdf, _child_link(urdf, robot.joint_names[-1]),
                       dict(zip(robot.joint_names, q, strict=True)))
        out_dir = tcp[:3, 3] - flange_pose[:3, 3]
        assert np.linalg.norm(out_dir) == pytest.approx(0.25, abs=1e-9)
        np.testing.assert_allclose(tcp[:3, 2], -out_dir / 0.25, atol=1e-9)
        assert (tcp[:3, 3] - last[:3, 3]) @ out_dir > 0  # out of the flange, not into the arm


def _child_link(urdf: Path, joint: str) -> str:
    """The child link of ``joint`` (where the joint's axis is)."""
    for j in ET.parse(urdf).getroot().iter("joint"):
        if j.get("name") == joint:
            return j.find("child").get("link")
    raise KeyError(joint)


def test_a_published_robot_from_init_plans_and_verifies(tmp_path, quick_scenario):
    """The IRB 2400 from its URDF, straight from robot init, runs the thesis cut."""
    out = tmp_path / "irb2400"
    assert main(["robot", "init", str(PUBLISHED / "irb2400.urdf"), "--out", str(out)]) == 0
    # FK of the written robot at (0, 20, 10, 0, 60, 0) deg: TCP at (1062.5, 0, 731.9) mm with
    # the tool pointing down; the cut starts 62.5 mm short of it
    p = quick_scenario("linear_peripheral", robot__directory=str(out),
                       robot__start_configuration_deg=[0, 20, 10, 0, 60, 0],
                       workpiece__position_mm=[1000.0, 0.0, 731.9], path__spacing_mm=1.0,
                       schedule__laws=["jerk"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None, report=False)
    jerk = result.summary["laws"]["jerk"]
    assert jerk["verified"] and jerk["exported"]
    assert any("PLACEHOLDER" in w for w in result.summary["warnings"])


def _variant(tmp_path: Path, source: Path, old: str, new: str) -> Path:
    text = source.read_text()
    assert old in text, old
    p = tmp_path / source.name
    p.write_text(text.replace(old, new, 1))
    return p


@pytest.mark.parametrize(("old", "new", "message"), [
    ('<joint name="joint_a3" type="revolute">',
     '<joint name="joint_a3" type="revolute">\n    <mimic joint="joint_a2"/>',
     "joint 'joint_a3' mimics 'joint_a2' on the arm's own chain"),
    ('<joint name="joint_a5" type="revolute">', '<joint name="joint_a5" type="continuous">',
     "joint 'joint_a5' is continuous"),
    ('<joint name="joint_a5" type="revolute">', '<joint name="joint_a5" type="floating">',
     "joint 'joint_a5' is a JointModelFreeFlyer joint of 6 degrees of freedom"),
    ('<joint name="joint_a5" type="revolute">', '<joint name="joint_a5" type="planar">',
     "joint 'joint_a5' is a JointModelPlanar joint of 3 degrees of freedom"),
])
def test_init_refuses_what_feedopt_cannot_plan_by_name(tmp_path, capsys, old, new, message):
    urdf = _variant(tmp_path, PUBLISHED / "kr120r2500pro.urdf", old, new)
    assert main(["robot", "init", str(urdf), "--out", str(tmp_path / "r")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_init_refuses_a_flange_off_the_last_axis_and_a_used_folder(tmp_path, capsys):
    kr120 = PUBLISHED / "kr120r2500pro.urdf"
    assert main(["robot", "init", str(kr120), "--out", str(tmp_path / "r"), "--flange",
                 "base_link"]) == 2
    assert "fixed to the base" in capsys.readouterr().err
    used = tmp_path / "used"
    used.mkdir()
    (used / "notes.txt").write_text("mine")
    assert main(["robot", "init", str(kr120), "--out", str(used)]) == 2
    assert "already holds files" in capsys.readouterr().err
    assert sorted(p.name for p in used.iterdir()) == ["notes.txt"]
    assert main(["robot", "init", str(kr120), "--out", str(PUBLISHED)]) == 2  # its own folder
    assert not (PUBLISHED / "robot.yaml").exists()


def test_a_seven_axis_arm_plans_and_verifies(tmp_path, quick_scenario, capsys):
    """The iiwa straight from robot init: 7 joints, the two extra degrees of freedom taken by
    the nearest (weighted minimum-norm) IK, verified by the replay, the setpoint CSV with 7
    joint columns; KRL, RSI and URScript are not written for it (said why)."""
    out = tmp_path / "iiwa"
    assert main(["robot", "init", str(PUBLISHED / "lbr_iiwa_14_r820.urdf"), "--out",
                 str(out)]) == 0
    # FK at (0, 40, 0, -80, 0, 60, 0) deg: TCP at (616.3, 0, 155.5) mm, tool pointing down
    p = quick_scenario("linear_peripheral", robot__directory=str(out),
                       robot__start_configuration_deg=[0, 40, 0, -80, 0, 60, 0],
                       workpiece__position_mm=[600.0, 0.0, 155.5], path__spacing_mm=1.0,
                       schedule__laws=["jerk"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None, report=False)
    jerk = result.summary["laws"]["jerk"]
    assert jerk["verified"] and jerk["exported"]
    header = next(line for line in (tmp_path / "out" / "jerk.csv").read_text().splitlines()
                  if line.startswith("t_s,"))
    assert "q7_deg,s_mm" in header
    assert "# q1..q7: " in (tmp_path / "out" / "jerk.csv").read_text()
    six = yaml.safe_load(p.read_text())
    six["robot"]["start_configuration_deg"] = [0, 40, 0, -80, 0, 60]
    p.write_text(yaml.safe_dump(six))
    capsys.readouterr()
    assert main(["validate", str(p)]) == 2  # validate refuses what run refuses
    assert "has 6 values; robot" in capsys.readouterr().err
    six["robot"]["start_configuration_deg"] = [0, 40, 0, -80, 0, 60, 0]
    p.write_text(yaml.safe_dump(six))
    doc = yaml.safe_load(p.read_text())
    doc["robot"]["redundancy"] = "optimise"  # holds the extra axis robot.yaml must name
    p.write_text(yaml.safe_dump(doc))
    capsys.readouterr()
    assert main(["validate", str(p)]) == 2
    assert "does not say which joint it is" in capsys.readouterr().err


def _on_a_track(tmp_path: Path) -> Path:
    """The KR120 on a 6 m linear track along x: a prismatic joint under its base_link."""
    text = (PUBLISHED / "kr120r2500pro.urdf").read_text()
    cut = text.index(">", text.index("<robot")) + 1
    track = """
  <link name="track"/>
  <joint name="joint_e1" type="prismatic">
    <origin rpy="0 0 0" xyz="0 0 0.3"/>
    <parent link="track"/>
    <child link="base_link"/>
    <axis xyz="1 0 0"/>
    <limit effort="0" lower="0" upper="6.0" velocity="1.0"/>
  </joint>
"""
    urdf = tmp_path / "kr120_track.urdf"
    urdf.write_text(text[:cut] + track + text[cut:])
    return urdf


def test_a_robot_on_a_linear_track_plans_with_the_track_nearly_still(tmp_path, quick_scenario,
                                                                    capsys):
    """The track in mm (its range 0..6000 mm), the arm following the 203 mm cut while the
    track moves by less than 0.5 mm (its IK weight: 10 mm of track cost as much as 1 rad)."""
    out = tmp_path / "track"
    assert main(["robot", "init", str(_on_a_track(tmp_path)), "--out", str(out)]) == 0
    assert "joint_e1 prismatic" in capsys.readouterr().out
    assert main(["validate", "--robot", str(out)]) == 0
    assert "joint_e1: 0.00 .. 6000.00 mm, speed 1000 mm/s" in capsys.readouterr().out
    p = quick_scenario("linear_peripheral", robot__directory=str(out),
                       robot__start_configuration_deg=[1000, 0.153, -63.99, 105.722, 0,
                                                       48.268, 0],
                       workpiece__position_mm=[2798.4, -4.8, 1100.0], path__spacing_mm=1.0,
                       schedule__laws=["jerk"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None, report=False)
    assert result.summary["laws"]["jerk"]["verified"]
    lines = [ln for ln in (tmp_path / "out" / "jerk.csv").read_text().splitlines()
             if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    track_mm = rows[:, head.index("q1_deg")]
    x_mm = rows[:, head.index("x_mm")]
    assert np.ptp(x_mm) > 200.0 and np.ptp(track_mm) < 0.5
    assert abs(track_mm[0] - 1000.0) < 0.5  # from the start configuration, not a jump
