"""A ball-nose raster end to end (issue 34): the generated CAMotics-style program on its roughed
STL stock with a 2 mm carbide ball-nose that bends, every law verified by replay, the tool's
share of the deflection in summary.json and the report, and a tool file that contradicts the
program's tool comment refused."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml

from feedopt.errors import InputError
from feedopt.report.inputs import input_rows
from feedopt.runner import run_scenario
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731
SCENARIO = ROOT / "scenarios" / "ball_raster.yaml"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return run_scenario(SCENARIO, tmp_path_factory.mktemp("ball") / "out", spacing_mm=0.1,
                        laws=["topp", "convex", "jerk"], progress=quiet, report=False)


def test_every_law_is_verified_within_the_limit_and_the_smooth_ones_exported(run):
    limit = run.summary["scenario"]["deflection_limit_mm"]
    for law in ("topp", "convex", "jerk"):
        row = run.summary["laws"][law]
        assert row["verified"], (law, row.get("problems"))
        assert row["max_deflection_mm"] <= limit * (1 + 1e-6)
    assert run.summary["laws"]["convex"]["exported"] and run.summary["laws"]["jerk"]["exported"]
    # the deflection bound is active somewhere: the ball's forces limit the feed
    assert run.summary["scenario"]["active_constraints"]["deflection"] > 0.05


def test_the_tool_is_the_ball_and_its_share_of_the_deflection_is_stated(run):
    tool = run.summary["scenario"]["tool"]
    assert tool["shape"] == "ball" and tool["corner_radius_mm"] == pytest.approx(1.0)
    share = tool["bending"]["share_of_mean_deflection"]
    assert 0.0 < share["median"] < 0.5 and 0.0 < share["at_largest"] < 0.5
    assert tool["bending"]["lateral_stiffness_n_per_um"] == pytest.approx(4.3667, rel=1e-4)
    row = dict(input_rows(run.summary))
    assert any("of the mean deflection is the tool's" in v for v in row.values())
    assert run.summary["part"] is None  # the wall/floor model is a flat end mill's
    assert any("the end-cutting model is a flat end mill's" in w
               for w in run.summary["warnings"])


def test_the_model_compliance_is_the_robots_plus_the_cantilever_about_the_tool_axis(run):
    """Independent of the wiring: the model's compliance minus the robot's has the eigenvalues
    (lateral, lateral, axial) of the tool and the tool axis as the axial eigenvector."""
    prepared = run.prepared
    diff = prepared.model.compliance - prepared.along.compliance
    lateral, axial = prepared.process.tool.tip_compliance()
    axes = prepared.model.frames[:, :, 2]
    i = np.linspace(0, diff.shape[0] - 1, 25).astype(int)
    eig = np.linalg.eigvalsh(diff[i])
    np.testing.assert_allclose(eig, np.tile(np.sort([lateral, lateral, axial]), (i.size, 1)),
                               rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", diff[i], axes[i]), axial * axes[i],
                               rtol=1e-9, atol=1e-18)


def test_a_flat_tool_file_for_the_ball_program_is_refused(tmp_path):
    for name in ("gcode", "tools", "materials"):
        shutil.copytree(ROOT / "scenarios" / name, tmp_path / name)
    doc = yaml.safe_load(SCENARIO.read_text())
    doc["tool"] = "tools/hss_2flute_19mm.yaml"
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=r"line 2: tool comment .*ball end mill.*flat cutter"):
        run_scenario(tmp_path / "s.yaml", tmp_path / "out", progress=quiet, report=False)


def test_surface_mode_with_a_ball_is_refused_naming_the_tool(tmp_path):
    for name in ("gcode", "tools", "materials"):
        shutil.copytree(ROOT / "scenarios" / name, tmp_path / name)
    doc = yaml.safe_load(SCENARIO.read_text())
    doc["deflection"] = {"limit_mm": 1.0, "mode": "surface", "wall_limit_mm": 0.05}
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match="flat end mill's; tool tools/carbide_ball_2mm.yaml is "
                                         "a ball cutter"):
        run_scenario(tmp_path / "s.yaml", tmp_path / "out", progress=quiet, report=False)


def test_a_limit_below_the_edge_forces_names_the_tools_stiffness(tmp_path):
    for name in ("gcode", "tools", "materials"):
        shutil.copytree(ROOT / "scenarios" / name, tmp_path / name)
    doc = yaml.safe_load(SCENARIO.read_text())
    doc["deflection"]["limit_mm"] = 0.02
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=r"exceeded by the edge forces alone.*The tool's own "
                                         r"bending is part of it: '2-flute 2 mm carbide "
                                         r"ball-nose' is 4.37 N/um at its tip"):
        run_scenario(tmp_path / "s.yaml", tmp_path / "out", progress=quiet, report=False)
