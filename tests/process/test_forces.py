"""Mechanistic force model (thesis Algorithm 1 + axial force) against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.process import (
    CuttingCoefficients,
    Engagement,
    average_forces,
    average_torque,
    feed_from_feed_per_tooth,
    feed_per_tooth,
    milling_forces,
    peripheral_engagement,
    rotation_angles,
    slot_engagement,
    spindle_power,
)

from .conftest import make_tool

K = CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3)


def brute_force(tool, k, entry, exit, a, c, angles, slices):
    """Algorithm 1 literally (loops), slices at mid-heights, half-open immersion test."""
    out = np.zeros((len(angles), 4))
    da = a / slices
    for i, phi in enumerate(angles):
        for tooth in range(tool.teeth):
            phi1 = phi + tooth * 2 * math.pi / tool.teeth
            for j in range(slices):
                phi2 = (phi1 - 2 * math.tan(tool.helix) / tool.diameter * (j + 0.5) * da) % (
                    2 * math.pi
                )
                if entry <= phi2 < exit:
                    h = c * math.sin(phi2)
                    ft, fr, fa = (
                        da * (k.ktc * h + k.kte),
                        da * (k.krc * h + k.kre),
                        da * (k.kac * h + k.kae),
                    )
                    out[i, 0] += -ft * math.cos(phi2) - fr * math.sin(phi2)
                    out[i, 1] += ft * math.sin(phi2) - fr * math.cos(phi2)
                    out[i, 2] += fa
                    out[i, 3] += tool.diameter / 2 * ft
    return out


@pytest.mark.parametrize("helix", [0.0, 30.0, 45.0])
@pytest.mark.parametrize("teeth", [1, 2, 3])
def test_matches_literal_algorithm_1(helix, teeth):
    tool = make_tool(helix, teeth)
    ae = np.array([tool.diameter, 0.3 * tool.diameter, 0.7 * tool.diameter])
    angles = np.linspace(0.0, 2 * math.pi, 37) + 0.013
    for milling in ("up", "down"):
        eng = peripheral_engagement(ae, tool.diameter, 3e-3, milling)
        split = milling_forces(tool, K, eng, angles, axial_slices=7)
        for c in (0.0, 4e-5, 1.1e-4):
            f, tq = split.forces(c), split.torque(c)
            for s in range(eng.n):
                ref = brute_force(tool, K, eng.entry[s], eng.exit[s], 3e-3, c, angles, 7)
                np.testing.assert_allclose(f[s], ref[:, :3], rtol=1e-9, atol=1e-9)
                np.testing.assert_allclose(tq[s], ref[:, 3], rtol=1e-9, atol=1e-12)


def _engagements(tool, a):
    half = np.array([tool.diameter / 2])
    return {
        "slot": slot_engagement(1, a),
        "half-up": peripheral_engagement(half, tool.diameter, a, "up"),
        "half-down": peripheral_engagement(half, tool.diameter, a, "down"),
    }


@pytest.mark.parametrize("helix", [0.0, 30.0])
@pytest.mark.parametrize("case", ["slot", "half-up", "half-down"])
def test_numeric_mean_equals_closed_form(helix, case):
    """Mean over 360 midpoint angles (1 deg step) vs Altintas' closed form: within 0.5 %."""
    tool = make_tool(helix)
    eng = _engagements(tool, 2.54e-3)[case]
    c = feed_per_tooth(4.23e-3, 2000, tool.teeth)
    split = milling_forces(tool, K, eng, rotation_angles(360, midpoint=True))
    num = split.forces(c)[0].mean(axis=0)
    closed = average_forces(tool, K, eng.entry, eng.exit, eng.axial_depth, c)[0]
    np.testing.assert_allclose(num, closed, rtol=0.005)
    torque = average_torque(tool, K, eng.entry, eng.exit, eng.axial_depth, c)[0]
    np.testing.assert_allclose(split.torque(c)[0].mean(), torque, rtol=0.005)


