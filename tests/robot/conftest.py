"""Shared fixtures of the robot-stage tests."""

from __future__ import annotations

import pytest

from feedopt.robot.model import RobotModel, load_robot
from tests.robot.helpers import KUKA_DIR, UR10_DIR


@pytest.fixture(scope="session")
def kuka() -> RobotModel:
    return load_robot(KUKA_DIR)


@pytest.fixture(scope="session")
def ur10() -> RobotModel:
    return load_robot(UR10_DIR)
