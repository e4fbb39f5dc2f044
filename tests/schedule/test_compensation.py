"""Compensation: the residual limit mode, the mean deflection, the offset cap, the fixed point.

References are hand computations: the slot force of straight teeth written out, its mean by
quadrature, and the largest feed by bisection, never the closed forms under test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.engagement import EngagementPieces, peripheral_engagement, slot_engagement
from feedopt.process.forces import Engagement, milling_forces
from feedopt.schedule.bounds import BoundInputs, deflection_feed_bound, feed_bound
from feedopt.schedule.compensation import CompensationCapConstraint, compensation_fixed_point
from feedopt.schedule.deflection import DeflectionModel, feed_frames

from .test_deflection import _model


def _slot_model(compliance, mode="residual", helix_deg=0.0, n=1, depth=2.0e-3):
    from feedopt.process.tool import Tool

    base = _model(n=n)
    tool = Tool("straight", 19.05e-3, 2, math.radians(helix_deg), 25e-3)
    return DeflectionModel(
        tool=tool, coefficients=base.coefficients, engagement=slot_engagement(n, depth),
        angles=np.deg2rad(np.arange(0.0, 180.0, 1.0)),
        frames=feed_frames(np.tile([1.0, 0.0, 0.0], (n, 1)), np.tile([0.0, 0.0, 1.0], (n, 1))),
        compliance=np.broadcast_to(compliance, (n, 3, 3)).copy(), rpm=2500.0, mode=mode,
        axial_slices=4)


def _hand_slot_force(k, a, c, phi):
    """Straight 2-tooth slot: tooth 1 at phi in [0, pi) cuts alone (tooth 2 then at phi + pi
    is outside [0, pi)); forces on the tool (x feed, y normal, z axis), Eq. 3.25's signs."""
    h = c * np.sin(phi)
    ft, fr, fa = a * (k.ktc * h + k.kte), a * (k.krc * h + k.kre), a * (k.kac * h + k.kae)
    return np.stack([-ft * np.cos(phi) - fr * np.sin(phi), ft * np.sin(phi) - fr * np.cos(phi),
                     fa], axis=-1)


def test_residual_bound_of_a_straight_slot_equals_a_hand_computation():
    """On a straight line in a slot the residual mode bounds max |C (F(phi) - mean F)| <= L;
    its largest feed per tooth, found here by bisection on a 200,000-angle grid with the mean
    by quadrature, equals the closed form within 1e-6."""
    rng = np.random.default_rng(1)
    m = rng.normal(size=(3, 3))
    compliance = (m @ m.T + 0.5 * np.eye(3)) * 2e-7
    model = _slot_model(compliance)
    k, a, limit = model.coefficients, model.engagement.axial_depth[0], 0.05e-3
    phi = (np.arange(200_000) + 0.5) * (math.pi / 200_000)  # one pitch, midpoints

    def residual_max(c):
        f = _hand_slot_force(k, a, c, phi)
        d = (f - f.mean(axis=0)) @ compliance.T  # frames are the identity here
        return np.linalg.norm(d, axis=1).max()

    lo, hi = 0.0, 1e-2
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if residual_max(mid) <= limit else (lo, mid)
    v_hand = lo * model.feed_per_unit_c
    v, _ = deflection_feed_bound(model, limit)
    assert v[0] == pytest.approx(v_hand, rel=1e-6)
    # the mean is what the norm mode also carries: the residual bound is higher here
    norm = _slot_model(compliance, mode="norm")
    assert deflection_feed_bound(norm, limit)[0][0] < v[0]
    # and the mean deflection is the hand mean times the compliance
    f_mean = _hand_slot_force(k, a, lo, phi).mean(axis=0)
    np.testing.assert_allclose(model.mean_deflection(np.array([v_hand]))[0],
                               compliance @ f_mean, rtol=1e-6)


@pytest.mark.parametrize("helix", [0.0, 30.0])
def test_mean_terms_are_the_revolution_mean_of_the_slice_model(helix):
    """The closed-form mean equals the mean of Algorithm 1's forces over 100,000 angles of a
    revolution (the jumps at entry and exit cost the midpoint rule ~1e-5), for slots, side
    cuts and a sample on pieces of different depths."""
    n = 4
    base = peripheral_engagement(np.array([19.05e-3, 4e-3, 9e-3, 2e-3]), 19.05e-3, 2.54e-3,
                                 "down")
    eng = Engagement(base.entry, base.exit, base.axial_depth, EngagementPieces(
        np.array([3, 3]), np.array([0.1, 1.2]), np.array([0.9, 2.8]), np.array([1e-3, 3e-3])))
    model = _model(n=n, engagement=eng, seed=4)
    from feedopt.process.tool import Tool

    tool = Tool("t", 19.05e-3, 2, math.radians(helix), 25e-3)
    model = DeflectionModel(tool=tool, coefficients=model.coefficients, engagement=eng,
                            angles=model.angles, frames=model.frames,
                            compliance=model.compliance, rpm=2500.0, axial_slices=20)
    angles = (np.arange(100_000) + 0.5) * (2 * math.pi / 100_000)
    split = milling_forces(tool, model.coefficients, eng, angles, 20)
    a_mean, b_mean = model.mean_terms(slice(0, n))
    cr = model.compliance @ model.frames
    np.testing.assert_allclose(a_mean, np.einsum("kij,kj->ki", cr, split.cutting.mean(axis=1)),
                               rtol=1e-4, atol=1e-12)
    np.testing.assert_allclose(b_mean, np.einsum("kij,kj->ki", cr, split.edge.mean(axis=1)),
                               rtol=1e-4, atol=1e-12)


