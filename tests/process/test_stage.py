"""The process stage's five-axis feed lean: the feed's component along the tool axis handed to
the force model, and the note where a flat-bottomed cutter descends into the material."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.process.cutter import CutterShape
from feedopt.process.stage import DESCENT_NOTE_DEG, descent_notes, feed_along_axis
from feedopt.process.tool import Tool

MM = 1e-3


def _samples(lean_deg: np.ndarray, axis: bool = True) -> SimpleNamespace:
    """Samples feeding along +x with the tool axis leaning by ``lean_deg`` towards the feed
    (a lead angle: k = (sin, 0, cos)), written out by hand."""
    lean = np.radians(np.asarray(lean_deg, dtype=float))
    n = lean.size
    tangent = np.tile([1.0, 0.0, 0.0], (n, 1))
    k = np.column_stack([np.sin(lean), np.zeros(n), np.cos(lean)])
    return SimpleNamespace(s=np.arange(n) * MM, tangent=tangent, axis=k if axis else None)


def test_the_feed_along_the_axis_is_the_sine_of_the_lead_on_cutting_samples():
    lean = np.array([10.0, -20.0, 35.0, 5.0])
    cutting = np.array([True, True, False, True])
    got = feed_along_axis(_samples(lean), cutting)
    assert np.allclose(got, [math.sin(math.radians(10)), -math.sin(math.radians(20)), 0.0,
                             math.sin(math.radians(5))], rtol=0, atol=1e-15)
    assert feed_along_axis(_samples(lean, axis=False), cutting) is None  # three axes
    assert feed_along_axis(_samples(lean), np.zeros(4, dtype=bool)) is None


FLAT = Tool("flat", 10 * MM, 3, math.radians(30), 20 * MM)
BALL = Tool("ball", 10 * MM, 2, math.radians(30), 20 * MM, shape=CutterShape.BALL,
            corner_radius=5 * MM)
BULL = Tool("bull", 10 * MM, 4, math.radians(30), 20 * MM, shape=CutterShape.BULL,
            corner_radius=1 * MM)


@pytest.mark.parametrize(("tool", "says"), [(FLAT, "does not have (the side edges take"),
                                           (BULL, "flat bottom cut a chip"),
                                           (BALL, "reach behind the tool")])
def test_a_descent_is_noted_with_what_the_model_assumes(tool, says):
    lean = np.array([0.0, -3.0, -12.0, -7.0, 20.0])
    samples = _samples(lean)
    fz = feed_along_axis(samples, np.ones(lean.size, dtype=bool))
    notes = descent_notes(samples, fz, tool)
    assert len(notes) == 1 and says in notes[0]
    assert "by up to 12 deg" in notes[0] and "2 sample(s) over 5 deg" in notes[0]
    assert "s = 2.00 mm" in notes[0]
    # a rising feed (a lead towards the feed) only: the end edges leave the material
    rising = _samples(np.array([DESCENT_NOTE_DEG + 10.0, 30.0]))
    assert descent_notes(rising, feed_along_axis(rising, np.ones(2, dtype=bool)), tool) == []


@pytest.mark.parametrize(("tool", "says", "not_says"),
                         [(FLAT, "flat bottom cut a chip", "the side edges take"),
                          (BALL, "found in the stock", "reach behind the tool")])
def test_a_descent_through_a_stock_is_noted_for_what_the_stock_does_not_give(tool, says,
                                                                             not_says):
    """With the engagement found in a tri-dexel, the ball's cut behind the tool is found
    (the note names the extrapolated tip instead); the flat bottom's chip is still not
    modelled, but the side edges no longer take the whole feed."""
    samples = _samples(np.array([0.0, -12.0]))
    fz = feed_along_axis(samples, np.ones(2, dtype=bool))
    notes = descent_notes(samples, fz, tool, stock=True)
    assert len(notes) == 1 and says in notes[0] and not_says not in notes[0]


def test_a_lead_that_takes_the_whole_stated_cut_off_the_front_is_noted():
    """A ball slotting 0.2 mm deep at a 20 deg lead: the edge below kappa = 20 deg (the
    depth R (1 - cos 20 deg) = 0.30 mm) is off the front of the tool, so nothing cuts; at
    1 mm deep it does. A flat end mill's side edges always cut."""
    from feedopt.process.engagement import Engagement
    from feedopt.process.stage import lifted_notes

    samples = _samples(np.array([20.0, 20.0, 0.0]))
    fz = feed_along_axis(samples, np.ones(3, dtype=bool))
    shallow = Engagement(np.zeros(3), np.full(3, np.pi), np.full(3, 0.2 * MM), feed_axial=fz)
    notes = lifted_notes(samples, shallow, BALL)
    assert len(notes) == 1 and "cuts nothing at 2 sample(s)" in notes[0]
    assert "by up to 20 deg" in notes[0] and "s = 0.00 mm" in notes[0]
    deep = Engagement(np.zeros(3), np.full(3, np.pi), np.full(3, 1.0 * MM), feed_axial=fz)
    assert lifted_notes(samples, deep, BALL) == []
    assert lifted_notes(samples, shallow, FLAT) == []
