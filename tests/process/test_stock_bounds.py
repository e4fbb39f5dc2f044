"""Stock size and units (issue 26, items 2, 10 and 11): STL meshes read in mm by default (or
m), the Z-map's cell count bounded before anything is allocated, and closed-mesh checks."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import feedopt.process.stock as stock_module
from feedopt.errors import InputError
from feedopt.process.material import build_stock
from feedopt.process.stock import MAX_CELLS, ZMap, grid_shape
from feedopt.scenario import StockSection

trimesh = pytest.importorskip("trimesh")
MM = 1e-3


def _box_stl(path, extents=(100.0, 50.0, 20.0), corner=(10.0, -20.0, -5.0), scale=1.0):
    """A CAD-like box STL with its lower corner at ``corner`` (file units = mm * scale)."""
    box = trimesh.creation.box(extents=np.array(extents) * scale)
    box.apply_translation((np.array(corner) + np.array(extents) / 2) * scale)
    box.export(path)
    return path


def _resolve(tmp_path):
    return lambda rel, what: tmp_path / rel


def test_an_stl_in_mm_gives_the_zmap_of_the_same_box(tmp_path):
    """The mm box STL, read with the scenario's default units, against the box written out
    cell by cell here: 100 x 50 mm at 0.25 mm is 400 x 200 cells, all 20 mm of material."""
    _box_stl(tmp_path / "box.stl")
    got = build_stock(StockSection(mesh="box.stl"), _resolve(tmp_path))
    assert got.shape == (400, 200) and got.cell == pytest.approx(0.25 * MM)
    assert got.origin == pytest.approx((10 * MM, -20 * MM), abs=1e-9)
    assert got.bottom == pytest.approx(-5 * MM, abs=1e-9)
    np.testing.assert_allclose(got.heights, np.full((400, 200), 15 * MM), atol=1e-7)
    assert got.volume() == pytest.approx(100 * 50 * 20 * MM**3, rel=1e-6)
    box = build_stock(StockSection(box_mm=[10, -20, -5, 110, 30, 15]), _resolve(tmp_path))
    assert box.shape == got.shape and box.origin == pytest.approx(got.origin, abs=1e-9)
    np.testing.assert_allclose(box.heights, got.heights, atol=1e-7)


def test_units_m_reads_an_stl_in_metres_the_same(tmp_path):
    _box_stl(tmp_path / "m.stl", scale=MM)
    in_m = build_stock(StockSection(mesh="m.stl", units="m"), _resolve(tmp_path))
    _box_stl(tmp_path / "mm.stl")
    in_mm = build_stock(StockSection(mesh="mm.stl", units="mm"), _resolve(tmp_path))
    assert in_m.shape == in_mm.shape
    np.testing.assert_allclose(in_m.heights, in_mm.heights, atol=1e-7)


def test_units_is_strict_and_for_meshes_only():
    with pytest.raises(ValueError, match="units applies to stock.mesh only"):
        StockSection(box_mm=[0, 0, 0, 1, 1, 1], units="mm")
    with pytest.raises(ValueError):
        StockSection(mesh="a.stl", units="inch")


def test_a_metres_mesh_read_as_mm_is_refused_before_allocating(tmp_path):
    """The issue's case the other way round: a mm STL (100 x 50 mm) read in metres asks for
    400,000 x 200,000 cells; refused at once, naming the unit it was read in."""
    _box_stl(tmp_path / "box.stl")
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        build_stock(StockSection(mesh="box.stl", units="m"), _resolve(tmp_path))
    assert time.perf_counter() - t0 < 2.0
    msg = str(exc.value)
    assert "read in m" in msg and "stock.units" in msg and "400,000 x 200,000" in msg


def test_a_2_km_box_is_refused_with_what_would_work(tmp_path):
    with pytest.raises(InputError) as exc:
        build_stock(StockSection(box_mm=[0, 0, 0, 2e6, 2e6, 10]), _resolve(tmp_path))
    msg = str(exc.value)
    # independent count: 2e6 / 0.25 cells each way, 4 bytes each
    n = 8_000_000
    assert msg.startswith("stock.box_mm") and f"{n:,} x {n:,}" in msg
    assert f"{n * n * 4 / 1024**3:.3g} GiB" in msg and f"{MAX_CELLS:,} cells" in msg
    assert "even 5 mm cells" in msg and "smaller stock" in msg


@pytest.mark.parametrize("span_mm", [(3000, 2000), (2e6, 400), (1581.2, 1581.2), (1.2e7, 0.3)])
def test_the_suggested_cell_size_fits(span_mm):
    """A stock too fine for the cap is refused with the smallest cell size (0.01 mm steps)
    that, used, builds; 0.01 mm less does not."""
    sx, sy = (v * MM for v in span_mm)
    with pytest.raises(InputError) as exc:
        ZMap.box(0, sx, 0, sy, 0, 0.01, cell=0.25 * MM, where="stock.box_mm")
    msg = str(exc.value)
    cell_mm = float(msg.split("cells of at least ")[1].split(" mm")[0])
    assert cell_mm >= 0.25 * math.sqrt(span_mm[0] * span_mm[1] / 0.25**2 / MAX_CELLS) - 1e-9
    nx, ny = grid_shape(sx, sy, cell_mm * MM, "x")
    assert nx * ny <= MAX_CELLS
    with pytest.raises(InputError):
        grid_shape(sx, sy, (cell_mm - 0.01) * MM, "x")


@pytest.mark.parametrize("box", [
    (-1e308, 1e308, 0, 1, 0, 1), (0, 1e308, 0, 1e308, 0, 1), (0, math.inf, 0, 1, 0, 1),
    (math.nan, 1, 0, 1, 0, 1), (0, 1, 0, 1, 0, math.nan)])
def test_overflowing_or_non_finite_boxes_are_input_errors(box):
    with pytest.raises(InputError, match="stock box"):
        ZMap.box(*box)


def test_the_cap_is_exact(monkeypatch):
    monkeypatch.setattr(stock_module, "MAX_CELLS", 100)
    assert ZMap.box(0, 10 * MM, 0, 10 * MM, 0, 1 * MM, cell=MM).shape == (10, 10)
    with pytest.raises(InputError, match="10 x 11 = 110 cells"):
        ZMap.box(0, 10 * MM, 0, 11 * MM, 0, 1 * MM, cell=MM)


def test_an_open_mesh_names_its_edges(tmp_path):
    box = trimesh.creation.box(extents=[100.0, 50.0, 20.0])
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    open_box.export(tmp_path / "open.stl")
    with pytest.raises(InputError, match=r"not closed \(not watertight: 3 edge\(s\) belong to "
                                         "one triangle only"):
        ZMap.from_mesh(tmp_path / "open.stl")
