"""``feedopt path PROGRAM.nc``: the CSV of a program path (line, n, move, nominal feed
columns), G2 by finite differences of the written CSV at two spacings, the junction table,
and refusals that name the line with nothing written."""

import csv

import numpy as np
import pytest

from feedopt.cli import main
from tests.conftest import SCENARIOS

PROFILE = SCENARIOS / "gcode" / "profile.nc"


def _read(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    head, body = rows[0], rows[1:]
    num = np.array([[float(v) for v in r[:10]] for r in body])
    return head, num, [r[10:] for r in body]


def _max_curvature_step(pos_mm, s_mm):
    """Largest change between samples of |curvature| from central differences of the
    written positions (independent of the path's own curvature columns)."""
    h = np.diff(s_mm).mean()
    k = np.linalg.norm((pos_mm[2:] - 2 * pos_mm[1:-1] + pos_mm[:-2]) / h**2, axis=1)
    return np.abs(np.diff(k)).max()


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    d = tmp_path_factory.mktemp("prog")
    out = {}
    for h in (0.02, 0.01):
        f = d / f"path_{h}.csv"
        assert main(["path", str(PROFILE), "--spacing", str(h), "--out", str(f)]) == 0
        out[h] = _read(f)
    return out


def test_program_csv_has_the_provenance_columns(written):
    head, num, extra = written[0.02]
    assert head[-4:] == ["line", "n", "move", "nominal_feed_mm_s"]
    moves = {r[2] for r in extra}
    assert moves == {"cut", "plunge", "rapid"}
    feeds = {r[3] for r in extra if r[2] == "cut"}
    assert feeds <= {"3.33333", "4.23333"}  # F200. and F254. in mm/s
    assert all(r[3] == "" for r in extra if r[2] == "rapid")
    lines = np.array([int(r[0]) for r in extra])
    assert np.all(np.diff(lines) >= 0)  # samples follow the program in order


def test_g2_by_finite_differences_of_the_written_csv_at_two_spacings(written):
    """In the cut at the stock depth, the largest curvature change between samples shrinks
    with the spacing (continuous curvature); a curvature jump would keep it at the jump."""
    steps = []
    for h in (0.02, 0.01):
        _, num, extra = written[h]
        cut = np.array([r[2] == "cut" for r in extra]) & (np.abs(num[:, 3] + 1.5) < 1e-9)
        idx = np.flatnonzero(cut)
        lo, hi = idx[0] + 50, idx[-1] - 50  # the contour, away from the entry and exit ramps
        steps.append(_max_curvature_step(num[lo:hi, 1:4], num[lo:hi, 0]))
    assert steps[1] < 0.7 * steps[0]


def test_junction_table_is_printed_with_lines_and_deviations(tmp_path, capsys):
    assert main(["path", str(PROFILE), "--max-rows", "0"]) == 0
    text = capsys.readouterr().out
    assert "smoothed chain: lines 28-177 (150 moves" in text
    assert "treatment" in text and "dev_mm" in text and "line 23 (N100)->24" in text
    assert "largest deviation" in text


def test_refusals_name_the_line_and_write_nothing(tmp_path, capsys):
    """A plunge is an ordinary move; the position lost (G28) with the tool in the stock is
    refused: the air link would start below the stock top."""
    prog = tmp_path / "lost.nc"
    prog.write_text("G21 G90 G17\nG0 X0 Y0 Z5\nS1000 M3\nG1 Z-3 F100\nG1 X10\n"
                    "G28 G91 Z0\nG90\nG0 X20 Y0 Z5\nG1 Z-3\nG1 X30\nM30\n")
    out = tmp_path / "p.csv"
    assert main(["path", str(prog), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert ("lost.nc line 5: the tool is at Z-3 mm, below the stock top (Z0 mm), when the "
            "program loses its position after this move") in err
    assert not out.exists()
    assert main(["path", str(prog), "--stock-top", "-5", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "note: lines 5-9: the tool position is unknown between them" in text
    assert "straight up to Z5 mm" in text and out.exists()


def test_stops_are_printed_and_sampled_exactly(tmp_path, capsys):
    prog = tmp_path / "stops.nc"
    prog.write_text("G21 G90 G17\nG0 X0 Y0 Z5\nS1000 M3\nG1 Z-1 F100\nG1 X10.05\n"
                    "G1 X0\nG4 P2\nG1 Y10\nM30\n")
    out = tmp_path / "p.csv"
    assert main(["path", str(prog), "--spacing", "0.1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "note: the tool stops on the path: 2 stop(s): 1 reversal, 1 dwell (2 s held)" in text
    assert "stop" in text.split("treatment")[1]
    _, num, _ = _read(out)
    for point in ([10.05, 0, -1], [0, 0, -1]):  # a sample on each stop, not 0.05 mm beside it
        assert np.linalg.norm(num[:, 1:4] - point, axis=1).min() < 1e-6
