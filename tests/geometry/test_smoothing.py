"""Smoothing of chains of short moves (feedopt.geometry.smoothing), checked independently:
brute-force distances to the polyline, Newton projections through Path.evaluate, finite
differences of the evaluated path and scipy's own quadrature of the arc length."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

from feedopt.errors import InputError
from feedopt.geometry import smoothing
from feedopt.geometry.path import Path, Segment, build_lipb_path
from feedopt.geometry.registry import segment_kinds
from feedopt.geometry.smoothing import SmoothedChain, smooth_chain
from feedopt.units import MM

R = 20 * MM


def _path(*chains: SmoothedChain) -> Path:
    segs, s0 = [], 0.0
    for ch in chains:
        segs.append(Segment("spline", s0, ch.length, -1, ch.params))
        s0 += ch.length
    return Path(segs)


def _circle_points(n: int = 120, chord: float = 0.3 * MM) -> np.ndarray:
    dth = 2 * np.arcsin(chord / (2 * R))
    th = np.arange(n + 1) * dth
    return np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros_like(th)])


def _sines(k: int, seed: int = 0, lo: float = 0.05 * MM, hi: float = 1.0 * MM) -> np.ndarray:
    """k moves of random length in [lo, hi] on a slowly varying sum of sines."""
    rng = np.random.default_rng(seed)
    s = np.concatenate([[0.0], np.cumsum(rng.uniform(lo, hi, k))])
    return np.column_stack([s, 5 * MM * np.sin(s / (30 * MM)) + 2 * MM * np.sin(s / (11 * MM)),
                            1 * MM * np.sin(s / (50 * MM))])


def _dist_to_polyline(x: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Brute force: distance of every point to every move of the polyline, the minimum."""
    a, v = pts[:-1], np.diff(pts, axis=0)
    ll = np.maximum(np.einsum("ij,ij->i", v, v), 1e-300)
    out = np.empty(len(x))
    for lo in range(0, len(x), 1000):
        rel = x[lo:lo + 1000, None, :] - a[None]
        f = np.clip(np.einsum("nkj,kj->nk", rel, v) / ll, 0.0, 1.0)
        out[lo:lo + 1000] = np.linalg.norm(rel - f[..., None] * v, axis=2).min(axis=1)
    return out


def _dist_to_curve(pts: np.ndarray, path: Path, spacing: float) -> np.ndarray:
    """Nearest dense sample, then Newton on (p(s) - x).T(s) = 0 through Path.evaluate."""
    dense = path.sample(spacing)
    _, i = cKDTree(dense.position).query(pts)
    s = dense.s[i]
    for _ in range(6):
        e = path.evaluate(s)
        rel = e.position - pts
        g = np.einsum("ij,ij->i", rel, e.tangent)
        gp = 1.0 + np.einsum("ij,ij->i", rel, e.curvature)
        s = np.clip(s - g / np.maximum(gp, 0.5), 0.0, path.length)
    return np.linalg.norm(path.evaluate(s).position - pts, axis=1)


def _check_within(ch: SmoothedChain, pts: np.ndarray, tol: float, spacing: float) -> Path:
    assert ch.deviation <= tol and ch.coverage <= tol
    path = _path(ch)
    dev = _dist_to_polyline(path.sample(spacing).position, pts).max()
    cov = _dist_to_curve(pts, path, spacing).max()
    assert dev <= tol * (1 + 1e-6), (dev / MM, ch.deviation / MM)
    assert cov <= tol * (1 + 1e-6), (cov / MM, ch.coverage / MM)
    # the reported values are measurements, not just bounds far off
    assert dev <= ch.deviation * (1 + 1e-3) + 1e-12, (dev / ch.deviation, dev / tol)
    assert cov <= ch.coverage * (1 + 1e-6) + 1e-12
    return path


def test_registered_kind():
    kind = next(k for k in segment_kinds() if k.name == "spline")
    assert kind is smoothing.SPLINE
    assert kind.evaluator is smoothing.SplineEvaluator and kind.colour == "tab:cyan"


