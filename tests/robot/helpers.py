"""Constants and path helpers shared by the robot-stage tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROBOTS = Path(__file__).resolve().parents[2] / "robots"
KUKA_DIR = ROBOTS / "kuka_kr500_3"
UR10_DIR = ROBOTS / "ur10"

# Thesis Table A.3: stiffness-calibration configurations of the KR500-3 [deg].
TABLE_A3_DEG = np.array(
    [
        [19.67, -52.14, 117.9, 11.86, -66.08, -4.84],
        [26.35, -32.54, 123.49, -8.99, -90.81, -0.15],
        [58.28, -10.5, 105.98, 42.39, -115.04, -2.57],
        [44.71, -70.81, 58.16, 138.51, -41.63, -125.84],
        [-23.13, -85.41, 80.84, 70.31, 83.63, -71.78],
        [2.39, -34.82, 69.97, 115.13, 72.1, 176.98],
        [25.21, -55.7, 130.03, 169.88, 72.17, -179.78],
        [42.99, -40.39, 97.42, -177.38, 72.1, -179.8],
        [42.99, -57.91, 110.04, -155.79, 51.1, -179.83],
        [28.12, -55.4, 84.06, -167.6, 27.07, -179.85],
    ]
)

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
