"""The rotation about a turning tool axis does not drift (issue 35). A zig-zag raster with a
10 deg lead (the tool leans into the feed, so the axis flips from one side to the other at
every link) makes the 5-DoF nearest IK's minimum-norm steps add up to a rotation about the
tool axis, pass after pass; with :func:`five_axis_x_axes` the rotation depends on the tool axis
alone, so the joints come back to the same values wherever the axis does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.robot.stage import TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes, start_joints
from tests.conftest import ROOT

START = [9.728, -64.745, 107.062, 0.0, 47.682, 0.0]
PASSES, PER_PASS, LINK = 12, 301, 38


def _axis(direction: int) -> np.ndarray:
    lead, tilt = math.radians(10.0), math.radians(3.0)
    f, n = np.array([direction, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    return math.sin(lead) * f + math.cos(lead) * (math.cos(tilt) * n
                                                   + math.sin(tilt) * np.cross(n, f))


@pytest.fixture(scope="module")
def task():
    robot = load_robot(ROOT / "robots" / "kuka_kr500_3")
    pts, axes = [], []
    for p in range(PASSES):
        d = 1 if p % 2 == 0 else -1
        for x in np.linspace(0.0, 0.06, PER_PASS)[::d]:
            if pts and not axes[-1] @ _axis(d) > 0.999:  # the link: turn over the step-over
                a, b = np.array(pts[-1]), np.array([1.72 + x, -0.3 + 0.001 * p, 0.8])
                for t in np.linspace(0.0, 1.0, LINK + 2)[1:-1]:
                    v = (1 - t) * axes[-1] + t * _axis(d)
                    pts.append(a + t * (b - a))
                    axes.append(v / np.linalg.norm(v))
            pts.append([1.72 + x, -0.3 + 0.001 * p, 0.8])
            axes.append(_axis(d))
    p, a = np.array(pts), np.array(axes)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    return robot, TcpPath(s, p, a), start_joints(robot, START)


def _pass_starts() -> np.ndarray:
    return np.arange(PASSES) * (PER_PASS + LINK)


def test_the_nearest_ik_drifts_and_the_reference_does_not(task):
    robot, path, q0 = task
    free = robot_along_path(robot, path, q0, "dpp").ik.q
    x = five_axis_x_axes(robot, q0, path.tool_axes)
    held = robot_along_path(robot, TcpPath(path.s, path.positions, path.tool_axes, x_axes=x),
                            q0, "dpp").ik.q
    even = _pass_starts()[::2]  # the same tool axis at the start of every even pass
    assert abs(np.degrees(free[even[-1], 5] - free[even[0], 5])) > 5.0  # the test can fail
    # with the reference only the position changes between them: the wrist comes back
    assert np.degrees(np.ptp(held[even, 3:], axis=0)).max() < 0.5
    # the held poses follow the path's axes (FK, not the IK's own residual)
    pose = forward_kinematics(robot, held)
    dot = np.clip(np.einsum("ij,ij->i", pose[:, :3, 2], path.tool_axes), -1.0, 1.0)
    assert np.degrees(np.arccos(dot)).max() < 1e-3
    assert np.abs(np.einsum("ij,ij->i", x, path.tool_axes)).max() < 1e-12


def test_a_fixed_axis_keeps_the_free_rotation_and_a_grazing_reference_is_refused(task):
    robot, path, q0 = task
    assert five_axis_x_axes(robot, q0, np.tile([0.0, 0.0, 1.0], (5, 1))) is None
    x0 = forward_kinematics(robot, q0[None])[0, :3, 0]
    axes = np.vstack([path.tool_axes[:2], x0])
    with pytest.raises(InputError, match="sample 2 turns to within"):
        five_axis_x_axes(robot, q0, axes)
