"""Deflection replay vs closed-form bound vs an independent per-sample computation."""

from pathlib import Path

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.coefficients import load_coefficients
from feedopt.process.engagement import peripheral_engagement, slot_engagement
from feedopt.process.forces import Engagement, critical_angles, milling_forces
from feedopt.process.tool import load_tool
from feedopt.schedule.bounds import BoundInputs, feed_bound
from feedopt.schedule.deflection import DeflectionModel, feed_frames

ROOT = Path(__file__).resolve().parents[2]


def _model(n: int = 50, mode: str = "norm", engagement=None, seed: int = 3,
           same_pose: bool = False) -> DeflectionModel:
    rng = np.random.default_rng(seed)
    tool = load_tool(ROOT / "scenarios" / "tools" / "hss_2flute_19mm.yaml")
    coeffs = load_coefficients(ROOT / "scenarios" / "materials" / "6061-T6511.yaml").at(2500)
    # Random SPD compliances of robot magnitude (stiffness ~ 1-10 N/um).
    m = rng.normal(size=(n, 3, 3))
    compliance = (m @ np.swapaxes(m, 1, 2) + 0.5 * np.eye(3)) * 2e-7
    theta = rng.uniform(0, 2 * np.pi, n)
    if same_pose:
        compliance[:] = compliance[0]
        theta[:] = theta[0]
    tangent = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n)])
    axis = np.tile([0.0, 0.0, 1.0], (n, 1))
    return DeflectionModel(
        tool=tool, coefficients=coeffs,
        engagement=engagement or slot_engagement(n, 2.54e-3),
        angles=np.deg2rad(np.arange(0, 180, 1.0)), frames=feed_frames(tangent, axis),
        compliance=compliance, rpm=2500, mode=mode,
    )


def test_frames_are_rotations() -> None:
    rng = np.random.default_rng(0)
    t = rng.normal(size=(20, 3))
    a = rng.normal(size=(20, 3))
    r = feed_frames(t, a)
    np.testing.assert_allclose(r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(r), 1.0)


@pytest.mark.parametrize("cut", ["slot", "down", "up"])
def test_replay_equals_brute_force_sup_over_the_revolution(cut: str) -> None:
    """The replay's max over the revolution (1 deg grid + slice entry/exit angles +
    refinement) equals an independent brute-force maximum on a 0.005 deg grid, also for
    down milling, where the chip is thickest at entry and the force jumps there."""
    n = 6
    eng = (slot_engagement(n, 2.54e-3) if cut == "slot"
           else peripheral_engagement(np.linspace(2e-3, 9.525e-3, n), 19.05e-3, 2.54e-3, cut))
    model = _model(n=n, engagement=eng)
    feed = np.linspace(1e-3, 6e-3, n)
    got = model.deflection(feed)
    fine = np.arange(0.0, np.pi, np.deg2rad(0.005))
    crit = critical_angles(model.tool, model.engagement)
    for i in range(n):
        # A fine uniform grid cannot land on a jump: add the sample's slice entry/exit angles.
        one = Engagement(eng.entry[i:i + 1], eng.exit[i:i + 1], eng.axial_depth[i:i + 1])
        split = milling_forces(model.tool, model.coefficients, one,
                               np.concatenate([fine, crit[i]]))
        c = feed[i] * 60 / (model.tool.teeth * model.rpm)
        f_model = c * split.cutting[0] + split.edge[0]  # (m, 3), independent of the model
        d = (model.compliance[i] @ model.frames[i] @ f_model.T).T
        brute = np.max(np.linalg.norm(d, axis=1))
        assert got[i] == pytest.approx(brute, rel=1e-6)


def test_grid_alone_would_miss_the_entry_jump() -> None:
    """Why the critical angles are needed: on the 1 deg grid only, down milling's maximum
    is underestimated by far more than the 1e-6 the verifier promises."""
    eng = peripheral_engagement(np.full(4, 4.7625e-3), 19.05e-3, 2.54e-3, "down")
    model = _model(n=4, engagement=eng)
    feed = np.full(4, 4e-3)
    c = feed[0] * 60 / (model.tool.teeth * model.rpm)
    split = milling_forces(model.tool, model.coefficients, model.engagement, model.angles)
    grid_only = np.array([
        np.max(np.linalg.norm((model.compliance[i] @ model.frames[i]
                               @ (c * split.cutting[i] + split.edge[i]).T).T, axis=1))
        for i in range(4)])
    assert np.all(model.deflection(feed) > grid_only * (1 + 1e-4))


@pytest.mark.parametrize("mode", ["norm", "normal"])
def test_bound_is_tight_under_replay(mode: str) -> None:
    model = _model(mode=mode)
    zero = model.deflection(np.zeros(model.n))
    limit = 1.5 * zero.max()
    bound = feed_bound(BoundInputs(model, limit, max_feed=1.0, dq_ds=np.ones((model.n, 6)),
                                   joint_velocity_max=np.full(6, 10.0)))
    assert np.all(bound.active_names() == "deflection")
    d = model.deflection(bound.v_max)
    np.testing.assert_allclose(d, limit, rtol=1e-7)
    d_over = model.deflection(bound.v_max * 1.001)
    assert np.all(d_over > limit)


