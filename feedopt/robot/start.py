"""The robot's start configuration as a scenario gives it: the controller's axis values turned
into the URDF's joints and checked against their ranges."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel, forward_kinematics

__all__ = ["five_axis_x_axes", "start_joints"]


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


def five_axis_x_axes(robot: RobotModel, q_start: np.ndarray, tool_axes: np.ndarray
                     ) -> np.ndarray | None:
    """Tool x axes (n, 3) for a path whose tool axis turns (a five-axis path): the x axis of
    the start configuration's TCP projected across each sample's tool axis; None when the
    tool axis does not turn (the 5-DoF IK keeps the rotation about it free).

    The 5-DoF nearest IK takes minimum-norm steps, and where the tool axis turns back and
    forth (a zig-zag with a lead angle) those steps add up to a rotation about the tool axis
    (the holonomy of the axis's path on the sphere): 118 to 350 deg of the last joint over the
    ball-nose raster of ``scenarios/five_axis_ball.yaml``, depending on the blends. A
    reference that depends on the tool axis alone cannot drift; ``robot.redundancy: optimise``
    still chooses the rotation about it."""
    axes = np.asarray(tool_axes, dtype=float)
    if np.ptp(axes, axis=0).max() <= 1e-12:
        return None
    x0 = forward_kinematics(robot, np.asarray(q_start, dtype=float)[None])[0, :3, 0]
    x = x0 - np.einsum("ij,j->i", axes, x0)[:, None] * axes
    norm = np.linalg.norm(x, axis=1)
    if np.any(norm < 0.2):
        k = int(np.argmin(norm))
        raise InputError(f"the tool axis at sample {k} turns to within "
                         f"{np.degrees(np.arcsin(norm[k])):.1f} deg of the start pose's tool x "
                         "axis, about which the rotation about the tool axis is measured: turn "
                         "the start configuration's last axis by 90 deg or set "
                         "robot.fix_tool_rotation: true (the workpiece's x)")
    return x / norm[:, None]

