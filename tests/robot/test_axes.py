"""Controller axis conventions (robot.yaml ``controller.axes``, issue 29).

References: KUKA's own convention for a KR210 whose published URDF has a different zero
(HOME {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}: upper arm vertical, forearm and flange pointing
forward; A1 positive turns the arm clockwise seen from above), checked by adding up the URDF's
joint origins by hand, not by pinocchio; and, end to end, the same cell planned with the
bundled KR500-3 under two conventions, whose exported axis values must differ exactly by the
convention while the trajectory stays the same.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.robot.axes import AxisConvention
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.runner import run_scenario

ROOT = Path(__file__).resolve().parents[2]
KR210 = ROOT / "tests" / "data" / "robots" / "kuka_kr210"
KR500 = ROOT / "robots" / "kuka_kr500_3"
HOME = np.array([0.0, -90.0, 90.0, 0.0, 0.0, 0.0])

# kr210l150.urdf joint origins [m] (base -> A1 -> ... -> A6 -> tool0), all rotations zero
ORIGINS = np.array([[-0.00262, 0.00097586, 0.33099], [0.35277, -0.037476, 0.4192],
                    [-9.8483e-05, -0.1475, 1.2499], [0.95795, 0.184, -0.055059],
                    [0.542, 0.0, 0.0], [0.1925, 0.0, 0.0], [0.0375, 0.0, -0.00023924]])
TOOL_MM = 300.0  # robot.yaml: along tool0's +x


def test_kr210_at_kukas_home_is_upright_with_the_tool_forward():
    robot = load_robot(KR210)
    q = robot.axis_convention.from_controller(HOME)
    np.testing.assert_allclose(np.rad2deg(q), 0.0, atol=1e-12)  # the URDF's own zero
    pose = forward_kinematics(robot, q)
    by_hand = ORIGINS.sum(axis=0) + [TOOL_MM * 1e-3, 0.0, 0.0]
    np.testing.assert_allclose(pose[:3, 3], by_hand, atol=1e-9)
    np.testing.assert_allclose(pose[:3, 2], [-1.0, 0.0, 0.0], atol=1e-12)  # TCP z into spindle


def test_kr210_axis_directions_follow_kuka():
    robot = load_robot(KR210)
    ax = robot.axis_convention
    turned = forward_kinematics(robot, ax.from_controller(HOME + [30, 0, 0, 0, 0, 0]))
    assert turned[1, 3] < -1.0  # A1 +30 deg: clockwise from above, to -y
    lowered = forward_kinematics(robot, ax.from_controller(HOME + [0, 10, 0, 0, 0, 0]))
    home = forward_kinematics(robot, ax.from_controller(HOME))
    assert lowered[2, 3] < home[2, 3] and lowered[0, 3] > home[0, 3]  # A2 +: the arm leans out
    # the URDF's range of joint_a2, -45..85 deg, is KUKA's -135..-5 deg
    ends = ax.to_controller(np.stack([robot.q_lower, robot.q_upper]))
    # (the URDF gives 9 digits of rad)
    np.testing.assert_allclose(np.sort(ends[:, 1]), [-135.0, -5.0], atol=1e-5)


@given(st.lists(st.floats(-350, 350), min_size=6, max_size=6),
       st.lists(st.sampled_from([1.0, -1.0]), min_size=6, max_size=6),
       st.lists(st.floats(-180, 180), min_size=6, max_size=6))
def test_conversion_round_trips(values, sign, offset):
    unit = np.full(6, np.pi / 180)
    ax = AxisConvention(np.array(sign), np.deg2rad(offset), unit, True)
    q = ax.from_controller(np.array(values))
    np.testing.assert_allclose(ax.to_controller(q), values, atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(ax.to_controller_si(q)), values, atol=1e-9)


def _robot_with_axes(tmp_path: Path, name: str, axes: dict | None) -> Path:
    d = tmp_path / name
    shutil.copytree(KR500, d)
    doc = yaml.safe_load((d / "robot.yaml").read_text())
    doc["controller"] = {"type": "kuka", **({"axes": axes} if axes else {})}
    (d / "robot.yaml").write_text(yaml.safe_dump(doc))
    return d


def _axis_lines(out: Path) -> dict[str, np.ndarray]:
    """The axis values a KRL and an RSI host program write: the .dat's approach AXIS and the
    host program's PTP to the start."""
    dat = (out / "thesis.dat").read_text()  # KRL: the thesis law's native program
    host = (out / "jerk_rsi.src").read_text()
    found = {}
    for key, text in (("krl_approach", dat), ("rsi_start", host)):
        block = re.findall(r"\{(A1 [^}]*)\}", text)[-1]
        found[key] = np.array([float(v) for v in re.findall(r"A\d (\S+?)(?:,|$)", block)])
    return found


