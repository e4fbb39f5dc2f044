"""`feedopt path` on five-axis inputs: an APT CL file and a waypoint CSV with tool vectors give
samples with i, j, k columns, which read back as a five-axis waypoint file."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.geometry.waypoints import read_tool_vectors_csv
from tests.conftest import ROOT


def _table(path):
    header = path.read_text().splitlines()[0].split(",")
    rows = np.genfromtxt(path, delimiter=",", skip_header=1, dtype=str)
    return header, rows


def test_apt_file_samples_carry_unit_tool_vectors(tmp_path, capsys):
    out = tmp_path / "swarf.csv"
    assert main(["path", str(ROOT / "scenarios/five_axis/swarf_wall.cls"), "--out",
                 str(out)]) == 0
    assert "tool vectors: 100 on the path" in capsys.readouterr().out
    header, rows = _table(out)
    ijk = rows[:, [header.index(c) for c in "ijk"]].astype(float)
    assert np.allclose(np.linalg.norm(ijk, axis=1), 1.0, atol=1e-9)
    tilt = np.degrees(np.arccos(ijk[:, 2]))
    assert tilt.max() == pytest.approx(20.0, abs=0.05)


def test_csv_vectors_round_trip(tmp_path):
    out = tmp_path / "tilted.csv"
    assert main(["path", str(ROOT / "scenarios/waypoints/five_axis_tilted.csv"),
                 "--radius", "12.7", "--out", str(out)]) == 0
    vectors = read_tool_vectors_csv(out)
    assert vectors is not None and vectors.shape[1] == 3
    assert np.degrees(np.arccos(vectors[:, 2])).max() > 10.0


def test_bad_orientation_tolerance_is_refused_before_reading(tmp_path, capsys):
    assert main(["path", str(tmp_path / "missing.cls"), "--orientation-tolerance", "nan"]) == 2
    assert "--orientation-tolerance must be in (0, 10] deg" in capsys.readouterr().err


@pytest.mark.parametrize(("text", "line", "kind"), [
    ("$$ CL file\nPARTNO/x\nGOTO/0,0,5,0,0,1\n", 2, "an APT CL statement"),
    ("(header)\nN10 G21 G90\nG1 X1 Y1 F100\n", 2, "a G-code block"),
    ("x_mm,y_mm\n0,0\ngoto/1,2,3\n", 3, "an APT CL statement"),
])
def test_a_program_in_a_file_named_like_waypoints_is_named(tmp_path, capsys, text, line, kind):
    """A CL file or G-code program saved as .txt: the message names its line and the
    suffixes that read it, instead of asking for a blend size; nothing is written."""
    src = tmp_path / "prog.txt"
    src.write_text(text)
    assert main(["path", str(src), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert f"its line {line}" in err and kind in err and "--radius" not in err
    assert not (tmp_path / "o.csv").exists()


def test_label_columns_that_look_like_gcode_words_are_still_waypoints(tmp_path, capsys):
    """A CSV row holding text such as "G1 start" in a label column is a waypoint row (a G-code
    block has no comma), read as before."""
    src = tmp_path / "labels.csv"
    src.write_text("note,x_mm,y_mm,z_mm\nM6 tool change,0,0,0\nG1 start,10,0,0\nc,10,10,0\n")
    assert main(["path", str(src), "--radius", "1", "--out", str(tmp_path / "o.csv")]) == 0
    assert (tmp_path / "o.csv").is_file()


def test_a_pipe_named_like_waypoints_is_refused_without_waiting(tmp_path):
    """The program sniff reads regular files only: a FIFO is refused by the reader (it would
    block on a read)."""
    import os
    import subprocess
    import sys

    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    done = subprocess.run([sys.executable, "-m", "feedopt.cli", "path", str(fifo), "--radius",
                           "1", "--out", str(tmp_path / "o.csv")], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2 and "named pipe" in done.stderr
