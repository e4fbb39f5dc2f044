"""deflection.mode surface end to end (issue 33): the triangle slot planned for the part
tolerances the 0.29 mm norm limit gives is faster than the norm mode, every law verified
against the part tolerances by replay, with the predicted part in summary.json and the CSVs."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.runner import run_scenario
from feedopt.scenario import load_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
LAWS = ["constant", "thesis", "convex", "jerk"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("surface")
    return {name: run_scenario(ROOT / "scenarios" / f"{name}.yaml", tmp / name, laws=LAWS,
                               progress=quiet, report=False)
            for name in ("triangle_slot", "triangle_slot_surface")}


def test_norm_mode_gives_the_tolerances_the_surface_scenario_states(runs):
    """The surface scenario's limits are what the norm mode's convex law reaches."""
    surface = runs["triangle_slot"].laws["convex"].verification.surface
    sc, _ = load_scenario(ROOT / "scenarios" / "triangle_slot_surface.yaml")
    wall = np.nanmax(surface.worst_wall()) * 1e3
    floor = np.nanmax(np.abs(surface.floor)) * 1e3
    assert wall == pytest.approx(sc.deflection.wall_limit_mm, abs=5e-5)
    assert floor == pytest.approx(sc.deflection.floor_limit_mm, abs=5e-5)


def test_surface_mode_is_faster_at_the_same_part_tolerance_and_verified(runs):
    norm, surf = runs["triangle_slot"], runs["triangle_slot_surface"]
    wall_limit, floor_limit = surf.prepared.schedule.wall_limit, surf.prepared.schedule.floor_limit
    for law in ("thesis", "convex", "jerk"):
        ver = surf.laws[law].verification
        assert ver.verified and ver.exportable, ver.problems
        assert np.nanmax(ver.surface.worst_wall()) <= wall_limit * (1 + 1e-6)
        assert np.nanmax(np.abs(ver.surface.floor)) <= floor_limit * (1 + 1e-6)
        gain = 1 - surf.laws[law].trajectory.duration / norm.laws[law].trajectory.duration
        assert gain > 0.03, (law, gain)
    # the constant feed breaks the floor tolerance: a baseline, warned, not exported
    const = surf.laws["constant"].verification
    assert const.verified and not const.exportable
    assert any("floor error" in b for b in const.export_blockers)
    active = surf.prepared.bound.active_fraction()
    assert active["floor_error"] > 0.3 and active["wall_error"] > 0


def test_predicted_part_in_summary_and_csv(runs):
    out = runs["triangle_slot_surface"].out_dir
    summary = json.loads((out / "summary.json").read_text())
    part = summary["part"]["laws"]
    for law in LAWS:
        segments = part[law]["segments"]
        assert [row["segment"] for row in segments] == list(range(1, 12))
        lines = [row for row in segments if row["kind"] == "line"]
        assert len(lines) == 6 and all(row["left_wall"]["flatness_mm"] >= 0 for row in lines)
        assert summary["laws"][law]["surface"]["wall_limit_mm"] == pytest.approx(0.0543)
        with open(out / part[law]["csv"], newline="") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].startswith("#")]
        assert rows[0][0] == "s_mm" and len(rows) - 1 == sum(r["dexels"] for r in segments)


def _edited(tmp_path, name: str, old: str, new: str):
    """scenarios/<name>.yaml with ``old`` replaced by ``new``, written to ``tmp_path`` with
    its relative paths made absolute."""
    text = (ROOT / "scenarios" / f"{name}.yaml").read_text()
    assert old in text
    path = tmp_path / f"{name}_edited.yaml"
    path.write_text(text.replace(old, new).replace("../robots", str(ROOT / "robots"))
                    .replace("tools/", str(ROOT / "scenarios" / "tools") + "/")
                    .replace("materials/", str(ROOT / "scenarios" / "materials") + "/"))
    return path


def test_surface_limits_are_refused_outside_mode_surface(tmp_path):
    bad = _edited(tmp_path, "triangle_slot", "  mode: norm",
                  "  mode: norm\n  wall_limit_mm: 0.05")
    with pytest.raises(InputError, match="mode 'surface' only"):
        load_scenario(bad)
    bad.write_text(bad.read_text().replace("  mode: norm\n  wall_limit_mm: 0.05",
                                           "  mode: surface"))
    with pytest.raises(InputError, match="needs wall_limit_mm, floor_limit_mm or both"):
        load_scenario(bad)


def test_a_tolerance_the_edge_forces_break_is_a_clear_error(tmp_path):
    bad = _edited(tmp_path, "triangle_slot_surface", "wall_limit_mm: 0.0543",
                  "wall_limit_mm: 0.01")
    with pytest.raises(InputError, match=r"wall_limit_mm 0.01 mm is exceeded by the wall error "
                                         r"of the edge forces alone.*smallest limit"):
        run_scenario(bad, tmp_path / "out", laws=["constant"], progress=quiet, report=False)
    assert not (tmp_path / "out").exists()
