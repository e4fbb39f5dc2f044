"""``feedopt path``: outputs, continuity printout, exit codes and nothing written on bad input."""

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.geometry import waves
from feedopt.geometry.path import build_lipb_path

HEADER = "s_mm,x_mm,y_mm,z_mm,tx,ty,tz,kx_1_mm,ky_1_mm,kz_1_mm"


def _write(tmp_path, w_mm, name="w.csv"):
    f = tmp_path / name
    rows = "\n".join(",".join(f"{v:.12g}" for v in r) for r in w_mm)
    f.write_text("x_mm,y_mm,z_mm\n" + rows + "\n")
    return f


def test_path_csv_and_report(tmp_path, capsys):
    f = _write(tmp_path, waves.triangle_wave() * 1e3)
    out, png = tmp_path / "path.csv", tmp_path / "path.png"
    rc = main(["path", str(f), "--blend", "varying_radius", "--radius", "12.7",
               "--spacing", "0.1", "--out", str(out), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "G2_1_mm" in text and "varying_radius" in text
    assert out.read_text().splitlines()[0] == HEADER
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    path = build_lipb_path(waves.triangle_wave(), "varying_radius", 0.0127)
    assert data.shape == (int(np.ceil(path.length / 1e-4)) + 1, 10)
    assert data[-1, 0] == pytest.approx(path.length * 1e3, rel=1e-9)
    pts = path.evaluate(data[:, 0] * 1e-3)
    np.testing.assert_allclose(data[:, 1:4], pts.position * 1e3, atol=1e-8)
    np.testing.assert_allclose(data[:, 4:7], pts.tangent, atol=1e-9)
    np.testing.assert_allclose(data[:, 7:10], pts.curvature * 1e-3, atol=1e-10)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(("blend", "opt"), [("bezier5", "--tolerance"), ("circle", "--radius"),
                                           ("none", None)])
def test_builtin_paths(tmp_path, capsys, blend, opt):
    args = ["path", "builtin:square", "--blend", blend]
    if opt:
        args += [opt, "10"]
    assert main(args) == 0
    assert "max over" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "content", "match"), [
    (["--blend", "circle", "--radius", "60"], None, "largest radius"),
    (["--blend", "circle"], None, "needs --radius"),
    (["--blend", "bezier4", "--radius", "5"], None, "takes --tolerance"),
    (["--blend", "circle", "--radius", "5", "--spacing", "0"], None, "--spacing"),
    (["--blend", "circle", "--radius", "5"], "x,y,z\n0,0,0\n1,1,1\n", "lacks column"),
    (["--blend", "circle", "--radius", "5"], "x_mm,y_mm,z_mm\n0,0,0\n0,0,0\n1,1,0\n",
     "repeat"),
    (["--blend", "circle", "--radius", "5"], "x_mm,y_mm,z_mm\n0,0,0\nnan,0,0\n1,1,0\n",
     "not finite"),
    (["--blend", "circle", "--radius", "1"], "x_mm,y_mm,z_mm\n0,0,0\n10,0,0\n5,0,0\n",
     "reverses"),
])
def test_bad_input_exit_2_nothing_written(tmp_path, capsys, args, content, match):
    if content is None:
        f = _write(tmp_path, waves.triangle_wave() * 1e3)
    else:
        f = tmp_path / "w.csv"
        f.write_text(content)
    out, png = tmp_path / "o.csv", tmp_path / "o.png"
    rc = main(["path", str(f), *args, "--out", str(out), "--plot", str(png)])
    assert rc == 2
    assert match in capsys.readouterr().err
    assert not out.exists() and not png.exists()


def test_drop_repeated_says_so(tmp_path, capsys):
    f = tmp_path / "w.csv"
    f.write_text("x_mm,y_mm,z_mm\n0,0,0\n0,0,0\n50,0,0\n50,50,0\n")
    assert main(["path", str(f), "--blend", "circle", "--radius", "5",
                 "--drop-repeated"]) == 0
    assert "dropped 1 repeated waypoint(s): indices 1" in capsys.readouterr().out


