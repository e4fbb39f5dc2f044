"""G0/G1/G2 jumps at junctions: circle 1/r, the other blends at numerical noise level."""

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from feedopt.geometry import waves
from feedopt.geometry.continuity import ContinuityReport, continuity_report
from feedopt.geometry.path import build_lipb_path

G2_KINDS = ["bezier4", "bezier5", "varying_radius"]


def _check(report: ContinuityReport, kind: str, size: float, scale: float) -> None:
    assert np.all(report.g0 <= 1e-12 * scale)
    assert np.all(report.g1 <= 1e-10)
    blend_side = np.array([a != "line" or b != "line"
                           for a, b in zip(report.kind_before, report.kind_after, strict=True)])
    assert blend_side.all()  # every junction touches a blend
    if kind == "circle":
        np.testing.assert_allclose(report.g2, 1.0 / size, rtol=1e-12)
    else:
        assert np.all(report.g2 <= 1e-7 / size)


@pytest.mark.parametrize("kind", ["circle", *G2_KINDS])
@pytest.mark.parametrize("wave", [waves.triangle_wave, waves.square_wave])
def test_thesis_waves(kind, wave):
    r = 0.0127
    path = build_lipb_path(wave(), kind, r)
    rep = continuity_report(path)
    n_corners = len(wave()) - 2
    assert len(rep) == 2 * n_corners
    _check(rep, kind, r, 0.3)
    assert sorted(set(rep.corner_index.tolist())) == list(range(1, n_corners + 1))


def test_no_blend_reports_the_kinks():
    w = waves.triangle_wave()
    rep = continuity_report(build_lipb_path(w, "none", 0))
    turn = 2 * np.arctan2(76.2, 50.8)
    np.testing.assert_allclose(rep.g1, 2 * np.sin(turn / 2), rtol=1e-12)
    assert np.all(rep.g0 <= 1e-16) and np.all(rep.g2 == 0)


def test_report_table_format():
    rep = continuity_report(build_lipb_path(waves.square_wave(), "circle", 0.0127))
    text = rep.table()
    assert "G2_1_mm" in text
    assert f"{1 / 12.7:.3g}" in text  # 1/r in 1/mm
    short = rep.table(max_rows=4)
    assert "junctions omitted" in short and len(short.splitlines()) == 1 + 4 + 1 + 1


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(["circle", *G2_KINDS]),
    turn=st.floats(0.01, 3.03),
    rot=st.integers(0, 2**32 - 1),
    mirror=st.booleans(),
    frac=st.floats(0.05, 1.0),
)
def test_single_corner_any_orientation_and_direction(kind, turn, rot, mirror, frac):
    """A corner rotated anywhere in 3D (and mirrored: other turning direction)."""
    l1, l2 = 0.05, 0.07
    w = np.array([[-l1, 0, 0], [0, 0, 0], [l2 * np.cos(turn), l2 * np.sin(turn), 0]])
    if mirror:
        w[:, 1] *= -1
    R = Rotation.random(random_state=rot).as_matrix()
    w = w @ R.T + np.array([0.3, -0.2, 0.5])
    room = 0.5 * min(l1, l2)
    size = frac * (room / np.tan(turn / 2) if kind in ("circle", "varying_radius") else room)
    path = build_lipb_path(w, kind, size)
    rep = continuity_report(path)
    _check(rep, kind, size, 1.0)
    blend = path.segments[1]
    assert blend.kind == kind
    p = path.evaluate([blend.s_start, blend.s_end]).position
    ls = size * np.tan(turn / 2) if kind in ("circle", "varying_radius") else size
    assert np.linalg.norm(p[0] - w[1]) == pytest.approx(ls, rel=1e-9)
    assert np.linalg.norm(p[1] - w[1]) == pytest.approx(ls, rel=1e-9)
    # the blend bends towards the inside of the corner: mid-point within the triangle
    mid = path.evaluate(blend.s_start + blend.length / 2)
    inward = (w[0] - w[1]) / l1 + (w[2] - w[1]) / l2
    assert (mid.position[0] - w[1]) @ inward > 0
    assert mid.curvature[0] @ inward > 0  # curving around the inside of the corner
    # planar: no component out of the corner plane
    normal = np.cross(w[1] - w[0], w[2] - w[1])
    pts = path.sample(size / 20)
    assert np.max(np.abs((pts.position - w[1]) @ normal)) <= 1e-12 * np.linalg.norm(normal)


@st.composite
def polylines(draw):
    n = draw(st.integers(3, 9))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n - 1, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    lens = rng.uniform(0.01, 0.1, size=n - 1)
    return np.vstack([np.zeros(3), np.cumsum(d * lens[:, None], axis=0)])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(w=polylines(), kind=st.sampled_from(["circle", *G2_KINDS]), frac=st.floats(0.1, 1.0))
def test_random_3d_polylines(w, kind, frac):
    v = np.diff(w, axis=0)
    lens = np.linalg.norm(v, axis=1)
    d = v / lens[:, None]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1, 1))
    assume(turn.max() < np.pi - (0.11 if kind == "bezier4" else 0.02) and turn.min() > 1e-3)
    room = 0.5 * np.minimum(lens[:-1], lens[1:])
    if kind in ("circle", "varying_radius"):
        size = frac * np.min(room / np.tan(turn / 2))
    else:
        size = frac * room.min()
    assume(size > 1e-5)
    path = build_lipb_path(w, kind, size)
    rep = continuity_report(path)
    _check(rep, kind, size, 1.0)
    assert sum(g.kind == kind for g in path.segments) == len(w) - 2
    # the path still starts and ends at the end waypoints
    ends = path.evaluate([0, path.length]).position
    np.testing.assert_allclose(ends, w[[0, -1]], atol=1e-14)
    # and is at most as long as the polyline (blends cut corners)
    assert path.length < lens.sum()
