"""Cases a hostile re-check of issue 26 found after the fixes: each is exit 2 with a true
message (they were exit 1, exit 0 or a misleading message)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from feedopt.cli import main, printable

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def job(tmp_path: Path) -> Path:
    """The triangle slot with its tool, material and robot copied beside it."""
    shutil.copytree(ROOT / "scenarios" / "tools", tmp_path / "tools")
    shutil.copytree(ROOT / "scenarios" / "materials", tmp_path / "materials")
    shutil.copytree(ROOT / "robots" / "kuka_kr500_3", tmp_path / "robot")
    text = (ROOT / "scenarios" / "triangle_slot.yaml").read_text()
    (tmp_path / "s.yaml").write_text(text.replace("../robots/kuka_kr500_3", "robot"))
    return tmp_path


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(("file", "old"), [
    ("tools/hss_2flute_19mm.yaml", "helix_deg: 30"),
    ("robot/robot.yaml", "dpp: [2.86"),
])
def test_an_integer_beyond_the_float_range_is_bad_input(job, capsys, file, old) -> None:
    """A 400-digit integer in a tool or robot file was OverflowError, exit 1."""
    key = old.split(":")[0]
    _edit(job / file, old, f"{key}: {'[' if '[' in old else ''}{'2' * 400}")
    assert main(["validate", str(job / "s.yaml")]) == 2
    err = capsys.readouterr().err
    assert "400 digits" in err and "internal error" not in err, err


@pytest.mark.parametrize("teeth", ["1000000", "99999999999999999999", "0"])
def test_a_tool_with_more_teeth_than_any_cutter_is_refused_by_validate(job, capsys,
                                                                       teeth) -> None:
    """teeth: 1000000 passed validate and failed run with a message about the angle step."""
    _edit(job / "tools" / "hss_2flute_19mm.yaml", "teeth: 2", f"teeth: {teeth}")
    assert main(["validate", str(job / "s.yaml")]) == 2
    err = capsys.readouterr().err
    assert ".teeth: expected a whole number from 1 to 100" in err, err


def test_a_file_name_with_terminal_escapes_is_printed_escaped(job, capsys) -> None:
    """A scenario naming tool "\\x1b[31mRED\\x1b[0m.yaml" printed the raw ESC bytes."""
    _edit(job / "s.yaml", "tool: tools/hss_2flute_19mm.yaml", 'tool: "\\e[31mRED\\e[0m.yaml"')
    assert main(["validate", str(job / "s.yaml")]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\\x1b[31mRED\\x1b[0m.yaml" in err, err


def test_printable_keeps_text_newlines_and_tabs() -> None:
    assert printable("a\tb\nc é µm") == "a\tb\nc é µm"
    assert printable("\x07\x1b\x7f\r") == "\\x07\\x1b\\x7f\\r"


def test_a_summary_with_a_5000_digit_integer_says_so(tmp_path, capsys) -> None:
    """compare printed Python's advice to call sys.set_int_max_str_digits()."""
    (tmp_path / "summary.json").write_text(json.dumps({"laws": {}})[:-1]
                                           + ', "x": ' + "1" * 5000 + "}")
    assert main(["compare", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "more than 4300 digits" in err and "set_int_max_str_digits" not in err, err
