"""summary.json's scenario section and per-law entries, and the report's inputs/warnings."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from feedopt.errors import InputError
from feedopt.report.data import validate_summary
from feedopt.report.html import render_report
from feedopt.report.inputs import input_rows, run_warnings
from feedopt.report.summary import law_summary, sample_place, scenario_summary
from feedopt.report.tables import ramp_table

from .conftest import fake_summary

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "triangle_slot.yaml"


@pytest.fixture(scope="module")
def planned():
    from feedopt.runner import plan_and_verify, prepare
    from feedopt.scenario import load_scenario

    scenario, base = load_scenario(SCENARIO)
    prepared = prepare(scenario, base, lambda _m: None, spacing_mm=2.0)
    results = plan_and_verify(prepared, ["constant", "jerk"], lambda _m: None)
    return prepared, results


def _yaml(path: Path) -> dict:
    return yaml.safe_load(path.read_text())


def test_scenario_section_lists_the_job(planned) -> None:
    prepared, _ = planned
    sc = scenario_summary(prepared)
    json.dumps(sc, allow_nan=False)  # plain JSON
    doc = _yaml(SCENARIO)
    robot_dir = (SCENARIO.parent / doc["robot"]["directory"]).resolve()
    robot = _yaml(robot_dir / "robot.yaml")
    tool = _yaml(SCENARIO.parent / doc["tool"])
    material = _yaml(SCENARIO.parent / doc["material"])

    assert sc["robot"]["name"] == robot["name"] == "kuka_kr500_3"
    assert sc["robot"]["stiffness_source"] == robot["joint_stiffness_mnm_per_rad"]["source"]
    assert sc["stiffness_set"] == doc["robot"]["stiffness"]
    np.testing.assert_allclose(sc["stiffness_mnm_per_rad"],
                               robot["joint_stiffness_mnm_per_rad"][doc["robot"]["stiffness"]],
                               rtol=1e-12)
    np.testing.assert_allclose(sc["tcp_offset_mm"], robot["tool"]["tcp_xyz_mm"], atol=1e-9)
    assert sc["tool"]["name"] == tool["name"] and sc["tool"]["teeth"] == tool["teeth"]
    assert sc["tool"]["diameter_mm"] == pytest.approx(tool["diameter_mm"], rel=1e-12)
    assert sc["tool"]["helix_deg"] == pytest.approx(tool["helix_deg"], rel=1e-12)
    assert sc["material"]["name"] == material["material"]
    assert sc["material"]["coefficient_source"] == material["source"]
    assert sc["material"]["calibrated_rpm"] == [s["rpm"] for s in material["speeds"]]
    assert sc["material"]["coefficients_at_rpm"] == "calibrated"  # 2500 rpm is in the table
    assert sc["cut"]["rpm"] == doc["cut"]["spindle_rpm"]
    assert sc["cut"]["axial_depth_mm"] == doc["cut"]["axial_depth_mm"]
    assert sc["cut"]["type"] == "slot" and sc["cut"]["milling"] == "down"
    assert sc["workpiece_position_mm"] == doc["workpiece"]["position_mm"]
    assert sc["workpiece_rpy_deg"] == doc["workpiece"]["rpy_deg"]
    assert sc["nominal_feed_mm_s"] == sc["max_feed_mm_s"] == doc["feed"]["nominal_mm_s"]
    assert sc["max_feed_is_default"] is True
    assert sc["deflection_limit_mm"] == doc["deflection"]["limit_mm"]
    assert sc["limit_mode"] == doc["deflection"]["mode"]
    assert sc["tangential_acceleration_mm_s2"] == doc["limits"]["tangential_acceleration_mm_s2"]
    assert sc["tangential_jerk_mm_s3"] == doc["limits"]["tangential_jerk_mm_s3"]
    # 2 mm spacing asked: n = ceil(L / 2 mm) + 1 uniform samples
    length = sc["path_length_mm"]
    assert sc["samples"] == int(np.ceil(length / 2.0 - 1e-9)) + 1
    assert sc["sample_spacing_mm"] == pytest.approx(length / (sc["samples"] - 1), rel=1e-12)
    assert sc["sample_spacing_mm"] <= 2.0


def test_law_entries_report_cutting_feed_and_ramps(planned) -> None:
    prepared, results = planned
    for res in results.values():
        entry = law_summary(prepared, res)
        json.dumps(entry, allow_nan=False)
        timing = res.verification.timing
        assert entry["min_feed_mm_s"] == pytest.approx(timing.min_cutting_feed * 1e3, rel=1e-12)
        for key, ramp in (("start_ramp", timing.start_ramp), ("stop_ramp", timing.stop_ramp)):
            got = entry[key]
            assert got["length_mm"] == pytest.approx(ramp.length * 1e3, rel=1e-12)
            assert got["duration_s"] == pytest.approx(ramp.duration, rel=1e-12)
            assert got["feed_mm_s"] == pytest.approx(ramp.feed * 1e3, rel=1e-12)
            assert got["ends_by"] == ramp.reason
    constant = law_summary(prepared, results["constant"])
    # the constant law cruises at the nominal feed once its ramps are over; its ramps are
    # the law's own (stats), whatever the sample spacing (2 mm here, ramps ~0.15 mm)
    assert constant["min_feed_mm_s"] == pytest.approx(4.23, rel=1e-12)
    up, down = results["constant"].trajectory.stats["ramp_lengths_mm"]
    assert constant["start_ramp"]["length_mm"] == pytest.approx(up, rel=1e-9)
    assert constant["stop_ramp"]["length_mm"] == pytest.approx(down, rel=1e-9)
    assert constant["start_ramp"]["feed_mm_s"] == pytest.approx(4.23, rel=1e-12)


def test_law_entries_name_where_the_deflection_is_largest(planned) -> None:
    prepared, results = planned
    for res in results.values():
        place = law_summary(prepared, res)["worst_deflection"]
        worst = int(np.argmax(res.verification.deflection))
        assert place["sample"] == worst
        assert place["s_mm"] == pytest.approx(prepared.problem.s[worst] * 1e3, rel=1e-12)
        assert place["line"] is None and place["label"] is None  # not a program path


def test_a_program_path_place_has_its_line() -> None:
    from types import SimpleNamespace

    from feedopt.geometry.program_tables import MoveTable

    nan = np.full(3, np.nan)
    moves = MoveTable(s_start=np.array([0.0, 0.010, 0.025]), line=np.array([7, 9, 12]),
                      n_number=np.array([70, -1, 120]), category=np.array(["cut"] * 3),
                      kind=np.array(["line"] * 3), feed=nan, spindle_rpm=nan,
                      tool=np.full(3, -1))
    prepared = SimpleNamespace(problem=SimpleNamespace(s=np.linspace(0.0, 0.03, 31)),
                               path=SimpleNamespace(moves=moves))
    # s = 12 mm lies in the second move (10-25 mm), line 9 without an N word; 30 mm in the third
    assert sample_place(prepared, 12) == {"sample": 12, "s_mm": pytest.approx(12.0),
                                          "line": 9, "label": "line 9"}
    assert sample_place(prepared, 30)["label"] == "line 12 (N120)"


@pytest.fixture(scope="module")
def full_summary(planned) -> dict:
    prepared, results = planned
    s = {"scenario": scenario_summary(prepared),
         "laws": {law: law_summary(prepared, r) for law, r in results.items()},
         "warnings": ["robot kuka_kr500_3: joint stiffness <placeholder> & not calibrated"]}
    return validate_summary(json.loads(json.dumps(s)))


def test_inputs_rows_read_like_the_scenario(full_summary) -> None:
    rows = dict(input_rows(full_summary))
    assert rows["robot"].startswith("kuka_kr500_3")
    assert rows["joint stiffness"] == "dpp: 2.86, 2.36, 1.67, 0.24, 0.16, 0.14 MNm/rad (joints 1-6)"
    assert rows["TCP offset"] == "(400, 0, 0) mm in the flange frame"
    assert rows["tool"] == "2-flute 19.05 mm HSS TiN: diameter 19.05 mm, 2 teeth, helix 30 deg"
    assert rows["material"] == "6061-T6511"
    assert rows["cutting coefficients"].startswith("thesis Table 3.3")
    assert "calibrated at 1000, 2000, 2500 rpm" in rows["cutting coefficients"]
    assert rows["spindle speed"] == "2500 rpm"
    assert rows["cut type"] == "slot" and rows["milling"] == "down"
    assert rows["axial depth"] == "1.5 mm"
    assert rows["radial depth"] == "full immersion (slot, 19.05 mm)"
    assert rows["workpiece position"] == "(1750, -300, 800) mm in the robot base frame"
    assert rows["workpiece orientation"].startswith("(0, 0, 0) deg")
    assert rows["nominal feed"] == "4.23 mm/s"
    assert rows["max feed"] == "4.23 mm/s (default: the nominal feed)"
    assert rows["deflection limit"] == "0.29 mm, mode norm (norm of the TCP deflection)"
    assert rows["tangential acceleration limit"] == "500 mm/s^2"
    assert rows["tangential jerk limit"] == "5000 mm/s^3"
    n = full_summary["scenario"]["samples"]
    assert rows["samples"].startswith(f"{n}, spacing ")
    assert rows["path length"].startswith(f"{full_summary['scenario']['path_length_mm']:.2f} mm")
    # an old summary without these keys only shows what it has
    assert input_rows(fake_summary()) == [("deflection limit", "0.29 mm")]
    assert input_rows({"laws": {}}) == []


def test_warnings_are_read_only_when_present() -> None:
    assert run_warnings(fake_summary()) == []
    assert run_warnings({"warnings": ["a", " ", "b"]}) == ["a", "b"]
    with pytest.raises(InputError, match="'warnings' must be a list of strings"):
        validate_summary({**fake_summary(), "warnings": [1]})


def test_report_shows_warnings_inputs_and_ramps(report_data, full_summary, monkeypatch) -> None:
    monkeypatch.setattr("feedopt.report.html.FIGURES", ())  # figures: tests/report/test_report
    data = replace(report_data, summary=full_summary)
    md, page, _ = render_report(data)
    heads = [ln for ln in md.splitlines() if ln.startswith("#")]
    assert heads == ["# feedopt report: triangle_slot <test>", "## Comparison of timing laws",
                     "### Where each law deflects most", "### Start and stop ramps",
                     "## Inputs", "## Warnings", "## Verification and notes"]
    # the verdict and the checks before anything else: the fit and the placeholder
    checks = md[md.index("<!-- verdict -->"):md.index("<!-- /verdict -->")]
    assert md.index("<!-- /verdict -->") < md.index("## Comparison")
    assert "- *fitted input*: cut.axial_depth_mm = 1.5 is a FIT" in checks
    assert ("- *placeholder input*: robot kuka_kr500_3: joint stiffness <placeholder> & not "
            "calibrated") in checks
    assert page.index("<h2>Check before cutting</h2>") < page.index("<h2>Warnings</h2>")
    assert "- robot kuka_kr500_3: joint stiffness <placeholder> & not calibrated" in md
    assert ("| joint stiffness               | dpp: 2.86, 2.36, 1.67, 0.24, 0.16, 0.14 MNm/rad"
            in md)
    assert ramp_table(full_summary) in md and "min cutting feed [mm/s]" in md
    assert "min cutting feed: the smallest feed between the start and stop ramps" in md
    # HTML: same order, escaped
    order = [page.index(x) for x in ("<h2>Comparison of timing laws</h2>",
                                     "<h3>Start and stop ramps</h3>", "<h2>Inputs</h2>",
                                     "<h2>Warnings</h2>")]
    assert order == sorted(order)
    assert "joint stiffness &lt;placeholder&gt; &amp; not calibrated" in page
    assert "<placeholder>" not in page
    assert '<table class="comparison inputs">' in page
    assert '<td class="txt">TCP offset</td>' in page
    # no warnings, no section
    md2, page2, _ = render_report(replace(report_data, summary={**full_summary, "warnings": []}))
    assert "## Warnings" not in md2 and "<h2>Warnings</h2>" not in page2
