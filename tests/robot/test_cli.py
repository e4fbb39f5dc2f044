"""``feedopt robot`` command."""

from __future__ import annotations

import numpy as np

from feedopt.cli import main
from feedopt.robot.model import forward_kinematics
from feedopt.robot.stiffness import deflection, translational_compliance
from tests.robot.helpers import KUKA_DIR, Q_START_DEG, UR10_DIR


def test_robot_command_prints_pose_stiffness_and_deflection(capsys, kuka):
    q = ",".join(f"{v}" for v in Q_START_DEG)
    assert main(["robot", str(KUKA_DIR), f"--q-deg={q}", "--force-n", "100,-50,20"]) == 0
    out = capsys.readouterr().out
    pose = forward_kinematics(kuka, np.deg2rad(Q_START_DEG)) * 1e3
    assert f"X={pose[0, 3]:.3f} Y={pose[1, 3]:.3f} Z={pose[2, 3]:.3f} mm" in out
    assert "principal stiffnesses" in out and out.count(" along [") == 3
    c = translational_compliance(kuka, np.deg2rad(Q_START_DEG)[None], "dpp")
    d = deflection(c, np.array([[100.0, -50.0, 20.0]]))[0] * 1e3
    assert f"dx={d[0]:.5f} dy={d[1]:.5f} dz={d[2]:.5f}" in out


def test_robot_command_second_robot_and_cp(capsys):
    assert main(["robot", str(UR10_DIR), "--q-deg=0,-90,90,-90,-90,0", "--stiffness", "cp"]) == 0
    assert "stiffness set: cp" in capsys.readouterr().out


def test_robot_command_bad_input_exit_2(capsys, tmp_path):
    assert main(["robot", str(KUKA_DIR), "--q-deg=1,2,3"]) == 2
    assert "expected 6" in capsys.readouterr().err
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,60,90,0,45,0"]) == 2
    assert "joint 2" in capsys.readouterr().err
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-60,90,0,45,0", "--stiffness", "x"]) == 2
    assert main(["robot", str(tmp_path), "--q-deg=0,-60,90,0,45,0"]) == 2
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-60,90,0,45,0", "--force-n", "a,b"]) == 2
