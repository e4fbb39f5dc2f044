"""Arc-length parameterisation and derivatives of Path, checked by finite differences."""

import numpy as np
import pytest

from feedopt.geometry import waves
from feedopt.geometry.path import Path, PathPoints, build_lipb_path

KINDS = ["circle", "bezier4", "bezier5", "varying_radius"]
# 8th-order central difference for the first derivative
_C8 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])


def _fd(f, s, h):
    """First derivative of f (n,3)-valued at s by an 8th-order stencil."""
    out = 0.0
    for k, c in zip(range(-4, 5), _C8, strict=True):
        if c:
            out = out + c * f(s + k * h)
    return out / h


def _interior_samples(path: Path, h: float, per_segment: int = 7) -> np.ndarray:
    s = []
    for g in path.segments:
        if g.length > 10 * h:
            s.append(np.linspace(g.s_start + 5 * h, g.s_end - 5 * h, per_segment))
    return np.concatenate(s)


def _paths():
    out = []
    for kind in KINDS:
        out.append((kind, 0.0127, build_lipb_path(waves.triangle_wave(), kind, 0.0127)))
        out.append((kind, 0.0127, build_lipb_path(waves.square_wave(), kind, 0.0127)))
        w3 = np.array([[0, 0, 0], [0.05, 0.01, 0.02], [0.06, 0.06, -0.01], [0.1, 0.05, 0.05],
                       [0.12, 0.0, 0.0]])
        out.append((kind, 0.004, build_lipb_path(w3, kind, 0.004)))
    return out


@pytest.mark.parametrize(("kind", "size", "path"), _paths())
def test_unit_speed_and_derivatives_by_finite_differences(kind, size, path):
    h = 0.01 * size
    s = _interior_samples(path, h)
    pts = path.evaluate(s)

    def pos(x):
        return path.evaluate(x).position - path.evaluate(s).position  # reduce rounding

    dp = _fd(pos, s, h)
    # |dp/ds| = 1 within 1e-9 (finite differences, independent of the tangent output)
    assert np.max(np.abs(np.linalg.norm(dp, axis=1) - 1.0)) < 1e-9
    np.testing.assert_allclose(pts.tangent, dp, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(pts.tangent, axis=1), 1.0, atol=1e-14)
    # curvature vector = d tangent / ds, its derivative = d curvature / ds
    kscale = 1.0 / size
    dk = _fd(lambda x: path.evaluate(x).tangent, s, h)
    np.testing.assert_allclose(pts.curvature, dk, atol=1e-8 * kscale)
    ddk = _fd(lambda x: path.evaluate(x).curvature, s, h)
    np.testing.assert_allclose(pts.dcurvature, ddk, atol=1e-6 * kscale**2)
    # curvature is normal to the tangent
    assert np.max(np.abs(np.einsum("ij,ij->i", pts.curvature, pts.tangent))) < 1e-9 * kscale


def test_sample_spacing_and_ends():
    path = build_lipb_path(waves.triangle_wave(), "bezier5", 0.0127)
    pts = path.sample(1e-4)
    n = int(np.ceil(path.length / 1e-4)) + 1
    assert isinstance(pts, PathPoints)
    assert pts.s.shape == (n,) and pts.position.shape == (n, 3)
    assert pts.s[0] == 0 and pts.s[-1] == path.length
    assert np.all(np.diff(pts.s) <= 1e-4 + 1e-15)
    np.testing.assert_allclose(pts.position[0], 0, atol=1e-15)
    np.testing.assert_allclose(pts.position[-1], [0.3048, 0, 0], atol=1e-15)
    # total length against the chord sum of the dense samples: a chord of an arc of length
    # h is shorter by kappa^2 h^3 / 24 (+ O(h^5))
    h = np.diff(pts.s)
    chords = np.linalg.norm(np.diff(pts.position, axis=0), axis=1)
    kappa2 = np.sum(pts.curvature[:-1] * pts.curvature[1:], axis=1)
    deficit = np.sum(kappa2 * h**3) / 24
    assert path.length - chords.sum() == pytest.approx(deficit, rel=1e-3)


def test_segment_bookkeeping():
    path = build_lipb_path(waves.square_wave(), "circle", 0.0127)
    assert path.segment_kind[0] == "line" and path.segment_kind[1] == "circle"
    np.testing.assert_allclose(path.segment_start,
                               [g.s_start for g in path.segments])
    lengths = np.array([g.length for g in path.segments])
    assert path.length == pytest.approx(lengths.sum(), rel=1e-15)
    # circle blend lengths: quarter circles
    arcs = [g for g in path.segments if g.kind == "circle"]
    assert len(arcs) == 12
    np.testing.assert_allclose([g.length for g in arcs], 0.0127 * np.pi / 2, rtol=1e-14)
    assert [g.corner_index for g in arcs] == list(range(1, 13))
    # a junction belongs to the segment that starts there; s = L to the last one
    pts = path.evaluate(np.concatenate([path.segment_start, [path.length]]))
    np.testing.assert_array_equal(pts.segment, list(range(len(path.segments))) + [
        len(path.segments) - 1])
    # scalar input works and is vectorised to shape (1,)
    assert path.evaluate(0.01).position.shape == (1, 3)
    with pytest.raises(ValueError):
        path.evaluate([-1e-3])


def test_none_blend_is_the_polyline():
    w = waves.triangle_wave()
    path = build_lipb_path(w, "none", 0.0)
    assert path.segment_kind == ("line",) * 6
    assert path.length == pytest.approx(np.linalg.norm(np.diff(w, axis=0), axis=1).sum())
    np.testing.assert_allclose(path.evaluate(path.segment_start).position, w[:-1], atol=1e-16)


def test_two_dimensional_waypoints_are_z_zero():
    w = waves.triangle_wave()
    a = build_lipb_path(w[:, :2], "bezier4", 0.01)
    b = build_lipb_path(w, "bezier4", 0.01)
    assert a.length == b.length
