"""Constants and path helpers shared by the robot-stage tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROBOTS = Path(__file__).resolve().parents[2] / "robots"
KUKA_DIR = ROBOTS / "kuka_kr500_3"
UR10_DIR = ROBOTS / "ur10"

# Thesis Table A.3: stiffness-calibration configurations of the KR500-3 [deg] (one copy, in
# scenarios/calibration, also read by its example-data script).
TABLE_A3_DEG = np.loadtxt(ROBOTS.parent / "scenarios" / "calibration" / "thesis_table_a3_poses.csv",
                          delimiter=",", comments="#", skiprows=2)

# Recommended scenario placement (see the robot-stage report): workpiece frame W aligned
# with the base, origin at (1747.6, -38.1, 800) mm, so the 304.8 x 76.2 mm triangle wave is
# centred at x = 1.9 m, y = 0, z = 0.8 m; tool axis vertical.
WORKPIECE_ORIGIN_M = np.array([1.7476, -0.0381, 0.8])
Q_START_DEG = np.array([1.249, -65.651, 108.658, 0.0, 46.993, 0.0])


def triangle_wave(n: int, length: float = 0.3048, height: float = 0.0762, waves: int = 3):
    """Sharp-cornered triangle wave in the workpiece XY plane, (n, 3) [m]."""
    s = np.linspace(0.0, 1.0, n)
    phase = (s * waves) % 1.0
    phase[-1] = 1.0
    y = height * (1.0 - np.abs(2.0 * phase - 1.0))
    return np.stack([length * s, y, np.zeros(n)], axis=1)
