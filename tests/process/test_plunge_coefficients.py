"""The optional ``plunge:`` block of a material file (issue 27) and the plunge calibration:
strict keys, units, signs, all speeds or none, interpolation, the round trip through
``save_coefficients``, and :func:`calibrate_plunge` recovering known coefficients."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.process.calibration import (
    PlungeForceRow,
    calibrate_plunge,
    read_plunge_forces,
)
from feedopt.process.coefficients import load_coefficients, save_coefficients
from feedopt.process.plunge import PlungeCoefficients

ROW = {"ktc_n_m2": 8.57e8, "krc_n_m2": 3.19e8, "kac_n_m2": -1.05e8, "kte_n_m": 7.42e3,
       "kre_n_m": 8.45e3, "kae_n_m": -2.13e3}  # fmt: skip
BLOCK = {"thrust_cutting_n_mm2": 1500.0, "thrust_edge_n_mm": 20.0,
         "torque_cutting_n_mm2": 900.0, "torque_edge_n_mm": 10.0}
KNOWN = set(BLOCK) | set(ROW) | {"rpm", "plunge"}


def _write(tmp_path, first: dict | None, second: dict | None):
    speeds = []
    for rpm, block in ((1000, first), (2000, second)):
        entry = {"rpm": rpm, **ROW}
        if block is not None:
            entry["plunge"] = block
        speeds.append(entry)
    p = tmp_path / "coeffs.yaml"
    p.write_text(yaml.safe_dump({"material": "test", "speeds": speeds}, sort_keys=False))
    return p


def test_plunge_block_is_read_in_n_mm_units_and_interpolated(tmp_path):
    second = {k: 2 * v for k, v in BLOCK.items()}
    table = load_coefficients(_write(tmp_path, BLOCK, second))
    k = table.at(1000).plunge
    assert (k.thrust_cutting, k.thrust_edge, k.torque_cutting, k.torque_edge) == (
        1.5e9, 2.0e4, 0.9e9, 1.0e4)
    np.testing.assert_allclose(table.at(1500).plunge.as_array(), 1.5 * k.as_array())
    assert load_coefficients(_write(tmp_path, None, None)).at(1500).plunge is None


def test_a_plunge_block_at_some_speeds_only_is_refused_naming_the_speed(tmp_path):
    p = _write(tmp_path, BLOCK, None)
    with pytest.raises(InputError, match=r"coeffs.yaml'.*: plunge coefficients are given at "
                                         r"some speeds but not at 2000 rpm"):
        load_coefficients(p)


@pytest.mark.parametrize(("block", "message"), [
    ({**BLOCK, "thrust_cutting_n_m2": 1.0}, "speeds[1].plunge: unknown key 'thrust_cutting_n_m2'"),
    ({k: v for k, v in BLOCK.items() if k != "torque_edge_n_mm"},
     "speeds[1].plunge: missing field 'torque_edge_n_mm'"),
    ({**BLOCK, "thrust_cutting_n_mm2": -5.0},
     "plunge.thrust_cutting_n_mm2 = -5 N/mm^2 (must be > 0"),
    ({**BLOCK, "torque_edge_n_mm": -1.0}, "plunge.torque_edge_n_mm = -1 N/mm (must be >= 0"),
    ({**BLOCK, "thrust_edge_n_mm": "lots"}, "speeds[1].plunge.thrust_edge_n_mm: expected a number"),
    ([1, 2, 3, 4], "speeds[1].plunge: expected a mapping"),
])
def test_bad_plunge_blocks_are_refused_naming_the_field(tmp_path, block, message):
    p = _write(tmp_path, BLOCK, block)
    with pytest.raises(InputError) as exc:
        load_coefficients(p)
    assert message in str(exc.value) and str(p) in str(exc.value)


@settings(max_examples=40, deadline=None)
@given(key=st.text(st.characters(codec="ascii", categories=("L", "N", "Pc")), min_size=1,
                   max_size=20).filter(lambda k: k not in KNOWN))
def test_any_unknown_plunge_key_is_refused_by_name(tmp_path_factory, key):
    p = _write(tmp_path_factory.mktemp("k"), BLOCK, {**BLOCK, key: 1.0})
    with pytest.raises(InputError) as exc:
        load_coefficients(p)
    assert f"speeds[1].plunge: unknown key {key!r}" in str(exc.value)


positive = st.floats(1e-3, 1e5, allow_nan=False, allow_infinity=False)
non_negative = st.one_of(st.just(0.0), positive)


@settings(max_examples=40, deadline=None)
@given(values=st.tuples(positive, non_negative, positive, non_negative))
def test_plunge_blocks_round_trip_through_save(tmp_path_factory, values):
    block = dict(zip(BLOCK, values, strict=True))
    tmp = tmp_path_factory.mktemp("rt")
    table = load_coefficients(_write(tmp, block, block))
    out = tmp / "again.yaml"
    save_coefficients(table, out)
    again = load_coefficients(out)
    np.testing.assert_allclose(again.plunge, table.plunge, rtol=1e-5)
    assert yaml.safe_load(out.read_text())["speeds"][0]["plunge"].keys() == BLOCK.keys()


def test_calibrate_plunge_recovers_known_coefficients():
    teeth, diameter = 2, 19.05e-3
    radius = diameter / 2
    want = {1000: PlungeCoefficients(1.4e9, 2.5e4, 0.8e9, 1.2e4),
            2000: PlungeCoefficients(1.6e9, 1.5e4, 1.0e9, 0.6e4)}
    rng = np.random.default_rng(5)
    rows = []
    for rpm, k in want.items():
        for feed in (0.5e-3, 1.2e-3, 2.0e-3, 3.1e-3):  # m/s along the axis
            c = feed * 60 / (teeth * rpm)
            # the totals of N full end edges: thrust N R (Ktc c + Kte), torque N R^2/2 (...)
            thrust = teeth * radius * (k.thrust_cutting * c + k.thrust_edge)
            torque = teeth * radius**2 / 2 * (k.torque_cutting * c + k.torque_edge)
            rows.append(PlungeForceRow(rpm, feed, thrust * (1 + 1e-9 * rng.normal()),
                                       torque * (1 + 1e-9 * rng.normal())))
    cals = calibrate_plunge(rows, teeth, diameter)
    assert [cal.rpm for cal in cals] == [1000, 2000]
    for cal in cals:
        np.testing.assert_allclose(cal.coeffs.as_array(), want[cal.rpm].as_array(), rtol=1e-6)
        assert np.all(cal.r2 > 1 - 1e-12)
    with pytest.raises(InputError, match="plunge calibration at 1000 rpm: need plunges at two"):
        calibrate_plunge(rows[:1], teeth, diameter)
    with pytest.raises(InputError, match="tool diameter must be > 0"):
        calibrate_plunge(rows, teeth, -1.0)


@pytest.mark.parametrize(("text", "message"), [
    ("spindle_rpm,feed_mm_s,thrust_n,torque_nm,fz_n\n1000,1,2,3,4\n", "unknown column(s) fz_n"),
    ("spindle_rpm,feed_mm_s,thrust_n\n1000,1,2\n", "missing column(s) torque_nm"),
    ("spindle_rpm,feed_mm_s,thrust_n,torque_nm\n1000,1,2,x\n", "data row 1: torque_nm = 'x'"),
    ("spindle_rpm,feed_mm_s,thrust_n,torque_nm\n1000,0,2,1\n", "feed_mm_s must be > 0"),
    ("spindle_rpm,feed_mm_s,thrust_n,torque_nm\n", "has no data rows"),
])
def test_the_plunge_csv_is_strict(tmp_path, text, message):
    p = tmp_path / "plunge.csv"
    p.write_text(text)
    with pytest.raises(InputError) as exc:
        read_plunge_forces(p)
    assert message in str(exc.value) and "plunge forces CSV" in str(exc.value)


@settings(max_examples=40, deadline=None)
@given(rows=st.lists(st.tuples(st.floats(100, 3e4), st.floats(1e-3, 100),
                               st.floats(-1e4, 1e4), st.floats(-1e3, 1e3)), min_size=1,
                     max_size=6))
def test_plunge_csv_values_are_read_back(tmp_path_factory, rows):
    p = tmp_path_factory.mktemp("csv") / "plunge.csv"
    p.write_text("# comment\nspindle_rpm,feed_mm_s,thrust_n,torque_nm\n"
                 + "".join(f"{a!r},{b!r},{c!r},{d!r}\n" for a, b, c, d in rows))
    got = read_plunge_forces(p)
    assert [(r.rpm, r.feed, r.thrust, r.torque) for r in got] == [
        (a, b * 1e-3, c, d) for a, b, c, d in rows]
    assert all(math.isfinite(r.feed) for r in got)