def test_peripheral_zero_immersion_is_unbounded_by_deflection() -> None:
    radial = np.linspace(0.0, 9.525e-3, 30)
    eng = peripheral_engagement(radial, 19.05e-3, 2.54e-3, "down")
    model = _model(n=30, engagement=eng, same_pose=True)
    bound = feed_bound(BoundInputs(model, 0.2e-3, max_feed=0.0127, dq_ds=np.ones((30, 6)),
                                   joint_velocity_max=np.full(6, 10.0)))
    assert bound.v_max[0] == pytest.approx(0.0127)  # no cut: only the max feed binds
    assert np.all(np.diff(bound.parts["deflection"][1:]) <= 1e-12)  # deeper cut, lower bound


def test_edge_forces_alone_exceeding_limit_is_a_clear_error() -> None:
    model = _model()
    zero = model.deflection(np.zeros(model.n))
    positions = np.zeros((model.n, 3))
    with pytest.raises(InputError) as e:
        feed_bound(BoundInputs(model, 0.5 * zero.max(), 0.01, np.ones((model.n, 6)),
                               np.full(6, 10.0), positions=positions))
    msg = str(e.value)
    assert "edge forces alone" in msg and "sample" in msg
    assert f"{zero.max() * 1e3:.4g} mm" in msg


def _pieced_engagement(n: int, seed: int = 5) -> Engagement:
    """Slots and side cuts, every third sample on 1-4 pieces of random depths."""
    from feedopt.process.engagement import EngagementPieces

    rng = np.random.default_rng(seed)
    base = peripheral_engagement(rng.uniform(1e-3, 19.05e-3, n), 19.05e-3, 2.54e-3, "down")
    sample, entry, exit_, depth = [], [], [], []
    for i in range(0, n, 3):
        k = 1 + i % 4
        edges = np.sort(rng.uniform(0.0, np.pi, 2 * k))
        for j in range(k):
            sample.append(i)
            entry.append(edges[2 * j])
            exit_.append(edges[2 * j + 1])
            depth.append(rng.uniform(0.5e-3, 4e-3))
    sample, entry, exit_, depth = map(np.array, (sample, entry, exit_, depth))
    hull_e, hull_x, hull_a = base.entry.copy(), base.exit.copy(), base.axial_depth.copy()
    for i in np.unique(sample):
        m = sample == i
        hull_e[i], hull_x[i], hull_a[i] = entry[m].min(), exit_[m].max(), depth[m].max()
    return Engagement(hull_e, hull_x, hull_a, EngagementPieces(sample, entry, exit_, depth))


@pytest.mark.parametrize("mode", ["norm", "normal"])
def test_pieced_samples_replay_and_bound_as_their_pieces_sum(monkeypatch, mode: str) -> None:
    """Samples on several pieces (random depths) among single-interval ones, in small
    chunks: the replay's maximum equals a brute-force maximum of the summed pieces on a
    0.005 deg grid plus every piece's jump angles, and the bound is tight under replay."""
    import feedopt.schedule.deflection as deflection

    monkeypatch.setattr(deflection, "_CHUNK_ELEMENTS", 7 * 220)  # a few samples per chunk
    n = 13
    eng = _pieced_engagement(n)
    model = _model(n=n, engagement=eng, mode=mode)
    chunks = list(model.sample_chunks(7))
    covered = np.concatenate([np.arange(n)[c] for c in chunks])
    assert sorted(covered.tolist()) == list(range(n))
    feed = np.linspace(1e-3, 6e-3, n)
    got = model.deflection(feed)
    fine = np.arange(0.0, np.pi, np.deg2rad(0.005))
    for i in range(n):
        m = eng.pieces.sample == i
        parts = ([(eng.entry[i], eng.exit[i], eng.axial_depth[i])] if not m.any() else
                 list(zip(eng.pieces.entry[m], eng.pieces.exit[m], eng.pieces.axial_depth[m],
                          strict=True)))
        crit = np.concatenate([critical_angles(model.tool, Engagement(
            np.array([e]), np.array([x]), np.array([a])))[0] for e, x, a in parts])
        angles = np.concatenate([fine, crit])
        c = feed[i] * 60 / (model.tool.teeth * model.rpm)
        f = sum(c * s.cutting[0] + s.edge[0] for s in (
            milling_forces(model.tool, model.coefficients,
                           Engagement(np.array([e]), np.array([x]), np.array([a])), angles)
            for e, x, a in parts))
        d = (model.compliance[i] @ model.frames[i] @ f.T).T
        brute = (np.max(np.linalg.norm(d, axis=1)) if mode == "norm"
                 else np.max(np.abs(d @ model.frames[i][:, 1])))
        assert got[i] == pytest.approx(brute, rel=1e-6)
    zero = model.deflection(np.zeros(n))
    limit = 1.5 * zero.max()
    bound = feed_bound(BoundInputs(model, limit, max_feed=1.0, dq_ds=np.ones((n, 6)),
                                   joint_velocity_max=np.full(6, 10.0)))
    cut = bound.active_names() == "deflection"
    np.testing.assert_allclose(model.deflection(bound.v_max)[cut], limit, rtol=1e-7)
