"""``feedopt validate --robot DIR`` and ``--robot-schema`` (issue 29): every robot.yaml mistake a
new user makes is refused at the command line with exit 2 and a message naming the field or
joint and what would work; a good directory prints what feedopt reads from it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from feedopt.cli import main

ROOT = Path(__file__).resolve().parents[2]
KR500 = ROOT / "robots" / "kuka_kr500_3"
KR210 = ROOT / "tests" / "data" / "robots" / "kuka_kr210"


def _copy(tmp_path: Path, yaml_edit=None, urdf_edit=None) -> Path:
    d = tmp_path / "robot"
    shutil.copytree(KR500, d)
    if yaml_edit is not None and yaml_edit[0] == "drop":  # a whole top-level field
        doc = yaml.safe_load((d / "robot.yaml").read_text())
        del doc[yaml_edit[1]]
        (d / "robot.yaml").write_text(yaml.safe_dump(doc))
        yaml_edit = None
    for name, edit in (("robot.yaml", yaml_edit), ("kr500_3.urdf", urdf_edit)):
        if edit is not None:
            old, new = edit
            text = (d / name).read_text()
            assert old in text, old
            (d / name).write_text(text.replace(old, new, 1))
    return d


def test_a_good_robot_prints_what_is_read(capsys):
    assert main(["validate", "--robot", str(KR210)]) == 0
    out = capsys.readouterr().out
    assert "kuka_kr210_l150: 6 joints, controller kuka" in out
    assert "A2 = q2-90, A3 = q3+90" in out
    assert "joint_a2: -135.00 .. -5.00 deg" in out  # limits in KUKA's axis values
    assert "PLACEHOLDERS" in out


@pytest.mark.parametrize(("yaml_edit", "urdf_edit", "message"), [
    (("tcp_xyz_mm:", "tcp_xyz:"), None, "tool.tcp_xyz: unknown field; did you mean 'tcp_xyz_mm'"),
    (("warnings:", "warning:"), None, "warning: unknown field; did you mean 'warnings'"),
    (("name: kuka_kr500_3\n", "name: kuka_kr500_3\nspindle_rpm: 18000\n"), None,
     "spindle_rpm: unknown field"),
    (("drop", "tool"), None, "tool: required field is missing"),
    (("dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]", "dpp: [2.86e6, 2.36e6, 1.67e6, 2.4e5, "
      "1.6e5, 1.4e5]"), None, "joint joint_a1 is 2.86e+06 MN m/rad, outside the plausible "
     "0.001-100 MN m/rad; it looks like N m/rad"),
    (("dpp: [2.86,", "dpp: [1.0e-12,"), None, "joint joint_a1 is 1e-12 MN m/rad"),
    (("flange_frame: flange", "flange_frame: base_link"), None, "fixed to the base"),
    (("flange_frame: flange", "flange_frame: flang"), None, "did you mean 'flange'"),
    (None, ('<joint name="joint_a6" type="revolute">', '<joint name="joint_a6" '
            'type="continuous">'), "joint 'joint_a6' is continuous"),
    (None, ('lower="-2.2689280275926285" upper="0.3490658503988659"',
            'lower="0.3490658503988659" upper="-2.2689280275926285"'),
     "joint 'joint_a2' has lower limit 0.349066 >= upper limit -2.26893: swap them"),
    (("    sign: [1, 1, 1, 1, 1, 1]", "    sign: [1, 1, 1, 1, 1]"), None,
     "controller.axes.sign: expected 6 values, one per joint (joint_a1"),
])
def test_robot_yaml_mistakes_are_refused_by_name(tmp_path, capsys, yaml_edit, urdf_edit,
                                                 message):
    d = _copy(tmp_path, yaml_edit, urdf_edit)
    assert main(["validate", "--robot", str(d)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_robot_schema_reference_and_its_out_file(tmp_path, capsys):
    assert main(["validate", "--robot-schema"]) == 0
    text = capsys.readouterr().out
    for field in ("controller.axes.offset_deg", "tool.tcp_xyz_mm", "joint_velocity_deg_s.values"):
        assert f"**{field}**" in text
    out = tmp_path / "robot_reference.md"
    assert main(["validate", "--robot-schema", "--out", str(out)]) == 0
    assert out.read_text() == text


def test_one_thing_at_a_time(tmp_path, capsys):
    assert main(["validate", "--robot", str(KR500), "--robot-schema"]) == 2
    assert "give one of" in capsys.readouterr().err
    assert main(["validate", "--robot", str(KR500), "--out", str(tmp_path / "x.md")]) == 2
    assert "checking a robot writes nothing" in capsys.readouterr().err
    assert not (tmp_path / "x.md").exists()