def test_exports_write_the_controllers_axis_values(tmp_path, quick_scenario):
    """The same cell under KUKA's convention and under a made-up one: the same trajectory,
    axis values differing exactly by sign and offset in KRL, RSI host program and CSV."""
    sign, offset = np.array([-1, 1, 1, -1, 1, 1.0]), np.array([5.0, -90, 90, 0, 0, 30])
    runs = {}
    for name, axes in (("plain", {"sign": [1] * 6, "offset_deg": [0] * 6}),
                       ("shifted", {"sign": sign.astype(int).tolist(),
                                    "offset_deg": offset.tolist()})):
        start = yaml.safe_load(quick_scenario("linear_peripheral").read_text())["robot"][
            "start_configuration_deg"]
        controller_start = (sign * np.array(start) + offset) if name == "shifted" else start
        p = quick_scenario("linear_peripheral",
                           robot__directory=str(_robot_with_axes(tmp_path, name, axes)),
                           robot__start_configuration_deg=np.asarray(controller_start).tolist(),
                           path__spacing_mm=1.0, schedule__laws=["thesis", "jerk"])
        out = tmp_path / f"out_{name}"
        run_scenario(p, out_dir=out, progress=lambda _m: None, report=False)
        runs[name] = (out, json.loads((out / "summary.json").read_text()))
    (plain, s_plain), (shifted, s_shifted) = runs["plain"], runs["shifted"]
    # the same plan (the start converted back to the same joints, to rounding)
    assert np.isclose(s_plain["laws"]["jerk"]["cycle_time_s"],
                      s_shifted["laws"]["jerk"]["cycle_time_s"], rtol=1e-12)
    a, b = _axis_lines(plain), _axis_lines(shifted)
    for key in a:
        np.testing.assert_allclose(b[key], sign * a[key] + offset, atol=2e-3, err_msg=key)
    q_plain = _q_columns(plain / "jerk.csv")
    q_shift = _q_columns(shifted / "jerk.csv")
    np.testing.assert_allclose(q_shift, sign * q_plain + offset, atol=1e-7)
    assert "controller.axes" in (shifted / "jerk.csv").read_text()


def _q_columns(csv: Path) -> np.ndarray:
    lines = [ln for ln in csv.read_text().splitlines() if ln and not ln.startswith("#")]
    header = lines[0].split(",")
    cols = [header.index(f"q{i}_deg") for i in range(1, 7)]
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:60]])
    return rows[:, cols]


def test_a_kuka_robot_without_axes_gets_no_kuka_program(tmp_path, quick_scenario):
    p = quick_scenario("linear_peripheral",
                       robot__directory=str(_robot_with_axes(tmp_path, "bare", None)),
                       path__spacing_mm=1.0, schedule__laws=["thesis", "jerk"])
    messages: list[str] = []
    result = run_scenario(p, out_dir=tmp_path / "out", progress=messages.append, report=False)
    thesis, jerk = result.summary["laws"]["thesis"], result.summary["laws"]["jerk"]
    assert thesis["krl_program"] is None and "controller.axes" in thesis["krl_not_written"]
    assert jerk["rsi_host_program"] is None and "controller.axes" in jerk["rsi_host_not_written"]
    assert not list((tmp_path / "out").glob("*.src"))
    assert any("controller.axes" in m for m in messages if m.startswith("warning"))
    assert (tmp_path / "out" / "jerk.csv").is_file()  # the setpoint CSV, URDF angles, says so
    assert "URDF's joint angles" in (tmp_path / "out" / "jerk.csv").read_text()



