"""Scenario validation: clear messages for bad input (issue 6)."""

from pathlib import Path

import pytest
import yaml

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.scenario import LAWS, load_scenario, schema_reference

ROOT = Path(__file__).resolve().parents[1]
BUNDLED = sorted((ROOT / "scenarios").glob("*.yaml"))


def _write(tmp_path: Path, data: dict) -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


@pytest.fixture
def triangle() -> dict:
    return yaml.safe_load((ROOT / "scenarios" / "triangle_slot.yaml").read_text())


def test_bundled_scenarios_exist_and_validate() -> None:
    names = {p.stem for p in BUNDLED}
    assert {"triangle_slot", "square_slot", "linear_peripheral"} <= names
    for p in BUNDLED:
        scenario, _ = load_scenario(p)
        assert set(scenario.schedule.laws) <= set(LAWS)


def test_unknown_field_suggests_closest_name(tmp_path: Path, triangle: dict) -> None:
    triangle["cut"]["axial_depht_mm"] = triangle["cut"].pop("axial_depth_mm")
    with pytest.raises(InputError) as e:
        load_scenario(_write(tmp_path, triangle))
    msg = str(e.value)
    assert "cut.axial_depht_mm: unknown field" in msg
    assert "did you mean 'axial_depth_mm'" in msg
    # without the misspelt field, the missing depth is named (required without a stock)
    del triangle["cut"]["axial_depht_mm"]
    with pytest.raises(InputError, match="cut.type and cut.axial_depth_mm: required without "
                                         "a stock"):
        load_scenario(_write(tmp_path, triangle))


def test_wrong_type_names_field_and_value(tmp_path: Path, triangle: dict) -> None:
    triangle["deflection"]["limit_mm"] = "small"
    with pytest.raises(InputError, match=r"deflection\.limit_mm: .*number.*'small'"):
        load_scenario(_write(tmp_path, triangle))


def test_negative_value_refused(tmp_path: Path, triangle: dict) -> None:
    triangle["feed"]["nominal_mm_s"] = -4.23
    with pytest.raises(InputError, match=r"feed\.nominal_mm_s: .*greater than 0"):
        load_scenario(_write(tmp_path, triangle))


def test_peripheral_needs_radial_depth(tmp_path: Path, triangle: dict) -> None:
    triangle["cut"]["type"] = "peripheral"
    with pytest.raises(InputError, match="radial_depth"):
        load_scenario(_write(tmp_path, triangle))


def test_malformed_yaml_gives_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("name: x\ncut: [1, 2\n")
    with pytest.raises(InputError, match="not valid YAML at line"):
        load_scenario(p)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        load_scenario(tmp_path / "nope.yaml")


def test_validate_cli_exit_codes(tmp_path: Path, triangle: dict, capsys) -> None:
    assert main(["validate", str(ROOT / "scenarios" / "triangle_slot.yaml")]) == 0
    assert "ok" in capsys.readouterr().out
    triangle["tool"] = "tools/missing_tool.yaml"
    bad = _write(tmp_path, triangle)
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "tool file not found: tools/missing_tool.yaml" in err


def test_schema_reference_documents_every_section() -> None:
    ref = schema_reference()
    for key in ("robot.stiffness", "workpiece.position_mm", "path.blend", "cut.spindle_rpm",
                "deflection.limit_mm", "limits.tangential_jerk_mm_s3", "schedule.laws",
                "export.rsi_cycle_ms"):
        assert f"**{key}**" in ref


# --- issue 19: no silent coercions -------------------------------------------------------

TRIANGLE_TEXT = (ROOT / "scenarios" / "triangle_slot.yaml").read_text()


def _text_scenario(tmp_path: Path, old: str, new: str) -> Path:
    assert old in TRIANGLE_TEXT
    p = tmp_path / "scenarios" / "s.yaml"
    p.parent.mkdir(exist_ok=True)
    p.write_text(TRIANGLE_TEXT.replace(old, new).replace("../robots", str(ROOT / "robots"))
                 .replace("tools/", str(ROOT / "scenarios" / "tools") + "/")
                 .replace("materials/", str(ROOT / "scenarios" / "materials") + "/"))
    return p


@pytest.mark.parametrize("written", ["true", "yes", "on", "0x1D", "0o35", "'0.29'", "1:30"])
def test_limit_written_as_a_non_number_is_refused(tmp_path, written) -> None:
    p = _text_scenario(tmp_path, "limit_mm: 0.29", f"limit_mm: {written}")
    with pytest.raises(InputError, match=r"deflection\.limit_mm: Input should be a valid number"):
        load_scenario(p)


def test_exponent_without_dot_is_a_number(tmp_path) -> None:
    p = _text_scenario(tmp_path, "limit_mm: 0.29", "limit_mm: 29e-2")
    assert load_scenario(p)[0].deflection.limit_mm == pytest.approx(0.29)


