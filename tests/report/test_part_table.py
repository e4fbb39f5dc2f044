"""The report's predicted-part section: the per-segment table of the program to run and the
baseline, the other mode's T*, and the part figure in a real run's report."""

from __future__ import annotations

from feedopt.report.part_table import PART_HEADERS, other_mode_line, part_rows
from feedopt.runner import run_scenario
from tests.conftest import ROOT


def _segment(k: int, kind: str, left: float) -> dict:
    wall = {"mean_distance_mm": left, "flatness_mm": 0.01 if kind == "line" else None}
    return {"segment": k, "kind": kind, "left_wall": wall, "right_wall": None,
            "floor": {"depth_mean_mm": -1.52, "depth_std_mm": 0.015}}


def _summary() -> dict:
    laws = {"constant": {"verified": True, "exported": False, "cycle_time_s": 100.0},
            "jerk": {"verified": True, "exported": True, "cycle_time_s": 120.0}}
    part = {law: {"segments": [_segment(1, "line", x), _segment(2, "arc", x)]}
            for law, x in (("constant", 0.03), ("jerk", 0.02))}
    other = {"mode": "norm", "law": "jerk", "wall_limit_mm": 0.0543, "floor_limit_mm": None,
             "lower_bound_s": 110.0, "other_lower_bound_s": 99.0}
    return {"laws": laws, "part": {"laws": part, "other_mode": other}}


def test_rows_pair_the_program_with_the_baseline_per_segment():
    rows = part_rows(_summary())
    assert all(len(r) == len(PART_HEADERS) for r in rows)
    assert [(r[0], r[2]) for r in rows] == [("1", "jerk"), ("1", "constant"), ("2", "jerk"),
                                            ("2", "constant")]
    assert rows[0][3:5] == ["0.0200", "0.0100"] and rows[2][4] == "-"  # no arc flatness
    assert rows[0][5:7] == ["-", "-"] and rows[0][7:] == ["-1.5200", "0.0150"]


def test_other_mode_line_names_the_tolerances_and_the_change():
    line = other_mode_line(_summary())
    assert "walls within 0.0543 mm" in line and "floor" not in line.split("),")[0]
    assert "T* = 99.00 s against 110.00 s here (-10.0%)" in line
    summary = _summary()
    del summary["part"]["other_mode"]
    assert other_mode_line(summary) is None and part_rows({"laws": {}}) == []


def test_a_real_report_has_the_part_figure_table_and_other_mode(tmp_path):
    result = run_scenario(ROOT / "scenarios" / "triangle_slot.yaml", tmp_path / "out",
                          laws=["constant", "jerk"], spacing_mm=1.0, progress=lambda _m: None)
    md = (result.out_dir / "report.md").read_text()
    html = (result.out_dir / "report.html").read_text()
    assert (result.out_dir / "report_part.png").is_file() and 'id="fig-part"' in html
    for text in (md, html):
        assert "The predicted part, per segment" in text
        assert "planned for instead (deflection.mode: surface" in text
