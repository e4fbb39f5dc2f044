"""The reduced per-angle terms (Gram-matrix route of DeflectionModel.angle_terms) against
the direct vectors a(phi), b(phi) of DeflectionModel.terms, and the threaded chunk loops
against a serial run."""

import numpy as np
import pytest

from feedopt.process.forces import Engagement
from feedopt.schedule import deflection as deflection_module
from feedopt.schedule.bounds import BoundInputs, feed_bound

from .test_deflection import _model


def _two_engagements(n: int) -> Engagement:
    """Half the samples in a full slot, half in a 60 deg down cut: two shared force rows."""
    entry = np.where(np.arange(n) % 2 == 0, 0.0, np.deg2rad(120.0))
    return Engagement(entry=entry, exit=np.full(n, np.pi), axial_depth=np.full(n, 2.54e-3))


@pytest.mark.parametrize("mode", ["norm", "normal", "direction", "residual"])
@pytest.mark.parametrize("shared", ["slot", "two"])
def test_reduced_terms_equal_the_direct_vectors(mode: str, shared: str) -> None:
    n = 64
    model = _model(n=n, mode=mode, engagement=None if shared == "slot" else _two_engagements(n))
    if mode == "direction":
        model = deflection_module.DeflectionModel(**{**model.__dict__,
                                                     "direction": np.array([1.0, 2.0, 0.5])})
    sl = slice(0, n)
    terms = model.angle_terms(sl)
    angles, a, b = model.terms(sl)
    np.testing.assert_array_equal(terms.angles, angles)
    if a.ndim == 3:  # |a|^2, a.b, |b|^2 written out, independent of the reduced route
        ref = {"aa": (a * a).sum(-1), "ab": (a * b).sum(-1), "bb": (b * b).sum(-1)}
    else:
        ref = {"a": a, "b": b}
    for name, want in ref.items():
        got = getattr(terms, name)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
    c = np.linspace(0.0, 2e-4, n)
    direct = (np.linalg.norm(c[:, None, None] * a + b, axis=-1) if a.ndim == 3
              else np.abs(c[:, None] * a + b))
    np.testing.assert_allclose(terms.magnitude(c), direct, rtol=1e-10,
                               atol=1e-12 * direct.max())


def test_threads_give_the_serial_result_bit_for_bit(monkeypatch) -> None:
    """Chunks of 5 samples over several threads: the bound and the replay are those of one
    thread, exactly (each chunk writes only its own samples)."""
    n = 53
    model = _model(n=n, engagement=_two_engagements(n))
    monkeypatch.setattr(deflection_module, "_CHUNK", 5)
    feeds = np.linspace(1e-3, 6e-3, 2 * n).reshape(2, n)
    results = []
    for threads in ("1", "3"):
        monkeypatch.setenv("FEEDOPT_THREADS", threads)
        inputs = BoundInputs(model=model, limit=0.29e-3, max_feed=np.inf,
                             dq_ds=np.zeros((n, 6)), joint_velocity_max=np.ones(6))
        bound = feed_bound(inputs)
        results.append((bound.v_max, bound.zero_feed_deflection, model.deflection(feeds)))
    for serial, threaded in zip(*results, strict=True):
        np.testing.assert_array_equal(serial, threaded)


def test_several_laws_replay_as_each_alone() -> None:
    """The replay of several feed profiles at once (forces per chunk and refinement windows
    shared between them) gives each profile's replay alone."""
    n = 40
    model = _model(n=n, engagement=_two_engagements(n))
    rng = np.random.default_rng(11)
    feeds = np.vstack([np.linspace(1e-3, 6e-3, n), np.full(n, 3e-3),
                       rng.uniform(1e-3, 6e-3, n), np.linspace(1e-3, 6e-3, n)[::-1]])
    together = model.deflection(feeds)
    alone = np.vstack([model.deflection(f) for f in feeds])
    np.testing.assert_allclose(together, alone, rtol=1e-14, atol=0)