@settings(max_examples=25, deadline=None)
@given(
    st.floats(0.0, math.pi),
    st.floats(0.0, math.pi),
    st.floats(0.0, 60.0),
    st.integers(1, 4),
    st.floats(1e-5, 2e-4),
)
def test_closed_form_any_entry_exit(p1, p2, helix, teeth, c):
    """Closed form vs numeric mean for arbitrary engagements (fine grid; tolerance relative to
    the size of the force so near-zero components are compared sensibly)."""
    tool = make_tool(helix, teeth)
    entry, exit = min(p1, p2), max(p1, p2)
    eng = Engagement(np.array([entry]), np.array([exit]), np.array([2e-3]))
    split = milling_forces(tool, K, eng, rotation_angles(2880, midpoint=True), axial_slices=16)
    num = split.forces(c)[0].mean(axis=0)
    closed = average_forces(tool, K, entry, exit, 2e-3, c)
    scale = 2e-3 * tool.teeth * (K.ktc * c + K.kte)  # ~ peak tangential force of one tooth
    assert np.all(np.abs(num - closed) <= 2e-3 * scale + 1e-12)


def test_slot_closed_form_is_eq_3_25():
    tool = make_tool()
    a, c, n = 1.27e-3, 5e-5, tool.teeth
    f = average_forces(tool, K, 0.0, math.pi, a, c)
    expected = [
        -n * a * K.krc * c / 4 - n * a * K.kre / math.pi,
        n * a * K.ktc * c / 4 + n * a * K.kte / math.pi,
        n * a * K.kac * c / math.pi + n * a * K.kae / 2,
    ]
    np.testing.assert_allclose(f, expected, rtol=1e-12)
    # Eq. 3.25 inverted
    fc = average_forces(tool, K, 0.0, math.pi, a, 1.0) - average_forces(tool, K, 0, math.pi, a, 0)
    fe = average_forces(tool, K, 0.0, math.pi, a, 0.0)
    np.testing.assert_allclose(4 * fc[1] / (n * a), K.ktc)
    np.testing.assert_allclose(-4 * fc[0] / (n * a), K.krc)
    np.testing.assert_allclose(math.pi * fc[2] / (n * a), K.kac)
    np.testing.assert_allclose(math.pi * fe[1] / (n * a), K.kte)
    np.testing.assert_allclose(-math.pi * fe[0] / (n * a), K.kre)
    np.testing.assert_allclose(2 * fe[2] / (n * a), K.kae)


def test_zero_helix_is_textbook_straight_tooth():
    """Straight teeth: every slice sees the same angle, so the force is a times the per-unit-
    height tooth force summed over teeth in the cut, independent of the slice count."""
    tool = make_tool(0.0, teeth=3)
    a, c = 2e-3, 8e-5
    eng = peripheral_engagement(np.array([0.6 * tool.diameter]), tool.diameter, a, "down")
    angles = rotation_angles(90) + 0.001
    f1 = milling_forces(tool, K, eng, angles, axial_slices=1).forces(c)[0]
    f9 = milling_forces(tool, K, eng, angles, axial_slices=9).forces(c)[0]
    np.testing.assert_allclose(f9, f1, rtol=1e-12, atol=1e-9)
    expected = np.zeros((angles.size, 3))
    for k in range(3):
        phi = np.mod(angles + k * 2 * math.pi / 3, 2 * math.pi)
        cut = (phi >= eng.entry[0]) & (phi < eng.exit[0])
        h = c * np.sin(phi)
        ft, fr, fa = a * (K.ktc * h + K.kte), a * (K.krc * h + K.kre), a * (K.kac * h + K.kae)
        expected += cut[:, None] * np.stack(
            [-ft * np.cos(phi) - fr * np.sin(phi), ft * np.sin(phi) - fr * np.cos(phi), fa], 1
        )
    np.testing.assert_allclose(f1, expected, rtol=1e-12, atol=1e-9)


