"""``feedopt compare`` on fake run directories."""

from __future__ import annotations

import json

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
