"""Per-segment measures of the predicted part against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.part.measure import flatness, segment_table
from feedopt.part.predict import PredictedPart


@settings(max_examples=50, deadline=None)
@given(st.floats(-1e-3, 1e-3), st.floats(-1e-3, 1e-3), st.floats(-1e-3, 1e-3),
       st.floats(1e-6, 1e-4))
def test_flatness_of_a_tilted_plane_with_one_bump(c0, ca, ch, bump):
    """A plane of any tilt is flat (0); one point raised by ``bump`` on a grid of 121 makes
    it ``bump * (1 - 1/121)``-ish: the LS plane moves by the bump's share, so the
    peak-to-valley is between (1 - 3/121) bump and bump."""
    a, h = np.meshgrid(np.linspace(0, 0.05, 11), np.linspace(0, 0.002, 11))
    a, h = a.ravel(), h.ravel()
    e = c0 + ca * a + ch * h
    assert flatness(a, h, e) == pytest.approx(0.0, abs=1e-15)
    e[60] += bump
    assert (1 - 3 / 121) * bump <= flatness(a, h, e) <= bump * (1 + 1e-9)


def _part(wall, floor, segment):
    b = wall.shape[0]
    return PredictedPart(sample=np.arange(b), s=np.arange(b) * 5e-4, segment=segment,
                         wall=wall, heights=np.tile([5e-4, 1e-3], (b, 1)), floor=floor,
                         offsets=np.array([-0.5, 0.0, 0.5]), sle_wall=wall,
                         sle_floor=floor[:, 1])


def test_segment_table_means_distances_and_depths():
    b = 10
    wall = np.full((b, 2, 2), np.nan)
    wall[:, 0] = -2e-5  # left wall overcut 0.02 mm everywhere
    wall[:5, 1] = 1e-5  # right wall only on the first segment, proud 0.01 mm
    floor = np.tile([-3e-5, -1e-5, -2e-5], (b, 1))
    rows = segment_table(_part(wall, floor, np.repeat([0, 1], 5)), ("line", "arc"),
                         np.full(b, 1.5e-3))
    first, second = rows
    assert first["segment"] == 1 and second["segment"] == 2
    assert first["left_wall"]["mean_distance_mm"] == pytest.approx(0.02)
    assert first["left_wall"]["mean_error_mm"] == pytest.approx(-0.02)
    assert first["left_wall"]["flatness_mm"] == pytest.approx(0.0, abs=1e-12)
    assert first["right_wall"]["mean_error_mm"] == pytest.approx(0.01)
    assert second["right_wall"] is None and second["left_wall"]["flatness_mm"] is None
    assert first["floor"]["depth_mean_mm"] == pytest.approx(-1.52)
    assert first["floor"]["depth_std_mm"] == pytest.approx(np.std([-3e-2, -1e-2, -2e-2]))


def test_a_long_program_shows_its_longest_segments_only():
    from feedopt.part.measure import MAX_SEGMENT_ROWS, shown_segments

    rng = np.random.default_rng(3)
    counts = rng.integers(1, 50, size=3 * MAX_SEGMENT_ROWS)
    segment = np.repeat(np.arange(counts.size), counts)
    shown = shown_segments(segment)
    assert shown.size == MAX_SEGMENT_ROWS and np.all(np.diff(shown) > 0)
    # every segment left out has at most as many dexels as the fewest shown
    left_out = np.setdiff1d(np.arange(counts.size), shown)
    assert counts[left_out].max() <= counts[shown].min()
    assert np.array_equal(shown_segments(segment[segment < 10]), np.arange(10))
