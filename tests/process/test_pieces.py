"""Engagement on several angular pieces, each with its own axial depth (EngagementPieces).

The references are independent of the vectorised force model: Algorithm 1 written out with
loops (:func:`brute_force` of test_forces) per piece, and a continuous reference that slices
the cutter on one fine axial grid and tests every slice against the depth of the piece its
angle falls in (the definition of an angle-dependent depth).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process import Engagement
from feedopt.process.engagement import EngagementPieces
from feedopt.process.forces import critical_angles, milling_forces, milling_forces_at

from .conftest import make_tool
from .test_forces import K, brute_force

DEG = math.pi / 180.0


def _pieced(pieces, n=3):
    """Sample 0: one interval (slot 1 mm); sample 1: the pieces; sample 2: air."""
    sample = np.full(len(pieces), 1)
    entry, exit_, depth = (np.array([p[k] for p in pieces]) for k in range(3))
    hull = (entry.min(), exit_.max(), depth.max())
    eng = Engagement(np.array([0.0, hull[0], 0.0]), np.array([math.pi, hull[1], 0.0]),
                     np.array([1e-3, hull[2], 1e-3]),
                     EngagementPieces(sample, entry, exit_, depth))
    assert eng.n == n
    return eng


TWO_CONTACTS = [(0.0, 26.4 * DEG, 2e-3), (63.6 * DEG, 116.4 * DEG, 2e-3)]  # inside corner
STEP = [(0.0, 90 * DEG, 5e-3), (90 * DEG, 180 * DEG, 3e-3)]  # a step across the cutter
STAIRS = [(10 * DEG, 40 * DEG, 1e-3), (40 * DEG, 70 * DEG, 2e-3), (70 * DEG, 150 * DEG, 3e-3)]


@pytest.mark.parametrize("pieces", [TWO_CONTACTS, STEP, STAIRS])
@pytest.mark.parametrize("helix", [0.0, 30.0])
def test_pieced_sample_is_the_sum_of_algorithm_1_per_piece(pieces, helix):
    tool = make_tool(helix, 2)
    eng = _pieced(pieces)
    angles = np.linspace(0.0, 2 * math.pi, 29) + 0.011
    split = milling_forces(tool, K, eng, angles, axial_slices=6)
    for c in (0.0, 7e-5):
        f = split.forces(c)
        ref = sum(brute_force(tool, K, e, x, a, c, angles, 6) for e, x, a in pieces)
        np.testing.assert_allclose(f[1], ref[:, :3], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(split.torque(c)[1], ref[:, 3], rtol=1e-9, atol=1e-12)
        # the single-interval and air samples are unaffected
        np.testing.assert_allclose(
            f[0], brute_force(tool, K, 0.0, math.pi, 1e-3, c, angles, 6)[:, :3], atol=1e-9)
        assert np.all(f[2] == 0.0)
    # per-sample angles give the same as the shared grid
    at = milling_forces_at(tool, K, eng, np.tile(angles, (3, 1)), axial_slices=6)
    np.testing.assert_allclose(at.cutting, split.cutting, rtol=0, atol=1e-9 * abs(
        split.cutting).max())


def _continuous_reference(tool, pieces, c, angles, dz):
    """Forces with the cutter sliced every dz from the tip: the slice at height z of a tooth
    at immersion phi cuts iff phi is in a piece and z < that piece's depth."""
    out = np.zeros((angles.size, 3))
    z = (np.arange(int(round(max(p[2] for p in pieces) / dz))) + 0.5) * dz
    lag = 2 * math.tan(tool.helix) / tool.diameter * z
    for tooth in range(tool.teeth):
        phi = np.mod(angles[:, None] + tooth * 2 * math.pi / tool.teeth - lag[None, :],
                     2 * math.pi)
        depth = np.zeros_like(phi)
        for e, x, a in pieces:
            depth = np.where((phi >= e) & (phi < x), a, depth)
        cut = z[None, :] < depth
        h = c * np.sin(phi)
        ft, fr, fa = (dz * (kc * h + ke) * cut for kc, ke in
                      ((K.ktc, K.kte), (K.krc, K.kre), (K.kac, K.kae)))
        out[:, 0] += np.sum(-ft * np.cos(phi) - fr * np.sin(phi), axis=1)
        out[:, 1] += np.sum(ft * np.sin(phi) - fr * np.cos(phi), axis=1)
        out[:, 2] += np.sum(fa, axis=1)
    return out


@pytest.mark.parametrize("pieces", [STEP, STAIRS])
def test_angle_dependent_depth_matches_a_continuous_model(pieces):
    """The pieces are a quadrature of the angle-dependent depth: with fine slices they agree
    with one fine axial grid to its discretisation error, and differ clearly from the hull
    at the largest depth (what one interval per sample would give)."""
    tool = make_tool(30.0, 2)
    eng = _pieced(pieces)
    angles = np.linspace(0.0, 2 * math.pi, 73) + 0.007
    c = 8e-5
    got = milling_forces(tool, K, eng, angles, axial_slices=300).forces(c)[1]
    ref = _continuous_reference(tool, pieces, c, angles, dz=1e-3 / 300)
    scale = np.abs(ref).max()
    np.testing.assert_allclose(got, ref, rtol=0, atol=0.01 * scale)
    hull = Engagement(eng.entry[1:2], eng.exit[1:2], eng.axial_depth[1:2])
    f_hull = milling_forces(tool, K, hull, angles, axial_slices=300).forces(c)[0]
    assert np.abs(f_hull - ref).max() > 0.15 * scale


