"""Caveats reach the user (issue 19): robot data warnings, tight path radii, exports that
cannot be written, all known before planning and kept in summary.json."""

import json
from pathlib import Path

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.runner import run_scenario

ROOT = Path(__file__).resolve().parents[1]


def test_ur10_run_carries_placeholder_warnings_and_writes_no_krl(tmp_path, quick_scenario) -> None:
    # UR10 at q0 = (0, -90, 90, -90, -90, 0) deg: TCP at (-688, -163.9, 447.1) mm, TCP z up,
    # TCP x along base +y (FK); the workpiece frame is put there so the path starts at q0.
    p = quick_scenario(
        "linear_peripheral",
        robot__directory=str(ROOT / "robots" / "ur10"),
        robot__start_configuration_deg=[0, -90, 90, -90, -90, 0],
        workpiece__position_mm=[-688.0, -163.941, 447.1],
        workpiece__rpy_deg=[0.0, 0.0, 90.0],
        path__end_mm=[40.0, -1.0, 0.0], path__spacing_mm=1.0,
        deflection__limit_mm=5.0, schedule__laws=["constant", "thesis", "jerk"],
    )
    messages: list[str] = []
    result = run_scenario(p, out_dir=tmp_path / "out", progress=messages.append, report=False)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert any("ILLUSTRATIVE PLACEHOLDER" in w for w in summary["warnings"])
    assert any(m.startswith("warning: robot ur10:") and "PLACEHOLDER" in m for m in messages)
    assert not list((tmp_path / "out").glob("*.src"))
    assert "controller 'ur'" in summary["laws"]["thesis"]["krl_not_written"]
    assert summary["laws"]["jerk"]["exported"] and (tmp_path / "out" / "jerk.csv").is_file()
    assert result.prepared.robot.controller == "ur"


def test_square_slot_warns_about_its_tight_corner(tmp_path, quick_scenario) -> None:
    p = quick_scenario("square_slot", path__spacing_mm=1.0,
                  schedule__laws=["constant", "jerk"])
    messages: list[str] = []
    result = run_scenario(p, out_dir=tmp_path / "out", progress=messages.append, report=False)
    radius = [w for w in result.summary["warnings"] if "tightest path radius" in w]
    assert len(radius) == 1 and "cutter radius of 9.525 mm" in radius[0]
    # The tightest radius by an independent dense evaluation of the same path.
    dense = result.prepared.path.sample(1e-5)
    r_min = 1e3 / np.max(np.linalg.norm(dense.curvature, axis=1))
    reported = float(radius[0].split("tightest path radius is ")[1].split(" mm")[0])
    assert reported == pytest.approx(r_min, rel=2e-2)  # 1 mm sampling of the run
    assert "varying_radius blend of corner" in radius[0]


def test_path_much_tighter_than_the_cutter_is_refused_before_planning(
        tmp_path, quick_scenario) -> None:
    p = quick_scenario("square_slot", path__blend="circle", path__blend_size_mm=3.0)
    messages: list[str] = []
    with pytest.raises(InputError, match=r"tightest path radius is 3 mm.*meaningless"):
        run_scenario(p, out_dir=tmp_path / "out", progress=messages.append)
    assert not any(m.startswith("[3/5]") for m in messages)
    assert not (tmp_path / "out").exists()


def test_krl_segment_cap_skips_krl_only_and_is_said_up_front(
        tmp_path, monkeypatch, quick_scenario) -> None:
    import feedopt.export.krl as krl

    monkeypatch.setattr(krl, "MAX_SEGMENTS", 5)
    p = quick_scenario("triangle_slot", path__spacing_mm=2.0,
                  schedule__laws=["thesis", "jerk"])
    messages: list[str] = []
    result = run_scenario(p, out_dir=tmp_path / "out", progress=messages.append, report=False)
    warn = [i for i, m in enumerate(messages) if "no KRL program" in m]
    first_law = next(i for i, m in enumerate(messages) if m.startswith("[5/5]"))
    assert warn and warn[0] < first_law  # said before any law was planned
    assert "more than the 5" in result.summary["laws"]["thesis"]["krl_not_written"]
    assert (tmp_path / "out" / "thesis.csv").is_file() and (tmp_path / "out" / "jerk.csv").is_file()
    assert not (tmp_path / "out" / "thesis.src").exists()


def test_dropped_waypoints_are_said(tmp_path, quick_scenario) -> None:
    csv = tmp_path / "w.csv"
    csv.write_text("x_mm,y_mm,z_mm\n0,0,0\n60,0,0\n60,0,0\n60,60,0\n")
    p = quick_scenario("triangle_slot", path__generator="csv", path__file=str(csv),
                       path__drop_repeated_waypoints=True, path__spacing_mm=2.0,
                       schedule__laws=["jerk"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None, report=False)
    assert any("dropped 1 repeated waypoint(s) (indices 2)" in w
               for w in result.summary["warnings"])


def test_force_workload_cap_is_said_before_any_force_is_computed(
        tmp_path, quick_scenario) -> None:
    p = quick_scenario(path__spacing_mm=0.01, schedule__angle_step_deg=0.01,
                       schedule__axial_slices=500)
    messages: list[str] = []
    with pytest.raises(InputError, match=r"about .* force evaluations, more than the 1e\+11"):
        run_scenario(p, out_dir=tmp_path / "out", progress=messages.append)
    assert not any(m.startswith("[4/5]") for m in messages)
    assert not (tmp_path / "out").exists()


def test_output_size_cap_refuses_before_planning(tmp_path, quick_scenario, monkeypatch) -> None:
    import feedopt.outputs as outputs

    monkeypatch.setattr(outputs, "MAX_CONTROLLER_ROWS", 1000)  # T* of this cut is ~54 s
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["jerk"])
    with pytest.raises(InputError, match=r"RSI cycles of 4 ms .* GB of CSV"):
        run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None)
    assert not (tmp_path / "out").exists()


def test_law_over_the_row_cap_is_not_exported_and_costs_no_other(tmp_path, quick_scenario,
                                                                 monkeypatch) -> None:
    import feedopt.outputs as outputs

    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["constant", "jerk"],
                       feed__nominal_mm_s=1.0, deflection__limit_mm=1.0)
    first = run_scenario(p, out_dir=tmp_path / "first", progress=lambda _m: None, report=False)
    rows = {law: r.trajectory.duration / 0.004 + 1 for law, r in first.laws.items()}
    longer, shorter = sorted(rows, key=rows.get, reverse=True)
    assert rows[longer] > rows[shorter]
    monkeypatch.setattr(outputs, "MAX_CONTROLLER_ROWS", 0.5 * (rows[longer] + rows[shorter]))
    result = run_scenario(p, out_dir=tmp_path / "out", progress=lambda _m: None, report=False)
    laws = result.summary["laws"]
    assert not laws[longer]["exported"] and not laws[longer]["exportable"]
    assert any("controller cycles" in b for b in laws[longer]["export_blockers"])
    assert not (tmp_path / "out" / f"{longer}.csv").exists()
    assert laws[shorter]["exported"] == first.summary["laws"][shorter]["exported"]
    assert (tmp_path / "out" / f"{shorter}.csv").is_file() == laws[shorter]["exported"]