def test_circle_arc_within_tolerance_and_true_circle():
    pts = _circle_points()
    tol = 0.01 * MM
    ch = smooth_chain(pts, tol)
    path = _check_within(ch, pts, tol, 0.01 * MM)
    sag = R - np.sqrt(R**2 - (0.15 * MM) ** 2)
    e = path.sample(0.01 * MM)
    r = np.linalg.norm(e.position[:, :2], axis=1)
    assert np.abs(r - R).max() <= tol + sag
    assert np.abs(e.position[:, 2]).max() <= 1e-12
    inner = (e.s > 2 * MM) & (e.s < path.length - 2 * MM)
    kappa = np.linalg.norm(e.curvature[inner], axis=1)
    np.testing.assert_allclose(kappa * R, 1.0, rtol=0.03)
    # in the plane, turning left: the curvature vector points to the centre
    assert np.all(np.einsum("ij,ij->i", e.curvature[inner], -e.position[inner]) > 0)
    assert ch.length == pytest.approx(R * np.arctan2(pts[-1, 1], pts[-1, 0]), abs=tol)
    assert np.all(np.diff(ch.node_s) >= 0)
    assert ch.node_s[0] == 0.0 and ch.node_s[-1] == ch.length
    # node_s: the curve points at node_s are the ones closest to the input points
    d_node = np.linalg.norm(path.evaluate(ch.node_s).position - pts, axis=1)
    np.testing.assert_allclose(d_node, _dist_to_curve(pts, path, 0.01 * MM), atol=1e-9)


@pytest.mark.parametrize("tangents", ["none", "true", "tilted"])
def test_end_points_exact_and_end_tangents(tangents):
    pts = _circle_points(60)
    tol = 0.005 * MM
    th_end = np.arctan2(pts[-1, 1], pts[-1, 0])
    t0, t1 = np.array([0.0, 1.0, 0.0]), np.array([-np.sin(th_end), np.cos(th_end), 0.0])
    if tangents == "tilted":  # 1 degree off the circle, partly out of its plane, not unit
        t0 = 3.0 * (t0 + np.radians(1.0) * np.array([0.6, 0.0, 0.8]))
        t1 = 0.5 * (t1 + np.radians(1.0) * np.array([0.0, 0.0, -1.0]))
    kw = {} if tangents == "none" else {"start_tangent": t0, "end_tangent": t1}
    ch = smooth_chain(pts, tol, **kw)
    path = _check_within(ch, pts, tol, 0.005 * MM)
    e = path.evaluate([0.0, path.length])
    np.testing.assert_allclose(e.position, pts[[0, -1]], rtol=0, atol=1e-9)
    if tangents != "none":
        np.testing.assert_allclose(e.tangent[0], t0 / np.linalg.norm(t0), atol=1e-9)
        np.testing.assert_allclose(e.tangent[1], t1 / np.linalg.norm(t1), atol=1e-9)


def _fd_curvature_steps(position: np.ndarray, h: float) -> float:
    """Max change from one sample to the next of the curvature |p[i+1] - 2p[i] + p[i-1]|/h^2."""
    kappa = np.linalg.norm(position[2:] - 2 * position[1:-1] + position[:-2], axis=1) / h**2
    return float(np.abs(np.diff(kappa)).max())


def test_curvature_is_continuous_by_finite_differences():
    pts = _sines(300, seed=3, lo=0.1 * MM, hi=0.5 * MM)
    path = _path(smooth_chain(pts, 0.01 * MM))
    lipb = build_lipb_path(pts, "bezier5", 0.002 * MM)  # tiny G2 blends at every vertex

    def steps(p: Path, h: float) -> float:
        n = int(p.length / h)
        return _fd_curvature_steps(p.evaluate(np.arange(n + 1) * h).position, h)

    spline_ratio = steps(path, 0.1 * MM) / steps(path, 0.05 * MM)
    lipb_ratio = steps(lipb, 0.1 * MM) / steps(lipb, 0.05 * MM)
    assert 1.6 < spline_ratio < 2.5, spline_ratio  # change per sample ~ kappa' h: halves
    assert lipb_ratio < 1.2, lipb_ratio  # the vertices' spikes do not shrink


def test_tangent_and_curvature_match_finite_differences():
    pts = _sines(200, seed=1)
    ch = smooth_chain(pts, 0.005 * MM, start_tangent=[1, 0.3, 0.05])
    path = _path(ch)
    knots = np.unique(ch.params["knots"])
    # a few points, one of them at the arc length of an interior knot
    s_k = smoothing._Chain(ch.params).arc_length(knots[len(knots) // 2:len(knots) // 2 + 1])
    s = np.concatenate([np.linspace(0.02, 0.9, 6) * path.length, s_k])
    h = 1e-6
    e, ep, em = path.evaluate(s), path.evaluate(s + h), path.evaluate(s - h)
    np.testing.assert_allclose(e.tangent, (ep.position - em.position) / (2 * h), atol=1e-8)
    scale = np.abs(e.curvature).max()
    np.testing.assert_allclose(e.curvature, (ep.tangent - em.tangent) / (2 * h),
                               atol=1e-5 * scale)
    scale3 = np.abs(e.dcurvature).max()
    np.testing.assert_allclose(e.dcurvature, (ep.curvature - em.curvature) / (2 * h),
                               atol=1e-4 * scale3)
    np.testing.assert_allclose(np.linalg.norm(e.tangent, axis=1), 1.0, atol=1e-12)


def _polyline_turn_curvature(pts: np.ndarray) -> np.ndarray:
    v = np.diff(pts, axis=0)
    ln = np.linalg.norm(v, axis=1)
    u = v / ln[:, None]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1, 1))
    return turn / (0.5 * (ln[:-1] + ln[1:]))


