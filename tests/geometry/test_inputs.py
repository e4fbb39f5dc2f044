"""Bad input: clear InputError messages (CLI exit code 2 is tested in test_cli)."""

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.geometry import waves
from feedopt.geometry.path import build_lipb_path
from feedopt.geometry.waypoints import read_waypoints_csv


def test_fewer_than_two_distinct_points():
    with pytest.raises(InputError, match="at least two"):
        build_lipb_path(np.zeros((1, 3)), "circle", 0.01)
    with pytest.raises(InputError, match="at least two distinct"):
        build_lipb_path(np.zeros((3, 3)), "circle", 0.01, drop_repeated=True)


def test_repeated_points_refused_or_dropped():
    w = waves.triangle_wave()
    wr = np.insert(w, [2, 4], w[[1, 3]], axis=0)  # repeats at new indices 2 and 5
    with pytest.raises(InputError, match=r"indices 2, 5"):
        build_lipb_path(wr, "bezier5", 0.01)
    a = build_lipb_path(wr, "bezier5", 0.01, drop_repeated=True)
    b = build_lipb_path(w, "bezier5", 0.01)
    assert a.length == pytest.approx(b.length, rel=1e-15)
    # corner indices refer to the caller's array
    assert [g.corner_index for g in a.segments if g.kind != "line"] == [1, 3, 4, 6, 7]


def test_collinear_corner_gets_no_blend():
    w = np.array([[0, 0, 0], [0.05, 0, 0], [0.1, 0, 0], [0.1, 0.05, 0]])
    path = build_lipb_path(w, "varying_radius", 0.01)
    assert path.segment_kind == ("line", "line", "varying_radius", "line")
    assert [g.corner_index for g in path.segments] == [-1, -1, 2, -1]


def test_reversal_refused_with_index():
    w = np.array([[0, 0, 0], [0.05, 0, 0], [0.1, 0, 0], [0.02, 0, 0]])
    for kind in ("circle", "bezier4", "none"):
        with pytest.raises(InputError, match=r"waypoint 2 .*reverses"):
            build_lipb_path(w, kind, 0.001)


@pytest.mark.parametrize("kind", ["circle", "bezier4", "bezier5", "varying_radius"])
def test_blend_too_large_names_corner_and_largest_fit(kind):
    w = waves.triangle_wave()
    w[3, 0] -= 0.03  # make the corner at waypoint 3 tighter
    with pytest.raises(InputError) as err:
        build_lipb_path(w, kind, 0.05)
    msg = str(err.value)
    assert "waypoint 1" in msg or "waypoint 2" in msg or "waypoint 3" in msg
    best = float(msg.rsplit("fits all corners is ", 1)[1].split(" mm")[0]) * 1e-3
    build_lipb_path(w, kind, best * (1 - 1e-6))  # the advertised size fits
    with pytest.raises(InputError, match="does not fit"):
        build_lipb_path(w, kind, best * 1.001)


def test_blend_fit_uses_half_of_each_line_independently():
    # corner turning 90 deg: circle tangent distance = r; lines 40 and 100 mm long
    w = np.array([[0, 0, 0], [0.04, 0, 0], [0.04, 0.1, 0]])
    build_lipb_path(w, "circle", 0.02)
    with pytest.raises(InputError, match=r"largest radius that fits there is 20 mm"):
        build_lipb_path(w, "circle", 0.0201)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite(bad):
    w = waves.triangle_wave()
    w[4, 1] = bad
    with pytest.raises(InputError, match="waypoint 4 is not finite"):
        build_lipb_path(w, "circle", 0.01)


def test_bad_blend_and_size():
    w = waves.triangle_wave()
    with pytest.raises(InputError, match="unknown blend"):
        build_lipb_path(w, "spline", 0.01)
    with pytest.raises(InputError, match="positive"):
        build_lipb_path(w, "circle", 0.0)
    with pytest.raises(InputError, match="shape"):
        build_lipb_path(np.zeros((4, 4)), "circle", 0.01)


def test_csv_reader(tmp_path):
    f = tmp_path / "w.csv"
    f.write_text("# comment\nz_mm,x_mm,y_mm,note\n1,0,0,a\n\n2,10,5,b\n")
    np.testing.assert_allclose(read_waypoints_csv(f), [[0, 0, 1e-3], [0.01, 0.005, 2e-3]])


@pytest.mark.parametrize(("text", "match"), [
    ("x,y,z\n0,0,0\n1,1,1\n", "lacks column"),
    ("x_mm,y_mm\n0,0\n1,1\n", "z_mm"),
    ("x_mm,y_mm,z_mm\n0,0,0\n1,abc,1\n", r"line 3, column y_mm: 'abc'"),
    ("x_mm,y_mm,z_mm\n0,0,0\n1,nan,1\n", "not finite"),
    ("x_mm,y_mm,z_mm\n0,0,0\n1,1\n", "line 3"),
    ("x_mm,y_mm,z_mm\n0,0,0\n", "at least two"),
    ("", "empty"),
])
def test_csv_errors(tmp_path, text, match):
    f = tmp_path / "w.csv"
    f.write_text(text)
    with pytest.raises(InputError, match=match):
        read_waypoints_csv(f)


def test_csv_missing_file(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_waypoints_csv(tmp_path / "nope.csv")


@pytest.mark.parametrize(("blend", "size", "message"), [
    ("circle", -0.003, "blend circle needs a positive, finite radius in mm, got -3 mm"),
    ("varying_radius", np.nan, "varying_radius needs a positive, finite radius in mm, got nan mm"),
    ("bezier5", -0.0127, "bezier5 needs a positive, finite tolerance in mm, got -12.7 mm"),
])
def test_blend_size_message_in_mm(blend, size, message):
    with pytest.raises(InputError) as exc:
        build_lipb_path(waves.triangle_wave(), blend, size)
    assert message in str(exc.value)
    assert "0.003" not in str(exc.value) and "0.0127" not in str(exc.value)


def test_other_geometry_messages_in_mm():
    w = waves.triangle_wave()
    w[4, 1] = np.nan
    with pytest.raises(InputError, match=r"waypoint 4 is not finite: \(203\.2, nan, 0\) mm"):
        build_lipb_path(w, "circle", 0.01)
    path = build_lipb_path(waves.triangle_wave(), "none", 0.0)
    with pytest.raises(InputError, match=r"spacing must be a positive, finite number of mm, "
                                         r"got -0\.1 mm"):
        path.sample(-1e-4)
    with pytest.raises(InputError, match="got -100 mm and 76.2 mm"):
        waves.triangle_wave(length=-0.1)
    with pytest.raises(InputError, match=r"got \(0, 0, 0\) mm and \(inf, 0, 0\) mm"):
        waves.straight_line(end=(np.inf, 0.0, 0.0))


def test_absurd_coordinate_is_refused_with_its_line(tmp_path) -> None:
    from feedopt.cli import main
    from feedopt.geometry.waypoints import read_waypoints_csv

    f = tmp_path / "w.csv"
    f.write_text("x_mm,y_mm,z_mm\n0,0,0\n10,1e308,0\n20,0,0\n")
    with pytest.raises(InputError, match=r"line 3, column y_mm: 1e\+308 mm is beyond"):
        read_waypoints_csv(f)
    assert main(["path", str(f), "--blend", "none", "--out", str(tmp_path / "p.csv")]) == 2
    assert not (tmp_path / "p.csv").exists()
