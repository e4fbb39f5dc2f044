"""Slice sums in O(1) per tooth and angle (force_sums) against a loop over every slice."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.process import CuttingCoefficients, Engagement, Tool
from feedopt.process.force_sums import Flutes, in_cut_sum_blocks, in_cut_sums
from feedopt.process.forces import critical_angles, milling_forces_at

TWO_PI = 2.0 * math.pi
K = CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3)


def reference_sums(tool: Tool, entry, exit_, depth, angles, slices: int) -> np.ndarray:
    """[1, sin, cos, sin cos, sin^2] of theta over the teeth x slices in the cut, (5, n, k).

    One tooth and one slice at a time. The in-cut test is the model's definition (thesis
    Algorithm 1 as :func:`milling_forces` evaluates it): slice j of tooth t has the angle
    ``theta = mod((phi + t p) - lag_j, 2 pi)`` with ``lag_j = (2 tan(beta) / D) ((j + 1/2) da)``
    and cuts while ``entry <= theta < exit``; written with these floating-point operations so
    that an angle exactly at a boundary is classified as the model classifies it.
    """
    rate = 2.0 * math.tan(tool.helix) / tool.diameter
    da = np.asarray(depth, dtype=float) / slices
    out = np.zeros((5,) + angles.shape)
    for t in range(tool.teeth):
        psi = angles + t * tool.pitch
        for j in range(slices):
            lag = rate * ((j + 0.5) * da)
            theta = np.mod(psi - lag[:, None], TWO_PI)
            cut = (theta >= entry[:, None]) & (theta < exit_[:, None])
            s, c = np.sin(theta), np.cos(theta)
            for q, value in enumerate((np.ones_like(s), s, c, s * c, s * s)):
                out[q] += np.where(cut, value, 0.0)
    return out


def _flutes(tool: Tool, slices: int) -> Flutes:
    return Flutes(tool.teeth, tool.pitch, 2.0 * math.tan(tool.helix) / tool.diameter, slices)


def _check(tool, entry, exit_, depth, angles, slices, max_rows=None):
    """Same slices in the cut (exactly) and the same sums to 1e-12 of the largest possible
    sum (N L, every slice of every tooth in the cut)."""
    entry, exit_ = np.asarray(entry, dtype=float), np.asarray(exit_, dtype=float)
    depth = np.broadcast_to(np.asarray(depth, dtype=float), entry.shape)
    angles = np.asarray(angles, dtype=float)
    ref = reference_sums(tool, entry, exit_, depth, angles, slices)
    height = depth / slices
    if max_rows is None:
        got = in_cut_sums(angles, entry, exit_, height, _flutes(tool, slices))
    else:
        got = np.empty_like(ref)
        for rows, b in in_cut_sum_blocks(angles, entry, exit_, height, _flutes(tool, slices),
                                         max_rows):
            got[:, rows] = b
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_allclose(got[1:], ref[1:], rtol=0, atol=1e-12 * tool.teeth * slices)
    return ref


def _tool(helix_deg=30.0, teeth=2, diameter=6e-3, flute=30e-3) -> Tool:
    return Tool("t", diameter, teeth, math.radians(helix_deg), flute)


def _cases(n_random: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """Entry/exit pairs: slot, up and down milling, no cut, a sliver, random intervals."""
    fixed = [(0.0, math.pi), (0.0, 1.0), (2.0, math.pi), (1.2, 1.2), (0.7, 0.7 + 1e-12),
             (0.0, 0.0), (math.pi, math.pi), (0.0, 1e-9)]
    e = rng.uniform(0.0, math.pi, n_random)
    x = rng.uniform(e, math.pi)
    entry = np.r_[[f[0] for f in fixed], e]
    exit_ = np.r_[[f[1] for f in fixed], x]
    return entry, exit_


def _angles(tool, entry, exit_, depth, slices, rng, extra=12):
    """Per sample: the critical angles (slice entries and exits, where the force jumps), a
    grid including angles outside [0, 2 pi), and random ones."""
    eng = Engagement(entry, exit_, np.broadcast_to(depth, entry.shape).copy())
    crit = critical_angles(tool, eng, slices)
    grid = np.r_[np.linspace(0.0, TWO_PI, 9), -1.0, -TWO_PI, 3 * math.pi, 4 * math.pi - 1e-3]
    rand = rng.uniform(-TWO_PI, 3 * TWO_PI, (entry.size, extra))
    return np.concatenate([crit, np.tile(grid, (entry.size, 1)), rand], axis=1)


@pytest.mark.parametrize("teeth", [1, 2, 3, 4, 5, 8])
@pytest.mark.parametrize("helix", [0.0, 15.0, 30.0, 45.0])
@pytest.mark.parametrize("slices", [1, 2, 7, 20])
def test_sums_equal_brute_force_at_critical_and_random_angles(teeth, helix, slices):
    rng = np.random.default_rng(teeth * 1000 + int(helix) * 10 + slices)
    tool = _tool(helix, teeth)
    entry, exit_ = _cases(6, rng)
    depth = rng.uniform(0.2e-3, 25e-3, entry.size)
    angles = _angles(tool, entry, exit_, depth, slices, rng)
    ref = _check(tool, entry, exit_, depth, angles, slices)
    assert ref[0].max() > 0 and (ref[0] == 0).any()  # cuts and gaps both exercised


@pytest.mark.parametrize("teeth", [1, 3, 4])
def test_sums_exact_within_ulps_of_every_slice_boundary(teeth):
    """Angles a few ulps either side of where each slice reaches entry or exit (the ends of
    a run are settled there by the exact test), on several turns."""
    tool = _tool(40.0, teeth)
    slices, depth = 9, 7e-3
    entry = np.array([0.0, 0.3, 1.1, 0.0])
    exit_ = np.array([math.pi, 2.0, 1.1 + 1e-7, 1.5])
    lag = 2.0 * math.tan(tool.helix) / tool.diameter * ((np.arange(slices) + 0.5) * (depth /
                                                                                     slices))
    rows = []
    for e, x in zip(entry, exit_, strict=True):
        base = np.concatenate([b + lag - t * tool.pitch + r * TWO_PI
                               for b in (e, x) for t in range(teeth) for r in (0, 1)])
        rows.append(np.concatenate([np.nextafter(base, base + d) if d else base
                                    for d in (-1.0, 0.0, 1.0)]
                                   + [base + d * np.spacing(base) for d in (-3, -2, 2, 3)]))
    angles = np.array(rows)
    _check(tool, entry, exit_, depth, angles, slices)


def test_sums_exact_where_the_turn_estimate_rounds_across_a_boundary():
    """Slice 0 exactly at the entry angle while psi - (lag_0 + entry) rounds below zero (about
    3 % of the angles one ulp below entry + lag_0): the turn holding the slice is still summed."""
    rng = np.random.default_rng(23)
    tool = _tool(30.0, 1)
    slices, n = 4, 300
    entry = rng.uniform(0.0, 3.0, n)
    exit_ = np.minimum(entry + rng.uniform(0.0, 1.0, n), math.pi)
    depth = rng.uniform(0.5e-3, 20e-3, n)
    lag0 = 2.0 * math.tan(tool.helix) / tool.diameter * (0.5 * (depth / slices))
    base = entry + lag0
    angles = np.stack([np.nextafter(base, -np.inf), base, np.nextafter(base, np.inf),
                       np.nextafter(np.nextafter(base, -np.inf), -np.inf)], axis=1)
    raw = angles - lag0[:, None]
    assert ((raw >= entry[:, None]) & (angles - (lag0 + entry)[:, None] < 0)).sum() > 3
    _check(tool, entry, exit_, depth, angles, slices)


@pytest.mark.parametrize(("helix", "diameter", "depth", "slices"), [
    (60.0, 6e-3, 20e-3, 20),  # lags span ~1.8 turns
    (80.0, 2e-3, 40e-3, 20),  # ~36 turns, more than one turn between neighbouring slices
    (80.0, 2e-3, 40e-3, 3),
    (45.0, 6e-3, 30e-3, 50),
])
def test_sums_with_lags_over_several_turns(helix, diameter, depth, slices):
    rng = np.random.default_rng(3)
    tool = _tool(helix, 3, diameter, flute=depth)
    entry, exit_ = _cases(5, rng)
    angles = _angles(tool, entry, exit_, depth, slices, rng)
    _check(tool, entry, exit_, depth, angles, slices)


@pytest.mark.parametrize("depth", [1e-6, 1e-9, 1e-15, 1e-300])
def test_sums_with_tiny_depth(depth):
    """Slices closer than the rounding of their angles: the ends are walked exactly."""
    rng = np.random.default_rng(5)
    tool = _tool(30.0, 4)
    entry, exit_ = _cases(4, rng)
    angles = _angles(tool, entry, exit_, depth, 6, rng)
    _check(tool, entry, exit_, depth, angles, 6)


def test_far_angles_and_blocks():
    """Angles many turns away (np.mod beyond [-2 pi, 4 pi)); blocks of 1 and 3 rows."""
    rng = np.random.default_rng(11)
    tool = _tool(30.0, 3)
    entry, exit_ = _cases(5, rng)
    angles = rng.uniform(-60.0, 60.0, (entry.size, 17))
    for max_rows in (None, 1, 3):
        _check(tool, entry, exit_, 5e-3, angles, 11, max_rows)


@pytest.mark.parametrize("teeth", [1, 2])
def test_one_angle_per_sample(teeth):
    """k = 1 (a single angle per sample, as the refinement of a worst angle asks)."""
    rng = np.random.default_rng(29)
    tool = _tool(35.0, teeth)
    entry, exit_ = _cases(6, rng)
    angles = _angles(tool, entry, exit_, 4e-3, 5, rng)
    for col in range(angles.shape[1]):
        _check(tool, entry, exit_, 4e-3, angles[:, col : col + 1], 5)


@settings(max_examples=120, deadline=None)
@given(
    teeth=st.integers(1, 8),
    helix=st.one_of(st.just(0.0), st.floats(1.0, 85.0)),
    slices=st.integers(1, 24),
    depth_mm=st.floats(1e-3, 40.0),
    interval=st.tuples(st.floats(0.0, math.pi), st.floats(0.0, math.pi)),
    seed=st.integers(0, 2**32 - 1),
)
def test_sums_equal_brute_force_hypothesis(teeth, helix, slices, depth_mm, interval, seed):
    rng = np.random.default_rng(seed)
    depth = depth_mm * 1e-3
    tool = _tool(helix, teeth, flute=depth)
    lo, hi = sorted(interval)
    entry = np.array([lo, 0.0, lo])
    exit_ = np.array([hi, math.pi, math.pi])
    angles = _angles(tool, entry, exit_, depth, slices, rng, extra=8)
    _check(tool, entry, exit_, depth, angles, slices)


@pytest.mark.parametrize("helix", [0.0, 30.0])
def test_milling_forces_at_projects_the_sums(helix):
    """Forces of milling_forces_at at critical angles equal the brute-force sums mapped by
    the force model (module docstring of forces.py) written out here."""
    rng = np.random.default_rng(17)
    tool = _tool(helix, 3)
    slices = 8
    entry, exit_ = _cases(5, rng)
    depth = rng.uniform(1e-3, 10e-3, entry.size)
    angles = _angles(tool, entry, exit_, depth, slices, rng)
    split = milling_forces_at(tool, K, Engagement(entry, exit_, depth), angles, slices)
    one, s, c, sc, ss = reference_sums(tool, entry, exit_, depth, angles, slices) * (
        depth / slices)[:, None]
    r = tool.diameter / 2
    # dFt = da (Ktc c sin + Kte), dFr = da (Krc c sin + Kre), dFa = da (Kac c sin + Kae)
    cutting = np.stack([-K.ktc * sc - K.krc * ss, K.ktc * ss - K.krc * sc, K.kac * s], axis=-1)
    edge = np.stack([-K.kte * c - K.kre * s, K.kte * s - K.kre * c, K.kae * one], axis=-1)
    for got, want in ((split.cutting, cutting), (split.edge, edge),
                      (split.cutting_torque, r * K.ktc * s), (split.edge_torque, r * K.kte * one)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
