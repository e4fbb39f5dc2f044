"""The closed-form feed bound against brute force (issue 5)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.schedule.bounds import (
    joint_velocity_feed_bound,
    largest_feed_per_tooth_norm,
    largest_feed_per_tooth_projected,
)


def _brute_force_norm(a: np.ndarray, b: np.ndarray, limit: float) -> float:
    """Largest c with max_phi |c a + b| <= limit: coarse scan, then bisection."""
    def ok(c: float) -> bool:
        return bool(np.max(np.linalg.norm(c * a + b, axis=-1)) <= limit)

    cs = np.linspace(0.0, 10.0, 20001)
    feasible = np.array([ok(c) for c in cs])
    if feasible.all():
        return np.inf
    hi_i = int(np.argmin(feasible))  # first infeasible feed of the scan
    lo, hi = cs[hi_i - 1], cs[hi_i]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(1, 40))
def test_norm_bound_equals_brute_force(seed: int, m: int) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(1, m, 3))
    b = rng.normal(size=(1, m, 3)) * 0.3
    limit = float(np.max(np.linalg.norm(b, axis=-1))) * rng.uniform(1.05, 3.0)
    got = largest_feed_per_tooth_norm(a, b, limit)[0]
    want = _brute_force_norm(a[0], b[0], limit)
    assert got == pytest.approx(want, rel=1e-4)
    # At the bound the limit is reached exactly at some angle.
    assert np.max(np.linalg.norm(got * a + b, axis=-1)) == pytest.approx(limit, rel=1e-9)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_projected_bound_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(1, 30))
    b = rng.normal(size=(1, 30)) * 0.3
    limit = float(np.max(np.abs(b))) * rng.uniform(1.05, 3.0)
    got = largest_feed_per_tooth_projected(a, b, limit)[0]
    cs = np.linspace(0, 20, 200001)
    feasible = np.max(np.abs(cs[:, None] * a[0] + b[0]), axis=1) <= limit
    want = cs[np.argmin(feasible) - 1] if not feasible.all() else np.inf
    assert got == pytest.approx(want, rel=1e-4, abs=2e-4)


def test_no_cutting_force_means_no_bound() -> None:
    a = np.zeros((1, 5, 3))
    b = np.full((1, 5, 3), 0.1)
    assert np.isinf(largest_feed_per_tooth_norm(a, b, 1.0)[0])


def test_cancellation_safe_when_b_along_a() -> None:
    # a.b > 0 and |b| just below the limit: the small root must not be lost to cancellation.
    a = np.array([[[1e6, 0.0, 0.0]]])
    b = np.array([[[0.29e-3 * (1 - 1e-9), 0.0, 0.0]]])
    c = largest_feed_per_tooth_norm(a, b, 0.29e-3)[0]
    assert c == pytest.approx(0.29e-3 * 1e-9 / 1e6, rel=1e-5)


def test_joint_velocity_bound() -> None:
    dq = np.array([[2.0, -4.0], [0.0, 1.0]])
    v = joint_velocity_feed_bound(dq, np.array([1.0, 2.0]))
    np.testing.assert_allclose(v, [0.5, 2.0])