def test_bound_and_replay_report_their_progress(monkeypatch) -> None:
    """``progress(done, total)`` after every chunk, in order, ending at every sample (what
    the runner's progress bars show for a long path)."""
    n = 23
    model = _model(n=n, engagement=_two_engagements(n))
    monkeypatch.setattr(deflection_module, "_CHUNK", 4)
    calls = []
    inputs = BoundInputs(model=model, limit=0.29e-3, max_feed=np.inf, dq_ds=np.zeros((n, 6)),
                         joint_velocity_max=np.ones(6),
                         progress=lambda done, total: calls.append((done, total)))
    feed_bound(inputs)
    model.deflection(np.full(n, 3e-3), lambda done, total: calls.append((done, total)))
    bound_calls, replay_calls = calls[: len(calls) // 2], calls[len(calls) // 2:]
    for seen in (bound_calls, replay_calls):
        done = [d for d, _ in seen]
        assert done == sorted(done) and done[-1] == n and len(done) == 6  # ceil(23 / 4)
        assert all(total == n for _, total in seen)


def _mixed_terms(n: int, mode: str) -> deflection_module.AngleTerms:
    """Angle terms of ``n`` samples over two engagements; ``direction`` mode along a fixed
    oblique base-frame direction."""
    model = _model(n=n, mode=mode, engagement=_two_engagements(n))
    if mode == "direction":
        model = deflection_module.DeflectionModel(**{**model.__dict__,
                                                     "direction": np.array([0.3, 1.0, 0.2])})
    return model.angle_terms(slice(0, n))


@pytest.mark.parametrize("block", [1, 7, 256])
def test_blocked_extreme_is_the_whole_array_extreme(block: int) -> None:
    """Row blocks give numpy's argmax / argmin over the whole array, ties included."""
    rng = np.random.default_rng(11)
    value = rng.integers(0, 4, (40, 9)).astype(float)  # many ties
    for worst, pick in (("max", np.argmax), ("min", np.argmin)):
        got = deflection_module.GridExtreme.blocked(lambda r: value[r], 40, worst, block)
        np.testing.assert_array_equal(got.index, pick(value, axis=1))
        np.testing.assert_array_equal(got.value, value[np.arange(40), pick(value, axis=1)])


@pytest.mark.parametrize("mode", ["norm", "direction"])
def test_largest_magnitude_is_the_max_of_the_magnitudes(mode: str, monkeypatch) -> None:
    """The blocked square-then-root extreme equals the extreme of :meth:`magnitude` (the
    whole (k, M) array of roots), and the zero-feed one that of :meth:`zero_feed`."""
    monkeypatch.setattr(deflection_module, "_ROWS_PER_BLOCK", 5)
    n = 23
    terms = _mixed_terms(n, mode)
    c = np.linspace(0.0, 2e-4, n)
    for got, whole in ((terms.largest_magnitude(c), terms.magnitude(c)),
                       (terms.largest_zero_feed(), terms.zero_feed())):
        np.testing.assert_array_equal(got.value, whole.max(axis=1))
        np.testing.assert_array_equal(whole[np.arange(n), got.index], whole.max(axis=1))


@pytest.mark.parametrize("mode", ["norm", "direction"])
def test_smallest_upper_root_is_the_min_of_the_roots(mode: str, monkeypatch) -> None:
    from feedopt.schedule.bounds import smallest_upper_root, upper_roots

    monkeypatch.setattr(deflection_module, "_ROWS_PER_BLOCK", 4)
    n = 19
    terms = _mixed_terms(n, mode)
    roots = upper_roots(terms, 0.29e-3)
    got = smallest_upper_root(terms, 0.29e-3)
    np.testing.assert_array_equal(got.index, roots.argmin(axis=1))
    np.testing.assert_array_equal(got.value, roots.min(axis=1))
