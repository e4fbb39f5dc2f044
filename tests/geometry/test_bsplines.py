"""Many B-splines in flat arrays (feedopt.geometry.bsplines) against scipy's BSpline one curve
at a time: values, derivatives, the design matrix, arc length (scipy quad) and its inverse."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.interpolate import BSpline

from feedopt.geometry.bsplines import Inverter, SplineBatch, arc_length, arc_table


def _curves(seed: int, m: int, k: int = 5):
    """``m`` clamped degree-k curves with random distinct interior knots and smooth, gently
    curving coefficients (a unit-speed-ish walk), parameter ranges of different lengths."""
    rng = np.random.default_rng(seed)
    knots, coef, ref = [], [], []
    for _ in range(m):
        u_end = 1.0 + 3.0 * rng.uniform()
        inner = np.unique(rng.uniform(0.05, 0.95, rng.integers(0, 7))) * u_end
        t = np.concatenate([np.zeros(k + 1), inner, np.full(k + 1, u_end)])
        n = len(t) - k - 1
        heading = np.cumsum(rng.normal(0.0, 0.3, n))
        step = u_end / n
        cf = np.column_stack([np.cumsum(step * np.cos(heading)),
                              np.cumsum(step * np.sin(heading)), rng.normal(0, 0.02, n)])
        knots.append(t)
        coef.append(cf)
        ref.append(BSpline(t, cf, k))
    return SplineBatch.from_lists(k, knots, coef), ref


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31), m=st.integers(1, 6), k=st.sampled_from([3, 5]))
def test_values_derivatives_and_design_matrix_match_scipy(seed, m, k):
    batch, ref = _curves(seed, m, k)
    rng = np.random.default_rng(seed + 1)
    c = rng.integers(0, m, 400)
    u = rng.uniform(0, 1, 400) * np.array([r.t[-1] for r in ref])[c]
    u[:m] = 0.0  # both ends of every curve
    u[m:2 * m] = np.array([r.t[-1] for r in ref])[np.arange(m)]
    c[:m] = c[m:2 * m] = np.arange(m)
    got = batch.evaluate(c, u, 3)
    for d in range(4):
        want = np.array([(r.derivative(d) if d else r)(x) for r, x in
                         zip((ref[i] for i in c), u, strict=True)])
        scale = max(np.abs(want).max(), 1.0)
        np.testing.assert_allclose(got[d], want, atol=1e-10 * scale)
    np.testing.assert_allclose(batch.derivative.evaluate(c, u)[0], got[1], atol=1e-10)
    dm = batch.design_matrix(c, u).toarray()
    for i in range(m):
        rows = c == i
        cols = slice(batch.coef_start[i], batch.coef_start[i + 1])
        want = BSpline.design_matrix(u[rows], ref[i].t, k).toarray()
        np.testing.assert_allclose(dm[rows][:, cols], want, atol=1e-12)
        assert np.all(np.delete(dm[rows], np.arange(cols.start, cols.stop), axis=1) == 0)


def test_arc_length_and_its_inverse_against_quadrature():
    batch, ref = _curves(3, 4)
    table = arc_table(batch, 2)
    for i, r in enumerate(ref):
        d1 = r.derivative()
        ends = np.unique(r.t)
        exact = sum(quad(lambda x, d1=d1: np.linalg.norm(d1(x)), a, b, epsabs=1e-14,
                         epsrel=1e-12)[0] for a, b in zip(ends[:-1], ends[1:], strict=True))
        assert table.length[i] == pytest.approx(exact, rel=1e-9)
    inv = Inverter.of(batch, table)
    rng = np.random.default_rng(5)
    c = rng.integers(0, 4, 5000)
    s = rng.uniform(0, 1, 5000) * table.length[c]
    u = inv.invert(c, s)
    np.testing.assert_allclose(arc_length(batch, table, c, u), s,
                               atol=1.01e-12 * table.length.max())
