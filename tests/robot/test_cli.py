"""``feedopt robot`` command."""

from __future__ import annotations

import numpy as np

from feedopt.cli import main
from feedopt.robot.model import forward_kinematics
from feedopt.robot.stiffness import deflection, translational_compliance
from feedopt.units import MM
from tests.robot.helpers import KUKA_DIR, Q_START_DEG, UR10_DIR


def test_robot_command_prints_pose_stiffness_and_deflection(capsys, kuka):
    q = ",".join(f"{v}" for v in Q_START_DEG)
    assert main(["robot", str(KUKA_DIR), f"--q-deg={q}", "--force-n", "100,-50,20"]) == 0
    out = capsys.readouterr().out
    pose = forward_kinematics(kuka, np.deg2rad(Q_START_DEG)) / MM
    assert f"X={pose[0, 3]:.3f} Y={pose[1, 3]:.3f} Z={pose[2, 3]:.3f} mm" in out
    assert "principal stiffnesses" in out and out.count(" along [") == 3
    c = translational_compliance(kuka, np.deg2rad(Q_START_DEG)[None], "dpp")
    d = deflection(c, np.array([[100.0, -50.0, 20.0]]))[0] / MM
    assert f"dx={d[0]:.5f} dy={d[1]:.5f} dz={d[2]:.5f}" in out


def test_robot_command_second_robot_and_cp(capsys):
    assert main(["robot", str(UR10_DIR), "--q-deg=0,-90,90,-90,-90,0", "--stiffness", "cp"]) == 0
    assert "stiffness set: cp" in capsys.readouterr().out


def test_robot_command_bad_input_exit_2(capsys, tmp_path):
    assert main(["robot", str(KUKA_DIR), "--q-deg=1,2,3"]) == 2
    assert "expected 6" in capsys.readouterr().err
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,60,90,0,45,0"]) == 2
    assert "axis 2 (joint joint_a2)" in capsys.readouterr().err
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-60,90,0,45,0", "--stiffness", "x"]) == 2
    assert main(["robot", str(tmp_path), "--q-deg=0,-60,90,0,45,0"]) == 2
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-60,90,0,45,0", "--force-n", "a,b"]) == 2


def test_robot_command_warns_at_exact_wrist_singularity(capsys):
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-65,108,0,0,0", "--force-n", "0,100,0"]) == 0
    captured = capsys.readouterr()
    cond = float(captured.out.split("condition number (1 m length scale): ")[1].split()[0])
    assert cond > 1e12  # rounding noise of an exactly singular Jacobian
    assert "deflection [mm]" in captured.out and "principal stiffnesses" in captured.out
    err = captured.err
    assert err.startswith("feedopt robot: warning: singular pose, wrist singularity: Jacobian "
                          f"condition number {cond:.3g} > 1e+12; joints 4, 6 can move together")
    assert "(-0.707 q4 +0.707 q6)" in err or "(+0.707 q4 -0.707 q6)" in err
    assert "rounding noise" in err
    assert "feedopt run refuses path samples whose condition number exceeds 100" in err
    assert err.count("\n") == 1


def test_robot_command_warns_near_wrist_singularity(capsys):
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-65,108,0,1,0"]) == 0
    captured = capsys.readouterr()
    assert "condition number (1 m length scale): 316.57" in captured.out
    err = captured.err
    assert err.startswith("feedopt robot: warning: near-singular pose, wrist singularity: "
                          "Jacobian condition number 317 > 100; joints 4, 6 can move together")
    assert "rounding noise" not in err


def test_robot_command_names_an_arm_singularity(capsys):
    # A3 = -atan(55 / 1025): forearm and wrist centre in line with the upper arm (elbow)
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-65,-3.0714621,0,47,0"]) == 0
    err = capsys.readouterr().err
    assert "near-singular pose, arm (shoulder/elbow) singularity" in err
    assert "joints 2, 3, 5 can move together" in err


def test_robot_command_quiet_away_from_singularities(capsys):
    q = ",".join(f"{v}" for v in Q_START_DEG)
    assert main(["robot", str(KUKA_DIR), f"--q-deg={q}"]) == 0
    assert capsys.readouterr().err == ""
    # just above the threshold in A5 warns, just below does not (cond ~ 316 / A5 [deg])
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-65,108,0,3.3,0"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["robot", str(KUKA_DIR), "--q-deg=0,-65,108,0,3.0,0"]) == 0
    assert "near-singular pose" in capsys.readouterr().err


def test_near_singular_threshold_is_the_path_ik_limit():
    from feedopt.commands.robot import NEAR_SINGULAR
    from feedopt.robot.ik import IKOptions

    assert NEAR_SINGULAR == IKOptions().max_condition == 100.0