@pytest.mark.parametrize("pieces", [TWO_CONTACTS, STEP, STAIRS])
def test_revolution_maximum_sits_on_grid_or_critical_angles(pieces):
    """critical_angles of a pieced sample hold every piece's force jumps: the maximum over a
    coarse grid joined with them equals the maximum over a 20,000-angle brute-force grid."""
    tool = make_tool(30.0, 2)
    eng = _pieced(pieces)
    crit = critical_angles(tool, eng, axial_slices=5)
    assert crit.shape[1] == len(pieces) * 10  # 2 L per piece
    coarse = np.linspace(0.0, math.pi, 31)
    c = 9e-5
    grid = milling_forces(tool, K, eng, coarse, axial_slices=5).forces(c)
    at = milling_forces_at(tool, K, eng, crit, axial_slices=5).forces(c)
    got = max(np.linalg.norm(grid[1], axis=1).max(), np.linalg.norm(at[1], axis=1).max())
    fine = np.linspace(0.0, math.pi, 20001)
    ref = sum(brute_force(tool, K, e, x, a, c, fine, 5)[:, :3] for e, x, a in pieces)
    ref_max = np.linalg.norm(ref, axis=1).max()
    # the coarse grid may miss a smooth maximum by its curvature over half a step, and the
    # fine grid the top of a jump by its slope over 1.6e-4 rad; never a whole jump
    assert got == pytest.approx(ref_max, rel=2e-3)
    coarse_only = np.linalg.norm(grid[1], axis=1).max()
    assert got >= coarse_only


def test_take_and_without_keep_the_pieces_of_their_samples():
    eng = _pieced(STEP)
    part = eng.take(slice(1, 3))
    assert part.n == 2 and part.pieces.count == 2 and np.all(part.pieces.sample == 0)
    assert eng.take(slice(0, 1)).pieces is None
    dropped = eng.without(np.array([False, True, False]))
    assert dropped.pieces is None and dropped.exit[1] == 0.0
    assert list(eng.pieced) == [False, True, False]


@pytest.mark.parametrize(("sample", "entry", "exit_", "why"), [
    ([0, 0], [0.0, 0.5], [0.6, 1.0], "disjoint"),
    ([1, 0], [0.0, 0.5], [0.4, 1.0], "sample order"),
    ([0], [0.5], [0.5], "entry < exit"),
    ([0], [0.5], [4.0], "180"),
])
def test_bad_pieces_are_refused_naming_the_piece(sample, entry, exit_, why):
    with pytest.raises(InputError, match="engagement piece"):
        EngagementPieces(np.array(sample), np.array(entry), np.array(exit_),
                         np.full(len(sample), 1e-3))


def test_pieces_beyond_the_samples_are_refused():
    with pytest.raises(InputError, match="of an engagement of 1 samples"):
        Engagement(np.zeros(1), np.ones(1), np.full(1, 1e-3),
                   EngagementPieces(np.array([3]), np.zeros(1), np.ones(1), np.full(1, 1e-3)))


def _many_pieced(rng, n=60, first=7, last=50):
    """Samples ``first..last`` pieced (1-3 disjoint pieces of their own depths), the others
    on one interval: a chunk the bound sees on a raster."""
    sample, entry, exit_, depth = [], [], [], []
    for i in range(first, last):
        cuts = np.sort(rng.uniform(0.0, math.pi, 2 * int(rng.integers(1, 4))))
        for e, x in cuts.reshape(-1, 2):
            if x - e > 1e-3:
                sample.append(i), entry.append(e), exit_.append(x)
                depth.append(rng.uniform(0.5e-3, 4e-3))
    sample = np.array(sample)
    hull_e = np.array([np.min(np.array(entry)[sample == i]) if np.any(sample == i) else 0.2
                       for i in range(n)])
    hull_x = np.array([np.max(np.array(exit_)[sample == i]) if np.any(sample == i) else 2.0
                       for i in range(n)])
    hull_a = np.array([np.max(np.array(depth)[sample == i]) if np.any(sample == i) else 2e-3
                       for i in range(n)])
    return Engagement(hull_e, hull_x, hull_a, EngagementPieces(
        sample, np.array(entry), np.array(exit_), np.array(depth)))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_block_of_pieced_samples_sums_each_sample_s_own_pieces(seed):
    # the consecutive pieced samples of a chunk are added by slices (forces._add_rows): each
    # sample must get exactly its own pieces, computed here one piece at a time
    rng = np.random.default_rng(seed)
    tool = make_tool(30.0, 3)
    eng = _many_pieced(rng)
    angles = np.linspace(0.0, 2 * math.pi / 3, 17) + 0.003
    split = milling_forces(tool, K, eng, angles, axial_slices=8)
    at = milling_forces_at(tool, K, eng, np.tile(angles, (eng.n, 1)) + 0.0, axial_slices=8)
    p = eng.pieces
    for i in range(eng.n):
        mine = np.flatnonzero(p.sample == i)
        if mine.size:
            parts = [milling_forces(tool, K, Engagement(p.entry[[j]], p.exit[[j]],
                                                        p.axial_depth[[j]]), angles, 8)
                     for j in mine]
            want = sum(s.cutting[0] for s in parts), sum(s.edge_torque[0] for s in parts)
        else:
            one = milling_forces(tool, K, eng.hull_only().take(np.array([i])), angles, 8)
            want = one.cutting[0], one.edge_torque[0]
        for got in (split, at):
            np.testing.assert_allclose(got.cutting[i], want[0], rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(got.edge_torque[i], want[1], rtol=1e-12, atol=1e-12)
