"""Property: mutated tool and cutting-coefficient files are either read (with physical values)
or refused with one InputError."""

from __future__ import annotations

import math

import numpy as np
import yaml
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.process.coefficients import CoefficientTable, load_coefficients
from feedopt.process.tool import Tool, load_tool

from ._support import (
    SCENARIOS,
    budget,
    garbage,
    mutated,
    text_mutations,
)

TOOL_FILE = SCENARIOS / "tools" / "hss_2flute_19mm.yaml"
COEFF_FILE = SCENARIOS / "materials" / "6061-T6511.yaml"
TOOL = yaml.safe_load(TOOL_FILE.read_text())
COEFFS = yaml.safe_load(COEFF_FILE.read_text())


def check_tool(path):
    try:
        tool = load_tool(path)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert isinstance(tool, Tool)
    assert math.isfinite(tool.diameter) and tool.diameter > 0
    assert isinstance(tool.teeth, int) and tool.teeth >= 1
    assert 0 <= tool.helix < math.pi / 2
    assert math.isfinite(tool.flute_length) and tool.flute_length > 0


def check_coefficients(path):
    try:
        table = load_coefficients(path)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert isinstance(table, CoefficientTable)
    for rpm in np.atleast_1d(table.rpm):
        c = table.at(float(rpm))
        assert np.all(np.isfinite(c.as_array()))


def _write(path, doc):
    path.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")


@budget(120)
@given(doc=mutated(TOOL))
def test_mutated_tool(tmp_path, doc):
    p = tmp_path / "tool.yaml"
    _write(p, doc)
    check_tool(p)


@budget(40)
@given(teeth=garbage, diameter=garbage, helix=garbage, flute=garbage)
def test_tool_field_values(tmp_path, teeth, diameter, helix, flute):
    doc = dict(TOOL, teeth=teeth, diameter_mm=diameter, helix_deg=helix, flute_length_mm=flute)
    p = tmp_path / "tool.yaml"
    _write(p, doc)
    check_tool(p)


@budget(120)
@given(doc=mutated(COEFFS))
def test_mutated_coefficients(tmp_path, doc):
    p = tmp_path / "coeffs.yaml"
    _write(p, doc)
    check_coefficients(p)


@budget(40)
@given(speeds=garbage, rng=garbage)
def test_coefficient_sections(tmp_path, speeds, rng):
    p = tmp_path / "coeffs.yaml"
    _write(p, dict(COEFFS, speeds=speeds))
    check_coefficients(p)
    _write(p, dict(COEFFS, feed_per_tooth_range_mm=rng))
    check_coefficients(p)


@budget(60)
@given(data=st.data(), which=st.sampled_from(["tool", "coeffs"]))
def test_raw_text_mutations(tmp_path, data, which):
    src = TOOL_FILE if which == "tool" else COEFF_FILE
    text = data.draw(text_mutations(src.read_text(), alphabet=list(":-[]{},#&*!|>' \t\n0.e+")))
    p = tmp_path / src.name
    p.write_text(text, encoding="utf-8", errors="surrogatepass")
    (check_tool if which == "tool" else check_coefficients)(p)


@budget(40)
@given(raw=st.binary(max_size=300))
def test_random_bytes(tmp_path, raw):
    p = tmp_path / "side.yaml"
    p.write_bytes(raw)
    check_tool(p)
    check_coefficients(p)
