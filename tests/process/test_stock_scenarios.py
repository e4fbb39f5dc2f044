"""Stocks in scenarios (issue 26, items 2, 8, 10, 11): `validate` builds the stock as `run`
does (bounded, mesh checked), a path that cuts nothing is refused unless stock.air_cut says
so (then a warning kept in summary.json), and a mm STL gives the box's engagement."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.runner import prepare_front
from feedopt.scenario import load_scenario

trimesh = pytest.importorskip("trimesh")
quiet = lambda _m: None  # noqa: E731
# linear_peripheral_stock's block and path (x 0..203.2 at z 0, drifting to y -9.525)
BOX = [0.0, -60.325, -23.9, 203.2, -9.525, 1.5]


@pytest.fixture
def stock_scenario(quick_scenario, tmp_path):
    def write(stock: dict, name: str = "s.yaml"):
        p = quick_scenario("linear_peripheral_stock", path__spacing_mm=1.0)
        doc = yaml.safe_load(p.read_text())
        doc.pop("fits", None)  # it names stock.box_mm[5]
        doc["stock"] = stock
        out = tmp_path / name
        out.write_text(yaml.safe_dump(doc))
        return out
    return write


def _run(scenario, out, capsys):
    code = main(["run", str(scenario), "--out", str(out), "--laws", "constant"])
    return code, capsys.readouterr().err


def test_a_stock_beside_the_path_is_refused_by_run_and_validate(stock_scenario, tmp_path,
                                                                capsys):
    far = [BOX[0] + 5000, *BOX[1:3], BOX[3] + 5000, *BOX[4:]]
    scenario = stock_scenario({"box_mm": far})
    out = tmp_path / "out"
    code, err = _run(scenario, out, capsys)
    assert code == 2 and not out.exists()
    assert "the path cuts no material at any of its" in err
    assert "do not overlap in x and y" in err
    # both extents, in mm: the path widened by R = 9.525 mm, the stock as given
    assert "spans x -9.525..212.725, y -19.05..9.525, z 0..0 mm" in err
    assert "the stock x 5000..5203.25" in err and "stock.air_cut: true" in err
    assert main(["validate", str(scenario)]) == 2
    err = capsys.readouterr().err
    # (validate refuses it before sweeping, or, running the run's process stage, as run does)
    assert ("the path cannot cut the stock" in err or "the path cuts no material" in err)
    assert "x 5000..5203.25" in err
    csv = tmp_path / "e.csv"
    assert main(["engagement", str(scenario), "--out", str(csv)]) == 2
    assert "the path cuts no material" in capsys.readouterr().err and not csv.exists()


def test_a_path_above_the_stock_is_refused(stock_scenario, tmp_path, capsys):
    low = [*BOX[:5], -0.5]  # top 0.5 mm below the tool tip
    code, err = _run(stock_scenario({"box_mm": low}), tmp_path / "out", capsys)
    assert code == 2 and "the tool tip stays at or above the stock's top" in err
    assert not (tmp_path / "out").exists()


def test_an_air_cut_is_a_warning_kept_in_the_summary(stock_scenario, tmp_path, capsys):
    far = [BOX[0] + 5000, *BOX[1:3], BOX[3] + 5000, *BOX[4:]]
    scenario = stock_scenario({"box_mm": far, "air_cut": True})
    assert main(["validate", str(scenario)]) == 0
    out = tmp_path / "out"
    code, err = _run(scenario, out, capsys)
    assert code == 0, err
    warnings = json.loads((out / "summary.json").read_text())["warnings"]
    hit = [w for w in warnings if "cuts no material" in w]
    assert len(hit) == 1 and "planned as an air cut" in hit[0]


def test_air_cut_on_a_cutting_path_is_a_warning(stock_scenario):
    sc, base = load_scenario(stock_scenario({"box_mm": BOX, "air_cut": True}))
    front = prepare_front(sc, base, progress=quiet)
    assert any("stock.air_cut is set but the path cuts material" in w for w in front.warnings)


def test_a_mm_stl_gives_the_engagement_of_the_same_box(stock_scenario, tmp_path):
    x0, y0, z0, x1, y1, z1 = BOX
    box = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    box.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    box.export(tmp_path / "block.stl")
    fronts = []  # 0.1 mm cells: the block is whole cells (a box rounds up to whole cells)
    for stock in ({"box_mm": BOX, "cell_mm": 0.1},
                  {"mesh": str(tmp_path / "block.stl"), "cell_mm": 0.1}):
        sc, base = load_scenario(stock_scenario(stock))
        fronts.append(prepare_front(sc, base, progress=quiet))
    a, b = (f.process.engagement for f in fronts)
    za, zb = (f.process.material.before for f in fronts)
    assert za.shape == zb.shape == (2032, 508)
    np.testing.assert_allclose(za.heights, zb.heights, atol=1e-9)
    assert np.mean(a.exit > a.entry) > 0.9  # the path cuts
    np.testing.assert_allclose(b.entry, a.entry, atol=1e-6)
    np.testing.assert_allclose(b.exit, a.exit, atol=1e-6)
    np.testing.assert_allclose(b.axial_depth, a.axial_depth, atol=1e-6)


@pytest.mark.parametrize(("stock", "want"), [
    ({"box_mm": [0, -1e6, -23.9, 2e6, -9.525, 1.5]}, "stock.box_mm"),
    ({"box_mm": [-1e308, -1e308, -23.9, 1e308, 1e308, 1.5]}, "overflows"),
    ({"mesh": "random.stl"}, "not an STL"),
    ({"mesh": "block_m.stl"}, "smaller than the 0.25 mm cells"),  # metres read as mm
    ({"mesh": "block_mm.stl", "units": "m"}, "read in m: stock.units"),
])
def test_validate_refuses_what_run_refuses(stock_scenario, tmp_path, capsys, stock, want):
    (tmp_path / "random.stl").write_bytes(np.random.default_rng(7).bytes(4000))
    for name, scale in (("block_m.stl", 1e-3), ("block_mm.stl", 1.0)):
        box = trimesh.creation.box(extents=[203.2 * scale, 50.8 * scale, 25.4 * scale])
        box.apply_translation(np.array([101.6, -34.925, -11.2]) * scale)
        box.export(tmp_path / name)
    scenario = stock_scenario(stock)
    assert main(["validate", str(scenario)]) == 2
    v_err = capsys.readouterr().err
    out = tmp_path / "out"
    code, err = _run(scenario, out, capsys)
    assert code == 2 and not out.exists()
    assert want in v_err and want in err
    assert "Traceback" not in err + v_err


def test_the_schema_reference_documents_units_and_air_cut(capsys):
    assert main(["validate", "--schema"]) == 0
    out = capsys.readouterr().out
    assert "stock.units" in out and "mm (default, the CAD convention) or m" in out
    assert "stock.air_cut" in out


def test_a_metres_stl_read_as_mm_at_fine_cells_is_warned(stock_scenario, tmp_path):
    box = trimesh.creation.box(extents=[0.2032, 0.0508, 0.0254])  # the block in metres
    box.apply_translation([0.1016, -0.034925, -0.0112])
    box.export(tmp_path / "block_m.stl")
    sc, base = load_scenario(stock_scenario({"mesh": "block_m.stl", "cell_mm": 0.02}))
    front = prepare_front(sc, base, progress=quiet)  # it grazes the 0.2 mm block once
    assert np.sum(~front.process.material.found.in_air) < 5
    assert any("only 0.22 x 0.06 x 0.0254 mm: if the STL is in metres, set stock.units: m" in w
               for w in front.warnings)


def test_validate_and_engagement_print_the_metres_warning(stock_scenario, tmp_path, capsys):
    """The warning was given by run only; validate and engagement said 'ok' / exit 0 silently
    (a hostile re-check)."""
    box = trimesh.creation.box(extents=[0.2032, 0.0508, 0.0254])
    box.apply_translation([0.1016, -0.034925, -0.0112])
    box.export(tmp_path / "block_m.stl")
    scenario = stock_scenario({"mesh": "block_m.stl", "cell_mm": 0.02})
    note = "if the STL is in metres, set stock.units: m"
    assert main(["validate", str(scenario)]) == 0
    out = capsys.readouterr().out
    assert "ok" in out and "warning: stock.mesh is read in mm and is only" in out
    assert note in out
    assert main(["engagement", str(scenario)]) == 0
    assert note in capsys.readouterr().out
