"""The tool's share of the mean deflection (summary.json scenario.tool.bending) against a hand
computation: the mean slot force of straight teeth by quadrature of the hand-written force, the
robot's compliance isotropic, the tool's lateral and axial about the tool axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.process.tool import Tool
from feedopt.schedule.stage import tip_compliance
from feedopt.schedule.tool_share import tool_bending_summary

from .test_compensation import _hand_slot_force, _slot_model


def test_share_of_a_slot_is_the_hand_computed_ratio():
    c_robot = 2e-6  # m/N, isotropic
    base = _slot_model(np.eye(3) * c_robot, mode="norm", n=3)
    tool = Tool("bent", 19.05e-3, 2, 0.0, 25e-3, stickout=60e-3, youngs_modulus=210e9)
    lateral, axial = tool.tip_compliance()
    model = type(base)(**{**base.__dict__, "tool": tool,
                          "compliance": tip_compliance(base.compliance, tool, base.frames)})
    feed = 4.23e-3
    out = tool_bending_summary(tool, model, feed)
    c = feed / model.feed_per_unit_c
    phi = (np.arange(200_000) + 0.5) * (2 * math.pi / 200_000)
    f = np.where((np.mod(phi, 2 * math.pi) < math.pi)[:, None],
                 _hand_slot_force(model.coefficients, 2.0e-3, c, phi), 0.0)
    f = f + np.where((np.mod(phi + math.pi, 2 * math.pi) < math.pi)[:, None],
                     _hand_slot_force(model.coefficients, 2.0e-3, c, phi + math.pi), 0.0)
    mean = f.mean(axis=0)  # force-model frame = base frame here (feed x, tool axis z)
    d_tool = np.array([lateral * mean[0], lateral * mean[1], axial * mean[2]])
    d_all = d_tool + c_robot * mean
    expected = np.linalg.norm(d_tool) / np.linalg.norm(d_all)
    share = out["share_of_mean_deflection"]
    assert share["median"] == pytest.approx(expected, rel=1e-6)
    assert share["at_largest"] == pytest.approx(expected, rel=1e-6)
    assert out["lateral_stiffness_n_per_um"] == pytest.approx(1e-6 / lateral)


def test_a_rigid_tool_says_so_and_adds_nothing():
    base = _slot_model(np.eye(3) * 2e-6, mode="norm")
    assert tool_bending_summary(base.tool, base, 4e-3)["model"] == "rigid"
    assert tip_compliance(base.compliance, base.tool, base.frames) is base.compliance