def test_duplicate_key_is_refused_with_both_lines(tmp_path) -> None:
    p = _text_scenario(tmp_path, "  limit_mm: 0.29\n", "  limit_mm: 0.29\n  limit_mm: 0.5\n")
    lines = p.read_text().splitlines()
    first = lines.index("  limit_mm: 0.29") + 1
    with pytest.raises(InputError, match=f"'limit_mm' is given twice.*lines {first} and "
                                         f"{first + 1}"):
        load_scenario(p)


def test_duplicate_section_is_refused(tmp_path) -> None:
    p = _text_scenario(tmp_path, "deflection:\n", "deflection:\n  limit_mm: 1.0\n\n"
                       "deflection:\n")
    with pytest.raises(InputError, match="'deflection' is given twice"):
        load_scenario(p)


def test_alias_bomb_is_refused_with_a_short_message(tmp_path) -> None:
    bomb = ['a0: &a0 ["x","x","x","x","x","x","x","x","x"]']
    bomb += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
    p = _text_scenario(tmp_path, "name: triangle_slot\n", "\n".join(bomb) + "\nname: *a8\n")
    with pytest.raises(InputError) as e:
        load_scenario(p)
    assert "expand to more than" in str(e.value) and len(str(e.value)) < 400


def test_long_bad_value_is_echoed_as_a_short_excerpt(tmp_path) -> None:
    p = _text_scenario(tmp_path, "limit_mm: 0.29", "limit_mm: [" + ", ".join(["1"] * 5000) + "]")
    with pytest.raises(InputError) as e:
        load_scenario(p)
    assert "deflection.limit_mm" in str(e.value) and len(str(e.value)) < 400


@pytest.mark.parametrize("cycle", ["1", "0.001", "100000", "8"])
def test_rsi_cycle_must_be_a_controller_cycle(tmp_path, cycle) -> None:
    p = _text_scenario(tmp_path, "rsi_cycle_ms: 4", f"rsi_cycle_ms: {cycle}")
    with pytest.raises(InputError, match=r"export.*not an RSI cycle.*4 ms.*12 ms"):
        load_scenario(p)


def test_rsi_cycle_of_12_ms_is_accepted(tmp_path) -> None:
    p = _text_scenario(tmp_path, "rsi_cycle_ms: 4", "rsi_cycle_ms: 12")
    assert load_scenario(p)[0].export.rsi_cycle_ms == 12


@pytest.mark.parametrize("name", ["../../etc", "/tmp/x", ".", "..", "a/b", ""])
def test_scenario_name_must_be_a_plain_folder_name(tmp_path, name) -> None:
    p = _text_scenario(tmp_path, "name: triangle_slot", f"name: '{name}'")
    with pytest.raises(InputError, match="name"):
        load_scenario(p)


def test_binary_scenario_is_bad_input(tmp_path, capsys) -> None:
    p = tmp_path / "garbage.yaml"
    p.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    assert main(["validate", str(p)]) == 2
    assert "not UTF-8 text" in capsys.readouterr().err


def test_warnings_for_max_feed_below_nominal_and_repeated_laws(tmp_path) -> None:
    from feedopt.scenario import scenario_warnings

    p = _text_scenario(tmp_path, "laws: [constant, thesis, topp, convex, jerk]",
                       "laws: [constant, jerk, jerk]")
    p.write_text(p.read_text().replace("nominal_mm_s: 4.23", "nominal_mm_s: 4.23\n  max_mm_s: 3"))
    warnings = scenario_warnings(load_scenario(p)[0])
    assert any("max_mm_s = 3 mm/s is below feed.nominal_mm_s = 4.23" in w for w in warnings)
    assert any("jerk more than once" in w for w in warnings)


def test_fit_notes_label_the_fitted_value_and_say_when_it_changed(quick_scenario):
    """A scenario value chosen to reproduce the thesis is labelled a fit, with the value the
    thesis's data suggest; a run at another value says its results are predictions there."""
    sc, _ = load_scenario(quick_scenario("triangle_slot"))
    (note,) = sc.fit_notes()
    assert note.startswith("cut.axial_depth_mm = 1.5 is a FIT")
    assert "2.54" in note and "0.686 mm" in note
    sc, _ = load_scenario(quick_scenario("triangle_slot", cut__axial_depth_mm=2.54))
    (note,) = sc.fit_notes()
    assert note.startswith("cut.axial_depth_mm = 2.54 here, not its fitted 1.5")
    sc, _ = load_scenario(quick_scenario("linear_peripheral_stock"))
    assert sc.fit_notes()[0].startswith("stock.box_mm[5] = 1.5 is a FIT")


@pytest.mark.parametrize(("field", "why"), [("cut.depth_mm", "no scenario field 'cut.depth_mm'"),
                                           ("stock.box_mm[9]", "has no element"),
                                           ("cut.type", "is not a number")])
def test_fit_notes_must_name_a_numeric_field(quick_scenario, field, why):
    bad = quick_scenario("triangle_slot_stock" if "box" in field else "triangle_slot")
    doc = yaml.safe_load(bad.read_text())
    doc["fits"] = [{"field": field, "value": 1.5, "why": "test"}]
    bad.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=why.replace("[", r"\[")):
        load_scenario(bad)
