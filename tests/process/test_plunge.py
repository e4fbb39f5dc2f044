"""Straight plunges (issue 27): the end-edge model against hand quadrature, its place in the
force split, the deflection feed bound and the spindle torque bound against brute force, and
where the plunge samples of a program without a stock come from."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.geometry.program_path import MoveTable
from feedopt.process.engagement import Engagement, EngagementPieces, slot_engagement
from feedopt.process.forces import milling_forces, milling_forces_at, rotation_angles
from feedopt.process.plunge import PlungeCoefficients, plunge_forces
from feedopt.process.stage import in_program_air, unmodelled_plunges
from feedopt.schedule.bounds import BoundInputs, feed_bound
from feedopt.schedule.deflection import DeflectionModel, feed_frames

from .conftest import TABLE_3_3, make_tool

#: 1500 N/mm^2, 20 N/mm, 900 N/mm^2, 10 N/mm in SI
PLUNGE = PlungeCoefficients(1.5e9, 2.0e4, 0.9e9, 1.0e4)
SIDE = dataclasses.replace(TABLE_3_3[2000], plunge=PLUNGE)


def _quadrature(teeth: int, radius: float, c: float, phi: float, k: PlungeCoefficients,
                steps: int = 4000) -> tuple[np.ndarray, float]:
    """Force on the tool and torque of a full plunge summed by hand: midpoint rule over the
    radius of every end edge, each tooth's tangential force opposing its tooth velocity (the
    tooth at angle psi sits at R (sin psi, cos psi), Altintas' convention)."""
    dr = radius / steps
    r = (np.arange(steps) + 0.5) * dr
    force, torque = np.zeros(3), 0.0
    for tooth in range(teeth):
        psi = phi + 2.0 * math.pi * tooth / teeth
        h = 1e-6
        pos = lambda a: np.array([math.sin(a), math.cos(a)])  # noqa: E731
        velocity = (pos(psi + h) - pos(psi - h)) / (2 * h)
        against = -velocity / np.linalg.norm(velocity)
        d_tan = (k.torque_cutting * c + k.torque_edge) * dr * np.ones_like(r)
        d_thrust = (k.thrust_cutting * c + k.thrust_edge) * dr * np.ones_like(r)
        force[:2] += against * d_tan.sum()
        force[2] += d_thrust.sum()  # the material pushes the tool up, into the spindle (+z)
        torque += float(np.sum(r * d_tan))
    return force, torque


@pytest.mark.parametrize("teeth", [2, 1, 3, 4])
def test_plunge_force_and_torque_equal_hand_quadrature(teeth):
    tool = make_tool(teeth=teeth)
    radius, c = tool.diameter / 2, 0.05e-3
    angles = np.radians([0.0, 17.0, 95.0, 200.0])
    eng = Engagement(np.zeros(1), np.zeros(1), np.full(1, 1e-3), plunge=np.ones(1))
    split = milling_forces(tool, SIDE, eng, angles)
    for j, phi in enumerate(angles):
        want_f, want_t = _quadrature(teeth, radius, c, phi, PLUNGE)
        got_f, got_t = plunge_forces(tool, PLUNGE, c, phi)
        np.testing.assert_allclose(got_f, want_f, rtol=1e-9, atol=1e-9 * abs(want_f[2]))
        assert got_t == pytest.approx(want_t, rel=1e-9)
        np.testing.assert_allclose(split.forces(c)[0, j], want_f, rtol=1e-9,
                                   atol=1e-9 * abs(want_f[2]))
        assert split.torque(c)[0, j] == pytest.approx(want_t, rel=1e-9)
    if teeth >= 2:  # the lateral forces cancel: constant over the rotation
        assert np.all(split.cutting[0, :, :2] == 0) and np.all(split.edge[0, :, :2] == 0)
    else:  # one tooth: a rotating lateral force as large as the tangential force
        lateral = np.linalg.norm(split.forces(c)[0, :, :2], axis=1)
        np.testing.assert_allclose(lateral, (PLUNGE.torque_cutting * c + PLUNGE.torque_edge)
                                   * radius, rtol=1e-12)