def test_noisy_chain_is_smoothed_within_tolerance():
    rng = np.random.default_rng(7)
    tol = 0.01 * MM
    pts = _sines(400, seed=7, lo=0.1 * MM, hi=0.4 * MM)
    clean = pts.copy()
    d = rng.normal(size=pts.shape)
    d *= (0.3 * tol * rng.uniform(0, 1, len(pts)) / np.linalg.norm(d, axis=1))[:, None]
    pts[1:-1] += d[1:-1]
    ch = smooth_chain(pts, tol)
    path = _check_within(ch, pts, tol, 0.01 * MM)
    kappa = np.linalg.norm(path.sample(0.01 * MM).curvature, axis=1).max()
    noisy = _polyline_turn_curvature(pts).max()
    true = _polyline_turn_curvature(clean).max()
    assert kappa < 0.2 * noisy, (kappa * MM, noisy * MM)
    assert kappa < 2.0 * true, (kappa * MM, true * MM)


@st.composite
def _chains(draw):
    """Random smooth chains: curvature a + b sin(c s + d) in a tilted plane plus a slow rise,
    moves of random lengths, a tolerance, and sometimes the true end tangents."""
    k = draw(st.integers(3, 120))
    seed = draw(st.integers(0, 2**31))
    rng = np.random.default_rng(seed)
    lo = draw(st.sampled_from([0.05, 0.2])) * MM
    steps = rng.uniform(lo, 1.0 * MM, k)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    a = draw(st.floats(-1 / 10, 1 / 10)) / MM
    b = draw(st.floats(0, 1 / 10)) / MM
    c = draw(st.floats(0.01, 0.3)) / MM
    ph = draw(st.floats(0, 2 * np.pi))
    fine = np.linspace(0, s[-1], 20 * k + 1)
    kappa = a + b * np.sin(c * fine + ph)
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * np.diff(fine))])
    xy = np.column_stack([np.cos(heading), np.sin(heading)])
    planar = np.concatenate([[[0.0, 0.0]], np.cumsum(0.5 * (xy[1:] + xy[:-1])
                                                      * np.diff(fine)[:, None], axis=0)])
    rise = draw(st.floats(-0.2, 0.2))
    curve = np.column_stack([planar, rise * fine])
    tilt = draw(st.floats(0, 1.0))
    rot = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    curve = curve @ rot.T
    pts = np.column_stack([np.interp(s, fine, curve[:, i]) for i in range(3)])
    tangent = np.gradient(curve, fine, axis=0)
    tol = draw(st.sampled_from([0.002, 0.005, 0.01, 0.05])) * MM
    ends = draw(st.booleans())
    kw = {"start_tangent": tangent[0], "end_tangent": tangent[-1]} if ends else {}
    return pts, tol, kw


@settings(max_examples=40)
@given(_chains())
def test_random_smooth_chains_within_tolerance(case):
    pts, tol, kw = case
    ch = smooth_chain(pts, tol, **kw)
    path = _check_within(ch, pts, tol, min(tol, 0.02 * MM))
    e = path.evaluate([0.0, path.length])
    np.testing.assert_allclose(e.position, pts[[0, -1]], rtol=0, atol=1e-9)
    if kw:
        t0 = kw["start_tangent"] / np.linalg.norm(kw["start_tangent"])
        np.testing.assert_allclose(e.tangent[0], t0, atol=1e-9)
    assert np.all(np.diff(ch.node_s) >= 0) and ch.node_s[-1] == ch.length


def _quad_length(d1: BSpline, knots: np.ndarray, x: float) -> float:
    """Arc length from the curve's start to parameter x by scipy quad, knot span by span."""
    ends = np.append(knots[knots < x], x)
    return sum(quad(lambda t: np.linalg.norm(d1(t)), lo, hi, epsabs=1e-15, epsrel=1e-13)[0]
               for lo, hi in zip(ends[:-1], ends[1:], strict=True))


