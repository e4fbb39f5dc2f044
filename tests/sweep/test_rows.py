"""A resumed sweep re-checks every row it reads back (issue 26, item 7b): an edited row is
refused by its line number and nothing is written; what is accepted is always a table a
sweep could have written, so best.json is strict JSON."""

from __future__ import annotations

import csv
import io
import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.sweep.objective import best, parse_objective
from feedopt.sweep.point import LawOutcome, PointResult, Status
from feedopt.sweep.run import _table_row
from feedopt.sweep.table import columns, read_table

LAWS = ["constant", "jerk"]
GRID = "workpiece.position_mm=x:1700;1750;5000"  # 5000: unreachable, a refused row


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """A finished sweep (3 points, one refused): its scenario, folder and arguments."""
    import yaml

    from tests.conftest import ROOT, SCENARIOS

    tmp = tmp_path_factory.mktemp("swept")
    doc = yaml.safe_load((SCENARIOS / "triangle_slot.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"], doc["material"] = (str(SCENARIOS / doc[k]) for k in ("tool", "material"))
    doc["path"]["spacing_mm"] = 5.0
    scenario = tmp / "triangle_slot.yaml"
    scenario.write_text(yaml.safe_dump(doc))
    out = tmp / "sweep"
    args = ["sweep", str(scenario), "--grid", GRID, "--laws", ",".join(LAWS), "--workers", "0",
            "--out", str(out), "--no-progress"]
    assert main(args) == 0
    return args, out, (out / "sweep.csv").read_text()


def _axes(swept):
    from feedopt.sweep.bundle import build_bundle
    from feedopt.sweep.grid import parse_grid

    bundle, _ = build_bundle(swept[0][1])
    return parse_grid([GRID], bundle.raw, bundle.robot_doc).axes


def _edited(text: str, row: int, column: str, value: str) -> str:
    lines = list(csv.reader(io.StringIO(text)))
    lines[row - 1][lines[0].index(column)] = value
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(lines)
    return buf.getvalue()


@pytest.mark.parametrize(("row", "column", "value", "says"), [
    (2, "t_star_s", "-inf", "t_star_s is '-inf'; a sweep writes only finite numbers"),
    (3, "t_star_s", "-1.5", "t_star_s is -1.5; it is always > 0"),
    (2, "max_deflection_nominal_mm", "nan", "finite numbers"),
    (2, "jerk.cycle_time_s", "1e400", "finite numbers"),
    (2, "status", "maybe", "status is 'maybe'"),
    (4, "feasible", "yes", "feasible is yes for a refused row"),
    (4, "t_star_s", "1.0", "a refused row has a t_star_s"),
    (2, "jerk.verdict", "failed", "feasible is yes for a ok row where a law failed"),
    (2, "jerk.verdict", "great", "jerk.verdict is 'great'"),
    (3, "samples", "99.5", "samples is '99.5', not a whole number"),
    (3, "workpiece.position_mm.x", "nan", "workpiece.position_mm.x"),
    (2, "seconds", "", "seconds is empty"),
])
def test_an_edited_row_is_refused_by_number_and_nothing_is_written(swept, row, column, value,
                                                                    says, capsys):
    args, out, table = swept
    (out / "sweep.csv").write_text(_edited(table, row, column, value))
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    try:
        assert main(args) == 2
        err = capsys.readouterr().err
        assert f"sweep.csv: row {row}: " in err and says in err, err
        assert "remove that row" in err and "--restart" in err
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # untouched
    finally:
        (out / "sweep.csv").write_text(table)


def test_the_untouched_table_resumes_with_nothing_to_do(swept, capsys):
    args, out, table = swept
    assert main(args) == 0
    assert "(0 evaluated now, 3 from the earlier table)" in capsys.readouterr().out
    assert (out / "sweep.csv").read_text() == table
    json.loads((out / "best.json").read_text(), parse_constant=_no_constant)


def _no_constant(name: str):
    raise AssertionError(f"best.json holds {name}, which is not JSON")


_TEXTS = st.one_of(
    st.sampled_from(["", "-inf", "inf", "nan", "-0.0", "0", "1", "1e308", "2.5", "ok",
                     "refused", "error", "yes", "no", "exportable", "verified", "failed",
                     "declined", "1700.0", "-1"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=8),
)


@given(edits=st.lists(st.tuples(st.integers(2, 4), st.integers(0, 100), _TEXTS), max_size=3))
def test_what_is_read_back_is_refused_by_row_or_gives_strict_json(swept, edits):
    _, out, table = swept
    header = next(csv.reader(io.StringIO(table)))
    for row, col, value in edits:
        table = _edited(table, row, header[col % len(header)], value.replace("\x00", ""))
    path = out.parent / "fuzzed.csv"
    path.write_text(table)
    axes = _axes(swept)
    assert columns(axes, LAWS, []) == header
    try:
        rows = read_table(path, header, axes, LAWS, [])
    except InputError as exc:
        assert any(f"fuzzed.csv: row {r}: " in str(exc) for r, _, _ in edits), exc
        return
    for objective in ("t_star", "max_deflection", "mean_deflection", "cycle_time:jerk"):
        found = best(rows.values(), parse_objective(objective, LAWS))
        if found is not None:
            assert math.isfinite(found[1]) and found[0]["status"] == "ok"
            json.dumps({"value": found[1], "row": found[0]}, allow_nan=False)


def test_a_non_finite_result_is_written_as_an_error_row_not_as_a_result():
    from feedopt.sweep.grid import Axis

    axes = (Axis("cut.axial_depth_mm", None, None, (1.0,)),)
    result = PointResult((1.0,), Status.OK, t_star_s=math.inf, max_deflection_nominal_mm=0.1,
                         mean_deflection_nominal_mm=0.1, max_condition_number=3.0,
                         min_bound_mm_s=1.0, samples=10,
                         laws={"jerk": LawOutcome("exportable", 2.0, 0.1)}, seconds=0.1)
    row = _table_row(result, axes, ["jerk"], [])
    assert (row["status"], row["feasible"], row["t_star_s"]) == ("error", "no", "")
    assert "t_star_s is 'inf'" in row["reason"]
    good = _table_row(PointResult(**{**result.__dict__, "t_star_s": 2.0}), axes, ["jerk"], [])
    assert (good["status"], good["feasible"], good["t_star_s"]) == ("ok", "yes", "2.0")
