"""Engagement from the cut type, the chapter-4 radial ramp, tool and coefficient files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process import (
    CoefficientTable,
    load_coefficients,
    load_tool,
    peripheral_engagement,
    radial_depth_profile,
    save_coefficients,
    slot_engagement,
)

from .conftest import MATERIAL_YAML, TABLE_3_3, TOOL_YAML

D = 19.05e-3


def test_slot_and_peripheral_angles():
    slot = slot_engagement(3, 1.27e-3)
    np.testing.assert_array_equal(slot.entry, 0.0)
    np.testing.assert_array_equal(slot.exit, math.pi)
    ae = np.array([0.0, D / 2, D, D * (1 - math.cos(math.radians(30))) / 2])
    up = peripheral_engagement(ae, D, 2.54e-3, "up")
    down = peripheral_engagement(ae, D, 2.54e-3, "down")
    np.testing.assert_allclose(up.entry, 0.0)
    np.testing.assert_allclose(up.exit, [0.0, math.pi / 2, math.pi, math.radians(30)])
    np.testing.assert_allclose(down.exit, math.pi)
    np.testing.assert_allclose(down.entry, [math.pi, math.pi / 2, 0.0, math.radians(150)])
    np.testing.assert_allclose(down.axial_depth, 2.54e-3)


@pytest.mark.parametrize(
    ("ae", "milling", "match"),
    [
        (np.array([1e-3, -1e-3]), "down", "radial_depth at sample 1"),
        (np.array([20e-3]), "up", "radial_depth at sample 0 .*\\[0, 19.05\\] mm"),
        (np.array([1e-3]), "climb", "milling must be 'up' or 'down'"),
    ],
)
def test_peripheral_bad_input(ae, milling, match):
    with pytest.raises(InputError, match=match):
        peripheral_engagement(ae, D, 1e-3, milling)


def test_chapter_4_radial_ramp():
    s = np.linspace(0.0, 0.2032, 9)
    ae = radial_depth_profile(s, [0.0, 0.2032], [0.0, 9.525e-3])
    np.testing.assert_allclose(ae, np.linspace(0.0, 9.525e-3, 9))
    eng = peripheral_engagement(ae, D, 2.54e-3, "down")
    np.testing.assert_allclose(eng.entry[[0, -1]], [math.pi, math.pi / 2])
    with pytest.raises(InputError, match="outside the table"):
        radial_depth_profile(np.array([0.25]), [0.0, 0.2032], [0.0, 9.525e-3])
    with pytest.raises(InputError, match="strictly increasing"):
        radial_depth_profile(s, [0.1, 0.0], [0.0, 1e-3])


def test_thesis_tool_file():
    tool = load_tool(TOOL_YAML)
    assert (tool.teeth, tool.diameter) == (2, pytest.approx(19.05e-3))
    assert tool.helix == pytest.approx(math.radians(30))
    assert tool.flute_length == pytest.approx(15 / 16 * 25.4e-3)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("diameter_mm: 19.05\nhelix_deg: 30\nflute_length_mm: 20\n", "missing field 'teeth'"),
        ("diameter_mm: 19.05\nteeth: 0\nhelix_deg: 30\nflute_length_mm: 20\n", "teeth"),
        ("diameter_mm: -1\nteeth: 2\nhelix_deg: 30\nflute_length_mm: 20\n", "diameter_mm"),
        ("diameter_mm: 19\nteeth: 2\nhelix_deg: 90\nflute_length_mm: 20\n", "helix_deg"),
        ("diameter_mm: 19\nteeth: 2\nhelix_deg: 30\n", "flute_length_mm"),
        ("- 1\n- 2\n", "mapping"),
    ],
)
def test_bad_tool_file(tmp_path, text, match):
    p = tmp_path / "tool.yaml"
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        load_tool(p)


def test_material_file_is_table_3_3_and_interpolates():
    table = load_coefficients(MATERIAL_YAML)
    assert "Table 3.3" in table.source
    for rpm, k in TABLE_3_3.items():
        np.testing.assert_allclose(table.at(rpm).as_array(), k.as_array())
    mid = table.at(2250).as_array()
    np.testing.assert_allclose(mid, (TABLE_3_3[2000].as_array() + TABLE_3_3[2500].as_array()) / 2)
    with pytest.raises(InputError, match="3000 rpm is outside the calibrated speeds"):
        table.at(3000)
    np.testing.assert_allclose(
        table.at(3000, extrapolate=True).as_array(), table.at(2500).as_array()
    )
    np.testing.assert_allclose(
        table.at(500, extrapolate=True).as_array(), table.at(1000).as_array()
    )


def test_coefficients_round_trip_and_plain_exponents(tmp_path):
    table = CoefficientTable.from_speeds(TABLE_3_3, material="6061", tool="t", source="test")
    p = tmp_path / "c.yaml"
    save_coefficients(table, p)
    back = load_coefficients(p)
    np.testing.assert_allclose(back.rpm, table.rpm)
    np.testing.assert_allclose(back.values, table.values, rtol=1e-6)
    assert (back.material, back.tool, back.source) == ("6061", "t", "test")
    # design.md writes 8.57e8, which PyYAML reads as a string: still accepted
    p.write_text(
        "speeds:\n  - rpm: 2000\n    ktc_n_m2: 8.57e8\n    krc_n_m2: 3.19e8\n"
        "    kac_n_m2: -1.05e8\n    kte_n_m: 7.42e3\n    kre_n_m: 8.45e3\n    kae_n_m: -2.13e3\n"
    )
    np.testing.assert_allclose(load_coefficients(p).at(2000).as_array(), TABLE_3_3[2000].as_array())


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("material: x\n", "missing field 'speeds'"),
        ("speeds:\n  - ktc_n_m2: 1\n", r"speeds\[0\]: missing field 'rpm'"),
        (
            "speeds:\n  - {rpm: 1000, ktc_n_m2: 1, krc_n_m2: 1, kac_n_m2: 1, kte_n_m: 1, "
            "kre_n_m: 1}\n",
            r"speeds\[0\]: missing field 'kae_n_m'",
        ),
        (
            "speeds:\n  - {rpm: 1000, ktc_n_m2: 1, krc_n_m2: 1, kac_n_m2: 1, kte_n_m: 1, "
            "kre_n_m: 1, kae_n_m: 1}\n  - {rpm: 1000, ktc_n_m2: 1, krc_n_m2: 1, kac_n_m2: 1, "
            "kte_n_m: 1, kre_n_m: 1, kae_n_m: 1}\n",
            "listed twice",
        ),
        ("speeds:\n  - {rpm: abc}\n", r"speeds\[0\]\.rpm: expected a number"),
    ],
)
def test_bad_coefficient_file(tmp_path, text, match):
    p = tmp_path / "c.yaml"
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        load_coefficients(p)
    with pytest.raises(InputError, match="does not exist"):
        load_coefficients(tmp_path / "missing.yaml")


def test_engagement_and_tool_messages_in_user_units():
    from feedopt.process import Engagement, Tool

    with pytest.raises(InputError, match=r"engagement\.axial_depth at sample 1 is -1\.5 mm: "
                                         r"must be > 0"):
        Engagement(np.zeros(2), np.full(2, math.pi), np.array([1e-3, -1.5e-3]))
    with pytest.raises(InputError, match=r"engagement\.exit at sample 0 is 200 deg: "
                                         r"must be in \[entry, 180\] deg"):
        Engagement(np.zeros(1), np.radians([200.0]), np.array([1e-3]))
    with pytest.raises(InputError, match=r"tool diameter must be > 0 mm, got -19\.05 mm"):
        peripheral_engagement(np.array([1e-3]), -D, 1e-3, "up")
    with pytest.raises(InputError, match=r"depth\[1\] is -2 mm, must be >= 0"):
        radial_depth_profile(np.array([0.0]), [0.0, 0.1], [0.0, -2e-3])
    with pytest.raises(InputError, match=r"tool\.diameter must be > 0 mm, got -19\.05 mm"):
        Tool("t", -D, 2, 0.5, 0.02)
    with pytest.raises(InputError, match=r"tool\.flute_length must be > 0 mm, got -20 mm"):
        Tool("t", D, 2, 0.5, -0.02)
