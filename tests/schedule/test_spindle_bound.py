"""Spindle torque and power bounds against the closed form of a straight-tooth slot.

In a slot a straight 2-tooth cutter has one tooth in the cut at a time; tooth 1 at phi in
[0, pi) carries the tangential force a (Ktc c sin phi + Kte), so the torque R a (Ktc c sin phi
+ Kte) is largest at phi = pi/2 and the largest feed per tooth within a torque T is
c = (T / (R a) - Kte) / Ktc; within a power P it is the same with T = P / omega. The bound
is computed in the same force pass as the deflection bound (``feed_bound``), so the test goes
through the registry as a run does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.schedule.bounds import BoundInputs, feed_bound, spindle_feed_bounds

from .test_compensation import _slot_model


def _inputs(model, torque_max, power_max, limit=1.0):
    n = model.n
    return BoundInputs(model=model, limit=limit, max_feed=np.inf, dq_ds=np.zeros((n, 6)),
                       joint_velocity_max=np.ones(6), torque_max=torque_max,
                       power_max=power_max)


def _closed_form(model, torque):
    k, a, r = model.coefficients, model.engagement.axial_depth[0], model.tool.diameter / 2
    return (torque / (r * a) - k.kte) / k.ktc * model.feed_per_unit_c


def test_torque_and_power_bounds_of_a_straight_slot_equal_the_closed_form():
    model = _slot_model(np.eye(3) * 1e-9, mode="norm", n=3)
    omega = model.rpm * 2 * math.pi / 60
    torque, power = 3.0, 2.0 * omega  # power: the same as a 2 N m torque
    bound = feed_bound(_inputs(model, torque, power))
    np.testing.assert_allclose(bound.parts["spindle_torque"], _closed_form(model, torque),
                               rtol=1e-9)
    np.testing.assert_allclose(bound.parts["spindle_power"], _closed_form(model, 2.0),
                               rtol=1e-9)
    # the same numbers when asked for alone (no deflection limit in the pass)
    v_t, v_p = spindle_feed_bounds(model, torque, power)
    np.testing.assert_array_equal(v_t, bound.parts["spindle_torque"])
    np.testing.assert_array_equal(v_p, bound.parts["spindle_power"])


def test_no_spindle_limits_leave_the_feed_free():
    model = _slot_model(np.eye(3) * 1e-9, mode="norm")
    bound = feed_bound(_inputs(model, np.inf, np.inf))
    assert np.all(np.isinf(bound.parts["spindle_torque"]))
    assert np.all(np.isinf(bound.parts["spindle_power"]))


def test_a_spindle_too_weak_for_the_edge_forces_is_refused():
    model = _slot_model(np.eye(3) * 1e-9, mode="norm")
    k, a, r = model.coefficients, model.engagement.axial_depth[0], model.tool.diameter / 2
    edge_torque = r * a * k.kte  # the torque at zero feed
    with pytest.raises(InputError, match="spindle cannot take this cut"):
        feed_bound(_inputs(model, 0.5 * edge_torque, np.inf))
