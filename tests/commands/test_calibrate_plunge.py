"""``feedopt calibrate --plunge-forces``: the plunge blocks of a material file fitted from
straight-plunge thrust and torque (issue 27), and the inputs it refuses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.process.coefficients import load_coefficients
from feedopt.process.plunge import PlungeCoefficients

ROOT = Path(__file__).resolve().parents[2]
SLOTS = ROOT / "scenarios" / "materials" / "thesis_table_3_2_slot_forces.csv"
TEETH, DIAMETER_MM = 2, 19.05
WANT = {1000: PlungeCoefficients(1.4e9, 2.5e4, 0.8e9, 1.2e4),
        2000: PlungeCoefficients(1.5e9, 2.0e4, 0.9e9, 1.0e4),
        2500: PlungeCoefficients(1.6e9, 1.5e4, 1.0e9, 0.6e4)}
BASE = ["calibrate", str(SLOTS), "--teeth", str(TEETH), "--axial-depth-mm", "1.27"]


def _plunge_csv(tmp_path: Path, want=WANT, extra_rpm: float | None = None,
                name: str = "plunges.csv") -> Path:
    """Thrust and torque of full plunges from the model's totals (N R (Ktc c + Kte) and
    N R^2 / 2 (Kcc c + Kce)) at four axial feeds per speed."""
    radius = DIAMETER_MM / 2 * 1e-3
    lines = ["spindle_rpm,feed_mm_s,thrust_n,torque_nm"]
    for rpm, k in want.items():
        for feed_mm_s in (0.4, 1.1, 2.3, 3.0):
            c = feed_mm_s * 1e-3 * 60 / (TEETH * rpm)
            thrust = TEETH * radius * (k.thrust_cutting * c + k.thrust_edge)
            torque = TEETH * radius**2 / 2 * (k.torque_cutting * c + k.torque_edge)
            lines.append(f"{rpm},{feed_mm_s},{thrust!r},{torque!r}")
    if extra_rpm is not None:
        lines += [f"{extra_rpm:g},1.0,100,1", f"{extra_rpm:g},2.0,150,1.5"]
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def test_calibrate_writes_the_fitted_plunge_blocks(tmp_path, capsys):
    out = tmp_path / "coeffs.yaml"
    plunges = _plunge_csv(tmp_path)
    args = BASE + ["--plunge-forces", str(plunges), "--diameter-mm", str(DIAMETER_MM),
                   "--out", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "plunge (fit" in text and "R2 F_z" in text
    assert "  2000  1500.00   20.000   900.00   10.000   1.0000 1.0000" in text
    table = load_coefficients(out)
    for rpm, k in WANT.items():
        np.testing.assert_allclose(table.at(rpm).plunge.as_array(), k.as_array(), rtol=1e-5)
    doc = yaml.safe_load(out.read_text())
    assert "plunge blocks: least-squares fit of plunges.csv --diameter-mm 19.05" in doc["source"]
    assert doc["speeds"][0]["plunge"]["thrust_cutting_n_mm2"] == pytest.approx(1400.0)
    # without --plunge-forces the file has no plunge block (and loads as before)
    plain = tmp_path / "plain.yaml"
    assert main(BASE + ["--out", str(plain)]) == 0
    assert "plunge" not in plain.read_text() and load_coefficients(plain).plunge is None


@pytest.mark.parametrize(("extra", "message"), [
    (["--diameter-mm", "19.05"], "--diameter-mm is only used with --plunge-forces"),
    (["--plunge-forces", "PLUNGES"], "--plunge-forces needs --diameter-mm > 0"),
    (["--plunge-forces", "PLUNGES", "--diameter-mm", "0"], "--plunge-forces needs --diameter-mm"),
    (["--plunge-forces", "MISSING", "--diameter-mm", "19.05"], "plunge forces CSV"),
    (["--plunge-forces", "SHORT", "--diameter-mm", "19.05"], "no plunge cuts at 2500 rpm"),
    (["--plunge-forces", "EXTRA", "--diameter-mm", "19.05"],
     "plunge cuts at 3000 rpm, where there are no slot cuts"),
    (["--plunge-forces", "NEGATIVE", "--diameter-mm", "19.05"],
     "plunge.thrust_cutting_n_mm2 = -1400 N/mm^2 (must be > 0"),
    (["--plunge-forces", "COLUMN", "--diameter-mm", "19.05"], "unknown column(s) fx_n"),
])
def test_calibrate_refuses_bad_plunge_input_and_writes_nothing(tmp_path, capsys, extra, message):
    negative = {r: PlungeCoefficients(-k.thrust_cutting, k.thrust_edge, k.torque_cutting,
                                      k.torque_edge) for r, k in WANT.items()}
    files = {
        "PLUNGES": _plunge_csv(tmp_path),
        "MISSING": tmp_path / "none.csv",
        "SHORT": _plunge_csv(tmp_path, {r: k for r, k in WANT.items() if r != 2500},
                             name="short.csv"),
        "EXTRA": _plunge_csv(tmp_path, extra_rpm=3000, name="extra.csv"),
        "NEGATIVE": _plunge_csv(tmp_path, negative, name="negative.csv"),
    }
    column = tmp_path / "column.csv"
    column.write_text("spindle_rpm,feed_mm_s,thrust_n,torque_nm,fx_n\n1000,1,2,3,4\n")
    files["COLUMN"] = column
    out = tmp_path / "coeffs.yaml"
    args = BASE + [str(files.get(a, a)) for a in extra] + ["--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("feedopt calibrate: error:") and message in err
    assert not out.exists()


def test_unphysical_plunge_fit_is_a_warning_without_out(tmp_path, capsys):
    neg = _plunge_csv(tmp_path, {r: PlungeCoefficients(k.thrust_cutting, k.thrust_edge,
                                                       k.torque_cutting, -k.torque_edge)
                                 for r, k in WANT.items()})
    assert main(BASE + ["--plunge-forces", str(neg), "--diameter-mm", "19.05"]) == 0
    err = capsys.readouterr().err
    assert "warning: the fit gives unphysical coefficient signs" in err
    assert "plunge.torque_edge_n_mm = -12 N/mm (must be >= 0" in err


def test_the_plunge_csv_is_not_overwritten_by_out(tmp_path, capsys):
    plunges = _plunge_csv(tmp_path)
    before = plunges.read_text()
    args = BASE + ["--plunge-forces", str(plunges), "--diameter-mm", "19.05", "--out",
                   str(plunges)]
    assert main(args) == 2
    assert plunges.read_text() == before
    assert "--out" in capsys.readouterr().err
