"""The path IK's refinement split between this process and a forked child (two chunks or
more) gives the single-process result bit for bit, Jacobians and progress included."""

import numpy as np

from feedopt import background
from feedopt.robot import ik
from feedopt.robot.ik import solve_path_ik

from .helpers import Q_START_DEG, WORKPIECE_ORIGIN_M, triangle_wave


def _solve(kuka, monkeypatch, fork: bool):
    monkeypatch.setattr(ik, "_CHUNK", 97)  # 7 chunks for 601 samples
    monkeypatch.setattr(background, "fork_available",
                        lambda: fork and hasattr(__import__("os"), "fork"))
    n = 601
    p = triangle_wave(n) + WORKPIECE_ORIGIN_M
    z = np.tile([0.0, 0.0, 1.0], (n, 1))
    seen = []
    res = solve_path_ik(kuka, p, z, np.deg2rad(Q_START_DEG), jacobians=True,
                        progress=lambda done, total: seen.append((done, total)))
    return res, seen


def test_split_refinement_is_the_single_process_one(kuka, monkeypatch) -> None:
    alone, _ = _solve(kuka, monkeypatch, fork=False)
    forked, start = [], background.start
    monkeypatch.setattr(background, "start",
                        lambda f, what: forked.append(what) or start(f, what))
    split, seen = _solve(kuka, monkeypatch, fork=True)
    assert forked == ["refining the path IK"]
    for name in ("q", "condition_number", "position_error", "axis_error", "jacobian"):
        np.testing.assert_array_equal(getattr(split, name), getattr(alone, name))
    done = [d for d, _ in seen]
    assert done == sorted(done) and done[-1] == seen[-1][1]  # the bar ends full
