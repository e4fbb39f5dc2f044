"""Write kr500_3_load_tests.csv: SYNTHETIC load tests of the KR500-3, not measurements.

The poses are the thesis's stiffness-calibration configurations (Table A.3); at each, forces of
1000 N along base +x, +y and -z act 200 mm from the TCP along the tool frame's x axis (the
loads of ``feedopt calibrate-stiffness --suggest``). The TCP displacement and rotation are the
six-parameter model (Eq. 3.19) with the thesis's DPP stiffness (Table 3.4: 2.86 2.36 1.67 0.24
0.16 0.14 MNm/rad) plus Gaussian noise of 0.01 mm and 0.005 mrad (seed 2024), about what a
laser tracker with a 6-DoF probe gives. ``feedopt calibrate-stiffness`` should give Table 3.4's
DPP values back within its standard errors. Run from the repository root:

    .venv/bin/python scenarios/calibration/make_kr500_3_load_tests.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feedopt.commands.calibrate_stiffness import (
    DISPLACEMENT_COLUMNS,
    FORCE_COLUMNS,
    MOMENT_COLUMNS,
    ROTATION_COLUMNS,
    joint_columns,
)
from feedopt.robot.identification import load_wrenches
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.robot.stiffness import compliance

HERE = Path(__file__).resolve().parent
ROBOT = HERE.parents[1] / "robots" / "kuka_kr500_3"
TABLE_A3_DEG = np.loadtxt(HERE / "thesis_table_a3_poses.csv", delimiter=",", comments="#",
                          skiprows=2)  # thesis Table A.3 [deg]
DPP_MNM = np.array([2.86, 2.36, 1.67, 0.24, 0.16, 0.14])
NOISE_MM, NOISE_MRAD, SEED = 0.01, 0.005, 2024


def main() -> None:
    robot = load_robot(ROBOT)
    q = np.deg2rad(TABLE_A3_DEG)
    wrench = load_wrenches(forward_kinematics(robot, q), 1000.0, 0.2)  # (10, 3, 6)
    qq = np.repeat(q, wrench.shape[1], axis=0)
    ww = wrench.reshape(-1, 6)
    motion = np.einsum("nij,nj->ni", compliance(robot, qq, DPP_MNM * 1e6), ww)  # [m, rad]
    rng = np.random.default_rng(SEED)
    d_mm = motion[:, :3] * 1e3 + rng.normal(0.0, NOISE_MM, (len(qq), 3))
    r_mrad = motion[:, 3:] * 1e3 + rng.normal(0.0, NOISE_MRAD, (len(qq), 3))
    cols = (joint_columns(6) + FORCE_COLUMNS + MOMENT_COLUMNS + DISPLACEMENT_COLUMNS
            + ROTATION_COLUMNS)
    lines = [
        "# SYNTHETIC load tests of the KUKA KR500-3 (not measurements), written by",
        "# make_kr500_3_load_tests.py: thesis Table A.3 poses, 1000 N at a 200 mm lever, TCP",
        "# motion from Table 3.4 DPP stiffness (Eq. 3.19) + noise 0.01 mm / 0.005 mrad.",
        ",".join(cols),
    ]
    for i in range(len(qq)):
        values = np.concatenate([np.rad2deg(qq[i]), ww[i], d_mm[i], r_mrad[i]])
        lines.append(",".join(f"{v + 0.0:.6g}" for v in values))
    (HERE / "kr500_3_load_tests.csv").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