def test_the_cap_bounds_the_compensating_offset():
    model = _model(n=20, mode="residual")
    model = DeflectionModel(**{**model.__dict__, "mode": "residual"})
    limit = 5 * model.deflection(np.zeros(model.n)).max()
    mean_at_limit = model.mean_deflection(deflection_feed_bound(model, limit)[0])
    cap = 0.5 * np.linalg.norm(mean_at_limit, axis=1).min()
    inputs = BoundInputs(model, limit, max_feed=1.0, dq_ds=np.ones((model.n, 6)),
                         joint_velocity_max=np.full(6, 10.0), compensation_cap=cap)
    bound = feed_bound(inputs)
    assert np.all(bound.active_names() == "compensation_cap")
    np.testing.assert_allclose(np.linalg.norm(model.mean_deflection(bound.v_max), axis=1), cap,
                               rtol=1e-9)
    # without the residual mode or a cap, no bound
    for mode, c in (("norm", cap), ("residual", np.inf)):
        m = DeflectionModel(**{**model.__dict__, "mode": mode})
        v = CompensationCapConstraint().v_max(BoundInputs(m, limit, 1.0, np.ones((20, 6)),
                                                          np.full(6, 10.0),
                                                          compensation_cap=c))
        assert np.all(np.isinf(v))
    with pytest.raises(InputError, match="compensation_cap_mm .* exceeded by the mean deflection "
                                         "of the edge forces alone"):
        CompensationCapConstraint().v_max(BoundInputs(model, limit, 1.0, np.ones((20, 6)),
                                                      np.full(6, 10.0), compensation_cap=1e-12))


def test_the_fixed_point_converges_and_says_how():
    """mean d depends on the commanded pose (through the compliance) and on the planned feed,
    which depends on the pose too: the iteration reaches commanded = nominal - mean
    d(commanded, feed(commanded)) and re-plans until the feed repeats."""
    rng = np.random.default_rng(2)
    nominal = rng.normal(size=(50, 3))
    d0 = rng.normal(size=(50, 3)) * 3e-4
    gain = rng.normal(size=(3, 3)) * 0.05  # |d mean d / d pose| ~ 0.05: a strong coupling
    plans = []

    def plan(commanded):  # the feed falls slightly with the offset (a smooth law)
        plans.append(1)
        feed = 1.0 - 10.0 * np.linalg.norm(commanded - nominal, axis=1)
        return feed, feed

    def mean_deflection(commanded, feed):
        return (d0 + (commanded - nominal) @ gain.T) * feed[:, None], None

    res = compensation_fixed_point(nominal, plan, mean_deflection, max_plans=8)
    assert res.converged and res.change <= 1e-10 and res.feed_change <= 1e-9
    assert res.plans == len(plans) and 2 <= res.plans <= 8
    feed, _ = plan(res.commanded)
    mean_d, _ = mean_deflection(res.commanded, feed)
    np.testing.assert_allclose(res.commanded + mean_d, nominal, atol=1e-8)
    # a law whose plan jumps: the pose is still solved for the last plan, which is kept
    jumpy = iter(range(100))

    def plan_jumpy(commanded):
        f = np.full(len(commanded), 1.0 + 0.1 * (next(jumpy) % 2))
        return f, f

    res = compensation_fixed_point(nominal, plan_jumpy, mean_deflection, max_plans=3)
    assert res.plans == 3 and res.feed_change > 0.05 and res.converged
    mean_d, _ = mean_deflection(res.commanded, res.plan_state)
    np.testing.assert_allclose(res.commanded + mean_d, nominal, atol=1e-9)
    # a pose map that diverges is reported, not hidden
    diverging = compensation_fixed_point(
        nominal, plan, lambda c, f: (d0 + 2.0 * (c - nominal), None), max_iterations=5,
        max_plans=1)
    assert not diverging.converged and diverging.iterations == 5


def test_a_cap_without_the_residual_mode_is_refused(quick_scenario):
    from feedopt.scenario import load_scenario

    bad = quick_scenario("triangle_slot", deflection__compensation_cap_mm=0.3)
    with pytest.raises(InputError, match="compensation_cap_mm applies to mode 'residual'"):
        load_scenario(bad)
    ok = quick_scenario("triangle_slot", deflection__compensation_cap_mm=0.3,
                        deflection__mode="residual")
    assert load_scenario(ok)[0].deflection.compensation_cap_mm == 0.3