def test_a_coupled_axis_fanuc_j2_j3(tmp_path):
    """FANUC's J3 is the forearm's angle from the horizontal: controller J3 = q3 + q2. The
    exports write it, start configurations are read back through it, validate shows it."""
    d = _robot_with_axes(tmp_path, "fanuc_like", {
        "sign": [1] * 6, "offset_deg": [0] * 6,
        "coupled": [{"axis": 3, "joint": 2, "factor": 1.0}]})
    robot = load_robot(d)
    ax = robot.axis_convention
    q = np.deg2rad([5.0, 10.0, 20.0, 0.0, 30.0, 0.0])
    np.testing.assert_allclose(ax.to_controller(q), [5, 10, 30, 0, 30, 0], atol=1e-12)
    np.testing.assert_allclose(ax.from_controller([5, 10, 30, 0, 30, 0]), q, atol=1e-15)
    assert "A3 = q3 + 1*q2" in ax.describe()
    bad = _robot_with_axes(tmp_path, "self", {"sign": [1] * 6, "offset_deg": [0] * 6,
                                              "coupled": [{"axis": 3, "joint": 3}]})
    with pytest.raises(InputError, match="two different ones"):
        load_robot(bad)
    singular = _robot_with_axes(tmp_path, "singular", {
        "sign": [1] * 6, "offset_deg": [0] * 6,
        "coupled": [{"axis": 2, "joint": 3, "factor": 1.0}, {"axis": 3, "joint": 2,
                                                              "factor": 1.0}]})
    with pytest.raises(InputError, match="singular"):
        load_robot(singular)


@given(st.lists(st.floats(-170, 170), min_size=6, max_size=6),
       st.floats(-2.0, 2.0).filter(lambda f: abs(f) > 1e-3 or f == 0.0))
def test_coupled_conversion_round_trips(values, factor):
    unit = np.full(6, np.pi / 180)
    coupling = np.zeros((6, 6))
    coupling[2, 1] = factor
    ax = AxisConvention(np.ones(6), np.zeros(6), unit, True, coupling)
    np.testing.assert_allclose(ax.to_controller(ax.from_controller(np.array(values))), values,
                               atol=1e-9)


def test_validate_shows_the_coupled_axis(tmp_path, capsys):
    from feedopt.cli import main

    d = _robot_with_axes(tmp_path, "fanuc_like", {
        "sign": [1] * 6, "offset_deg": [0] * 6,
        "coupled": [{"axis": 3, "joint": 2, "factor": 1.0}]})
    assert main(["validate", "--robot", str(d)]) == 0
    out = capsys.readouterr().out
    assert "A3 = q3 + 1*q2" in out
    assert "joint_a3: -100.00 .. 144.00 deg (the URDF joint's range" in out
    assert "joint_a2: -130.00 .. 20.00 deg, speed" in out  # not coupled: its own range


def test_coupling_factors_are_in_controller_units_per_joint_unit():
    """A track (mm) coupled into axis 2 (deg) with 0.01 deg per mm: 1000 mm of track add 10
    deg, whatever the SI units inside."""
    unit = np.array([1e-3] + [np.pi / 180] * 6)
    coupling = np.zeros((7, 7))
    coupling[1, 0] = 0.01
    ax = AxisConvention(np.ones(7), np.zeros(7), unit, True, coupling)
    q = np.array([1.0, 0, 0, 0, 0, 0, 0])  # 1 m of track, the arm at zero
    np.testing.assert_allclose(ax.to_controller(q), [1000, 10, 0, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(ax.from_controller([1000, 10, 0, 0, 0, 0, 0]), q, atol=1e-15)


def test_a_start_configuration_outside_the_limits_is_named_in_controller_values(
        tmp_path, quick_scenario, capsys):
    from feedopt.cli import main

    d = _robot_with_axes(tmp_path, "shifted", {"sign": [1] * 6,
                                               "offset_deg": [0, -90, 90, 0, 0, 0]})
    p = quick_scenario("linear_peripheral", robot__directory=str(d),
                       robot__start_configuration_deg=[0, -90, 300, 0, 45, 0])
    assert main(["validate", str(p)]) == 2
    err = capsys.readouterr().err
    assert ("robot.start_configuration_deg: axis 3 (joint joint_a3) = 300 deg puts the joint "
            "at 210.000 deg (URDF)") in err
