"""benchmarks/ballnose_raster.py: the ball's drop-cutter tip heights against closed forms and a
brute-force gouge check, the scallop height, and the program as feedopt's reader sees it.

Closed forms (ball of radius R, tip = lowest point of the ball):

- flat f = c: the ball rests on the plane, tip = c.
- plane tilted by a (f = c + x tan a): the ball's centre is R from the plane along its
  normal, i.e. R / cos a above it vertically, so tip = f(x, y) + R / cos a - R; it touches at
  the horizontal offset R sin a (inside the disc) up the slope.
- hemisphere of radius S on a floor (f = c0 + sqrt(S^2 - r^2) for r <= S, c0 elsewhere): over
  horizontal distance d <= S from its centre the ball's centre is S + R from the sphere's
  centre, so tip = c0 + sqrt((S + R)^2 - d^2) - R (over the top, d = 0: tip = c0 + S, the
  top); the contact lies on the sphere (offset d R / (S + R) < R from the axis) and this is
  above the floor contact c0 since d^2 <= S^2 + 2 S R.
- scallop: two balls 2w apart on a flat floor meet at height R - sqrt(R^2 - w^2).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import trimesh

from feedopt.gcode import MoveCategory, MoveKind, ToolShape, parse_gcode
from tests.conftest import load_benchmark

br = load_benchmark("ballnose_raster")

TOL = 1e-6  # [mm]


@pytest.mark.parametrize("radius", [1.0, 1.5875])
def test_flat_surface_tip_is_the_surface(radius):
    x, y = np.meshgrid(np.linspace(-3, 3, 7), np.linspace(-2, 2, 5))
    z = br.drop_ball_tip_mm(x, y, radius, lambda a, b: np.full(np.shape(a), -1.25))
    assert np.allclose(z, -1.25, atol=1e-12)


@pytest.mark.parametrize("deg", [5.0, 20.0, 40.0, 60.0])
@pytest.mark.parametrize("radius", [1.0, 1.5875])
def test_tilted_plane_tip_is_r_over_cos_minus_r_above(deg, radius):
    t = math.tan(math.radians(deg))

    def plane(a, b):
        return -2.0 + t * (0.8 * a + 0.6 * b)  # steepest along (0.8, 0.6)

    x, y = np.meshgrid(np.linspace(-2, 2, 5), np.linspace(-1, 1, 3))
    z = br.drop_ball_tip_mm(x, y, radius, plane)
    expected = plane(x, y) + radius / math.cos(math.radians(deg)) - radius
    assert np.max(np.abs(z - expected)) < TOL


@pytest.mark.parametrize("radius", [1.0, 1.5875])
def test_hemisphere_tip(radius):
    s, c0 = 5.0, -6.0

    def sphere(a, b):
        return c0 + np.sqrt(np.maximum(s * s - a * a - b * b, 0.0))

    d = np.linspace(0.0, s, 11)
    ang = np.linspace(0.3, 5.0, 11)
    z = br.drop_ball_tip_mm(d * np.cos(ang), d * np.sin(ang), radius, sphere)
    expected = c0 + np.sqrt((s + radius) ** 2 - d ** 2) - radius
    assert abs(z[0] - (c0 + s)) < TOL  # over the top: the top
    assert np.max(np.abs(z - expected)) < TOL


def _brute_gap(x, y, radius, z_tip, surface, n=401):
    """Over a fine square grid of the disc (not the generator's: 401 points across), the
    ball's lower surface minus the surface; its min is >= 0 without gouge, ~0 in contact."""
    g = np.linspace(-radius, radius, n)
    u, v = np.meshgrid(g, g)
    inside = u ** 2 + v ** 2 <= radius ** 2
    u, v = u[inside], v[inside]
    ball = z_tip + radius - np.sqrt(np.maximum(radius ** 2 - u ** 2 - v ** 2, 0.0))
    return ball - surface(x + u, y + v)


@pytest.mark.parametrize("radius", [1.0, 1.5875, 3.0])
def test_no_gouge_and_contact_on_the_bump_field(radius):
    rng = np.random.default_rng(20240611)
    x = rng.uniform(-2.0, br.WIDTH_MM + 2.0, 12)
    y = rng.uniform(-2.0, br.LENGTH_MM + 2.0, 12)
    z = br.drop_ball_tip_mm(x, y, radius)
    for xi, yi, zi in zip(x, y, z, strict=True):
        gap = _brute_gap(xi, yi, radius, zi, br.surface_mm)
        assert gap.min() >= -TOL, (xi, yi, gap.min())
        # touching: the fine grid's closest point is within its own sampling error (h^2/R)
        assert gap.min() < (2 * radius / 400) ** 2 / radius, (xi, yi, gap.min())


def test_scallop_height():
    assert br.scallop_height_mm(1.0, 0.2) == pytest.approx(1.0 - math.sqrt(1.0 - 0.01))
    assert br.scallop_height_mm(1.5875, 0.0) == 0.0
    assert br.scallop_height_mm(1.0, 2.0) == pytest.approx(1.0)
    # independent: two balls 0.3 apart on the floor z = 0 meet halfway at this height
    r, w = 1.5875, 0.15
    lower = r - math.sqrt(r * r - w * w)
    assert br.scallop_height_mm(r, 2 * w) == pytest.approx(lower)
    with pytest.raises(ValueError):
        br.scallop_height_mm(1.0, 2.5)


def _small(style, ball_mm=2.0):
    return br.program_text(ball_mm=ball_mm, width_mm=2.0, length_mm=0.6, step_mm=0.5,
                           stepover_mm=0.2, style=style)


@pytest.mark.parametrize("ball_mm", [2.0, 3.175])
@pytest.mark.parametrize("style", ["fusion", "camotics"])
def test_program_reads_as_ball_end_mill(style, ball_mm):
    text = _small(style, ball_mm)
    prog = parse_gcode(text, source="ballnose.nc")
    assert prog.units == "mm" and prog.tools == (1,)
    (h,) = prog.tool_headers
    assert h.number == 1 and h.shape is ToolShape.BALL
    assert h.diameter_mm == pytest.approx(ball_mm)
    if style == "fusion":
        assert h.corner_radius_mm == pytest.approx(ball_mm / 2)
        ends = np.array([m.end for m in prog.moves if m.kind is MoveKind.LINE])
        assert h.z_min_mm == pytest.approx(ends[:, 2].min())


@pytest.mark.parametrize("style", ["fusion", "camotics"])
def test_small_program_has_the_rows_and_points_asked(style):
    text = _small(style)  # 2.0 / 0.5 -> 5 points a row, 0.6 / 0.2 -> 4 rows
    prog = parse_gcode(text)
    cuts = [m for m in prog.moves if m.category is MoveCategory.CUT]
    plunge = [m for m in prog.moves if m.category is MoveCategory.PLUNGE]
    assert len(plunge) == 2 and len(cuts) == 4 * 5 - 1
    pts = np.array([plunge[-1].end] + [m.end for m in cuts])
    ys = np.unique(np.round(pts[:, 1], 4))
    assert np.allclose(ys, [0.0, 0.2, 0.4, 0.6])
    for r, y in enumerate(ys):
        row = pts[np.isclose(pts[:, 1], y)]
        xs = np.linspace(0.0, 2.0, 5)
        assert np.allclose(row[:, 0], xs if r % 2 == 0 else xs[::-1])  # zigzag
        # Z is the drop-cutter tip, written rounded up to 4 decimals
        z = br.drop_ball_tip_mm(row[:, 0], row[:, 1], 1.0, lambda a, b: br.surface_mm(
            a, b, width_mm=2.0, length_mm=0.6, height_mm=br.HEIGHT_MM))
        assert np.all(row[:, 2] >= z - 1e-9) and np.all(row[:, 2] - z < 1e-4 + 1e-9)
    assert all(re.fullmatch(r"G1 X-?\d+\.\d{4} Y-?\d+\.\d{4} Z-?\d+\.\d{4}( F\d+\.)?", ln)
               for ln in text.splitlines() if ln.startswith("G1 X"))
    end = ["M5", "M30"] + (["%"] if style == "fusion" else [])
    assert text.splitlines()[-len(end):] == end


def test_main_writes_the_file(tmp_path, capsys):
    out = tmp_path / "b.nc"
    assert br.main([str(out), "--width-mm", "1", "--length-mm", "0.4", "--step-mm", "0.5",
                    "--stepover-mm", "0.2", "--style", "camotics"]) == 0
    assert out.read_text().count("\nG1 X") == 3 * 3 - 1
    assert "scallop 0.0050 mm" in capsys.readouterr().out


# --- the roughed stock (roughed_stock_stl) -------------------------------------------------

STOCK = dict(width_mm=6.0, length_mm=4.0, height_mm=1.5, allowance_mm=0.3, margin_mm=1.0,
             bottom_mm=-5.0, cell_mm=0.04)


def _stock_top(x, y):
    """f + allowance of the STOCK patch [mm]."""
    size = {k: STOCK[k] for k in ("width_mm", "length_mm", "height_mm")}
    return br.surface_mm(x, y, **size) + STOCK["allowance_mm"]


@pytest.fixture(scope="module")
def stock_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("stock") / "stock.stl"
    br.roughed_stock_stl(path, **STOCK)
    return path


@pytest.mark.parametrize("slope", [(0.0, 0.0), (0.3, -0.2)])
def test_height_field_solid_of_a_plane_is_the_exact_prism(slope):
    """A plane top is represented exactly: volume = area x (height at the centre - bottom)."""
    xs, ys = np.linspace(-1.0, 2.0, 7), np.linspace(0.0, 1.0, 4)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    mesh = trimesh.Trimesh(*br.height_field_solid(xs, ys, 1.0 + slope[0] * gx + slope[1] * gy,
                                                   -2.0), process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    centre = 1.0 + slope[0] * 0.5 + slope[1] * 0.5
    assert mesh.volume == pytest.approx(3.0 * 1.0 * (centre + 2.0), rel=1e-12)
    assert np.allclose(mesh.bounds, [[-1.0, 0.0, -2.0], [2.0, 1.0, mesh.vertices[:, 2].max()]])


def test_stock_stl_is_a_closed_solid_of_the_integral_volume(stock_path):
    mesh = trimesh.load(stock_path, file_type="stl")  # read back: float32 binary STL
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    m = STOCK["margin_mm"]
    lo, hi = mesh.bounds
    assert np.allclose(lo, [-m, -m, STOCK["bottom_mm"]], atol=1e-6)
    assert np.allclose(hi[:2], [STOCK["width_mm"] + m, STOCK["length_mm"] + m], atol=1e-6)
    # midpoint rule on a 0.005 mm grid of the integral of (f + allowance - bottom)
    d = 0.005
    x = np.arange(-m + d / 2, STOCK["width_mm"] + m, d)
    y = np.arange(-m + d / 2, STOCK["length_mm"] + m, d)
    gx, gy = np.meshgrid(x, y, indexing="ij")
    integral = float(np.sum(_stock_top(gx, gy) - STOCK["bottom_mm"])) * d * d
    assert mesh.volume == pytest.approx(integral, rel=1e-3)


def _hessian_norm_max(x0, x1, y0, y1, spacing=0.02, d=1e-3):
    """max over a grid of the Frobenius norm (>= the spectral norm) of the Hessian of f,
    by central differences [1/mm]."""
    gx, gy = np.meshgrid(np.arange(x0, x1 + spacing, spacing),
                         np.arange(y0, y1 + spacing, spacing), indexing="ij")
    f = _stock_top
    fxx = (f(gx + d, gy) - 2 * f(gx, gy) + f(gx - d, gy)) / d ** 2
    fyy = (f(gx, gy + d) - 2 * f(gx, gy) + f(gx, gy - d)) / d ** 2
    fxy = (f(gx + d, gy + d) - f(gx + d, gy - d) - f(gx - d, gy + d)
           + f(gx - d, gy - d)) / (4 * d * d)
    return float(np.max(np.sqrt(fxx ** 2 + 2 * fxy ** 2 + fyy ** 2)))


def test_stock_reads_as_zmap_of_the_surface_plus_allowance(stock_path):
    from feedopt.process.stock import ZMap

    zmap = ZMap.from_mesh(stock_path, cell=0.25e-3)  # metres
    m = STOCK["margin_mm"]
    assert zmap.shape == (32, 24)  # 8 x 6 mm
    assert zmap.origin == pytest.approx((-m * 1e-3, -m * 1e-3), abs=1e-9)
    assert zmap.bottom == pytest.approx(STOCK["bottom_mm"] * 1e-3, abs=1e-9)
    cx, cy = np.meshgrid(zmap.x_centres / 1e-3, zmap.y_centres / 1e-3, indexing="ij")
    err = np.abs(zmap.heights.astype(float) / 1e-3 - _stock_top(cx, cy))
    # linear interpolation on a triangle of legs h: |f - I f| <= 1/2 max|H| (sqrt(2) h)^2
    # (the vertices are within sqrt(2) h of any point); 10 % for the Hessian's sampling,
    # 1e-5 mm for float32 (STL and Z-map)
    h = STOCK["cell_mm"]
    bound = 1.1 * _hessian_norm_max(-m, STOCK["width_mm"] + m, -m, STOCK["length_mm"] + m) * h * h
    assert bound < 0.02
    assert err.max() <= bound + 1e-5, (err.max(), bound)


def test_stock_bottom_above_top_is_refused(tmp_path):
    with pytest.raises(ValueError, match="below its top"):
        br.roughed_stock_stl(tmp_path / "s.stl", **{**STOCK, "bottom_mm": 0.0})


def test_main_writes_program_and_stock(tmp_path, capsys):
    out, stl = tmp_path / "b.nc", tmp_path / "b.stl"
    assert br.main([str(out), "--width-mm", "1", "--length-mm", "0.4", "--step-mm", "0.5",
                    "--stepover-mm", "0.2", "--style", "camotics", "--stock-stl", str(stl),
                    "--stock-cell-mm", "0.05"]) == 0
    assert out.is_file() and "wrote stock" in capsys.readouterr().out
    mesh = trimesh.load(stl, file_type="stl")
    assert mesh.is_watertight and mesh.volume > 0
    # defaults: margin R + 1 = 2 mm around the 1 x 0.4 patch (the outer rows y = 0, 0.4 and
    # points x = 0, 1 have 2 mm of material beside them); bottom 3 mm below the lowest f
    xs, ys = br.stock_grid(1.0, 0.4, 2.0, 0.05)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    f = br.surface_mm(gx, gy, width_mm=1.0, length_mm=0.4, height_mm=br.HEIGHT_MM)
    assert np.allclose(mesh.bounds, [[-2.0, -2.0, f.min() - 3.0], [3.0, 2.4, f.max() + 0.3]],
                       atol=1e-5)
