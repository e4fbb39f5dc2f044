"""``feedopt path PROGRAM --tool T --stock-box ...`` applies the stock checks of ``feedopt run``
(issue 28): a rapid whose swept volume meets the stock is refused with its line, as the run
refuses it (the run's message, checked against the same program through ``feedopt validate``
in tests/commands/test_validate.py), and nothing is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from feedopt.cli import main

ROOT = Path(__file__).resolve().parents[2]
TOOL = str(ROOT / "scenarios" / "tools" / "hss_2flute_19mm.yaml")
BOX = ["-20", "-20", "-25", "140", "100", "0"]
PROGRAM = """%
G21 G90 G17
T1 M6
S1500 M3
G0 X-30. Y0. Z5.
G0 Z-2.
G1 X10. F300.
G0 X60.
G0 Z5.
M5
M30
"""
SAFE = PROGRAM.replace("G0 X60.\nG0 Z5.", "G0 Z5.\nG0 X60.")


def _program(tmp_path: Path, text: str) -> str:
    p = tmp_path / "job.nc"
    p.write_text(text)
    return str(p)


def test_a_rapid_through_the_stock_is_refused_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "path.csv"
    code = main(["path", _program(tmp_path, PROGRAM), "--tool", TOOL, "--stock-box", *BOX,
                 "--out", str(out)])
    assert code == 2
    assert "job.nc line 8: a rapid (G0) meets material" in capsys.readouterr().err
    assert not out.exists()


def test_the_rapid_above_the_stock_passes_and_the_cut_is_counted(tmp_path, capsys):
    assert main(["path", _program(tmp_path, SAFE), "--tool", TOOL, "--stock-box", *BOX]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("stock:"))
    # 160 x 120 mm at 0.25 mm; the G1 from X-30 to X10 at Z-2 cuts from X-9.525 (the
    # cutter's edge reaches the box at X-20) on: 30 mm of 0.1 mm samples at least
    assert line.startswith("stock: 640 x 480 cells of 0.25 mm;")
    cut = int(line.split(";")[1].split()[0])
    assert 300 <= cut <= 420


@pytest.mark.parametrize(("args", "message"), [
    (["--stock-box", *BOX], "the stock checks need the cutter: add --tool"),
    (["--tool", TOOL], "--tool is used by the stock checks only"),
    (["--tool", TOOL, "--stock-box", *BOX, "--stock-from-program"], "not both"),
    (["--tool", TOOL, "--stock-box", "20", "-20", "-25", "10", "100", "0"],
     "--stock-box / --stock-cell: Value error, box_mm must be"),
])
def test_incomplete_stock_options_are_refused(tmp_path, capsys, args, message):
    assert main(["path", _program(tmp_path, SAFE), *args]) == 2
    assert message in capsys.readouterr().err


def test_stock_options_on_a_waypoint_path_are_refused(capsys):
    assert main(["path", "builtin:triangle", "--tool", TOOL]) == 2
    assert "builtin:triangle is not a program" in capsys.readouterr().err
