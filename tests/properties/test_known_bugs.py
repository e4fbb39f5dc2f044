"""Regression tests of the bugs the property tests found (issue 17), reproduced exactly:
control characters in YAML, NUL bytes and over-long names in output paths."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.outdir import check_destination
from feedopt.outfile import check_output_file
from feedopt.scenario import load_scenario

LONG = "x" * 300  # one path component longer than NAME_MAX (255 bytes)


def test_yaml_control_character(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text("\x1fname: x\n")  # any C0 control other than tab/LF/CR; also U+FFFE
    with pytest.raises(InputError):
        load_scenario(p)


def test_yaml_control_character_cli(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text("\x1fname: x\n")
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["validate", str(p)]) == 2


def test_output_file_nul_byte():
    with pytest.raises(InputError):
        check_output_file("a\0b", "--out")


def test_destination_nul_byte():
    with pytest.raises(InputError):
        check_destination(Path("a\0b"), [Path.cwd()], False)


def test_output_file_name_too_long(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError):
        check_output_file(LONG, "--out")


def test_destination_name_too_long(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError):
        check_destination(Path(LONG), [Path.cwd()], False)


def test_run_out_name_too_long(tmp_path, monkeypatch, quick_scenario):
    scen = quick_scenario("linear_peripheral", path__spacing_mm=2.0,
                          schedule__laws=["constant", "jerk"])
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", str(scen), "--out", LONG, "--no-report"]) == 2


def test_schema_out_name_too_long(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["validate", "--schema", "--out", f"{LONG}/y.md"]) == 2
