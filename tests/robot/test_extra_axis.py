"""A 7-axis robot's extra axis held where the arm is stiffest (feedopt.robot.extra_axis).

The held joint against the IK (it never moves, the TCP still follows the path: FK), the
chosen value against a brute-force grid of held values, and whole runs of the published
KR120 on a linear track and the LBR iiwa 14 with ``robot.redundancy: optimise``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.report.data import redundancy_series
from feedopt.robot.extra_axis import choose_extra_axis, evaluate_held, start_with_held
from feedopt.robot.ik import IKOptions, solve_path_ik
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.robot.redundancy import RedundancyOptions, RedundancyStatus, RedundancyTask
from feedopt.robot.stage import TcpPath, robot_along_path
from feedopt.runner import prepare_front, run_scenario, start_joints
from feedopt.scenario import load_scenario
from feedopt.schedule.stage import schedule_problem
from feedopt.units import MM
from tests.robot.test_init import PUBLISHED, _on_a_track

TRACK_START = [1000, 0.153, -63.99, 105.722, 0, 48.268, 0]
TRACK_WORKPIECE = [2798.4, -4.8, 1100.0]


@pytest.fixture()
def track(tmp_path) -> Path:
    out = tmp_path / "track"
    assert main(["robot", "init", str(_on_a_track(tmp_path)), "--out", str(out)]) == 0
    return out


def _line(robot_dir: Path, q_deg: list[float], n: int = 41):
    robot = load_robot(robot_dir)
    q0 = robot.axis_convention.from_controller(np.asarray(q_deg, dtype=float))
    tcp = forward_kinematics(robot, q0)
    p = tcp[:3, 3] + np.linspace(0.0, 0.1, n)[:, None] * np.array([0.0, 1.0, 0.0])
    return robot, q0, p, np.tile(tcp[:3, 2], (n, 1))


def test_a_held_joint_keeps_its_value_and_the_tcp_follows_the_path(track):
    robot, q0, p, z = _line(track, TRACK_START)
    free = solve_path_ik(robot, p, z, q0)
    q_held = start_with_held(robot, p[0], z[0], q0, 0, 1.2)  # the track 200 mm further
    assert q_held[0] == 1.2
    held = solve_path_ik(robot, p, z, q_held, options=IKOptions(held_joint=0))
    assert np.all(held.q[:, 0] == 1.2)  # exactly: the Newton steps never move it
    tcp = forward_kinematics(robot, held.q)
    assert np.abs(tcp[:, :3, 3] - p).max() < 1e-9
    assert np.abs(tcp[:, :3, 2] - z).max() < 1e-9
    assert np.ptp(free.q[:, 0]) > 0  # the nearest IK moves it a little
    with pytest.raises(ValueError, match="held_joint"):
        IKOptions(held_joint=-1)
    with pytest.raises(InputError, match="held joint index 7"):
        solve_path_ik(robot, p, z, q0, options=IKOptions(held_joint=7))


def _tasks(tmp_path, quick_scenario, robot_dir, start, workpiece):
    scen = quick_scenario("linear_peripheral", robot__directory=str(robot_dir),
                          robot__start_configuration_deg=start,
                          workpiece__position_mm=workpiece, path__spacing_mm=2.0,
                          schedule__laws=["jerk"], robot__redundancy="optimise")
    sc, base = load_scenario(scen)
    front = prepare_front(sc, base, lambda _m: None)
    robot = load_robot(robot_dir)
    nearest = robot_along_path(robot, TcpPath(front.samples.s, front.placement.positions,
                                              front.placement.tool_axes),
                               start_joints(robot, sc), sc.robot.stiffness)
    task = RedundancyTask(front.samples.s, front.placement.positions,
                          front.placement.tool_axes,
                          lambda a: schedule_problem(sc, front.process, robot, a,
                                                     front.placement, front.samples,
                                                     front.path), nearest)
    return robot, sc, task, front.placement


def test_the_held_value_is_the_best_of_a_brute_force_grid(tmp_path, quick_scenario, track):
    robot, sc, task, placement = _tasks(tmp_path, quick_scenario, track, TRACK_START,
                                        TRACK_WORKPIECE)
    options = RedundancyOptions()
    got = choose_extra_axis(robot, 0, task, task, sc.robot.stiffness, options)
    grid = np.linspace(robot.q_lower[0] + 0.005, robot.q_upper[0] - 0.005, 61)
    brute = []
    for v in grid:
        try:
            brute.append(evaluate_held(robot, task, 0, float(v), sc.robot.stiffness,
                                       options).objective)
        except InputError:
            brute.append(np.inf)
    best = float(np.min(brute))
    assert got.status is RedundancyStatus.IMPROVED
    assert got.t_star <= best * (1 + 1e-3)  # the scan + Brent finds the grid's best
    assert got.t_star < got.t_star_nearest
    assert np.all(got.along.q[:, 0] == got.value)
    assert got.summary()["extra_axis"] == "joint_e1" and got.summary()["unit"] == "mm"
    # the report's redundancy panel: the held track against the nearest IK's, in mm
    series = redundancy_series(got, task.nearest.compliance, placement)
    assert series.profile_label == "joint_e1 [mm]"
    np.testing.assert_allclose(series.psi_deg, got.value / MM)
    np.testing.assert_allclose(series.profile_nearest, task.nearest.q[:, 0] / MM)


def test_a_track_run_holds_the_track_and_verifies(tmp_path, quick_scenario, track):
    p = quick_scenario("linear_peripheral", robot__directory=str(track),
                       robot__start_configuration_deg=TRACK_START,
                       workpiece__position_mm=TRACK_WORKPIECE, path__spacing_mm=1.0,
                       schedule__laws=["jerk"], robot__redundancy="optimise")
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None)
    red = result.summary["scenario"]["redundancy"]
    assert red["extra_axis"] == "joint_e1" and red["status"] == "improved"
    assert red["t_star_s"] < red["t_star_nearest_s"]
    jerk = result.summary["laws"]["jerk"]
    assert jerk["verified"] and jerk["exported"]
    lines = [ln for ln in (tmp_path / "out" / "jerk.csv").read_text().splitlines()
             if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    track_mm = np.array([float(ln.split(",")[head.index("q1_deg")]) for ln in lines[1:]])
    assert np.ptp(track_mm) < 1e-6 and abs(track_mm[0] - red["held_value"]) < 1e-6
    assert "its extra axis, held" in (tmp_path / "out" / "report.html").read_text()


def test_a_seven_joint_arm_names_its_extra_axis(tmp_path, quick_scenario, capsys):
    out = tmp_path / "iiwa"
    assert main(["robot", "init", str(PUBLISHED / "lbr_iiwa_14_r820.urdf"), "--out",
                 str(out)]) == 0
    p = quick_scenario("linear_peripheral", robot__directory=str(out),
                       robot__start_configuration_deg=[0, 40, 0, -80, 0, 60, 0],
                       workpiece__position_mm=[600.0, 0.0, 155.5], path__spacing_mm=1.0,
                       schedule__laws=["jerk"], robot__redundancy="optimise")
    capsys.readouterr()
    assert main(["validate", str(p)]) == 2
    assert "add 'extra_axis: <joint>' to its robot.yaml" in capsys.readouterr().err
    doc = yaml.safe_load((out / "robot.yaml").read_text())
    doc["extra_axis"] = "joint_3"
    (out / "robot.yaml").write_text(yaml.safe_dump(doc))
    assert main(["validate", "--robot", str(out)]) == 2
    assert "did you mean 'joint_a3'?" in capsys.readouterr().err
    doc["extra_axis"] = "joint_a3"  # KUKA's E1
    (out / "robot.yaml").write_text(yaml.safe_dump(doc))
    result = run_scenario(p, out_dir=tmp_path / "run", progress=lambda _m: None, report=False)
    red = result.summary["scenario"]["redundancy"]
    assert red["extra_axis"] == "joint_a3"
    assert red["t_star_s"] <= red["t_star_nearest_s"]
    assert result.summary["laws"]["jerk"]["verified"]


def test_extra_axis_on_a_six_axis_robot_is_refused(tmp_path, capsys):
    src = Path(__file__).resolve().parents[2] / "robots" / "kuka_kr500_3"
    out = tmp_path / "kr500"
    out.mkdir()
    for f in src.iterdir():
        (out / f.name).write_bytes(f.read_bytes())
    doc = yaml.safe_load((out / "robot.yaml").read_text())
    doc["extra_axis"] = "joint_a1"
    (out / "robot.yaml").write_text(yaml.safe_dump(doc))
    assert main(["validate", "--robot", str(out)]) == 2
    assert "is for 7-axis robots" in capsys.readouterr().err
