"""Property: a mutated ``robot.yaml`` (beside the KR500-3's URDF) is either read into a robot
with physical values or refused with one InputError (exit 2) - never another exception.

Mutations: values replaced by garbage (NaN, inf, 1e308, strings, lists, mappings), fields
deleted, unknown keys added, values wrapped in lists or mappings, raw-text edits and random
bytes. The whole file runs in a few seconds (load_robot builds the URDF each time).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.robot.model import RobotModel, forward_kinematics, load_robot
from feedopt.robot.stiffness import compliance

from ._support import ROOT, budget, garbage, mutated, text_mutations

KUKA = ROOT / "robots" / "kuka_kr500_3"
ROBOT_YAML = (KUKA / "robot.yaml").read_text()
ROBOT = yaml.safe_load(ROBOT_YAML)
FIELDS = sorted(ROBOT)


@pytest.fixture(scope="module")
def robot_dir(tmp_path_factory) -> Path:
    """A copy of the KR500-3 directory; each example overwrites its robot.yaml."""
    d = tmp_path_factory.mktemp("robot") / "kuka_kr500_3"
    shutil.copytree(KUKA, d)
    return d


def check_robot(directory: Path) -> None:
    """load_robot reads the directory into sane values, or refuses it with an InputError."""
    try:
        robot = load_robot(directory)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert isinstance(robot, RobotModel) and isinstance(robot.name, str)
    assert robot.dof == 6
    for arr in (robot.joint_velocity_max, robot.joint_acceleration_max, *robot.stiffness.values()):
        assert arr.shape == (6,) and np.all(np.isfinite(arr)) and np.all(arr > 0)
    assert robot.stiffness and all(isinstance(k, str) for k in robot.stiffness)
    assert robot.tcp_offset.shape == (4, 4) and np.all(np.isfinite(robot.tcp_offset))
    np.testing.assert_allclose(robot.tcp_offset[:3, :3] @ robot.tcp_offset[:3, :3].T,
                               np.eye(3), atol=1e-9)
    assert all(isinstance(v, str) for v in robot.sources.values())
    assert all(isinstance(w, str) for w in robot.data_warnings)
    assert robot.controller in ("kuka", "ur", "generic")
    # what the commands compute from it stays finite: the TCP pose and every compliance
    q = (robot.q_lower + robot.q_upper) / 2
    assert np.all(np.isfinite(forward_kinematics(robot, q)))
    for name in robot.stiffness:
        assert np.all(np.isfinite(compliance(robot, q[None], name)))


def _write(directory: Path, doc) -> None:
    (directory / "robot.yaml").write_text(
        yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")


def test_the_original_loads(robot_dir):
    _write(robot_dir, ROBOT)
    assert math.isclose(load_robot(robot_dir).tcp_offset[0, 3], 0.4)


@budget(150)
@given(doc=mutated(ROBOT))
def test_mutated_robot_yaml(robot_dir, doc):
    _write(robot_dir, doc)
    check_robot(robot_dir)


@budget(60)
@given(field=st.sampled_from(FIELDS + ["tool.tcp_xyz_mm", "tool.tcp_rpy_deg", "tool.source",
                                        "joint_stiffness_mnm_per_rad.dpp",
                                        "joint_stiffness_mnm_per_rad.source",
                                        "joint_velocity_deg_s.values",
                                        "joint_acceleration_deg_s2.source"]),
       value=garbage)
def test_one_field_garbage(robot_dir, field, value):
    """Every field (and the nested ones) replaced by garbage, one at a time."""
    doc = yaml.safe_load(ROBOT_YAML)
    *parents, last = field.split(".")
    target = doc
    for p in parents:
        target = target[p]
    target[last] = value
    _write(robot_dir, doc)
    check_robot(robot_dir)


huge = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 1e30, -1e30, 5e-324,
                        0.0, -0.0, 2**64, "1e308", "nan"])


@budget(40)
@given(xyz=st.lists(huge, min_size=3, max_size=3), rpy=st.lists(huge, min_size=3, max_size=3),
       k=st.lists(huge, min_size=6, max_size=6))
def test_huge_and_non_finite_numbers(robot_dir, xyz, rpy, k):
    doc = yaml.safe_load(ROBOT_YAML)
    doc["tool"]["tcp_xyz_mm"], doc["tool"]["tcp_rpy_deg"] = xyz, rpy
    doc["joint_stiffness_mnm_per_rad"]["cp"] = k
    _write(robot_dir, doc)
    check_robot(robot_dir)


any_float = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)


@budget(60)
@given(field=st.sampled_from(["tool.tcp_xyz_mm", "tool.tcp_rpy_deg",
                              "joint_stiffness_mnm_per_rad.cp", "joint_velocity_deg_s.values",
                              "joint_acceleration_deg_s2.values"]),
       data=st.data())
def test_vectors_of_any_floats(robot_dir, field, data):
    """Right-length vectors of any float (subnormal, 1e308, negative): read sane or refused."""
    doc = yaml.safe_load(ROBOT_YAML)
    parent, last = field.split(".")
    n = len(doc[parent][last])
    doc[parent][last] = data.draw(st.lists(st.one_of(any_float, huge), min_size=n, max_size=n))
    _write(robot_dir, doc)
    check_robot(robot_dir)


@budget(50)
@given(data=st.data())
def test_raw_text_mutations(robot_dir, data):
    text = data.draw(text_mutations(ROBOT_YAML, alphabet=list(":-[]{},#&*!|>' \t\n0.e+")))
    (robot_dir / "robot.yaml").write_text(text, encoding="utf-8", errors="surrogatepass")
    check_robot(robot_dir)


@budget(30)
@given(raw=st.binary(max_size=300))
def test_random_bytes(robot_dir, raw):
    (robot_dir / "robot.yaml").write_bytes(raw)
    check_robot(robot_dir)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("tool.tcp_xyz_mm", [1e308, 0.0, 0.0], "tool.tcp_xyz_mm: every value must be between"),
    ("joint_stiffness_mnm_per_rad.dpp", [5e-324] * 6, "joint_stiffness_mnm_per_rad.dpp"),
    ("joint_velocity_deg_s.values", [1e308] * 6, "joint_velocity_deg_s: every value"),
    ("tool.tcp_rpy_deg", [float("nan"), 0.0, 0.0],
     "tool.tcp_rpy_deg.0: Input should be a finite number"),
])
def test_cli_refuses_absurd_robot_numbers(tmp_path, capsys, field, value, message):
    """Through the command line: exit 2 naming the field, nothing written."""
    robot = tmp_path / "robot"
    shutil.copytree(KUKA, robot)
    doc = yaml.safe_load(ROBOT_YAML)
    parent, last = field.split(".")
    doc[parent][last] = value
    _write(robot, doc)
    out = tmp_path / "plan.csv"
    code = main(["calibrate-stiffness", "--suggest", "3", "--robot", str(robot), "--out",
                 str(out), "--candidates", "50"])
    captured = capsys.readouterr()
    assert code == 2 and message in captured.err and "Traceback" not in captured.err
    assert not out.exists()


@pytest.mark.parametrize("urdf", ["x" * 5000, {"a": 1}, ["kr500_3.urdf"], "", 3, "a\x00b"])
def test_urdf_names_that_are_no_file_name(robot_dir, urdf):
    """Found by the fuzz (nightly profile): a mapping as urdf became a 300-character path and
    is_file raised OSError (File name too long)."""
    doc = yaml.safe_load(ROBOT_YAML)
    doc["urdf"] = urdf
    _write(robot_dir, doc)
    with pytest.raises(InputError, match="urdf"):
        load_robot(robot_dir)
