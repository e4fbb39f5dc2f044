"""Deflection replay vs closed-form bound vs an independent per-sample computation."""

from pathlib import Path

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.coefficients import load_coefficients
from feedopt.process.engagement import peripheral_engagement, slot_engagement
from feedopt.process.forces import milling_forces
from feedopt.process.tool import load_tool
from feedopt.schedule.bounds import feed_bound
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


def test_replay_matches_independent_computation() -> None:
    model = _model(n=7)
    feed = np.linspace(1e-3, 6e-3, 7)
    got, _ = model.deflection(feed)
    # Independent: forces at the commanded feed per tooth, one sample at a time.
    split = milling_forces(model.tool, model.coefficients, model.engagement, model.angles)
    for i in range(7):
        c = feed[i] * 60 / (model.tool.teeth * model.rpm)
        f_model = c * split.cutting[i] + split.edge[i]  # (m, 3)
        d = (model.compliance[i] @ model.frames[i] @ f_model.T).T
        assert got[i] == pytest.approx(np.max(np.linalg.norm(d, axis=1)), rel=1e-12)


@pytest.mark.parametrize("mode", ["norm", "normal"])
def test_bound_is_tight_under_replay(mode: str) -> None:
    model = _model(mode=mode)
    zero, _ = model.deflection(np.zeros(model.n))
    limit = 1.5 * zero.max()
    bound = feed_bound(model, limit, max_feed=1.0, dq_ds=np.ones((model.n, 6)),
                       joint_velocity_max=np.full(6, 10.0))
    assert np.all(bound.active_names() == "deflection")
    d, _ = model.deflection(bound.v_max)
    np.testing.assert_allclose(d, limit, rtol=1e-9)
    d_over, _ = model.deflection(bound.v_max * 1.001)
    assert np.all(d_over > limit)


def test_peripheral_zero_immersion_is_unbounded_by_deflection() -> None:
    radial = np.linspace(0.0, 9.525e-3, 30)
    eng = peripheral_engagement(radial, 19.05e-3, 2.54e-3, "down")
    model = _model(n=30, engagement=eng, same_pose=True)
    bound = feed_bound(model, 0.2e-3, max_feed=0.0127, dq_ds=np.ones((30, 6)),
                       joint_velocity_max=np.full(6, 10.0))
    assert bound.v_max[0] == pytest.approx(0.0127)  # no cut: only the max feed binds
    assert np.all(np.diff(bound.parts["deflection"][1:]) <= 1e-12)  # deeper cut, lower bound


def test_edge_forces_alone_exceeding_limit_is_a_clear_error() -> None:
    model = _model()
    zero, _ = model.deflection(np.zeros(model.n))
    positions = np.zeros((model.n, 3))
    with pytest.raises(InputError) as e:
        feed_bound(model, 0.5 * zero.max(), 0.01, np.ones((model.n, 6)), np.full(6, 10.0),
                   positions=positions)
    msg = str(e.value)
    assert "edge forces alone" in msg and "sample" in msg
    assert f"{zero.max() * 1e3:.4g} mm" in msg
