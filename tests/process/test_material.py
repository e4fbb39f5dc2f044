"""A run's engagement from its stock (issue 12): scenario rules, the program checks against
the material (rapids, plunges), the chapter-4 line against its closed-form engagement, and
the `feedopt engagement` CSV."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
import yaml

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.process.stock import angle_error_bound
from feedopt.runner import prepare, prepare_front
from feedopt.scenario import load_scenario, scenario_warnings
from tests.conftest import SCENARIOS

quiet = lambda _m: None  # noqa: E731
R = 9.525  # mm


def _chapter4_entry_deg(x_mm: np.ndarray) -> np.ndarray:
    """Closed form: the cutter centre on the line (0, 0) -> (203.2, -9.525), the stock edge
    y = -9.525 (material below); the rim point at angle phi (Altintas: from +y_tool, clockwise
    seen from the spindle) is R (sin phi u + cos phi n) with u the feed and n its left
    normal; it meets the edge where R cos(phi + a) = -9.525 - y_c (a = the drift angle)."""
    a = math.atan2(9.525, 203.2)
    y_c = -9.525 * x_mm / 203.2
    return np.degrees(np.arccos(np.clip((-9.525 - y_c) / R, -1, 1))) - math.degrees(a)


def test_chapter4_line_gets_its_closed_form_engagement_from_the_stock():
    sc, base = load_scenario(SCENARIOS / "linear_peripheral_stock.yaml")
    front = prepare_front(sc, base, progress=quiet, spacing_mm=0.5)
    e = front.process.engagement
    x = front.samples.position[:, 0] * 1e3
    inside = (x > 20) & (x < 203.2 - R - 1)  # away from the snap at the start and the exit
    want = _chapter4_entry_deg(x[inside])
    got = np.degrees(e.entry[inside])
    # within the Z-map's stated error for its 0.1 mm cells: the lateral bound plus the
    # lookahead term of a boundary across the feed (the line drifts into the edge)
    h, phi = 0.1e-3, np.radians(want)
    bound = angle_error_bound(phi, h, R * 1e-3) + math.sqrt(2) * h / (R * 1e-3 * np.sin(phi))
    assert np.all(np.abs(got - want) <= np.degrees(bound))
    assert np.abs(got - want).max() < 1.0  # the target: within 1 deg
    assert np.allclose(np.degrees(e.exit[inside]), 180.0)  # down milling: out at the right
    assert np.allclose(e.axial_depth[inside] * 1e3, 1.5)
    # the last cutter radius leaves the block: the engaged arc shrinks to nothing
    assert e.exit[-1] == e.entry[-1]


def test_a_stock_replaces_the_hand_written_cut_and_says_so(quick_scenario):
    both = quick_scenario("linear_peripheral_stock", cut__type="slot", cut__axial_depth_mm=1.0)
    sc, _ = load_scenario(both)
    assert any("the engagement comes from the stock" in w for w in scenario_warnings(sc))
    none = quick_scenario("linear_peripheral", cut__type=None)
    with pytest.raises(InputError, match="cut.type and cut.axial_depth_mm: required without "
                                         "a stock"):
        load_scenario(none)
    tilted = quick_scenario("linear_peripheral_stock", workpiece__tool_axis=[0.0, 0.1, 1.0])
    with pytest.raises(InputError, match="tool axis along \\+z"):
        load_scenario(tilted)


def _program_scenario(quick_scenario, tmp_path, text):
    prog = tmp_path / "job.nc"
    prog.write_text(text)
    return quick_scenario("profile", path__file=str(prog),
                          stock__box_mm=[-10.0, -10.0, -20.0, 140.0, 100.0, 0.0])


HEAD = "G21 G17 G90 G94\nT1 M6\nS2500 M3\nG0 X-30. Y40. Z5.\n"


def test_a_rapid_into_the_stock_is_refused_with_its_line(quick_scenario, tmp_path):
    text = HEAD + ("G1 Z-1. F300.\nG1 X-20. F254.\nG0 X20.\nG1 X40.\nG0 Z5.\nM30\n")
    bad = _program_scenario(quick_scenario, tmp_path, text)
    sc, base = load_scenario(bad)
    with pytest.raises(InputError, match=r"line 7: a rapid \(G0\) meets material"):
        prepare(sc, base, progress=quiet)


PLUNGE_BLOCK = {"thrust_cutting_n_mm2": 1500.0, "thrust_edge_n_mm": 20.0,
                "torque_cutting_n_mm2": 900.0, "torque_edge_n_mm": 10.0}


def _plunge_front(quick_scenario, tmp_path, depth_mm: float, coefficients: bool,
                  bottom_mm: float = -20.0):
    """The front of a program that plunges ``depth_mm`` into the stock at line 6 (and leaves
    by a G1 retract: the first sample of a G0 out of a deep slot's corner blend sees the slot
    end in the sweep's lookahead and is refused as a rapid into material)."""
    text = HEAD + f"G0 X20.\nG1 Z-{depth_mm:g} F300.\nG1 X40. F254.\nG1 Z5.\nM30\n"
    prog = tmp_path / "job.nc"
    prog.write_text(text)
    material = yaml.safe_load((SCENARIOS / "materials" / "6061-T6511.yaml").read_text())
    if coefficients:
        for speed in material["speeds"]:
            speed["plunge"] = dict(PLUNGE_BLOCK)
    mat = tmp_path / "material.yaml"
    mat.write_text(yaml.safe_dump(material))
    path = quick_scenario("profile", path__file=str(prog),
                          stock__box_mm=[-10.0, -10.0, bottom_mm, 140.0, 100.0, 0.0])
    doc = yaml.safe_load(path.read_text())
    doc["material"] = str(mat)
    path.write_text(yaml.safe_dump(doc))
    sc, base = load_scenario(path)
    return prepare_front(sc, base, progress=quiet)


def _plunge_samples(front) -> np.ndarray:
    moves, s = front.path.moves, front.samples.s
    return (moves.category[moves.index_at(s)] == "plunge") & (front.samples.position[:, 2] < 0)


def test_a_plunge_into_the_stock_is_a_full_plunge(quick_scenario, tmp_path):
    front = _plunge_front(quick_scenario, tmp_path, 1.0, coefficients=True)
    e, inside = front.process.engagement, _plunge_samples(front)
    assert inside.sum() >= 5
    assert e.plunging.tolist() == inside.tolist()  # every plunge sample below the top, no other
    # no side engagement on the way straight down; the corner blend into the next cut (which
    # the move table gives to the plunge) moves sideways too, and its side edges do cut
    down = inside & (np.linalg.norm(front.samples.tangent[:, :2], axis=1) < 1e-6)
    assert down.sum() >= 5
    assert np.all(e.exit[down] == e.entry[down])
    assert not front.process.unmodelled_plunge.any()
    assert front.process.coefficients.plunge is not None
    assert not any("plunge" in w for w in front.process.warnings)


def test_a_plunge_without_plunge_coefficients_is_unmodelled_and_named(quick_scenario, tmp_path):
    front = _plunge_front(quick_scenario, tmp_path, 1.0, coefficients=False)
    inside = _plunge_samples(front)
    assert front.process.unmodelled_plunge.tolist() == inside.tolist()
    assert front.process.engagement.plunge is None  # no force model there
    notes = [w for w in front.process.warnings if "plunges along the tool axis" in w]
    assert len(notes) == 1 and "at line 6 (" in notes[0] and "no plunge coefficients" in notes[0]


def test_a_plunge_deeper_than_the_flutes_is_refused_with_its_line(quick_scenario, tmp_path):
    with pytest.raises(InputError, match=r"job.nc line 6: the plunge reaches more than the "
                                         r"flute length 23.8125 mm of tool"):
        _plunge_front(quick_scenario, tmp_path, 30.0, coefficients=True, bottom_mm=-40.0)
    # 20 mm, within the 23.8 mm flutes: modelled
    assert _plunge_front(quick_scenario, tmp_path, 20.0, coefficients=True,
                         bottom_mm=-40.0).process.engagement.plunging.any()


def test_engagement_command_writes_one_row_per_sample(tmp_path, capsys):
    out, png, pieces = tmp_path / "e.csv", tmp_path / "e.png", tmp_path / "p.csv"
    rc = main(["engagement", str(SCENARIOS / "linear_peripheral_stock.yaml"), "--spacing", "1",
               "--out", str(out), "--plot", str(png), "--intervals", str(pieces)])
    assert rc == 0 and png.stat().st_size > 0
    with open(out, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["s_mm", "x_mm", "y_mm", "z_mm", "line", "entry_deg", "exit_deg",
                       "radial_depth_mm", "axial_depth_mm", "intervals"]
    body = rows[1:]
    assert len(body) == 205  # 203.4 mm at 1 mm
    mid = body[100]
    radial = float(mid[7])
    assert abs(radial - 9.525 * 100 / 203.2) < 1.0
    # one interval per engaged sample on this line, and it is the row's own
    with open(pieces, newline="") as fh:
        prow = list(csv.reader(fh))
    assert prow[0] == ["sample", "s_mm", "entry_deg", "exit_deg", "axial_depth_mm"]
    engaged = [k for k, r in enumerate(body) if r[9] not in ("", "0")]
    assert [int(r[0]) for r in prow[1:]] == engaged
    for r in prow[1:]:
        row = body[int(r[0])]
        assert float(r[2]) == pytest.approx(float(row[5]), abs=1e-6)
        assert float(r[3]) == pytest.approx(float(row[6]), abs=1e-6)
    assert "cutting" in capsys.readouterr().out


def test_engagement_command_needs_a_stock(capsys):
    assert main(["engagement", str(SCENARIOS / "linear_peripheral.yaml")]) == 2
    assert "no stock: section" in capsys.readouterr().err


def test_a_slot_through_fresh_stock_is_the_hand_written_full_slot():
    """triangle_slot_stock.yaml computes what triangle_slot.yaml states (a slot, 1.5 mm):
    the same feed bound wherever the stock is fresh ahead of the cutter (the wave never
    crosses its own track: 12.7 mm blends, 76.2 mm between its legs)."""
    bounds = {}
    for name in ("triangle_slot", "triangle_slot_stock"):
        sc, base = load_scenario(SCENARIOS / f"{name}.yaml")
        bounds[name] = prepare(sc, base, progress=quiet, spacing_mm=1.0).bound.v_max
    a, b = bounds["triangle_slot"], bounds["triangle_slot_stock"]
    assert np.allclose(a[1:-1], b[1:-1], rtol=1e-6)


def test_the_run_report_has_the_engagement_figure_and_the_removal_rate(tmp_path):
    import json

    from feedopt.runner import run_scenario

    out = tmp_path / "run"
    run_scenario(SCENARIOS / "linear_peripheral_stock.yaml", out, laws=["jerk"],
                 progress=quiet, spacing_mm=1.0)
    assert (out / "report_engagement.png").stat().st_size > 0
    assert "report_engagement.png" in (out / "report.md").read_text()
    summary = json.loads((out / "summary.json").read_text())
    stock = summary["scenario"]["stock"]
    # the removed volume: the triangle the drifting cutter cuts off the block's edge,
    # 203.2 x 9.525 / 2 mm^2, times the 1.5 mm depth, plus the end of the cutter disc
    assert stock["removed_mm3"] == pytest.approx(203.2 * 9.525 / 2 * 1.5, rel=0.02)
    rate = summary["laws"]["jerk"]["material_removal_rate"]
    duration = summary["laws"]["jerk"]["cycle_time_s"]
    assert rate["mean_mm3_s"] == pytest.approx(stock["removed_mm3"] / duration)
    # its peak: a_e a_p v_f at its largest (the widest engagement runs at the lowest feed)
    assert rate["max_mm3_s"] <= 9.525 * 1.5 * 4.23 * 1.05


def test_removal_rate_integrates_to_the_removed_volume():
    """The time integral of the removal rate along a law's feed is the removed volume."""
    from feedopt.report.summary import removal_rates

    sc, base = load_scenario(SCENARIOS / "linear_peripheral_stock.yaml")
    prepared = prepare(sc, base, progress=quiet, spacing_mm=0.5)
    feed = np.full(prepared.samples.s.size, 3e-3)  # 3 mm/s everywhere
    rate = removal_rates(prepared, feed)  # mm^3/s
    dt = np.diff(prepared.samples.s, prepend=0.0) / feed
    removed = prepared.process.material.removed_volume / 1e-9  # mm^3
    assert np.sum(rate * dt) == pytest.approx(removed, rel=0.01)
