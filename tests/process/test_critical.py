"""Per-sample rotation angles (milling_forces_at) and the force jumps (critical_angles)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process import Engagement, milling_forces, peripheral_engagement, slot_engagement
from feedopt.process.forces import critical_angles, milling_forces_at, rotation_angles

from .conftest import make_tool
from .test_forces import K, brute_force

FIELDS = ("cutting", "edge", "cutting_torque", "edge_torque")


def _mixed_engagements(tool, depths):
    ae = np.linspace(0.0, tool.diameter, 5)
    parts = [peripheral_engagement(ae, tool.diameter, d, m) for d in depths for m in ("up", "down")]
    parts.append(slot_engagement(2, depths[0]))
    return Engagement(
        np.concatenate([e.entry for e in parts]),
        np.concatenate([e.exit for e in parts]),
        np.concatenate([e.axial_depth for e in parts]),
    )


def _one(eng, s):
    return Engagement(eng.entry[s : s + 1], eng.exit[s : s + 1], eng.axial_depth[s : s + 1])


def _assert_split_close(got, ref, rtol=1e-12):
    for name in FIELDS:
        a, b = getattr(got, name), getattr(ref, name)
        assert a.shape == b.shape, name
        np.testing.assert_allclose(a, b, rtol=0, atol=rtol * max(np.abs(b).max(), 1e-300))


@pytest.mark.parametrize("helix", [0.0, 30.0, 45.0])
@pytest.mark.parametrize("teeth", [1, 2, 3])
def test_at_equals_milling_forces_on_shared_angles(helix, teeth):
    tool = make_tool(helix, teeth)
    eng = _mixed_engagements(tool, [1e-3, 4e-3, 15e-3])
    angles = np.linspace(-1.0, 3 * math.pi, 41)  # also outside one revolution
    ref = milling_forces(tool, K, eng, angles, axial_slices=11)
    got = milling_forces_at(tool, K, eng, np.tile(angles, (eng.n, 1)), axial_slices=11)
    _assert_split_close(got, ref)
    np.testing.assert_array_equal(got.angles, np.tile(angles, (eng.n, 1)))
    # a (k,) array is shared by all samples
    _assert_split_close(milling_forces_at(tool, K, eng, angles, axial_slices=11), ref)


def test_at_equals_milling_forces_with_many_depths_and_chunks(monkeypatch):
    """Many distinct depths (slice-sum path of milling_forces) and several sample chunks."""
    import feedopt.process.forces as forces

    monkeypatch.setattr(forces, "_AT_CHUNK", 97)  # chunks of 3 samples, last one partial
    tool = make_tool(30.0, 3)
    n = 80
    ae = np.linspace(0.0, tool.diameter, n)
    eng = peripheral_engagement(ae, tool.diameter, np.linspace(0.5e-3, 20e-3, n), "down")
    angles = rotation_angles(32) + 0.003
    ref = milling_forces(tool, K, eng, angles)
    _assert_split_close(milling_forces_at(tool, K, eng, np.tile(angles, (n, 1))), ref)


def test_at_matches_literal_algorithm_1_with_per_sample_angles():
    tool = make_tool(30.0, 3)
    eng = _mixed_engagements(tool, [3e-3])
    rng = np.random.default_rng(7)
    angles = rng.uniform(0.0, 2 * math.pi, (eng.n, 9))
    split = milling_forces_at(tool, K, eng, angles, axial_slices=7)
    c = 8e-5
    f, tq = split.forces(c), split.torque(c)
    assert f.shape == (eng.n, 9, 3) and tq.shape == (eng.n, 9)
    for s in range(eng.n):
        ref = brute_force(tool, K, eng.entry[s], eng.exit[s], 3e-3, c, angles[s], 7)
        np.testing.assert_allclose(f[s], ref[:, :3], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(tq[s], ref[:, 3], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("helix", [0.0, 30.0, 45.0])
@pytest.mark.parametrize("teeth", [1, 2, 4])
def test_critical_angles_are_slice_entries_and_exits(helix, teeth):
    tool = make_tool(helix, teeth)
    eng = _mixed_engagements(tool, [2e-3, 20e-3])
    slices = 9
    crit = critical_angles(tool, eng, axial_slices=slices)
    per = 1 if helix == 0 else slices
    assert crit.shape == (eng.n, 2 * per)
    assert np.all((crit >= 0) & (crit < tool.pitch))
    lag = (
        2
        * math.tan(tool.helix)
        / tool.diameter
        * (np.arange(per) + 0.5)
        * (eng.axial_depth[:, None] / slices)
    )
    for col, target in ((slice(0, per), eng.entry), (slice(per, 2 * per), eng.exit - 1e-9)):
        # some tooth k has theta = crit + k pitch - lag_j == target (mod 2 pi)
        d = np.mod(crit[:, col] - lag - target[:, None] + 0.5 * tool.pitch, tool.pitch)
        cut = eng.entry < eng.exit
        np.testing.assert_allclose(d[cut], 0.5 * tool.pitch, rtol=0, atol=1e-12)


@pytest.mark.parametrize("helix", [0.0, 30.0])
@pytest.mark.parametrize("milling", ["down", "up"])
def test_force_at_critical_angles_is_the_one_sided_limit(helix, milling):
    """At an entry angle the force equals its limit from the right (the slice is in the cut),
    at an exit angle its limit from the left; and the force does jump there."""
    tool = make_tool(helix, 2)
    ae = np.array([0.2, 0.5, 0.8, 1.0]) * tool.diameter
    eng = peripheral_engagement(ae, tool.diameter, 4e-3, milling)
    slices = 6
    crit = critical_angles(tool, eng, axial_slices=slices)
    per = crit.shape[1] // 2
    at = milling_forces_at(tool, K, eng, crit, axial_slices=slices)
    c = 1e-4
    f_at = at.forces(c)
    jumps = []
    for s in range(eng.n):
        one = _one(eng, s)
        right = milling_forces(tool, K, one, crit[s] + 1e-12, axial_slices=slices).forces(c)[0]
        left = milling_forces(tool, K, one, crit[s] - 1e-12, axial_slices=slices).forces(c)[0]
        scale = np.abs(f_at[s]).max()
        np.testing.assert_allclose(f_at[s, :per], right[:per], rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(f_at[s, per:], left[per:], rtol=0, atol=1e-9 * scale)
        before = milling_forces(tool, K, one, crit[s, :per] - 1e-8, axial_slices=slices)
        jumps.append(np.abs(before.forces(c)[0] - f_at[s, :per]).max() / scale)
    assert min(jumps) > 1e-3  # every slice entry is a visible step (edge forces at least)


@pytest.mark.parametrize(("helix", "a"), [(30.0, 3e-3), (30.0, 8e-3), (45.0, 5e-3)])
def test_critical_angles_capture_the_supremum(helix, a):
    """Down milling at half immersion: thick chip at entry. A 1 deg grid misses max |F| by
    more than 0.05 %; joined with the critical angles it is within 2e-4 of a 0.01 deg grid."""
    tool = make_tool(helix, 2)
    eng = peripheral_engagement(np.array([tool.diameter / 2]), tool.diameter, a, "down")
    c = 1e-4

    def peak(split):
        return np.linalg.norm(split.forces(c), axis=-1).max()

    fine = peak(milling_forces(tool, K, eng, rotation_angles(18000, teeth=2)))
    grid = rotation_angles(180, teeth=2)
    coarse = peak(milling_forces(tool, K, eng, grid))
    joined = np.concatenate([np.tile(grid, (eng.n, 1)), critical_angles(tool, eng)], axis=1)
    with_crit = peak(milling_forces_at(tool, K, eng, joined))
    assert coarse < fine * (1 - 5e-4)
    assert with_crit >= fine * (1 - 2e-4)


def test_no_cut_and_empty_inputs():
    tool = make_tool(30.0, 2)
    eng = Engagement(np.array([1.0, 0.5]), np.array([1.0, 2.0]), np.array([2e-3, 2e-3]))
    crit = critical_angles(tool, eng, axial_slices=4)
    assert crit.shape == (2, 8) and np.all(np.isfinite(crit))
    split = milling_forces_at(tool, K, eng, crit, axial_slices=4)
    assert np.all(split.forces(1e-4)[0] == 0)
    empty = Engagement(np.zeros(0), np.zeros(0), np.zeros(0))
    assert critical_angles(tool, empty).shape == (0, 40)
    split = milling_forces_at(tool, K, empty, np.zeros((0, 3)))
    assert split.cutting.shape == (0, 3, 3) and split.edge_torque.shape == (0, 3)


def test_bad_angles_and_slices_refused():
    tool = make_tool()
    eng = slot_engagement(2, 1e-3)
    with pytest.raises(InputError, match=r"shape \(n, k\)"):
        milling_forces_at(tool, K, eng, np.zeros((3, 4)))
    with pytest.raises(InputError, match="finite"):
        milling_forces_at(tool, K, eng, np.array([[0.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(InputError, match="non-empty"):
        milling_forces_at(tool, K, eng, np.zeros((2, 0)))
    with pytest.raises(InputError, match="axial_slices"):
        milling_forces_at(tool, K, eng, np.zeros((2, 1)), axial_slices=0)
    with pytest.raises(InputError, match="axial_slices"):
        critical_angles(tool, eng, axial_slices=1.5)
