"""An unreachable path: a workpiece position that reaches it, or 'none found'."""

from pathlib import Path

import numpy as np
import pytest

from feedopt.cell import workpiece_transform
from feedopt.robot.ik import UnreachableError, solve_path_ik
from feedopt.robot.model import load_robot
from feedopt.robot.placement_search import (
    candidate_positions,
    subset,
    suggest_workpiece_position,
)
from feedopt.units import MM

ROBOT = Path(__file__).resolve().parents[2] / "robots" / "kuka_kr500_3"
Q0 = np.deg2rad([9.728, -64.745, 107.062, 0.0, 47.682, 0.0])


@pytest.fixture(scope="module")
def robot():
    return load_robot(ROBOT)


def _square_mm(size: float = 200.0) -> np.ndarray:
    t = np.linspace(0.0, 1.0, 50)
    edge = np.stack([t * size, np.zeros_like(t), np.zeros_like(t)], axis=1)
    return np.vstack([edge, edge[:, [1, 0, 2]] + [size, 0, 0]]) * MM


def test_far_workpiece_gets_a_position_the_ik_reaches(robot):
    path = _square_mm()
    far = [3300.0, -300.0, 800.0]  # beyond a KR 500's 2.8 m reach
    with pytest.raises(UnreachableError):
        solve_path_ik(robot, path + np.array(far) * MM, np.tile([0, 0, -1.0], (100, 1)), Q0)
    text = suggest_workpiece_position(robot, path, far, [0, 0, 0], [0, 0, 1], Q0, False)
    assert text.startswith("workpiece.position_mm: [")
    found = np.array([float(v) for v in text.split("[")[1].split("]")[0].split(",")])
    # independent check: the IK reaches every sample of the path placed there
    tr = workpiece_transform(found, [0, 0, 0])
    pts = path @ tr[:3, :3].T + tr[:3, 3]
    axes = np.broadcast_to(tr[:3, :3] @ [0, 0, 1.0], pts.shape)
    ik = solve_path_ik(robot, pts, axes, Q0)
    assert np.isfinite(ik.q).all()
    assert any(np.allclose(found, c) for c in candidate_positions(np.array(far)))


def test_hopeless_position_says_none_found(robot):
    text = suggest_workpiece_position(robot, _square_mm(), [40000.0, 0.0, 800.0], [0, 0, 0],
                                      [0, 0, 1], Q0, False)
    assert text.startswith("no workpiece position found") and "15 positions" in text


def test_subset_spreads_and_keeps_ends():
    idx = subset(1000)
    assert idx[0] == 0 and idx[-1] == 999 and idx.size == 60
    assert subset(5).tolist() == [0, 1, 2, 3, 4]
