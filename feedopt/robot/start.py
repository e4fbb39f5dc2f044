"""The robot's start configuration as a scenario gives it: the controller's axis values turned
into the URDF's joints and checked against their ranges."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel

__all__ = ["start_joints"]


def start_joints(robot: RobotModel, given: Sequence[float]) -> np.ndarray:
    """A scenario's ``robot.start_configuration_deg`` (``given``), the controller's axis
    values (robot.yaml ``controller.axes``), as the URDF's joints [rad]; InputError naming
    the axis for a wrong count or a value outside its joint's range."""
    if len(given) != robot.dof:
        raise InputError(f"robot.start_configuration_deg has {len(given)} values; robot "
                         f"{robot.name} has {robot.dof} joints ({', '.join(robot.joint_names)}): "
                         "give one value per joint, in the controller's axis values")
    q = robot.axis_convention.from_controller(given)
    out = np.flatnonzero((q < robot.q_lower) | (q > robot.q_upper))
    if out.size:
        j = int(out[0])
        unit = robot.axis_convention.unit[j]
        name = robot.axis_convention.unit_names()[j]
        raise InputError(
            f"robot.start_configuration_deg: axis {j + 1} (joint {robot.joint_names[j]}) = "
            f"{given[j]:g} {name} puts the joint at {q[j] / unit:.3f} {name} (URDF), outside its "
            f"range [{robot.q_lower[j] / unit:.1f}, {robot.q_upper[j] / unit:.1f}] {name}")
    return q
