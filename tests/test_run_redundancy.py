"""robot.redundancy: optimise through a whole run: the bundled coaxial spindle leaves nothing
to choose (the run is today's run exactly); the side-mounted spindle cell gets a lower T*,
verified laws, a redundancy entry in summary.json and the report figure."""

from __future__ import annotations

import json

import pytest
import yaml

from feedopt.errors import InputError
from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
SCENARIOS = ROOT / "scenarios"


def _scenario(tmp_path, name, **robot):
    doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    doc["robot"]["directory"] = str((SCENARIOS / doc["robot"]["directory"]).resolve())
    doc["tool"] = str(SCENARIOS / doc["tool"])
    doc["material"] = str(SCENARIOS / doc["material"])
    doc["robot"].update(robot)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_coaxial_spindle_leaves_nothing_to_choose_and_the_run_is_unchanged(tmp_path):
    """Turning about the tool axis of the bundled KR500-3 turns A6 only: status last_joint,
    and every law's cycle time is the nearest-IK run's exactly."""
    kw = dict(laws=["thesis", "jerk"], spacing_mm=2.0, progress=quiet, report=False)
    opt = run_scenario(_scenario(tmp_path, "triangle_slot", redundancy="optimise"),
                       tmp_path / "opt", **kw)
    near = run_scenario(SCENARIOS / "triangle_slot.yaml", tmp_path / "near", **kw)
    summary = json.loads((tmp_path / "opt" / "summary.json").read_text())
    assert summary["scenario"]["redundancy"]["status"] == "last_joint"
    for law in ("thesis", "jerk"):
        assert opt.laws[law].trajectory.duration == near.laws[law].trajectory.duration


def test_the_side_spindle_cell_gets_a_lower_t_star_and_a_report_figure(tmp_path):
    path = _scenario(tmp_path, "triangle_slot_side_redundancy",
                     redundancy_options={"search_spacing_mm": 4.0, "max_evaluations": 60})
    res = run_scenario(path, tmp_path / "out", laws=["convex", "jerk"], spacing_mm=2.0,
                       progress=quiet)
    red = res.prepared.redundancy
    assert red.status.value == "improved" and red.t_star < red.t_star_nearest * (1 - 1e-3)
    assert res.prepared.problem.lower_bound_time() == pytest.approx(red.t_star, rel=1e-12)
    for law in ("convex", "jerk"):
        assert res.laws[law].verification.exportable, res.laws[law].verification.problems
        assert res.laws[law].trajectory.duration < 1.03 * red.t_star  # on the new bound (2 mm)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["scenario"]["redundancy"]["gain"] > 1e-3
    assert (tmp_path / "out" / "report_redundancy.png").stat().st_size > 10_000


def test_optimise_with_a_fixed_rotation_is_refused(tmp_path):
    from feedopt.scenario import load_scenario

    bad = _scenario(tmp_path, "triangle_slot", redundancy="optimise", fix_tool_rotation=True)
    with pytest.raises(InputError, match="redundancy: optimise needs the rotation about the "
                                         "tool axis free"):
        load_scenario(bad)