def test_the_plunge_adds_to_the_side_edges_in_every_force_routine():
    tool = make_tool()
    n = 3
    slot = slot_engagement(n, 1.5e-3)
    plunge = np.array([1.0, 0.0, 1.0])
    both = slot.with_plunge(plunge)
    angles = rotation_angles(37, tool.teeth)
    extra_f, extra_t = plunge_forces(tool, PLUNGE, 1.0)
    edge_f, edge_t = plunge_forces(tool, PLUNGE, 0.0)
    cut_f, cut_t = extra_f - edge_f, extra_t - edge_t
    a, b = milling_forces(tool, SIDE, slot, angles), milling_forces(tool, SIDE, both, angles)

    def each(x: np.ndarray, like: np.ndarray) -> np.ndarray:  # per sample, every angle
        return np.broadcast_to(plunge.reshape((n,) + (1,) * (like.ndim - 1)) * x, like.shape)

    np.testing.assert_allclose(b.cutting - a.cutting, each(cut_f, a.cutting), atol=1e-3)
    np.testing.assert_allclose(b.edge - a.edge, each(edge_f, a.edge), atol=1e-9)
    np.testing.assert_allclose(b.cutting_torque - a.cutting_torque,
                               each(cut_t, a.cutting_torque), rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(b.edge_torque - a.edge_torque, each(edge_t, a.edge_torque),
                               rtol=1e-12, atol=1e-12)
    per_sample = np.random.default_rng(1).uniform(0, 2 * np.pi, (n, 5))
    a_at = milling_forces_at(tool, SIDE, slot, per_sample)
    b_at = milling_forces_at(tool, SIDE, both, per_sample)
    np.testing.assert_allclose(b_at.edge - a_at.edge, each(edge_f, a_at.edge), atol=1e-9)
    # a sample engaged on pieces keeps its plunge too (added once, not per piece)
    pieces = EngagementPieces(np.array([1, 1]), np.array([0.2, 1.5]), np.array([0.9, 2.5]),
                              np.array([1e-3, 2e-3]))
    pieced = Engagement(slot.entry, slot.exit, slot.axial_depth, pieces, np.ones(n))
    side = milling_forces(tool, SIDE, pieced.side_only(), angles)
    full = milling_forces(tool, SIDE, pieced, angles)
    np.testing.assert_allclose(full.edge - side.edge, np.broadcast_to(edge_f, full.edge.shape),
                               atol=1e-9)


def test_a_plunge_without_plunge_coefficients_is_refused():
    tool = make_tool()
    eng = Engagement(np.zeros(2), np.zeros(2), np.full(2, 1e-3), plunge=np.array([0.0, 1.0]))
    with pytest.raises(InputError, match="sample 1 plunges .* no plunge block"):
        milling_forces(tool, TABLE_3_3[2000], eng, rotation_angles(8))


def test_the_plunge_column_is_zero_or_one_and_follows_the_samples():
    with pytest.raises(InputError, match=r"engagement.plunge at sample 1 is 0.5: must be 0 .* "
                                         "or 1"):
        Engagement(np.zeros(2), np.zeros(2), np.full(2, 1e-3), plunge=np.array([1.0, 0.5]))
    with pytest.raises(InputError, match="plunge has shape"):
        Engagement(np.zeros(2), np.zeros(2), np.full(2, 1e-3), plunge=np.ones(3))
    eng = Engagement(np.zeros(4), np.zeros(4), np.full(4, 1e-3), plunge=np.array([0, 1, 1, 0]))
    assert eng.take(np.array([1, 3])).plunge.tolist() == [1.0, 0.0]
    dropped = eng.without(np.array([False, True, False, False]))
    assert dropped.plunging.tolist() == [False, False, True, False]
    assert eng.side_only().plunge is None and eng.plunging.tolist() == [False, True, True, False]
    assert Engagement(np.zeros(2), np.zeros(2), 1e-3, plunge=np.zeros(2)).plunge is None


def _plunge_model(teeth: int, n: int = 4, mode: str = "norm") -> DeflectionModel:
    rng = np.random.default_rng(7)
    m = rng.normal(size=(n, 3, 3))
    compliance = (m @ np.swapaxes(m, 1, 2) + 0.5 * np.eye(3)) * 2e-7
    eng = Engagement(np.zeros(n), np.zeros(n), np.full(n, 1e-3), plunge=np.ones(n))
    frames = feed_frames(np.tile([1.0, 0.0, 0.0], (n, 1)), np.tile([0.0, 0.0, 1.0], (n, 1)))
    return DeflectionModel(tool=make_tool(teeth=teeth), coefficients=SIDE, engagement=eng,
                           angles=np.deg2rad(np.arange(0.0, 360.0 / teeth, 1.0)), frames=frames,
                           compliance=compliance, rpm=2000, mode=mode)


def _bisect(ok, lo: float = 0.0, hi: float = 1.0) -> float:
    assert ok(lo) and not ok(hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


@pytest.mark.parametrize("teeth", [2, 1])
def test_plunge_feed_bound_equals_brute_force_bisection(teeth):
    model = _plunge_model(teeth)
    tool = model.tool
    edge = [_quadrature(teeth, tool.diameter / 2, 0.0, p, PLUNGE, steps=4)[0]
            for p in np.radians(np.arange(0.0, 360.0, 5.0))]
    zero_feed = max(np.linalg.norm(model.compliance[i] @ model.frames[i] @ f)
                    for i in range(model.n) for f in edge)
    limit = 3.0 * zero_feed
    bound = feed_bound(BoundInputs(model, limit, max_feed=10.0, dq_ds=np.ones((model.n, 6)),
                                   joint_velocity_max=np.full(6, 1e3)))
    assert np.all(bound.active_names() == "deflection")
    phi = np.radians(np.arange(0.0, 360.0, 0.05)) if teeth == 1 else np.zeros(1)
    # the hand-summed force over the revolution at c = 0 and c = 1 mm (it is affine in c)
    f0, f1 = (np.array([_quadrature(teeth, tool.diameter / 2, c, p, PLUNGE, steps=4)[0]
                        for p in phi]) for c in (0.0, 1e-3))
    for i in range(model.n):
        cr = model.compliance[i] @ model.frames[i]

        def ok(c: float, cr=cr) -> bool:
            forces = f0 + (c / 1e-3) * (f1 - f0)
            return bool(np.max(np.linalg.norm(forces @ cr.T, axis=1)) <= limit)

        c_max = _bisect(ok)
        v_want = c_max * teeth * 2000 / 60
        assert bound.v_max[i] == pytest.approx(v_want, rel=1e-6 if teeth > 1 else 2e-5)
    # the replay at the bound reaches the limit
    np.testing.assert_allclose(model.deflection(bound.v_max), limit, rtol=1e-6)


def test_spindle_torque_bound_of_a_plunge_is_the_closed_form():
    model = _plunge_model(2, n=2)
    tool, r = model.tool, model.tool.diameter / 2
    torque_max = 5.0  # N m
    bound = feed_bound(BoundInputs(model, 1.0, max_feed=10.0, dq_ds=np.ones((2, 6)),
                                   joint_velocity_max=np.full(6, 1e3), torque_max=torque_max))
    # T = N (Kcc c + Kce) R^2 / 2 = torque_max
    c = (torque_max / (tool.teeth * r * r / 2) - PLUNGE.torque_edge) / PLUNGE.torque_cutting
    np.testing.assert_allclose(bound.parts["spindle_torque"], c * tool.teeth * 2000 / 60,
                               rtol=1e-12)


def test_mean_deflection_and_distinct_rows_include_the_plunge():
    model = _plunge_model(2, n=3)
    feed = np.array([1e-3, 2e-3, 3e-3])
    c = feed / model.feed_per_unit_c
    want = [model.compliance[i] @ model.frames[i] @ plunge_forces(model.tool, PLUNGE, c[i])[0]
            for i in range(3)]
    np.testing.assert_allclose(model.mean_deflection(feed), want, rtol=1e-12)
    # a constant force leaves no residual over the revolution
    left = dataclasses.replace(model, mode="residual").angle_terms(slice(0, 3))
    full = model.angle_terms(slice(0, 3))
    assert np.all(left.aa <= 1e-20 * full.aa) and np.all(left.bb <= 1e-20 * full.bb)
    two = Engagement(np.zeros(2), np.zeros(2), np.full(2, 1e-3), plunge=np.array([0.0, 1.0]))
    mixed = dataclasses.replace(model, engagement=two, frames=model.frames[:2],
                                compliance=model.compliance[:2])
    unique, row = mixed.distinct_engagements(np.arange(2))
    assert unique.n == 2 and row.tolist() == [0, 1]
    assert mixed.deflection(np.full(2, 1e-3))[0] == 0.0
    assert mixed.deflection(np.full(2, 1e-3))[1] > 0.0


def _moves(categories: list[str]) -> MoveTable:
    m = len(categories)
    return MoveTable(s_start=np.arange(m) * 10e-3, line=np.arange(m) + 5,
                     n_number=np.full(m, -1), category=np.array(categories),
                     kind=np.array(["line"] * m), feed=np.full(m, 5e-3),
                     spindle_rpm=np.full(m, 2000.0), tool=np.ones(m, dtype=int))


def test_program_plunges_below_the_stock_top_are_full_plunges():
    # rapid above, plunge from z = +2 mm to z = -3 mm, a cut at z = -3 mm
    s = np.linspace(0.0, 29.9e-3, 300)
    z = np.where(s < 10e-3, 2e-3, np.where(s < 20e-3, 2e-3 - (s - 10e-3) / 2, -3e-3))
    samples = SimpleNamespace(s=s, position=np.column_stack([s, 0 * s, z]))
    moves = _moves(["rapid", "plunge", "cut"])
    eng = in_program_air(slot_engagement(s.size, 2e-3), moves, samples, 0.0, make_tool(),
                         "job.nc")
    plunge = (s >= 10e-3) & (s < 20e-3) & (z < -1e-9)
    assert eng.plunging.tolist() == plunge.tolist()
    assert np.all(eng.exit[plunge] == eng.entry[plunge])  # no side engagement
    assert np.all(eng.exit[s >= 20e-3] == math.pi)
    # without plunge coefficients: no force model, the mask and the line in a warning
    kept, mask, notes = unmodelled_plunges(eng, TABLE_3_3[2000], moves, samples, "al.yaml")
    assert kept.plunge is None and mask.tolist() == plunge.tolist()
    assert len(notes) == 1 and "line 6" in notes[0] and "'al.yaml' has no plunge" in notes[0]
    same, none, quiet = unmodelled_plunges(eng, SIDE, moves, samples, "al.yaml")
    assert same is eng and not none.any() and quiet == []


def test_a_plunge_deeper_than_the_flutes_is_refused_naming_line_and_flute_length():
    s = np.linspace(0.0, 19.9e-3, 200)
    z = np.where(s < 10e-3, 0.0, -(s - 10e-3) * 3)  # down to 30 mm below the top
    samples = SimpleNamespace(s=s, position=np.column_stack([0 * s, 0 * s, z]))
    with pytest.raises(InputError, match=r"job.nc line 6: the plunge reaches 2[34][.\d]* mm, "
                                         r"more than the flute length 23.8125 mm of tool "
                                         r"'test'"):
        in_program_air(slot_engagement(s.size, 2e-3), _moves(["cut", "plunge"]), samples, 0.0,
                       make_tool(), "job.nc")
