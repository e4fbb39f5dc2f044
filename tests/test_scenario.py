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
    assert "cut.axial_depth_mm: required field is missing" in msg


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
