"""Dense extrema of a trajectory chunk by chunk against all points at once."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import PPoly

from feedopt.schedule import polynomial
from feedopt.schedule.checks import dense_extrema
from feedopt.schedule.polynomial import sample_piece_chunks, sample_pieces
from feedopt.schedule.trajectory import Trajectory


def _random_trajectory(pieces: int, seed: int) -> Trajectory:
    """A quintic s(t) with random pieces (not a plausible motion: extremes everywhere,
    a negative feed somewhere)."""
    rng = np.random.default_rng(seed)
    x = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.2, pieces))])
    c = rng.normal(size=(6, pieces)) * 1e-3
    return Trajectory(law="test", timing=PPoly(c, x))


@pytest.mark.parametrize("chunk", [1, 7, 1 << 15])
def test_chunks_join_to_the_whole_sampling(chunk: int) -> None:
    x = np.cumsum(np.random.default_rng(2).uniform(0.1, 1.0, 40))
    joined = np.concatenate(list(sample_piece_chunks(x, 9, pieces=chunk)))
    np.testing.assert_array_equal(joined, sample_pieces(x, 9))


@pytest.mark.parametrize("chunk", [1, 5, 1 << 15])
def test_extrema_are_those_of_every_point_at_once(chunk: int, monkeypatch) -> None:
    monkeypatch.setattr(polynomial, "PIECES_PER_CHUNK", chunk)
    traj = _random_trajectory(37, 4)
    # the reference: every point at once, numpy's first argmax / argmin
    m = traj.at(sample_pieces(traj.timing.x, 9))
    got = dense_extrema(traj)
    for extreme, values, pick in ((got.max_accel, np.abs(m.sddot), np.argmax),
                                  (got.max_jerk, np.abs(m.sdddot), np.argmax),
                                  (got.min_feed, m.sdot, np.argmin)):
        i = int(pick(values))
        assert (extreme.value, extreme.t, extreme.s) == (values[i], m.t[i], m.s[i])
    assert got.max_feed == np.max(m.sdot)
    assert got.min_feed.value < 0  # the random law reverses: found


def test_ties_report_the_first_point(monkeypatch) -> None:
    """A constant acceleration is largest everywhere: the first point is reported, whatever
    the chunks."""
    monkeypatch.setattr(polynomial, "PIECES_PER_CHUNK", 2)
    x = np.linspace(0.0, 1.0, 9)
    c = np.zeros((3, 8))
    c[0], c[1] = 0.5, 0.1 + x[:-1]  # s = 0.5 (t - x_i)^2 + v_i (t - x_i): sddot = 1
    traj = Trajectory(law="test", timing=PPoly(c, x), continuity=1)
    got = dense_extrema(traj)
    assert got.max_accel.value == 1.0 and got.max_accel.t == 0.0


@pytest.mark.parametrize("chunk", [3, 1 << 15])
def test_a_nan_is_the_extreme_as_in_one_pass(chunk: int, monkeypatch) -> None:
    """A NaN coefficient in a late piece: every extreme is NaN, as numpy's over all points."""
    monkeypatch.setattr(polynomial, "PIECES_PER_CHUNK", chunk)
    traj = _random_trajectory(10, 6)
    traj.timing.c[2, 8] = np.nan
    m = traj.at(sample_pieces(traj.timing.x, 9))
    got = dense_extrema(traj)
    i = int(np.argmax(np.abs(m.sddot)))  # numpy: the first NaN
    assert np.isnan(got.max_accel.value) and got.max_accel.t == m.t[i]
    assert np.isnan(got.max_jerk.value) and np.isnan(got.min_feed.value)
    assert np.isnan(got.max_feed)
