"""Where to put the workpiece so that the robot reaches the whole path.

When the IK finds a path sample unreachable, the message should say what would work. A few
workpiece positions are tried, from the scenario's toward the robot's base (the usual cause:
a part placed beyond the reach) and up and down: the path is placed there and the IK solved
on a coarse subset of its samples. The first position at which every tried sample is
reached is returned; None when none is (the caller says so: "none found").
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from feedopt.errors import InputError

#: Fractions of the workpiece's horizontal distance from the base that are tried, nearest
#: first, each at these height offsets [mm].
PULL_FRACTIONS = (0.9, 0.8, 0.7, 0.6, 0.5)
HEIGHT_OFFSETS_MM = (0.0, 200.0, -200.0)
#: Samples of the path tried per candidate (evenly spread, ends included).
TRIED_SAMPLES = 60


def candidate_positions(position_mm: np.ndarray) -> list[np.ndarray]:
    """Workpiece origins to try [mm], in order: pulled toward the base's z axis, then moved
    up or down."""
    p = np.asarray(position_mm, dtype=float)
    out = []
    for f in PULL_FRACTIONS:
        for dz in HEIGHT_OFFSETS_MM:
            out.append(np.array([p[0] * f, p[1] * f, p[2] + dz]))
    return out


def reaching_position(position_mm, reached: Callable[[np.ndarray], bool]
                      ) -> np.ndarray | None:
    """The first candidate workpiece origin [mm] at which ``reached(origin)`` holds."""
    for candidate in candidate_positions(np.asarray(position_mm, dtype=float)):
        try:
            if reached(candidate):
                return candidate
        except InputError:
            continue
    return None


def subset(n: int) -> np.ndarray:
    """Indices of at most :data:`TRIED_SAMPLES` samples spread over ``n`` (ends included)."""
    return np.unique(np.linspace(0, n - 1, min(n, TRIED_SAMPLES)).round().astype(int))


def suggest_workpiece_position(robot, position_w: np.ndarray, position_mm, rpy_deg,
                               tool_axis_w, q_start: np.ndarray, fix_rotation: bool) -> str:
    """The sentence to add to an unreachable-sample error: a ``workpiece.position_mm`` at
    which the IK reaches a spread of the path's samples (``position_w``: tool tips in the
    workpiece frame [m]), or that none of the tried positions does."""
    from feedopt.robot.frames import workpiece_transform
    from feedopt.robot.ik import solve_path_ik

    idx = subset(position_w.shape[0])
    axis_w = np.asarray(tool_axis_w, dtype=float)
    axis_w = axis_w / np.linalg.norm(axis_w)

    def reached(origin: np.ndarray) -> bool:
        transform = workpiece_transform(origin, rpy_deg)
        rot = transform[:3, :3]
        pts = position_w[idx] @ rot.T + transform[:3, 3]
        axes = np.broadcast_to(rot @ axis_w, pts.shape).copy()
        x_axes = np.broadcast_to(rot[:, 0], pts.shape).copy() if fix_rotation else None
        solve_path_ik(robot, pts, axes, q_start, x_axes=x_axes)
        return True

    found = reaching_position(position_mm, reached)
    tried = len(candidate_positions(np.asarray(position_mm, dtype=float)))
    if found is None:
        return (f"no workpiece position found that reaches the path: {tried} positions "
                "tried, toward the base and 200 mm up and down (robot.start_configuration_deg "
                "or workpiece.rpy_deg may help)")
    shown = ", ".join(f"{v:.0f}" for v in found)
    return (f"workpiece.position_mm: [{shown}] reaches {idx.size} samples spread over the "
            "whole path (IK checked there, not on every sample)")


@contextmanager
def suggesting_position(robot, position_w: np.ndarray, workpiece: Any, q_start: np.ndarray,
                        fix_rotation: bool, five_axis: bool = False) -> Iterator[None]:
    """An unreachable sample's error (:class:`feedopt.robot.ik.UnreachableError`) raised in
    the block, as an InputError with a workpiece position that reaches the path
    (:func:`suggest_workpiece_position`, or "none found"). ``workpiece`` is the scenario's
    section (``position_mm``, ``rpy_deg``, ``tool_axis``); ``five_axis``: the path's tool
    axis turns, the search (along ``tool_axis``) does not apply: no suggestion."""
    from feedopt.robot.ik import UnreachableError

    try:
        yield
    except UnreachableError as exc:
        if five_axis:  # the search places a tool along workpiece.tool_axis, not the path's
            raise InputError(f"{exc}; move the workpiece (no position is suggested for a path "
                             "whose tool axis turns)") from None
        hint = suggest_workpiece_position(
            robot, position_w, workpiece.position_mm, workpiece.rpy_deg, workpiece.tool_axis,
            q_start, fix_rotation)
        raise InputError(f"{exc}; {hint}") from None
