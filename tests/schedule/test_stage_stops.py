"""The schedule stage's view of stops and unmodelled plunges."""

from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.schedule.stage import stop_samples, unmodelled_plunge_cap
from feedopt.units import MM


class _Stops(SimpleNamespace):
    def __len__(self):
        return len(self.s)

def test_stops_become_sample_indices():
    s = np.linspace(0.0, 0.1, 101)
    t = _Stops(s=np.array([0.0, s[40], 0.1]), hold_s=np.array([1.0, 0.0, 0.0]),
               kind=("dwell", "reversal", "exact stop"), label=("a", "b", "c"))
    out = stop_samples(t, s)
    assert out.index.tolist() == [0, 40, 100]
    assert out.hold_s.tolist() == [1.0, 0.0, 0.0] and out.kind[1] == "reversal"

def test_only_end_stops_without_hold_are_no_stops():
    s = np.linspace(0.0, 0.1, 11)
    t = _Stops(s=np.array([0.0, 0.1]), hold_s=np.zeros(2), kind=("a", "b"), label=("a", "b"))
    assert stop_samples(t, s) is None
    assert stop_samples(None, s) is None

def test_a_stop_between_samples_is_an_internal_error():
    s = np.linspace(0.0, 0.1, 11)
    t = _Stops(s=np.array([0.015]), hold_s=np.zeros(1), kind=("a",), label=("line 9",))
    with pytest.raises(RuntimeError, match="line 9"):
        stop_samples(t, s)

def test_unmodelled_plunges_run_at_the_program_feed_capped_never_at_max_feed():
    max_feed = np.array([20.0, 20.0, 20.0]) * MM  # feed.max_mm_s replaced the program's F
    programmed = np.array([5.0, 5.0, 10.0]) * MM
    plunge = np.array([False, True, True])
    out = unmodelled_plunge_cap(max_feed, programmed, plunge, None)
    assert out.tolist() == pytest.approx([20 * MM, 5 * MM, 10 * MM])
    out = unmodelled_plunge_cap(max_feed, programmed, plunge, 8.0)
    assert out.tolist() == pytest.approx([20 * MM, 5 * MM, 8 * MM])
    assert unmodelled_plunge_cap(max_feed, programmed, None, 8.0) is max_feed
