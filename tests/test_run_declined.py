"""Laws that decline a path, and what the exit code says when some laws fail (issue 17)."""

import dataclasses
import json
import sys
import types

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.runner import run_scenario
from feedopt.schedule.laws import LAWS, LawSpec, register_law

quiet = lambda _m: None  # noqa: E731


def test_thesis_declines_a_bound_it_would_have_to_reverse_for(quick_scenario, tmp_path,
                                                               capsys) -> None:
    # The reported case: the default scenario with a 0.075 mm limit made thesis "fail" with a
    # negative velocity and the run exit 1 although jerk was verified.
    p = quick_scenario("triangle_slot", deflection__limit_mm=0.075, path__spacing_mm=1.0,
                       schedule__laws=["thesis", "jerk"])
    assert main(["run", str(p), "--out", str(tmp_path / "out"), "--no-report"]) == 0
    err = capsys.readouterr().err
    assert "thesis: declined: thesis law: its quintic piece" in err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "run backwards" in summary["declined_laws"]["thesis"]
    assert "thesis" not in summary["laws"] and summary["laws"]["jerk"]["exported"]
    assert any(w.startswith("law thesis declined") for w in summary["warnings"])


def test_thesis_declines_dense_paths_before_planning(quick_scenario, tmp_path, capsys) -> None:
    # A dense waypoint cloud (the kind a scanner or a CAM export gives): 2100 points on an arc.
    angle = np.linspace(0.0, 1.0, 2101)
    pts = np.column_stack([60 * np.sin(angle), 60 * (1 - np.cos(angle)), 0 * angle])
    csv = tmp_path / "dense.csv"
    np.savetxt(csv, pts, delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    p = quick_scenario("triangle_slot", path__generator="csv", path__file=str(csv),
                       path__blend="none", path__spacing_mm=0.5, schedule__laws=["thesis"])
    assert main(["run", str(p), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "more than the 2000 it plans" in err and "add convex or jerk" in err
    assert not (tmp_path / "out").exists()


def test_constant_declines_a_feed_the_joints_cannot_run(quick_scenario, tmp_path) -> None:
    p = quick_scenario("triangle_slot", feed__nominal_mm_s=1000.0, path__spacing_mm=1.0,
                       schedule__laws=["constant", "jerk"])
    result = run_scenario(p, out_dir=tmp_path / "a", progress=quiet, report=False)
    why = result.prepared.declined["constant"]
    assert "joint 3 would need" in why and "acceleration limit" in why
    runs = float(why.split("a feed of at most ")[1].split(" mm/s")[0])
    # Independent check: at 99 % of the feed it names, the verification's own joint check
    # passes (the constant law then plans, ramps included).
    p = quick_scenario("triangle_slot", feed__nominal_mm_s=0.99 * runs, path__spacing_mm=1.0,
                       schedule__laws=["constant"])
    ok = run_scenario(p, out_dir=tmp_path / "b", progress=quiet, report=False)
    timing = ok.laws["constant"].verification.timing
    assert timing.joint_acceleration_ratio <= 1.0 and timing.joint_velocity_ratio <= 1.0
    assert ok.laws["constant"].verification.verified


@pytest.fixture
def liar():
    def plan_liar(problem, options=None):
        from feedopt.schedule.topp import plan_topp

        return dataclasses.replace(plan_topp(problem), law="liar")

    module = types.ModuleType("feedopt_test_liar_cli")
    module.plan_liar = plan_liar
    module.LiarOptions = LAWS["jerk"].options_model()
    sys.modules[module.__name__] = module
    register_law(LawSpec("liar", module.__name__, continuity=2))
    yield
    del LAWS["liar"]
    del sys.modules[module.__name__]


def test_exit_code_3_when_some_laws_fail_and_others_are_exported(liar, quick_scenario,
                                                                tmp_path, capsys) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["liar", "jerk"])
    assert main(["run", str(p), "--out", str(tmp_path / "a"), "--no-report"]) == 3
    assert "exported: jerk" in capsys.readouterr().err
    assert (tmp_path / "a" / "jerk.csv").is_file() and not (tmp_path / "a" / "liar.csv").exists()
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["liar"])
    assert main(["run", str(p), "--out", str(tmp_path / "b"), "--no-report"]) == 1
    assert "nothing was exported" in capsys.readouterr().err
