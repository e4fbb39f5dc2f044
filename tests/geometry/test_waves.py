"""Thesis test paths: layout of the triangle and square waves and the chapter-4 line."""

import numpy as np

from feedopt.geometry import waves


def test_triangle_wave_layout():
    w = waves.triangle_wave()
    assert w.shape == (7, 3)
    np.testing.assert_allclose(w[0], 0)
    np.testing.assert_allclose(w[-1], [0.3048, 0, 0])
    np.testing.assert_allclose(w[1::2, 1], 0.0762)  # peaks
    np.testing.assert_allclose(w[0::2, 1], 0.0)  # base line
    dy = np.diff(w[:, 1])
    assert np.all(dy[0::2] > 0) and np.all(dy[1::2] < 0)  # up, down, up, ...
    assert np.all(np.diff(w[:, 0]) > 0)


def test_square_wave_layout():
    w = waves.square_wave()
    assert w.shape == (14, 3)
    np.testing.assert_allclose(w[[0, -1]], [[0, 0, 0], [0.3048, 0, 0]])
    d = np.diff(w, axis=0)
    # alternating horizontal and vertical lines, every corner 90 deg
    assert np.all((np.abs(d[:, 0]) < 1e-15) ^ (np.abs(d[:, 1]) < 1e-15))
    assert set(np.round(w[:, 1], 12)) == {0.0, 0.0762}
    np.testing.assert_allclose(np.abs(d[1::2, 1]), 0.0762)


def test_straight_line_defaults_are_chapter_4():
    w = waves.straight_line()
    np.testing.assert_allclose(w, [[0, 0, 0], [0.2032, 0.009525, 0]])
    np.testing.assert_allclose(waves.straight_line((1, 2, 3), (4, 5, 6))[1], [4, 5, 6])
