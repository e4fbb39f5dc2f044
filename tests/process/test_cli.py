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
