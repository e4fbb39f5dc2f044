"""``feedopt forces`` and ``feedopt calibrate`` end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.process import (
    average_forces,
    average_torque,
    feed_per_tooth,
    load_coefficients,
    load_tool,
    peripheral_engagement,
)

from .conftest import MATERIAL_YAML, TABLE_3_3, TOOL_YAML

BASE = [
    "forces", "--tool", str(TOOL_YAML), "--coeffs", str(MATERIAL_YAML), "--rpm", "2000",
    "--feed-mm-s", "4.23", "--axial-depth-mm", "2.54",
]  # fmt: skip


def test_forces_writes_one_revolution(tmp_path, capsys):
    out, png = tmp_path / "f.csv", tmp_path / "f.png"
    args = BASE + ["--radial-depth-mm", "9.525", "--milling", "down", "--out", str(out)]
    assert main(args + ["--plot", str(png)]) == 0
    assert png.stat().st_size > 0
    header = out.read_text().splitlines()[0]
    assert header == "angle_deg,fx_n,fy_n,fz_n,f_n,torque_nm,power_w"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (360, 7)
    np.testing.assert_allclose(data[:, 0], np.arange(360))
    np.testing.assert_allclose(data[:, 4], np.hypot(data[:, 1], data[:, 2]), rtol=1e-5)
    np.testing.assert_allclose(data[:, 6], data[:, 5] * 2000 * 2 * math.pi / 60, rtol=1e-5)
    # mean over the revolution = closed-form average (half-immersion down milling)
    tool = load_tool(TOOL_YAML)
    c = feed_per_tooth(4.23e-3, 2000, 2)
    eng = peripheral_engagement(np.array([9.525e-3]), tool.diameter, 2.54e-3, "down")
    closed = average_forces(tool, TABLE_3_3[2000], eng.entry, eng.exit, 2.54e-3, c)[0]
    np.testing.assert_allclose(data[:, 1:4].mean(axis=0), closed, rtol=0.005)
    torque = average_torque(tool, TABLE_3_3[2000], eng.entry, eng.exit, 2.54e-3, c)[0]
    np.testing.assert_allclose(data[:, 5].mean(), torque, rtol=0.005)
    # forces repeat every tooth pitch (180 deg for 2 flutes)
    np.testing.assert_allclose(data[:180, 1:], data[180:, 1:], rtol=1e-4, atol=1e-4)
    assert "entry 90.00 deg, exit 180.00 deg" in capsys.readouterr().out


def test_forces_default_is_slot(tmp_path):
    out = tmp_path / "slot.csv"
    assert main(BASE + ["--out", str(out)]) == 0
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    mean = data[:, 1:4].mean(axis=0)
    assert mean[0] < 0 < mean[1] and mean[2] < 0  # Table 3.2 signs


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--radial-depth-mm", "20"], "--radial-depth-mm 20 exceeds the tool diameter"),
        (["--radial-depth-mm", "0"], "--radial-depth-mm must be > 0"),
        (["--radial-depth-mm", "-3"], "--radial-depth-mm must be > 0"),
        (["--milling", "climb"], "--milling must be 'up' or 'down'"),
        (["--rpm", "3500"], "3500 rpm is outside the calibrated speeds"),
        (["--axial-depth-mm", "30"], "--axial-depth-mm 30 exceeds the flute length"),
        (["--axial-depth-mm", "0"], "--axial-depth-mm must be > 0"),
        (["--feed-mm-s", "-1"], "--feed-mm-s must be > 0"),
        (["--axial-slices", "10000000"], "--axial-slices must be a whole number in 1..500, "
         "got 10000000"),
        (["--axial-slices", "0"], "--axial-slices must be a whole number in 1..500, got 0"),
        (["--step-deg", "0.001"], "--step-deg must be in [0.01, 90] deg, got 0.001"),
        (["--step-deg", "nan"], "--step-deg must be in [0.01, 90] deg, got nan"),
        (["--step-deg", "0.1", "--axial-slices", "500"],
         "--step-deg 0.1 (3600 angles) x 2 teeth (tool '2-flute 19.05 mm HSS TiN') x "
         "--axial-slices 500 = 3,600,000 slice evaluations, more than 2,000,000"),
        (["--rpm", "1e6"], "--rpm 1e+06 is above 100000 rpm"),
        (["--rpm", "inf"], "--rpm must be > 0 rpm, got inf"),
        (["--feed-mm-s", "1e6"], "--feed-mm-s 1e+06 at 2000 rpm with 2 teeth is a feed per "
         "tooth of 15000 mm, not below the tool radius 9.525 mm"),
        (["--feed-mm-s", "635"], "use a feed below 635 mm/s at this speed"),
    ],
)
def test_forces_bad_input_exit_2_nothing_written(tmp_path, capsys, extra, match):
    out = tmp_path / "f.csv"
    args = BASE + ["--out", str(out)]
    # later options override the base ones
    assert main(args + extra) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()


def test_forces_bad_files_exit_2(tmp_path, capsys):
    tool = tmp_path / "tool.yaml"
    tool.write_text("diameter_mm: 19.05\nteeth: 0\nhelix_deg: 30\nflute_length_mm: 20\n")
    args = BASE + ["--tool", str(tool)]
    assert main(args) == 2
    assert "teeth" in capsys.readouterr().err
    coeffs = tmp_path / "c.yaml"
    coeffs.write_text("speeds:\n  - {ktc_n_m2: 1}\n")
    assert main(BASE + ["--coeffs", str(coeffs)]) == 2
    assert "speeds[0]: missing field 'rpm'" in capsys.readouterr().err


def test_calibrate_prints_table_and_writes_coefficients(table_3_2, tmp_path, capsys):
    out = tmp_path / "coeffs.yaml"
    args = ["calibrate", str(table_3_2), "--teeth", "2", "--axial-depth-mm", "1.27"]
    assert main(args + ["--out", str(out), "--material", "6061-T6511"]) == 0
    text = capsys.readouterr().out
    assert "Ktc" in text and "R2 x" in text
    assert "  2000   8.568   7.422   3.190" in text
    table = load_coefficients(out)
    assert table.material == "6061-T6511"
    for rpm, k in TABLE_3_3.items():
        np.testing.assert_allclose(table.at(rpm).as_array(), k.as_array(), rtol=0.02)


def test_calibrate_bad_input(tmp_path, capsys, table_3_2):
    assert main(["calibrate", str(table_3_2), "--teeth", "0", "--axial-depth-mm", "1"]) == 2
    assert "--teeth must be >= 1" in capsys.readouterr().err
    assert main(["calibrate", str(table_3_2), "--teeth", "2", "--axial-depth-mm", "-1"]) == 2
    assert "--axial-depth-mm must be > 0" in capsys.readouterr().err
    missing = tmp_path / "none.csv"
    assert main(["calibrate", str(missing), "--teeth", "2", "--axial-depth-mm", "1"]) == 2
    out = tmp_path / "c.yaml"
    bad = tmp_path / "bad.csv"
    bad.write_text("spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n\n1000,1,2,3,4\n")
    args = ["calibrate", str(bad), "--teeth", "2", "--axial-depth-mm", "1", "--out", str(out)]
    assert main(args) == 2
    assert "two or more different feeds" in capsys.readouterr().err
    assert not out.exists()


def test_forces_table_bound_counts_the_tool_teeth(tmp_path, capsys):
    tool = tmp_path / "many.yaml"
    tool.write_text("name: many\ndiameter_mm: 19.05\nteeth: 100\nhelix_deg: 30\n"
                    "flute_length_mm: 20\n")
    assert main(BASE + ["--tool", str(tool), "--step-deg", "0.1", "--axial-slices", "20"]) == 2
    err = capsys.readouterr().err
    assert "(3600 angles) x 100 teeth (tool 'many') x --axial-slices 20 = 7,200,000" in err
    tool.write_text(tool.read_text().replace("teeth: 100", "teeth: 100000"))
    assert main(BASE + ["--tool", str(tool), "--step-deg", "90", "--axial-slices", "20"]) == 2
    assert "teeth: expected a whole number from 1 to 100" in capsys.readouterr().err


def test_forces_nominal_feed_no_warning(capsys):
    assert main(BASE) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    ("feed", "c_mm", "side"), [("40", "0.6", "above"), ("0.5", "0.0075", "below")]
)
def test_forces_warns_outside_calibrated_feed_per_tooth(tmp_path, capsys, feed, c_mm, side):
    out = tmp_path / "f.csv"
    assert main(BASE + ["--feed-mm-s", feed, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        f"feedopt forces: warning: feed per tooth {c_mm} mm is {side} the range the cutting "
        "coefficients of '6061-T6511' were calibrated for (0.01905..0.12705 mm per tooth); the "
        "linear force model (thesis Eq. 3.24) is extrapolated there and the forces may be "
        "wrong\n"
    )
    assert f"c = {float(c_mm):.5f} mm/tooth" in captured.out
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape == (360, 7)  # still computed


def test_forces_no_range_in_file_no_warning(tmp_path, capsys):
    text = "\n".join(ln for ln in MATERIAL_YAML.read_text().splitlines()
                     if not ln.startswith("feed_per_tooth_range_mm"))
    coeffs = tmp_path / "c.yaml"
    coeffs.write_text(text)
    assert load_coefficients(coeffs).feed_per_tooth_range is None
    assert main(BASE + ["--coeffs", str(coeffs), "--feed-mm-s", "40"]) == 0
    assert capsys.readouterr().err == ""


def test_forces_step_not_dividing_360_warns(tmp_path, capsys):
    out = tmp_path / "f.csv"
    assert main(BASE + ["--step-deg", "7", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        "feedopt forces: warning: --step-deg 7 does not divide 360 deg; using 51 steps of "
        "7.05882 deg\n"
    )
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_allclose(data[:, 0], np.arange(51) * 360 / 51, rtol=1e-5)


def test_forces_extrapolate_warns(capsys):
    assert main(BASE + ["--rpm", "3000", "--feed-mm-s", "4", "--extrapolate"]) == 0
    assert capsys.readouterr().err == (
        "feedopt forces: warning: --rpm 3000 is outside the calibrated speeds (1000..2500 rpm);"
        " --extrapolate holds the coefficients of 2500 rpm\n"
    )


def test_calibrate_records_feed_per_tooth_range(table_3_2, tmp_path, capsys):
    out = tmp_path / "coeffs.yaml"
    args = ["calibrate", str(table_3_2), "--teeth", "2", "--axial-depth-mm", "1.27"]
    assert main(args + ["--out", str(out)]) == 0
    assert "feed per tooth of the cuts: 0.01905..0.12705 mm" in capsys.readouterr().out
    lo, hi = load_coefficients(out).feed_per_tooth_range
    assert lo == pytest.approx(1.27e-3 * 60 / 4000) and hi == pytest.approx(8.47e-3 * 60 / 4000)
    # what forces then warns about, the file it wrote knows
    assert main(BASE + ["--coeffs", str(out), "--feed-mm-s", "40"]) == 0
    assert "0.01905..0.12705 mm per tooth" in capsys.readouterr().err


def _slot_csv(tmp_path, fy):
    """Slot forces at 2000 rpm, 2 teeth: Fx, Fz physical, Fy = fy(c_mm)."""
    rows = ["spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n"]
    for feed in (1.27, 3.39, 5.93, 8.47):
        c = feed * 60 / 4000
        rows.append(f"2000,{feed},{-10 - 170 * c:.4f},{fy(c):.4f},{-4 - 75 * c:.4f}")
    p = tmp_path / "forces.csv"
    p.write_text("\n".join(rows) + "\n")
    return p


@pytest.mark.parametrize(
    ("fy", "field"),
    [
        (lambda c: -(8 + 550 * c), "ktc_n_m2"),  # forces on the workpiece: Ktc < 0
        (lambda c: -2 + 550 * c, "kte_n_m"),  # negative intercept: Kte < 0
    ],
)
def test_calibrate_unphysical_fit_refused_with_out_warned_without(tmp_path, capsys, fy, field):
    csv = _slot_csv(tmp_path, fy)
    out = tmp_path / "c.yaml"
    args = ["calibrate", str(csv), "--teeth", "2", "--axial-depth-mm", "1.27"]
    assert main(args + ["--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert "  2000 " in captured.out  # the fit is still shown
    err = captured.err
    assert err.startswith("feedopt calibrate: error: the fit gives unphysical coefficient signs")
    assert f"at 2000 rpm: {field} = -" in err
    assert ("ktc_n_m2" in err) == (field == "ktc_n_m2") and "krc_n_m2" not in err
    assert f"Not writing {out}: feedopt would refuse to load it" in err
    assert "Kac and Kae may have either sign" in err
    assert not out.exists()
    assert main(args) == 0
    err = capsys.readouterr().err
    assert err.startswith("feedopt calibrate: warning: the fit gives unphysical coefficient")
    assert f"{field} = -" in err and "Not writing" not in err


def test_forces_notes_a_cutter_wider_above_its_tip(tmp_path, capsys):
    import yaml
    tool = tmp_path / "taper.yaml"
    tool.write_text(yaml.safe_dump({"name": "taper", "diameter_mm": 6.0, "teeth": 2,
                                    "helix_deg": 30, "flute_length_mm": 10, "shape": "tapered",
                                    "taper_deg": 5}))
    args = ["forces", "--tool", str(tool), "--coeffs", str(MATERIAL_YAML), "--rpm", "2000",
            "--feed-mm-s", "4.23", "--axial-depth-mm", "2"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "warning: the tapered cutter is 7.75 mm across at the top of its flutes" in err
