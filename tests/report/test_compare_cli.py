"""``feedopt compare`` on fake run directories."""

from __future__ import annotations

import json
import os
import time

import pytest

from feedopt.cli import main

from .conftest import fake_summary


def _run_dir(root, name, scale=1.0):
    d = root / name
    d.mkdir()
    (d / "summary.json").write_text(json.dumps(fake_summary(name, scale)))
    return d


def test_compare_two_runs(tmp_path, capsys):
    a = _run_dir(tmp_path, "triangle_slot")
    b = _run_dir(tmp_path, "triangle_slot_far", scale=1.5)
    assert main(["compare", str(a), str(b / "summary.json")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("| run ") and "T/T(baseline)" in out[0]
    rows = [ln for ln in out[2:]]
    assert len(rows) == 6
    assert rows[0].startswith("| triangle_slot ") and rows[3].startswith("| triangle_slot_far")
    assert "187.5" in rows[4]  # thesis 125 s * 1.5


def test_compare_missing_summary_exits_2_with_nothing_on_stdout(tmp_path, capsys):
    a = _run_dir(tmp_path, "ok")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["compare", str(a), str(empty)]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert "empty/summary.json does not exist" in cap.err and "feedopt run" in cap.err


def test_compare_invalid_summary_exits_2(tmp_path, capsys):
    d = tmp_path / "bad"
    d.mkdir()
    (d / "summary.json").write_text(json.dumps({"laws": {"thesis": {"cycle_time_s": 1}}}))
    assert main(["compare", str(d)]) == 2
    assert "laws.thesis lacks lower_bound_s" in capsys.readouterr().err


def test_same_named_dirs_are_told_apart(tmp_path, capsys):
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    a = _run_dir(tmp_path / "x", "run")
    b = _run_dir(tmp_path / "y", "run")
    assert main(["compare", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert str(a) in out and str(b) in out


# ------------------------------------------------------------------ hostile summaries (issue 26)

def _edited(root, name, edit):
    """A run directory whose summary.json is the fake one with ``edit`` applied to its text."""
    d = root / name
    d.mkdir()
    (d / "summary.json").write_text(edit(json.dumps(fake_summary(name))))
    return d


def _law_value(value_text):
    """Replace the thesis law's cycle time (125.0) by ``value_text`` as written in the JSON."""
    return lambda text: text.replace('"cycle_time_s": 125.0', f'"cycle_time_s": {value_text}')


@pytest.mark.parametrize(("value", "message"), [
    ("NaN", "laws.thesis.cycle_time_s = nan: a run writes a finite number"),
    ("Infinity", "laws.thesis.cycle_time_s = inf: a run writes a finite number"),
    ("-Infinity", "laws.thesis.cycle_time_s = -inf: a run writes a finite number"),
    ("1e308", "laws.thesis.cycle_time_s = 1e+308: a run writes a finite number of at most 1e+15"),
    ("1" + "0" * 400, "laws.thesis.cycle_time_s = 1000"),
    ("-5", "laws.thesis.cycle_time_s = -5: a run writes a number > 0 here (or null)"),
    ("0", "laws.thesis.cycle_time_s = 0: a run writes a number > 0"),
    ("9" * 5000, "holds an integer of more than 4300 digits"),
    ('"125"', "laws.thesis.cycle_time_s must be a number or null, got '125'"),
])
def test_impossible_numbers_are_refused_naming_file_and_field(tmp_path, capsys, value, message):
    d = _edited(tmp_path, "run", _law_value(value))
    assert main(["compare", str(tmp_path / "run")]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert f"{d / 'summary.json'}: " in cap.err and message in cap.err, cap.err


@pytest.mark.parametrize(("edit", "message"), [
    (lambda t: t.replace('"max_deflection_mm": 0.29,', '"max_deflection_mm": -0.29,'),
     "laws.thesis.max_deflection_mm = -0.29: a run writes a number >= 0"),
    (lambda t: t.replace('"deflection_ratio": 0.9997', '"deflection_ratio": NaN'),
     "laws.topp.deflection_ratio = nan"),
    (lambda t: t.replace('"length_mm": 0.16', '"length_mm": -1'),
     "laws.thesis.start_ramp.length_mm = -1"),
    (lambda t: t.replace('"ends_by": "flat"', '"ends_by": 3'),
     "laws.thesis.start_ramp.ends_by must be one of flat, bound, path or null, got 3"),
    (lambda t: t.replace('"deflection_limit_mm": 0.29', '"deflection_limit_mm": -1'),
     "scenario.deflection_limit_mm = -1: a run writes a number > 0"),
    (lambda t: t.replace('"name": "run"', '"name": [1]'), "scenario.name must be a string"),
    (lambda t: t.replace('"thesis":', '"the\\nsis |":'), "is not a timing law name"),
    (lambda t: t.replace('"c2": true', '"c2": "yes"', 1), "laws.constant.c2 must be true, false"),
    (lambda t: t.replace('{"scenario"', '{"laws": {}, "scenario"'),
     "invalid JSON: the key 'laws' is given twice in one object"),
    (lambda t: t.replace('"topp": {', '"topp": ' + "[" * 100_000 + "]" * 100_000 + ', "x": {'),
     "the JSON is nested too deeply to be a run summary"),
])
def test_edited_summaries_are_refused_naming_the_field(tmp_path, capsys, edit, message):
    _edited(tmp_path, "run", edit)
    assert main(["compare", str(tmp_path / "run")]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and message in cap.err, cap.err


def test_an_oversized_summary_is_refused_before_parsing(tmp_path, capsys):
    d = tmp_path / "run"
    d.mkdir()
    with open(d / "summary.json", "wb") as fh:  # sparse: 1 GB of nothing on no disk
        fh.write(b'{"laws": ')
        fh.truncate(10**9)
    t0 = time.perf_counter()
    assert main(["compare", str(d)]) == 2
    assert time.perf_counter() - t0 < 2.0
    err = capsys.readouterr().err
    assert (f"run summary {d / 'summary.json'} is 953.7 MiB (1,000,000,000 bytes), more than the "
            "16.0 MiB") in err


@pytest.mark.parametrize("kind", ["fifo", "loop", "device"])
def test_a_summary_that_is_not_a_file_gets_its_own_message(tmp_path, capsys, kind):
    d = tmp_path / "run"
    d.mkdir()
    target = d / "summary.json"
    if kind == "fifo":
        os.mkfifo(target)  # opened for reading, it would block the command forever
    elif kind == "loop":
        target.symlink_to(d / "other.json")
        (d / "other.json").symlink_to(target)
    else:
        target.symlink_to("/dev/zero")
    assert main(["compare", str(d)]) == 2
    err = capsys.readouterr().err
    assert {"fifo": "named pipe (FIFO)", "loop": "symbolic link loop",
            "device": "character device"}[kind] in err


def test_a_real_shaped_summary_with_nulls_still_compares(tmp_path, capsys):
    """null stays allowed where a run writes it (no lower bound, no jerk of a C1 law)."""
    def edit(text):
        return text.replace('"max_jerk_mm_s3": 80.0', '"max_jerk_mm_s3": null')
    _edited(tmp_path, "run", edit)
    assert main(["compare", str(tmp_path / "run")]) == 0
    lines = capsys.readouterr().out.splitlines()
    cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines]
    jerk = cells[0].index("max jerk [mm/s^3]")
    assert [row[jerk] for row in cells[2:]] == ["-", "-", "-"]
