"""``feedopt validate``: --schema takes no scenario, --out writes the reference."""

from __future__ import annotations

from pathlib import Path

import pytest

from feedopt.cli import main
from feedopt.scenario import schema_reference

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "triangle_slot.yaml"


def test_schema_prints_the_reference(capsys):
    assert main(["validate", "--schema"]) == 0
    out = capsys.readouterr()
    assert out.out == schema_reference()
    assert out.out.startswith("# Scenario reference") and "**path.blend_size_mm**" in out.out
    assert out.err == ""


def test_schema_with_a_scenario_is_refused_and_the_file_untouched(tmp_path, capsys):
    scenario = tmp_path / "mine.yaml"
    scenario.write_bytes(SCENARIO.read_bytes())
    before = scenario.read_bytes()
    assert main(["validate", "--schema", str(scenario)]) == 2
    err = capsys.readouterr()
    assert err.out == ""  # no reference printed either: one clear answer
    assert "--schema prints the field reference and takes no scenario file" in err.err
    assert repr(str(scenario)) in err.err
    assert f"feedopt validate {scenario}" in err.err and "--schema --out reference.md" in err.err
    assert scenario.read_bytes() == before


def test_schema_out_writes_the_reference(tmp_path, capsys):
    out = tmp_path / "reference.md"
    assert main(["validate", "--schema", "--out", str(out)]) == 0
    assert out.read_text() == schema_reference()
    stdout = capsys.readouterr().out
    assert stdout == f"wrote {out}\n"


@pytest.mark.parametrize("name", ["scenario.yaml", "x.yml", "noext"])
def test_schema_out_refuses_non_text_names(tmp_path, capsys, name):
    out = tmp_path / name
    assert main(["validate", "--schema", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "the reference is Markdown text, not a scenario" in err and ".md or .txt" in err
    assert not out.exists()


def test_schema_out_missing_directory(tmp_path, capsys):
    out = tmp_path / "no" / "ref.md"
    assert main(["validate", "--schema", "--out", str(out)]) == 2
    assert f"--out: directory {out.parent} does not exist" in capsys.readouterr().err


def test_out_without_schema_is_refused(tmp_path, capsys):
    out = tmp_path / "ref.md"
    assert main(["validate", str(SCENARIO), "--out", str(out)]) == 2
    assert "--out writes the --schema reference" in capsys.readouterr().err
    assert not out.exists()


def test_no_scenario_no_schema(capsys):
    assert main(["validate"]) == 2
    assert "give a scenario file (or --schema)" in capsys.readouterr().err


def test_help_documents_schema_and_out(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["validate", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "takes no SCENARIO" in text and "--out FILE" in text
    assert "write the reference to FILE (.md or .txt)" in text
