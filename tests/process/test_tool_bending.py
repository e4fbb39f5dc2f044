"""Tool bending (issue: tool and holder compliance in series with the robot's): the stepped
cantilever against hand numbers and numerical integration, the 3x3 compliance and the tool's
share of the deflection."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_trapezoid

from feedopt.errors import InputError
from feedopt.process.tool_bending import (
    EQUIVALENT_DIAMETER_RATIO,
    YOUNGS_MODULUS_PA,
    ToolBeam,
    compliance_matrices,
    tip_compliance_m_per_n,
    tool_share,
)

CARBIDE = YOUNGS_MODULUS_PA["carbide"]


def _beam(d=10e-3, lf=20e-3, out=35e-3, ds=10e-3, e=CARBIDE) -> ToolBeam:
    return ToolBeam(diameter_m=d, flute_length_m=lf, stickout_m=out, shank_diameter_m=ds,
                    youngs_modulus_pa=e)


def test_issue_figure_2mm_carbide_10mm_out():
    # A 2 mm carbide cylinder 10 mm out: 3 E I / L^3 with I = pi (2 mm)^4 / 64 = 7.854e-13 m^4,
    # 3 * 600e9 * 7.854e-13 / 1e-6 = 1.414e6 N/m, the issue's ~1.41 N/um. Uniform because the
    # shank is the flutes' equivalent diameter 0.8 D (D = 2.5 mm).
    beam = _beam(d=2.5e-3, lf=4e-3, out=10e-3, ds=2e-3)
    lateral, axial = tip_compliance_m_per_n(beam)
    stiffness_n_per_um = 1.0 / lateral * 1e-6
    assert stiffness_n_per_um == pytest.approx(1.41, rel=0.01)
    assert stiffness_n_per_um == pytest.approx(1.4137, rel=1e-4)
    # axial: L / (E A) = 0.01 / (600e9 * pi * 1e-6) = 5.305e-9 m/N
    assert axial == pytest.approx(5.3052e-9, rel=1e-4)


def test_uniform_when_flutes_longer_than_stickout():
    # only flute sticks out: a 12.5 mm cutter acts as a 10 mm cylinder, 40 mm out in HSS
    beam = _beam(d=12.5e-3, lf=50e-3, out=40e-3, ds=12e-3, e=YOUNGS_MODULUS_PA["hss"])
    assert beam.shank_out_m == 0.0 and beam.flute_out_m == 40e-3
    i = math.pi * 0.01**4 / 64  # 4.909e-10 m^4
    lateral, axial = tip_compliance_m_per_n(beam)
    assert lateral == pytest.approx(0.04**3 / (3 * 210e9 * i), rel=1e-12)
    assert lateral == pytest.approx(2.0696e-7, rel=1e-4)  # 4.83 N/um
    assert axial == pytest.approx(0.04 / (210e9 * math.pi * 0.01**2 / 4), rel=1e-12)


def test_stepped_beam_against_double_integration():
    d, lf, out, ds, e = 10e-3, 22e-3, 47e-3, 12e-3, CARBIDE
    beam = _beam(d=d, lf=lf, out=out, ds=ds, e=e)
    ls = out - lf
    # two grids sharing the step x = L_s (a zero-width interval there adds nothing), so the
    # discontinuous I(x) is sampled exactly on each side
    x = np.concatenate([np.linspace(0.0, ls, 100001), np.linspace(ls, out, 100001)])
    diameter = np.where(np.arange(x.size) <= 100000, ds, EQUIVALENT_DIAMETER_RATIO * d)
    inertia = np.pi * diameter**4 / 64.0
    p = 1.0
    curvature = p * (out - x) / (e * inertia)  # w'' = M / (E I), M = P (L - x)
    slope = cumulative_trapezoid(curvature, x, initial=0.0)  # w'(0) = 0
    w = cumulative_trapezoid(slope, x, initial=0.0)  # w(0) = 0
    lateral, axial = tip_compliance_m_per_n(beam)
    assert lateral == pytest.approx(w[-1] / p, rel=1e-6)
    strain = p / (e * np.pi * diameter**2 / 4.0)
    assert axial == pytest.approx(cumulative_trapezoid(strain, x)[-1] / p, rel=1e-9)


lengths = st.floats(1e-3, 0.2)
diameters = st.floats(0.5e-3, 40e-3)


@settings(max_examples=200, deadline=None)
@given(d=diameters, lf=lengths, out=lengths, ds=diameters, grow=st.floats(1.01, 3.0))
def test_monotone_in_stickout_and_diameter(d, lf, out, ds, grow):
    lat, ax = tip_compliance_m_per_n(_beam(d=d, lf=lf, out=out, ds=ds))
    lat_long, ax_long = tip_compliance_m_per_n(_beam(d=d, lf=lf, out=out * grow, ds=ds))
    assert lat_long > lat and ax_long > ax
    lat_thick, ax_thick = tip_compliance_m_per_n(_beam(d=d * grow, lf=lf, out=out, ds=ds * grow))
    assert lat_thick < lat and ax_thick < ax
    # either diameter alone never makes it more compliant
    for beam in (_beam(d=d * grow, lf=lf, out=out, ds=ds),
                 _beam(d=d, lf=lf, out=out, ds=ds * grow)):
        lat_one, ax_one = tip_compliance_m_per_n(beam)
        assert lat_one <= lat * (1 + 1e-12) and ax_one <= ax * (1 + 1e-12)


@settings(max_examples=200, deadline=None)
@given(d=diameters, lf=lengths, out=lengths, ds=diameters)
def test_stepped_between_all_shank_and_all_flute(d, lf, out, ds):
    e = CARBIDE
    lat, ax = tip_compliance_m_per_n(_beam(d=d, lf=lf, out=out, ds=ds))
    de = EQUIVALENT_DIAMETER_RATIO * d
    uniform_lat = [out**3 / (3 * e * math.pi * di**4 / 64) for di in (ds, de)]
    uniform_ax = [out / (e * math.pi * di**2 / 4) for di in (ds, de)]
    assert min(uniform_lat) * (1 - 1e-12) <= lat <= max(uniform_lat) * (1 + 1e-12)
    assert min(uniform_ax) * (1 - 1e-12) <= ax <= max(uniform_ax) * (1 + 1e-12)


def test_compliance_matrices_eigenstructure():
    rng = np.random.default_rng(7)
    axes = rng.normal(size=(50, 3)) * rng.uniform(0.1, 10.0, size=(50, 1))  # not unit length
    lateral, axial = 3e-7, 4e-9
    c = compliance_matrices(lateral, axial, axes)
    assert c.shape == (50, 3, 3)
    np.testing.assert_allclose(c, np.swapaxes(c, 1, 2), rtol=0, atol=1e-22)
    np.testing.assert_allclose(np.linalg.eigvalsh(c), np.tile([axial, lateral, lateral], (50, 1)),
                               rtol=1e-9)
    a = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", c, a), axial * a, rtol=0, atol=1e-20)
    u = np.cross(a, rng.normal(size=(50, 3)))  # perpendicular to a
    np.testing.assert_allclose(np.einsum("nij,nj->ni", c, u), lateral * u, rtol=0, atol=1e-18)


def test_compliance_matrices_z_axis_by_hand_and_per_sample_values():
    c = compliance_matrices(np.array([2.0, 5.0]), np.array([1.0, 0.5]),
                            np.array([[0.0, 0.0, 3.0], [2.0, 0.0, 0.0]]))
    np.testing.assert_array_equal(c[0], np.diag([2.0, 2.0, 1.0]))
    np.testing.assert_array_equal(c[1], np.diag([0.5, 5.0, 5.0]))


@pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [np.nan, 0.0, 1.0], [np.inf, 0.0, 0.0]])
def test_compliance_matrices_refuse_bad_axes(bad):
    with pytest.raises(InputError, match="tool axis at sample 1"):
        compliance_matrices(1e-7, 1e-9, np.array([[0.0, 0.0, 1.0], bad]))


def test_tool_share():
    rng = np.random.default_rng(3)
    n = 20
    forces = rng.normal(size=(n, 3)) * 100.0
    m = rng.normal(size=(n, 3, 3))
    robot = np.einsum("nij,nkj->nik", m, m) * 1e-7 + np.eye(3) * 1e-8  # SPD
    rigid = compliance_matrices(0.0, 0.0, np.tile([0.0, 0.0, 1.0], (n, 1)))
    np.testing.assert_array_equal(tool_share(robot, rigid, forces), np.zeros(n))
    iso = np.broadcast_to(np.eye(3) * 2e-7, (n, 3, 3))
    np.testing.assert_allclose(tool_share(iso, iso, forces), 0.5, rtol=1e-12)
    # a force along the tool axis against an isotropic robot: c_ax / (c_ax + c_robot)
    tool = compliance_matrices(5e-7, 1e-8, np.tile([0.0, 0.0, 1.0], (n, 1)))
    axial_forces = np.tile([0.0, 0.0, -300.0], (n, 1))
    np.testing.assert_allclose(tool_share(iso, tool, axial_forces), 1e-8 / (1e-8 + 2e-7),
                               rtol=1e-12)
    zero_force = forces.copy()
    zero_force[4] = 0.0
    share = tool_share(robot, tool, zero_force)
    assert np.isnan(share[4]) and np.all(np.isfinite(np.delete(share, 4)))


@pytest.mark.parametrize("field", ["diameter_m", "flute_length_m", "stickout_m",
                                   "shank_diameter_m", "youngs_modulus_pa"])
@pytest.mark.parametrize("value", [0.0, -1e-3, math.nan, math.inf, True])
def test_tool_beam_refuses_bad_fields(field, value):
    fields = {"diameter_m": 10e-3, "flute_length_m": 20e-3, "stickout_m": 30e-3,
              "shank_diameter_m": 10e-3, "youngs_modulus_pa": CARBIDE, field: value}
    with pytest.raises(InputError, match=rf"ToolBeam\.{field} must be a finite number > 0"):
        ToolBeam(**fields)
