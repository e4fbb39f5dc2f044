"""The controller's orientation interpolation against the planned tool axis
(feedopt.export.orientation), in closed form."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.export.orientation import gap_notes, orientation_gap_deg


def _job(theta: np.ndarray, s: np.ndarray) -> SimpleNamespace:
    """Tool axes turned about y by ``theta(s)`` [rad] from +z."""
    axes = np.column_stack([np.sin(theta), np.zeros(s.size), np.cos(theta)])
    return SimpleNamespace(sample_tool_axes=axes, problem=SimpleNamespace(s=s))


def test_a_quadratic_turn_between_two_points_is_off_by_a_quarter_of_it():
    """theta = T s^2 over s in [0, 1], one move: the even turn is T s, off by T (s - s^2),
    largest T / 4 at s = 1/2; with a point at 1/2 too, T / 16 at s = 1/4 and 3/4."""
    s = np.linspace(0.0, 1.0, 2001)
    turn = math.radians(20.0)
    job = _job(turn * s**2, s)
    assert orientation_gap_deg(job, np.array([0.0, 1.0])) == pytest.approx(5.0, rel=1e-6)
    assert orientation_gap_deg(job, np.array([0.0, 0.5, 1.0])) == pytest.approx(1.25, rel=1e-6)


def test_an_even_turn_or_a_fixed_axis_has_no_gap():
    s = np.linspace(0.0, 2.0, 101)
    assert orientation_gap_deg(_job(0.3 * s, s), np.array([0.0, 2.0])) < 1e-9
    assert orientation_gap_deg(_job(np.zeros(s.size), s), np.array([0.0, 2.0])) is None
    assert gap_notes(None, "targets") == []
    assert "up to 1.25 deg" in gap_notes(1.25, "targets")[0]
