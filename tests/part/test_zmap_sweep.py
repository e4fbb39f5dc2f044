"""The predicted part against the stock model (issue 33, "must show"): a straight slot cut by a
tool displaced by a known deflection D, swept through the Z-map (feedopt.process.stock), has
its walls at the nominal plus the envelope's predicted error and its floor at the nominal plus
D.z, within the Z-map's cell."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.part.envelope import DeflectionTable, SweptTool, floor_envelope, wall_envelope
from feedopt.process.stock import FlatEndMill, ZMap, sweep

R = 9.525e-3
CELL = 0.05e-3
DEPTH = 1.5e-3


@pytest.mark.parametrize("d", [(0.0, 0.12e-3, -0.03e-3), (0.05e-3, -0.21e-3, 0.02e-3)])
def test_zmap_walls_and_floor_of_a_displaced_tool_match_the_envelope(d):
    d = np.asarray(d)
    s = np.arange(0.0, 40e-3 + 1e-12, 0.1e-3)
    centres = np.column_stack([s, np.zeros_like(s), np.full_like(s, -DEPTH)])
    frames = np.tile(np.eye(3), (s.size, 1, 1))
    tool = SweptTool(centres=centres, frames=frames, s=s, cutting=np.ones(s.size, bool),
                     radius=R, pitch=math.pi, lag_rate=0.0)
    table = DeflectionTable(0, np.broadcast_to(d, (s.size, 8, 3)).copy(), math.pi)
    dexels = np.flatnonzero((s > 15e-3) & (s < 25e-3))
    heights = np.full((dexels.size, 1), DEPTH / 2)
    left = wall_envelope(tool, table, dexels, 1, heights, reach=3e-3)[:, 0]
    right = wall_envelope(tool, table, dexels, -1, heights, reach=3e-3)[:, 0]
    floor = floor_envelope(tool, table, dexels, np.array([0.0]))[:, 0]

    stock = ZMap.box(-15e-3, 55e-3, -15e-3, 15e-3, -10e-3, 0.0, cell=CELL)
    sweep(stock, FlatEndMill(R, 20e-3), centres + d, np.tile([1.0, 0, 0], (s.size, 1)))
    x0, y0 = stock.origin
    ys = y0 + (np.arange(stock.heights.shape[1]) + 0.5) * CELL
    for i, x in zip(dexels[::10], s[dexels[::10]], strict=True):
        col = stock.heights[int((x - x0) / CELL)]
        cut = col < -1e-6
        top_cut, low_cut = ys[cut].max(), ys[cut].min()
        k = np.searchsorted(dexels, i)
        left_wall, right_wall = R - left[k], -R + right[k]  # material left moves the wall in
        assert top_cut <= left_wall + 1e-9 and left_wall <= top_cut + CELL + 1e-9
        assert low_cut >= right_wall - 1e-9 and right_wall >= low_cut - CELL - 1e-9
        assert float(col[np.argmin(np.abs(ys - d[1]))]) == pytest.approx(-DEPTH + floor[k],
                                                                          abs=1e-8)
    assert left == pytest.approx(np.full(dexels.size, -d[1]), abs=1e-10)  # first order in |D| / R
    assert right == pytest.approx(np.full(dexels.size, d[1]), abs=1e-10)  # first order in |D| / R
    assert floor == pytest.approx(np.full(dexels.size, d[2]), abs=1e-10)  # first order in |D| / R