def test_missing_output_directory(tmp_path, capsys):
    rc = main(["path", "builtin:triangle", "--blend", "none",
               "--out", str(tmp_path / "no" / "x.csv")])
    assert rc == 2 and "does not exist" in capsys.readouterr().err


@pytest.mark.parametrize(("args", "message"), [
    (["--blend", "none", "--max-rows", "-5"],
     "--max-rows must be >= 0 (0 = all junction rows), got -5"),
    (["--radius", "-3"], "--radius must be a positive, finite number of mm, got -3 "
     "(e.g. --radius 12.7)"),
    (["--radius", "0"], "--radius must be a positive, finite number of mm, got 0"),
    (["--radius", "nan"], "--radius must be a positive, finite number of mm, got nan"),
    (["--blend", "bezier5", "--tolerance", "inf"],
     "--tolerance must be a positive, finite number of mm, got inf"),
    (["--blend", "bezier4", "--tolerance", "-1"],
     "--tolerance must be a positive, finite number of mm, got -1"),
    (["--radius", "5", "--spacing", "-0.1"],
     "--spacing must be a positive, finite number of mm, got -0.1"),
    (["--radius", "5", "--spacing", "inf"],
     "--spacing must be a positive, finite number of mm, got inf"),
    (["--blend", "none", "--radius", "5"], "--radius sizes a blend; --blend none has none"),
])
def test_numeric_options_refused(tmp_path, capsys, args, message):
    out = tmp_path / "o.csv"
    assert main(["path", "builtin:triangle", *args, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"feedopt path: error: {message}")
    assert captured.out == ""
    assert not out.exists()


def _junction_rows(text):
    return [ln for ln in text.splitlines() if ln.strip()[:1].isdigit()]


def test_max_rows_zero_prints_all_and_small_values_truncate(capsys):
    args = ["path", "builtin:triangle", "--radius", "5"]  # 5 corners, 10 junctions
    assert main(args + ["--max-rows", "0"]) == 0
    out = capsys.readouterr().out
    assert [int(r.split()[0]) for r in _junction_rows(out)] == list(range(10))
    assert "omitted" not in out
    assert main(args + ["--max-rows", "4"]) == 0
    out = capsys.readouterr().out
    assert [int(r.split()[0]) for r in _junction_rows(out)] == [0, 1, 8, 9]
    assert "(6 junctions omitted)" in out


def test_unknown_builtin_lists_the_builtins(capsys):
    assert main(["path", "builtin:hexagon", "--blend", "none"]) == 2
    err = capsys.readouterr().err
    assert "unknown built-in path 'builtin:hexagon'" in err
    assert "builtin:triangle, builtin:square, builtin:line" in err
    assert "x_mm,y_mm,z_mm" in err


def test_program_beyond_the_sample_cap_of_run_is_refused_with_its_message(tmp_path, capsys):
    """A 250 m program at 0.1 mm would be 2.5e6 samples: refused (exit 2) before sampling,
    with the message ``feedopt run`` gives (its limit, the spacing that would do); nothing is
    written."""
    from feedopt.geometry.path import MAX_SAMPLES

    prog = tmp_path / "long.nc"
    prog.write_text("G21 G90 G17\nG0 X0 Y0 Z5\nS1000 M3\nG1 Z-1 F100\nG1 X250000\n"
                    "G0 Z5\nM30\n")
    out = tmp_path / "p.csv"
    assert main(["path", str(prog), "--spacing", "0.1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    length = 250000 + 6 + 6  # mm: the plunge, the line, the retract (blends shorten it a hair)
    assert f"--spacing = 0.1 mm gives {length / 0.1 + 1:.3g} samples on the" in err
    assert f"at most {MAX_SAMPLES:.0e} are planned" in err
    assert f"use a spacing of at least {length / (MAX_SAMPLES - 1):.2g} mm" in err
    assert not out.exists()
    # the same program at a spacing within the cap is written
    assert main(["path", str(prog), "--spacing", "0.2"]) == 0