def test_linear_in_axial_depth_when_helix_lag_small():
    tool0, tool_small = make_tool(0.0), make_tool(0.05)  # lag over 4 mm ~ 0.02 deg
    angles = rotation_angles(72, midpoint=True)
    for tool, tol in ((tool0, 1e-12), (tool_small, 2e-3)):
        f = [
            milling_forces(tool, K, slot_engagement(1, a), angles).forces(6e-5)[0]
            for a in (1e-3, 4e-3)
        ]
        # compared relative to the peak force (components cross zero)
        assert np.abs(f[1] - 4 * f[0]).max() <= tol * np.abs(f[1]).max()
    # ... and not with a 30 deg helix over a deep cut (the test above can fail)
    tool = make_tool(30.0)
    f = [
        milling_forces(tool, K, slot_engagement(1, a), angles).forces(6e-5)[0]
        for a in (1e-3, 15e-3)
    ]
    assert np.abs(f[1] - 15 * f[0]).max() > 0.05 * np.abs(f[1]).max()


def test_force_is_affine_in_feed_per_tooth():
    tool = make_tool(30.0)
    eng = peripheral_engagement(np.array([4e-3, 12e-3]), tool.diameter, 3e-3, "up")
    split = milling_forces(tool, K, eng, rotation_angles(50))
    cs = np.array([0.0, 3e-5, 7e-5, 1.3e-4])
    f = np.stack([split.forces(c) for c in cs])  # (4, n, m, 3)
    np.testing.assert_array_equal(f[0], split.edge)
    # exactly affine: second differences in c vanish, slope is the cutting part
    slope = (f[3] - f[1]) / (cs[3] - cs[1])
    np.testing.assert_allclose(slope, split.cutting, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(f[2], f[0] + cs[2] * split.cutting, rtol=1e-12, atol=1e-9)
    # per-sample c broadcasts over samples
    fc = split.forces(np.array([3e-5, 7e-5]))
    np.testing.assert_allclose(fc[0], f[1][0])
    np.testing.assert_allclose(fc[1], f[2][1])


def test_periodic_over_tooth_pitch():
    tool = make_tool(30.0, teeth=3)
    eng = peripheral_engagement(np.array([7e-3]), tool.diameter, 5e-3, "down")
    angles = rotation_angles(40, teeth=3)
    a = milling_forces(tool, K, eng, angles).forces(5e-5)
    b = milling_forces(tool, K, eng, angles + 2 * math.pi / 3).forces(5e-5)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_deduplicated_and_mixed_engagements_match_one_by_one():
    tool = make_tool(30.0)
    slot = slot_engagement(1, 2e-3)
    per = peripheral_engagement(np.array([0.0, 3e-3, 3e-3, 9e-3]), tool.diameter, 4e-3, "down")
    eng = Engagement(
        np.concatenate([per.entry, slot.entry, per.entry[::-1]]),
        np.concatenate([per.exit, slot.exit, per.exit[::-1]]),
        np.concatenate([per.axial_depth, slot.axial_depth, per.axial_depth]),
    )
    angles = rotation_angles(30)
    split = milling_forces(tool, K, eng, angles)
    for s in range(eng.n):
        one = Engagement(eng.entry[s : s + 1], eng.exit[s : s + 1], eng.axial_depth[s : s + 1])
        ref = milling_forces(tool, K, one, angles)
        np.testing.assert_array_equal(split.cutting[s], ref.cutting[0])
        np.testing.assert_array_equal(split.edge[s], ref.edge[0])
        np.testing.assert_array_equal(split.cutting_torque[s], ref.cutting_torque[0])
        np.testing.assert_array_equal(split.edge_torque[s], ref.edge_torque[0])
    assert np.all(split.forces(1e-4)[0] == 0)  # a_e = 0: no contact


def test_power_and_feed_conversions():
    assert feed_per_tooth(4.23e-3, 2500, 2) == pytest.approx(4.23e-3 / (2500 / 60 * 2))
    assert feed_from_feed_per_tooth(feed_per_tooth(5e-3, 1800, 3), 1800, 3) == pytest.approx(5e-3)
    np.testing.assert_allclose(feed_per_tooth(np.array([1e-3, 2e-3]), 600, 1), [0.1e-3, 0.2e-3])
    assert spindle_power(2.0, 60.0) == pytest.approx(2.0 * 2 * math.pi)
    tool = make_tool()
    split = milling_forces(tool, K, slot_engagement(2, 1e-3), rotation_angles(8))
    np.testing.assert_allclose(
        split.power(5e-5, 3000), split.torque(5e-5) * 3000 * 2 * math.pi / 60
    )
    with pytest.raises(InputError, match="spindle speed"):
        feed_per_tooth(1e-3, 0.0, 2)


def test_bad_engagement_and_slices_refused():
    tool = make_tool()
    angles = rotation_angles(4)
    with pytest.raises(InputError, match="axial_depth at sample 1 .*flute length"):
        milling_forces(tool, K, slot_engagement(2, np.array([1e-3, 30e-3])), angles)
    with pytest.raises(InputError, match="axial_depth at sample 0 .*must be > 0"):
        slot_engagement(1, 0.0)
    with pytest.raises(InputError, match="exit at sample 0"):
        Engagement(np.array([1.0]), np.array([0.5]), np.array([1e-3]))
    with pytest.raises(InputError, match="axial_slices"):
        milling_forces(tool, K, slot_engagement(1, 1e-3), angles, axial_slices=0)


def test_many_distinct_axial_depths_use_slice_sums_consistently(monkeypatch):
    """The slice-by-slice path (many distinct depths) equals the sorted-table path."""
    import feedopt.process.forces as forces

    tool = make_tool(30.0, teeth=3)
    n = 7
    ae = np.linspace(0.0, tool.diameter, n)
    eng = peripheral_engagement(ae, tool.diameter, np.linspace(1e-3, 9e-3, n), "up")
    eng = Engagement(np.r_[eng.entry, eng.entry[:2]], np.r_[eng.exit, eng.exit[:2]],
                     np.r_[eng.axial_depth, eng.axial_depth[:2]])  # fmt: skip
    angles = rotation_angles(45) + 0.01
    table = milling_forces(tool, K, eng, angles, axial_slices=9)
    monkeypatch.setattr(forces, "_MAX_TABLES", 2)
    sliced = milling_forces(tool, K, eng, angles, axial_slices=9)
    for name in ("cutting", "edge", "cutting_torque", "edge_torque"):
        a, b = getattr(table, name), getattr(sliced, name)
        np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9 * np.abs(a).max())


def test_exact_ties_at_late_rotation_angles():
    """A slice exactly on entry/exit at a late angle index (large row offset in the sorted
    table) is still classified by the exact half-open test, as in Algorithm 1."""
    tool = make_tool(0.0, teeth=3)
    eng = peripheral_engagement(np.array([0.25, 0.75]) * tool.diameter, tool.diameter, 2e-3, "up")
    eng = Engagement(np.r_[eng.entry, math.pi / 3], np.r_[eng.exit, math.pi], np.full(3, 2e-3))
    angles = np.linspace(-1.0, 3 * math.pi, 41)  # a tooth at exactly pi/3 at index 40
    split = milling_forces(tool, K, eng, angles, axial_slices=3)
    for s in range(eng.n):
        ref = brute_force(tool, K, eng.entry[s], eng.exit[s], 2e-3, 1e-4, angles, 3)
        np.testing.assert_allclose(split.forces(1e-4)[s], ref[:, :3], rtol=1e-9, atol=1e-9)
