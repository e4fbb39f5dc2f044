"""Sweeps end to end: a local Dask cluster gives the serial results, failed points are rows,
an interrupted sweep resumes, and the folder rules protect the user's files."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.runner import prepare
from feedopt.scenario import load_scenario
from feedopt.sweep import Execution, SweepSettings, run_sweep
from feedopt.sweep.point import nominal_feed
from feedopt.units import MM

LAWS = ["constant", "jerk"]
SPACING = {"path__spacing_mm": 5.0}  # ~100 samples: a point plans in about 0.1 s
SERIAL = Execution(workers=0)
JERK, CONSTANT = SweepSettings(laws=["jerk"]), SweepSettings(laws=["constant"])


def _table(folder) -> list[dict]:
    with open(folder / "sweep.csv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _without_time(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]


def test_local_cluster_gives_exactly_the_serial_results(quick_scenario, tmp_path):
    scenario = quick_scenario("triangle_slot", **SPACING)
    grid = ["workpiece.position_mm=x:1750;5000", "cut.axial_depth_mm=1.0;1.5"]
    parallel = run_sweep(scenario, grid, out_dir=tmp_path / "dask",
                         settings=SweepSettings(laws=LAWS), execution=Execution(workers=2))
    serial = run_sweep(scenario, grid, out_dir=tmp_path / "serial",
                       settings=SweepSettings(laws=LAWS), execution=SERIAL)
    rows = _table(tmp_path / "dask")
    differ = [(k, c, a[c], b[c]) for k, (a, b) in enumerate(zip(
        _without_time(rows), _without_time(_table(tmp_path / "serial")), strict=True))
        for c in a if a[c] != b[c]]
    assert not differ, differ
    assert [(r["workpiece.position_mm.x"], r["cut.axial_depth_mm"]) for r in rows] == [
        ("1750.0", "1.0"), ("1750.0", "1.5"), ("5000.0", "1.0"), ("5000.0", "1.5")]
    assert parallel.counts == serial.counts == {"ok": 2, "refused": 2, "error": 0,
                                                "feasible": 2}

    # the unreachable placement is a row with its reason, not a lost sweep
    for row in rows[2:]:
        assert (row["status"], row["feasible"]) == ("refused", "no")
        assert "unreachable" in row["reason"] and "x=5000.000" in row["reason"]
        assert row["t_star_s"] == row["jerk.cycle_time_s"] == ""

    # the grid point is the scenario a user would write by hand
    by_hand = quick_scenario("triangle_slot", workpiece__position_mm=[1750.0, -300.0, 800.0],
                             cut__axial_depth_mm=1.0, **SPACING)
    sc, base = load_scenario(by_hand)
    p = prepare(sc, base, lambda _m: None)
    assert float(rows[0]["t_star_s"]) == p.problem.lower_bound_time()
    d = p.model.deflection(np.full(p.problem.n, 4.23 * MM))
    assert float(rows[0]["max_deflection_nominal_mm"]) == pytest.approx(d.max() / MM, rel=1e-12)
    np.testing.assert_array_equal(nominal_feed(p.problem), 4.23 * MM)
    # a deeper cut deflects more and needs more time
    assert float(rows[1]["max_deflection_nominal_mm"]) > float(rows[0]["max_deflection_nominal_mm"])
    assert float(rows[1]["t_star_s"]) > float(rows[0]["t_star_s"])

    # best = smallest T* over the feasible rows, found here from the table itself
    t_star = {(r["workpiece.position_mm.x"], r["cut.axial_depth_mm"]): float(r["t_star_s"])
              for r in rows if r["feasible"] == "yes"}
    best = json.loads((tmp_path / "dask" / "best.json").read_text())
    assert best["value"] == min(t_star.values())
    assert best["point"] == {"workpiece.position_mm.x": 1750.0, "cut.axial_depth_mm": 1.0}
    assert (tmp_path / "dask" / ("heatmap_workpiece.position_mm.x__cut.axial_depth_mm.png")
            ).stat().st_size > 1000


def test_an_interrupted_sweep_resumes_without_redoing_finished_points(quick_scenario,
                                                                      tmp_path):
    scenario = quick_scenario("triangle_slot", **SPACING)
    grid = ["workpiece.position_mm=x:1700;1750;1800"]
    out = tmp_path / "sweep"
    first = run_sweep(scenario, grid, out_dir=out, settings=JERK, execution=SERIAL)
    assert first.evaluated == 3
    complete = _table(out)

    # what a killed sweep leaves: a finished row (marked, to see it is not recomputed), a row
    # that hit an internal error (retried), and the first half of a row being written
    lines = (out / "sweep.csv").read_text().splitlines(keepends=True)
    marked = lines[1].replace(complete[0]["t_star_s"], "999.0")
    errored = ",".join([complete[1]["workpiece.position_mm.x"], "error", "no",
                        "internal error: MemoryError: "] + [""] * (len(complete[0]) - 4)) + "\n"
    (out / "sweep.csv").write_text(lines[0] + marked + errored + lines[3][:40])
    (out / "best.json").unlink()

    again = run_sweep(scenario, grid, out_dir=out, settings=JERK, execution=SERIAL)
    assert (again.evaluated, again.reused) == (2, 1)
    rows = _table(out)
    assert rows[0]["t_star_s"] == "999.0"  # taken from the table, not evaluated again
    assert _without_time(rows[1:]) == _without_time(complete[1:])
    assert len(rows) == 3  # one row per point: the error row was replaced
    assert json.loads((out / "best.json").read_text())["point"] == {
        "workpiece.position_mm.x": float(complete[1]["workpiece.position_mm.x"])
        if float(complete[1]["t_star_s"]) < float(complete[2]["t_star_s"])
        else float(complete[2]["workpiece.position_mm.x"])}

    # a finished sweep run again evaluates nothing
    assert run_sweep(scenario, grid, out_dir=out, settings=JERK, execution=SERIAL).evaluated == 0


def test_the_folder_rules(quick_scenario, tmp_path):
    scenario = quick_scenario("triangle_slot", **SPACING)
    out = tmp_path / "sweep"
    run_sweep(scenario, ["cut.axial_depth_mm=1.5"], out_dir=out, settings=JERK, execution=SERIAL)
    mine = out / "notes.txt"
    mine.write_text("mine")
    with pytest.raises(InputError, match="notes.txt"):
        run_sweep(scenario, ["cut.axial_depth_mm=1.5"], out_dir=out, settings=JERK,
                  execution=SERIAL, restart=True)
    mine.unlink()
    with pytest.raises(InputError, match="other inputs .*the laws"):
        run_sweep(scenario, ["cut.axial_depth_mm=1.5"], out_dir=out, settings=CONSTANT,
                  execution=SERIAL)
    result = run_sweep(scenario, ["cut.axial_depth_mm=1.5"], out_dir=out, settings=CONSTANT,
                       execution=SERIAL, restart=True)
    assert result.evaluated == 1 and "constant.verdict" in _table(out)[0]
    marker = json.loads((out / ".feedopt-output.json").read_text())
    assert set(marker["files"]) >= {p.name for p in out.iterdir()}
    with pytest.raises(InputError, match="current directory"):
        run_sweep(scenario, ["cut.axial_depth_mm=1.5"], out_dir=".", settings=JERK,
                  execution=SERIAL)
