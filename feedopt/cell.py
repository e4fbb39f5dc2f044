"""The cell: where the workpiece and its path are in the robot's base frame.

The path is planned in the workpiece frame W (scenario ``workpiece``: origin, roll-pitch-yaw,
tool axis in W); the robot and the force model need it in the base frame B. This is computed
once per run (:func:`place_path`) and every stage uses the same :class:`Placement`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.geometry.path import PathPoints
from feedopt.robot.frames import workpiece_transform
from feedopt.schedule.deflection import feed_frames
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class Placement:
    """The sampled path in the base frame.

    transform : (4, 4) W -> B [m]; positions (n, 3) TCP positions [m]; tool_axes (n, 3) unit,
    from the tool tip into the spindle; tangents (n, 3) unit path tangents; frames (n, 3, 3)
    force-model frame -> B (x feed, z tool axis, Altintas' frame).
    """

    transform: np.ndarray
    positions: np.ndarray
    tool_axes: np.ndarray
    tangents: np.ndarray
    frames: np.ndarray

    def to_base(self, points_w: np.ndarray) -> np.ndarray:
        """Points (m, 3) of the workpiece frame in the base frame [m]."""
        return points_w @ self.transform[:3, :3].T + self.transform[:3, 3]


def place_path(samples: PathPoints, position_mm, rpy_deg, tool_axis_w=None,
               air: np.ndarray | None = None) -> Placement:
    """Put the path samples into the base frame; InputError when the tool axis is zero or the
    path runs along it somewhere (milling needs a feed across the tool axis).

    ``air`` (n,) marks samples that do not cut (a program's rapids, plunges and retracts):
    they may run along the tool axis; their force-model frame then takes the workpiece x
    axis as its feed direction (no force acts there)."""
    transform = workpiece_transform(position_mm, rpy_deg)
    rot = transform[:3, :3]
    positions = samples.position @ rot.T + transform[:3, 3]
    axis = _tool_axes(samples, rot, tool_axis_w)
    tangents = samples.tangent @ rot.T
    along = np.abs(np.sum(tangents * axis, axis=1))
    frame_tangents = tangents
    if air is not None:
        vertical = air & (along > 1 - 1e-6)
        if vertical.any():
            x = rot[:, 0] if abs(rot[:, 0] @ axis[0]) < 0.9 else rot[:, 1]
            frame_tangents = np.where(vertical[:, None], x, tangents)
        along = np.where(air, 0.0, along)
    if np.any(along > 1 - 1e-6):
        i = int(np.argmax(along))
        raise InputError(f"the path runs along the tool axis at sample {i} "
                         f"(s = {samples.s[i] / MM:.3f} mm): milling needs a feed direction "
                         "across the tool axis")
    return Placement(transform=transform, positions=positions, tool_axes=axis,
                     tangents=tangents, frames=feed_frames(frame_tangents, axis))


def _tool_axes(samples: PathPoints, rot: np.ndarray, tool_axis_w) -> np.ndarray:
    """(n, 3) unit tool axes in the base frame: a five-axis path's own (``samples.axis``,
    then ``workpiece.tool_axis`` must not be given: None), else ``tool_axis_w`` (None: +z)."""
    axis_w = np.asarray((0.0, 0.0, 1.0) if tool_axis_w is None else tool_axis_w, dtype=float)
    if samples.axis is not None:
        if tool_axis_w is not None:
            raise InputError("workpiece.tool_axis is for three-axis paths: this path's tool "
                             "vectors give the tool axis at every point (remove tool_axis)")
        return samples.axis @ rot.T
    if np.linalg.norm(axis_w) < 1e-12:
        raise InputError("workpiece.tool_axis must be a non-zero vector")
    return np.broadcast_to(rot @ (axis_w / np.linalg.norm(axis_w)),
                           samples.position.shape).copy()


def fixed_x_axes(placement: Placement, fix_tool_rotation: bool) -> np.ndarray | None:
    """Prescribed tool x axes (``robot.fix_tool_rotation``: the workpiece's x along the whole
    path) or None (5-DoF, the nearest IK chooses the rotation about the tool axis)."""
    if not fix_tool_rotation:
        return None
    return np.broadcast_to(placement.transform[:3, 0], placement.positions.shape).copy()
