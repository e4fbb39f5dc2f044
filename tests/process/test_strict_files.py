"""Tool and material (cutting-coefficient) files are strict (issue 26, item 5): an unknown
key is refused with the file, the key, a close match or a hint, and the known keys."""

from __future__ import annotations

import pytest
import yaml

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.process.coefficients import FILE_KEYS, FILE_TOP_KEYS, load_coefficients
from feedopt.process.tool import TOOL_KEYS, load_tool
from tests.conftest import SCENARIOS

TOOL_FILE = SCENARIOS / "tools" / "hss_2flute_19mm.yaml"
COEFF_FILE = SCENARIOS / "materials" / "6061-T6511.yaml"


def _tool(tmp_path, **changes):
    doc = yaml.safe_load(TOOL_FILE.read_text()) | changes
    p = tmp_path / "tool.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def _coeffs(tmp_path, top=None, speed=None):
    doc = yaml.safe_load(COEFF_FILE.read_text()) | (top or {})
    doc["speeds"][1] |= speed or {}
    p = tmp_path / "coeffs.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_the_bundled_files_load():
    tool = load_tool(TOOL_FILE)
    assert tool.teeth == 2 and tool.diameter == pytest.approx(19.05e-3)
    assert load_coefficients(COEFF_FILE).rpm.tolist() == [1000.0, 2000.0, 2500.0]


@pytest.mark.parametrize(("key", "want"), [
    ("flute_lenght_mm", "did you mean 'flute_length_mm'?"),
    ("corner_radiuss_mm", "did you mean 'corner_radius_mm'?"),
    ("nose_r", "use corner_radius_mm"),
    ("cutter_type", "use shape (flat, ball, bull, tapered, face)"),
    ("overhang", "use stickout_mm"),
    ("colour", ""),
])
def test_an_unknown_tool_key_is_refused(tmp_path, key, want):
    p = _tool(tmp_path, **{key: 1})
    with pytest.raises(InputError) as exc:
        load_tool(p)
    msg = str(exc.value)
    assert str(p) in msg and f"unknown key {key!r}" in msg and want in msg
    assert "known keys: " + ", ".join(TOOL_KEYS) in msg


@pytest.mark.parametrize(("field", "value", "want"), [
    ("overall_length_mm", -1, "overall_length_mm: must be > 0"),
    ("overall_length_mm", 10, "shorter than the flute length"),
    ("shank_diameter_mm", "wide", "shank_diameter_mm: expected a number"),
    ("source", {"a": 1}, "source: expected text"),
    ("name", [1], "name: expected text"),
])
def test_the_informative_tool_fields_hold_what_they_say(tmp_path, field, value, want):
    with pytest.raises(InputError, match=want):
        load_tool(_tool(tmp_path, **{field: value}))


def test_an_unknown_material_key_is_refused_at_the_top_and_per_speed(tmp_path):
    p = _coeffs(tmp_path, top={"shape": "block"})
    with pytest.raises(InputError) as exc:
        load_coefficients(p)
    msg = str(exc.value)
    assert str(p) in msg and "unknown key 'shape'" in msg
    assert "known keys: " + ", ".join(FILE_TOP_KEYS) in msg
    p = _coeffs(tmp_path, speed={"ktc_n_m": 1.0})
    with pytest.raises(InputError) as exc:
        load_coefficients(p)
    msg = str(exc.value)
    assert "speeds[1]: unknown key 'ktc_n_m': did you mean 'ktc_n_m2'?" in msg
    assert "known keys: rpm, " + ", ".join(FILE_KEYS.values()) in msg


def test_validate_and_run_refuse_a_tool_with_an_unknown_key(tmp_path, quick_scenario, capsys):
    tool = _tool(tmp_path, corner_radiuss_mm=1.0)
    scenario = quick_scenario("linear_peripheral")
    doc = yaml.safe_load(scenario.read_text())
    scenario.write_text(yaml.safe_dump(doc | {"tool": str(tool)}))
    out = tmp_path / "out"
    for argv in (["validate", str(scenario)], ["run", str(scenario), "--out", str(out)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "unknown key 'corner_radiuss_mm'" in err and str(tool) in err
    assert not out.exists()
