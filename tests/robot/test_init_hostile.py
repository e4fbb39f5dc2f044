"""``feedopt robot init`` and robot directories against hostile input (issue 29's review):
each case exit 2 with a message naming the joint, frame or file, or the right result."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.robot.model import forward_kinematics, load_robot

ROOT = Path(__file__).resolve().parents[2]
PUBLISHED = ROOT / "tests" / "data" / "robots" / "published"
KR120 = PUBLISHED / "kr120r2500pro.urdf"
IRB2400 = PUBLISHED / "irb2400.urdf"


def _variant(tmp_path: Path, source: Path, *edits: tuple[str, str], name: str | None = None
             ) -> Path:
    text = source.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    p = tmp_path / (name or source.name)
    p.write_text(text)
    return p


ONE_JOINT = """<robot name="one"><link name="base_link"/><link name="l1"/><link name="tool0"/>
<joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>
<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="0" velocity="1"/></joint>
<joint name="f" type="fixed"><parent link="l1"/><child link="tool0"/>
<origin xyz="0.1 0 0"/></joint></robot>"""


@pytest.mark.parametrize(("edits", "message"), [
    ((('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>'),), "have <axis xyz=\"0 0 0\">"),
    ((('lower="-3.22885911619" upper="3.22885911619"', 'lower="-185" upper="185"'),),
     "spans -185 .. 185 rad"),
])
def test_degenerate_joints_are_refused_by_name(tmp_path, capsys, edits, message):
    urdf = _variant(tmp_path, KR120, *edits)
    assert main(["robot", "init", str(urdf), "--out", str(tmp_path / "r")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_an_arm_with_too_few_joints_is_refused(tmp_path, capsys):
    urdf = tmp_path / "one.urdf"
    urdf.write_text(ONE_JOINT)
    assert main(["robot", "init", str(urdf), "--out", str(tmp_path / "r")]) == 2
    assert "has 1 joint(s) (j1); feedopt plans arms of 6 to 12 joints" in (
        capsys.readouterr().err)
    assert main(["robot", "init", str(KR120), "--out", str(tmp_path / "r"), "--flange",
                 "link_4"]) == 2  # a frame inside the arm: the joints after it are named
    assert "frame 'link_4' is not at the end of the arm" in capsys.readouterr().err


def test_an_unwritable_out_is_exit_2(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    for out in (afile / "sub", Path("/proc/feedopt_robot")):
        assert main(["robot", "init", str(KR120), "--out", str(out)]) == 2
        assert "cannot write in" in capsys.readouterr().err


def test_names_survive_yaml(tmp_path, capsys):
    """A robot named '#1' and a URDF file 'robot #2: a.urdf' are legal; robot.yaml keeps them."""
    urdf = _variant(tmp_path, KR120, ('<robot name="kuka_kr120r2500pro"', '<robot name="#1"'),
                    name="robot #2: a.urdf")
    out = tmp_path / "r"
    assert main(["robot", "init", str(urdf), "--out", str(out)]) == 0
    robot = load_robot(out)
    assert robot.name == "#1"
    assert yaml.safe_load((out / "robot.yaml").read_text())["urdf"] == "robot #2: a.urdf"
    assert "wrote" in capsys.readouterr().out


def test_a_speed_that_is_no_speed_names_the_joint(tmp_path, capsys):
    urdf = _variant(tmp_path, KR120, ('velocity="2.72271363311"', 'velocity="1e-6"'))
    assert main(["robot", "init", str(urdf), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "<limit velocity> of joint_a" in err and ".robot-init-" not in err


def test_the_default_flange_is_the_last_frame_on_the_last_joint(tmp_path):
    """tool0 renamed and moved 50 mm out along the axis: robot init takes it, not link_6."""
    urdf = _variant(tmp_path, IRB2400, ('<link name="tool0"/>', '<link name="spindle_mount"/>'),
                    ('<child link="tool0"/>\n    <origin rpy="0 1.57079632679 0" xyz="0 0 0"/>',
                     '<child link="spindle_mount"/>\n    <origin rpy="0 1.57079632679 0" '
                     'xyz="0.05 0 0"/>'))
    out = tmp_path / "r"
    assert main(["robot", "init", str(urdf), "--out", str(out), "--tool-length-mm", "100"]) == 0
    assert yaml.safe_load((out / "robot.yaml").read_text())["flange_frame"] == "spindle_mount"
    tcp = forward_kinematics(load_robot(out), np.zeros(6))
    np.testing.assert_allclose(tcp[:3, 3] * 1e3, [940 + 50 + 100, 0, 1455], atol=1e-6)