def test_arc_length_against_quadrature_and_several_chains():
    """Two chains and a line between them in one path: positions at s equal the B-spline at
    the parameter whose arc length (scipy quad) is s; a trimmed segment (offset) too."""
    a = smooth_chain(_sines(150, seed=4), 0.01 * MM)
    pts_b = _circle_points(80) + np.array([0.3, 0.0, 0.0])
    b = smooth_chain(pts_b, 0.005 * MM)
    line = {"origin": np.zeros(3), "direction": np.array([0.0, 0.0, 1.0])}
    segs = [Segment("spline", 0.0, a.length, -1, a.params),
            Segment("line", a.length, 0.01, -1, line),
            Segment("spline", a.length + 0.01, b.length - 1 * MM, -1, b.params, offset=1 * MM)]
    path = Path(segs)
    for ch, seg in ((a, segs[0]), (b, segs[2])):
        bs = BSpline(ch.params["knots"], ch.params["coefficients"], int(ch.params["degree"]))
        d1 = bs.derivative()
        knots = np.unique(ch.params["knots"])
        u = np.array([0.37, 0.81]) * knots[-1]
        s_u = np.array([_quad_length(d1, knots, x) for x in u])
        assert ch.length == pytest.approx(_quad_length(d1, knots, knots[-1]), rel=1e-12)
        e = path.evaluate(seg.s_start + s_u - seg.offset)
        np.testing.assert_allclose(e.position, bs(u), rtol=0, atol=1e-10)
        np.testing.assert_array_equal(e.segment, [segs.index(seg)] * 2)
    # interleaved samples of both chains in one call equal separate calls
    s = np.linspace(0, path.length, 2001)
    rng = np.random.default_rng(0)
    perm = rng.permutation(s.size)
    np.testing.assert_array_equal(path.evaluate(s[perm]).position, path.evaluate(s).position[perm])


def test_inversion_reaches_its_tolerance():
    ch = smooth_chain(_sines(2000, seed=5), 0.005 * MM)
    chain = smoothing._Chain(ch.params)
    s = np.random.default_rng(1).uniform(0, ch.length, 20000)
    t = chain.invert(s)
    assert np.abs(chain.arc_length(t) - s).max() <= 1e-12 * ch.length * 1.01


@pytest.mark.parametrize(("points", "tol", "kw", "match"), [
    (np.zeros((3, 3)) + np.arange(3)[:, None] * MM, 0.01 * MM, {}, "at least 3 moves"),
    (np.arange(12.0).reshape(4, 3) * MM, 0.0, {}, "tolerance must be a positive"),
    (np.arange(12.0).reshape(4, 3) * MM, -1e-5, {}, "tolerance must be a positive"),
    (np.arange(12.0).reshape(4, 3) * MM, np.nan, {}, "tolerance must be a positive"),
    (np.array([[0, 0, 0], [1, 0, 0], [np.nan, 0, 0], [3, 0, 0]]) * MM, 1e-5, {},
     "point 2 is not finite"),
    (np.arange(12.0).reshape(4, 3) * MM, 1e-5, {"start_tangent": [0, 0, 0]}, "non-zero"),
    (np.arange(12.0).reshape(4, 3) * MM, 1e-5, {"end_tangent": [-1, -1, -1]}, "backwards"),
    (np.zeros((5, 3)), 1e-5, {}, "all its points coincide"),
    (np.zeros((5, 4)), 1e-5, {}, r"\(n, 3\) array"),
])
def test_bad_input(points, tol, kw, match):
    with pytest.raises(InputError, match=match):
        smooth_chain(points, tol, **kw)


def test_sharp_corner_is_refused_or_followed():
    """A 90 degree corner in the chain: the spline either follows it within the tolerance or
    the call says where it cannot."""
    pts = np.array([[x, 0, 0] for x in range(6)] + [[5, y, 0] for y in range(1, 6)]) * MM
    try:
        ch = smooth_chain(pts, 0.01 * MM)
    except InputError as exc:
        assert "split the chain" in str(exc)
    else:
        _check_within(ch, pts, 0.01 * MM, 0.002 * MM)


def test_chains_fitted_together_are_each_within_their_tolerance_and_as_fitted_alone():
    """smooth_chains: chains of different sizes and tolerances in one call; each checked by
    brute force against its own polyline, and the same curve as its own smooth_chain call
    (the batch mixes nothing between chains)."""
    from feedopt.geometry.smoothing import smooth_chains

    chains = [_sines(40, seed=1), _circle_points(30), _sines(300, seed=2, lo=0.1 * MM),
              _sines(3, seed=3), _circle_points(200, chord=0.2 * MM)]
    tols = [0.01 * MM, 0.005 * MM, 0.02 * MM, 0.01 * MM, 0.002 * MM]
    together = smooth_chains(chains, tols)
    for pts, tol, ch in zip(chains, tols, together, strict=True):
        _check_within(ch, pts, tol, min(tol, 0.01 * MM))
        alone = smooth_chain(pts, tol)
        # (the chord lengths of the flat arrays round differently: 1e-15 m)
        np.testing.assert_allclose(ch.params["knots"], alone.params["knots"], rtol=0,
                                   atol=1e-13)
        np.testing.assert_allclose(ch.params["coefficients"], alone.params["coefficients"],
                                   rtol=0, atol=1e-10)
        assert ch.length == pytest.approx(alone.length, rel=1e-12)
    assert smooth_chains([], []) == []
