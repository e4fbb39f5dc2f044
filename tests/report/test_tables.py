"""Comparison table and summary.json validation."""

from __future__ import annotations

import html
import json
import re

import pytest

from feedopt.errors import InputError
from feedopt.report.data import load_summary, validate_summary
from feedopt.report.tables import (
    comparison_table,
    comparison_table_html,
    deflection_ratio,
    not_exported_lines,
    where_rows,
)

from .conftest import fake_summary


def _cells(table: str) -> list[list[str]]:
    lines = table.splitlines()
    return [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[:1] + lines[2:]]


def test_single_run_table_values():
    cells = _cells(comparison_table([fake_summary()]))
    head, rows = cells[0], {r[0]: dict(zip(cells[0], r, strict=True)) for r in cells[1:]}
    assert head[0] == "law" and "run" not in head
    assert list(rows) == ["constant", "thesis", "topp"]
    th = rows["thesis"]
    assert th["T [s]"] == "125" and th["T* [s]"] == "110"
    assert th["T/T*"] == f"{125 / 110:.3f}" and th["T/T(baseline)"] == "1.250"
    assert th["defl./limit"] == f"{0.29 / 0.29:.3f}"
    assert rows["constant"]["defl./limit"] == f"{0.41 / 0.29:.3f}"
    assert rows["constant"]["T* [s]"] == "-" and rows["constant"]["T/T*"] == "-"
    assert rows["topp"]["defl./limit"] == "1.000"  # given 0.9997 wins over 0.2899/0.29
    assert th["max feed [mm/s]"] == "4.02" and th["min cutting feed [mm/s]"] == "2.75"
    assert th["ramps start/stop [mm]"] == "0.16 / 0.2866"
    assert rows["constant"]["ramps start/stop [mm]"] == "-"  # an older summary: no ramps
    assert th["verified"] == "yes" and th["C2"] == "yes"


def test_columns_are_aligned():
    lines = comparison_table([fake_summary()]).splitlines()
    assert len({len(ln) for ln in lines}) == 1
    assert [i for i, ch in enumerate(lines[0]) if ch == "|"] == [
        i for i, ch in enumerate(lines[2]) if ch == "|"
    ]


def test_several_runs_get_a_run_column():
    table = comparison_table([fake_summary("a"), fake_summary("b", 2.0)], names=["r1", "r2"])
    cells = _cells(table)
    assert cells[0][0] == "run" and len(cells) == 1 + 6
    assert [r[0] for r in cells[1:]] == ["r1"] * 3 + ["r2"] * 3
    assert cells[5][4] == "250"  # thesis cycle time doubled in run 2
    default = _cells(comparison_table([fake_summary("a"), fake_summary("b")]))
    assert [r[0] for r in default[1:]] == ["a"] * 3 + ["b"] * 3


def _cells_html(page: str) -> dict[str, dict[str, tuple[str, str, str]]]:
    """{law: {header: (classes, title, text)}} of an HTML comparison table."""
    heads = re.findall(r"<th>([^<]*)</th>", page)
    rows = {}
    for row in re.findall(r"<tr>(<td.*?)</tr>", page):
        cells = re.findall(r'<td class="([^"]*)"(?: title="([^"]*)")?>([^<]*)</td>', row)
        rows[cells[0][2]] = {html.unescape(h): (c, html.unescape(tip), html.unescape(x))
                             for h, (c, tip, x) in zip(heads, cells, strict=True)}
    return rows


def test_html_table_marks_failed_checks_and_the_program_to_run():
    s = fake_summary()
    s["laws"]["topp"].update(verified=False, problems=["jerk 9 exceeds 5"], exported=False,
                             export_blockers=["not C2: the acceleration jumps"], c2=False)
    s["laws"]["constant"].update(exported=False, export_blockers=["deflection reaches 0.41 mm"])
    s["laws"]["thesis"]["exported"] = True
    page = comparison_table_html([s])
    assert page.count("<tr>") == 4
    rows = _cells_html(page)
    assert rows["topp"]["verified"] == ("txt bad", "jerk 9 exceeds 5; not C2: the acceleration "
                                        "jumps", "NO")
    assert rows["topp"]["exported"][0] == "txt warn" and rows["topp"]["C2"][0] == "txt warn"
    assert rows["constant"]["exported"] == ("txt warn", "deflection reaches 0.41 mm", "no")
    # the limit broken: 0.41 / 0.29 = 1.414 > 1; the thesis law at 0.29 / 0.29 = 1 is not
    assert rows["constant"]["defl./limit"][0] == "num bad"
    assert rows["thesis"]["defl./limit"][0] == "num" and rows["thesis"]["exported"][0] == "txt"
    # the program to run: the only law verified and exported
    assert rows["thesis"]["law"][0] == "txt pick"
    assert [r["law"][0] for k, r in rows.items() if k != "thesis"] == ["txt", "txt"]
    assert not_exported_lines(s) == ["constant: deflection reaches 0.41 mm",
                                     "topp: jerk 9 exceeds 5; not C2: the acceleration jumps"]


def test_where_rows_name_the_program_line():
    s = fake_summary()
    s["laws"]["constant"]["worst_deflection"] = {"sample": 17950, "s_mm": 1794.92, "line": 118,
                                                 "label": "line 118 (N1030)"}
    s["laws"]["thesis"]["worst_deflection"] = {"sample": 3, "s_mm": 0.3, "line": None,
                                               "label": None}
    rows, marks = where_rows(s)  # topp has no worst_deflection (an older summary): no row
    assert rows == [["constant", "0.41", f"{0.41 / 0.29:.3f}", "line 118 (N1030)", "1794.92",
                     "17950"], ["thesis", "0.29", "1.000", "-", "0.30", "3"]]
    assert marks == [["", "", "bad", "", "", ""], [""] * 6]


def test_deflection_ratio_needs_a_limit():
    s = fake_summary()
    del s["scenario"]["deflection_limit_mm"]
    assert deflection_ratio(s, "thesis") is None
    assert deflection_ratio(s, "topp") == 0.9997


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda s: s.pop("laws"), "missing or empty 'laws'"),
        (lambda s: s["laws"]["thesis"].pop("c2"), "laws.thesis lacks c2"),
        (lambda s: s["laws"]["thesis"].update(cycle_time_s="12"), "cycle_time_s must be a num"),
        (lambda s: s["laws"]["thesis"].update(cycle_time_s=True), "cycle_time_s must be a num"),
        (lambda s: s["laws"]["thesis"].update(verified=1), "verified must be true"),
        (lambda s: s["laws"].update(topp=[1]), "laws.topp must be an object"),
    ],
)
def test_validate_summary_errors(mutate, message):
    s = fake_summary()
    mutate(s)
    with pytest.raises(InputError, match=message):
        validate_summary(s, "x/summary.json")


def test_load_summary_from_dir_or_file(tmp_path):
    (tmp_path / "summary.json").write_text(json.dumps(fake_summary()))
    assert load_summary(tmp_path) == load_summary(tmp_path / "summary.json") == fake_summary()
    (tmp_path / "summary.json").write_text('{"laws": {\n  "a": 1,\n}')
    with pytest.raises(InputError, match="invalid JSON at line 3"):
        load_summary(tmp_path)
    with pytest.raises(InputError, match="does not exist"):
        load_summary(tmp_path / "missing")
