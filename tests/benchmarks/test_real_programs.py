"""benchmarks/real_programs.py (issue 27): folding of refusals, the scenario made from the
template, the table, the time limit; and the imitation programs of tests/data/gcode/posts."""

from __future__ import annotations

import json
import os
import re
import signal
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from tests.conftest import load_benchmark

ROOT = Path(__file__).resolve().parents[2]
POSTS = ROOT / "tests" / "data" / "gcode" / "posts"
TEMPLATE = ROOT / "benchmarks" / "real_programs_scenario.yaml"


rp = load_benchmark("real_programs")


def test_cause_folds_specifics_but_keeps_codes():
    a = ("feedopt path: error: /tmp/a/x.nc line 12 (N40): G64: G code not supported by the "
         "reader")
    b = "feedopt run: error: /other/y.ngc line 7: G64: G code not supported by the reader"
    c = "feedopt run: error: /other/y.ngc line 7: G61: G code not supported by the reader"
    assert rp.cause(a) == "PROGRAM: line # (N#): G64: G code not supported by the reader"
    assert rp.cause(b) == "PROGRAM: line #: G64: G code not supported by the reader"
    assert rp.cause(b) != rp.cause(c)
    # file names anywhere and quoted words fold too
    d = ("feedopt run: error: tool comment: the tool file /tmp/s/t.yaml describes 19.05 mm, "
         "'T1 D=6.' says 6 mm")
    assert rp.cause(d) == "tool comment: the tool file FILE describes # mm, '…' says # mm"
    assert rp.cause("feedopt run: internal error: KeyError: 'x'") == "KeyError: '…'"


def test_first_error_skips_warnings():
    err = ("warning: the robot's accelerations are a placeholder\n"
           "feedopt run: error: x.nc line 3: G4: dwell (G4) is not supported\n")
    assert rp.first_error(err, "").startswith("feedopt run: error: x.nc line 3")
    assert rp.first_error("", "[1/5] geometry\nsomething\n") == "something"
    assert rp.first_error("only a warning\n", "") == "only a warning"
    verdict = ("[5/5] convex: 162.74 s cycle, FAILED VERIFICATION\n"
               "feedopt run: 2 law(s) FAILED their own verification and were not exported\n")
    assert rp.first_error(verdict, "").startswith("feedopt run: 2 law(s) FAILED")


def test_template_files_resolve_and_program_scenario(tmp_path):
    template = rp.load_template(TEMPLATE)
    for field in (template["robot"]["directory"], template["tool"], template["material"]):
        assert Path(field).is_absolute() and Path(field).exists(), field
    program = tmp_path / "odd name (1).nc"
    program.write_text("G0 X0 Y0 Z5\n")
    with_stock = rp.scenario_for(template, program, program_stock=True)
    assert with_stock["name"] == "odd_name__1_"
    assert with_stock["path"]["file"] == str(program.resolve())
    assert with_stock["stock"] == {"from_program": True, "cell_mm": 0.25}
    without = rp.scenario_for(template, program, program_stock=False)
    assert "stock" not in without
    assert without["cut"] == {"extrapolate_coefficients": True, **rp.FALLBACK_CUT}
    # the template itself is not changed by either
    assert template["stock"]["from_program"] is True and "type" not in template["cut"]
    assert template["path"]["file"].endswith("pocket.nc")
    tool = rp.load_template(TEMPLATE, POSTS / "tool_6mm_2flute.yaml")["tool"]
    assert tool == str((POSTS / "tool_6mm_2flute.yaml").resolve())


def test_run_summary_lines(tmp_path):
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({
        "laws": {"convex": {"cycle_time_s": 159.71, "verified": True, "exported": True},
                 "programmed": {"cycle_time_s": 121.24, "verified": False,
                                "problems": ["joint 3 acceleration over its limit", "other"]}},
        "declined_laws": {"thesis": "too many stretches"}}))
    assert rp.run_summary(summary) == (
        "convex 159.7 s verified, exported; programmed 121.2 s NOT verified (joint 3 "
        "acceleration over its limit); declined: thesis")
    assert rp.run_summary(tmp_path / "none.json").startswith("no readable summary.json")


def test_run_exit_1_with_outputs_is_nothing_exported(tmp_path, monkeypatch):
    program = tmp_path / "part.nc"
    program.write_text("G0 X0 Y0 Z5\n")

    def fake_execute(cmd, timeout_s):
        out = Path(cmd[cmd.index("--out") + 1])
        out.mkdir()
        (out / "summary.json").write_text(json.dumps({"laws": {"convex": {
            "cycle_time_s": 2.0, "verified": False, "problems": ["jerk 2 x its limit"]}}}))
        return 1, 0.5, "", "feedopt run: 1 law(s) FAILED their own verification\n"

    monkeypatch.setattr(rp, "_execute", fake_execute)
    o = rp.run_run(program, rp.load_template(TEMPLATE), False, "convex", 5.0)
    assert o.message == "nothing exported: convex 2.0 s NOT verified (jerk 2 x its limit)"
    line = rp.outcome_counts([o, rp.Outcome(1, 1.0, "feedopt run: internal error: X")], "run")
    assert "none was exported (exit 1): 1; internal error (exit 1): 1;" in line


def test_run_run_writes_the_scenario_and_cleans_up(tmp_path, monkeypatch):
    program = tmp_path / "part.nc"
    program.write_text("G0 X0 Y0 Z5\n")
    seen = {}

    def fake_execute(cmd, timeout_s):
        scen = Path(cmd[cmd.index("run") + 1])
        out = Path(cmd[cmd.index("--out") + 1])
        seen.update(scenario=yaml.safe_load(scen.read_text()), cmd=cmd, folder=scen.parent)
        assert not out.exists() and out.parent != scen.parent  # never the scenario's folder
        out.mkdir()
        (out / "summary.json").write_text(json.dumps(
            {"laws": {"convex": {"cycle_time_s": 2.0, "verified": True}}}))
        return 0, 0.5, "", ""

    monkeypatch.setattr(rp, "_execute", fake_execute)
    o = rp.run_run(program, rp.load_template(TEMPLATE), False, "convex", 5.0)
    assert o == rp.Outcome(0, 0.5, "convex 2.0 s verified")
    assert seen["scenario"]["path"]["file"] == str(program.resolve())
    assert seen["cmd"][-3:] == ["--no-report", "--laws", "convex"]
    assert not seen["folder"].exists()  # the temporary folder is gone


def test_execute_kills_at_the_time_limit():
    t0 = time.perf_counter()
    code, wall, _, _ = rp._execute([sys.executable, "-c", "import time; time.sleep(60)"], 0.5)
    assert code is None and wall < 15 and time.perf_counter() - t0 < 15


def test_interrupt_stops_the_children(tmp_path, monkeypatch, capsys):
    """SIGTERM (or Ctrl-C) to the benchmark stops the feedopt commands it started (they run in
    their own sessions, so the terminal's signal does not reach them) and writes no table."""
    (tmp_path / "a.nc").write_text("G0 X0\n")
    started = []

    def slow_path(program, timeout_s):
        threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGTERM)).start()
        t0 = time.perf_counter()
        code, *_ = rp._execute([sys.executable, "-c", "import time; time.sleep(60)"], 60)
        started.append((code, time.perf_counter() - t0))
        return rp.Outcome(code, 0.0, "")

    monkeypatch.setattr(rp, "run_path", slow_path)
    out = tmp_path / "t.md"
    try:
        assert rp.main([str(tmp_path), "--out", str(out)]) == 130
        deadline = time.perf_counter() + 15
        while not started and time.perf_counter() < deadline:
            time.sleep(0.05)
    finally:
        rp._STOPPING.clear()
    assert started and started[0][0] is not None and started[0][1] < 15  # killed, not 60 s
    assert not out.exists() and "interrupted" in capsys.readouterr().err
    assert not rp._LIVE


def _row(name, source, path_code, run_code, msg="feedopt run: error: x.nc line 1: G4: dwell"):
    path = rp.Outcome(path_code, 1.0, msg if path_code else "program: 3 moves")
    run = rp.Outcome(run_code, 2.0, msg if run_code not in (0, 3) else "convex 1.0 s verified")
    return rp.Row(Path("/c") / source / name, source, 10, path, run)


def test_table_counts_by_outcome_source_and_cause():
    rows = [_row("a.nc", "fusion", 0, 0), _row("b.nc", "fusion", 2, 2),
            _row("c.nc", "haas", 2, None), _row("d.nc", "haas", 1, 3)]
    text = rp.table(rows, Path("/c"))
    assert "| fusion/a.nc | fusion | 10 | 0 | 1.0 |" in text
    assert "| haas/c.nc | haas | 10 | 2 | 1.0 |" in text and "| - | 2.0 |" in text
    assert "path: read: 1 of 4; refused (exit 2): 2; internal error (exit 1): 1" in text
    assert ("run: planned and exported (exit 0): 1 of 4; refused (exit 2): 1; planned, some "
            "laws broke their promises (exit 3): 1; planned, a law broke its promises and none "
            "was exported (exit 1): 0; internal error (exit 1): 0; timed out: 1") in text
    assert "| fusion | 2 | 1 | 1 | 0 | 1 | 0 | 1 | 0 |" in text
    assert "| haas | 2 | 0 | 1 | 1 | 1 | 0 | 0 | 1 |" in text
    path_part, run_part = text.split("| run: failures | cause |")
    assert "| 3 | PROGRAM: line #: G4: dwell |" in path_part  # b, c, d folded to one row
    assert "| 2 | PROGRAM: line #: G4: dwell |" in run_part  # b and c; d (exit 3) planned


def test_path_mode_end_to_end(tmp_path):
    folder = tmp_path / "corpus" / "mine"
    folder.mkdir(parents=True)
    src = POSTS / "fusion_mm_pocket.nc"
    (folder / src.name).write_text(src.read_text())
    (folder / "notes.txt").write_text("not a program")
    out = tmp_path / "table.md"
    assert rp.main([str(tmp_path / "corpus"), "--out", str(out), "--timeout", "60"]) == 0
    text = out.read_text()
    n_lines = len(src.read_text().splitlines())
    row = [ln for ln in text.splitlines() if ln.startswith("| mine/fusion_mm_pocket.nc |")]
    assert len(row) == 1 and f"| mine | {n_lines} |" in row[0]
    assert "notes.txt" not in text and "run exit" not in text
    assert re.search(r"path: read: [01] of 1;", text)


def test_no_programs_is_exit_2(tmp_path, capsys):
    assert rp.main([str(tmp_path)]) == 2
    assert "no G-code programs" in capsys.readouterr().err


# -- the imitation programs (tests/data/gcode/posts) ---------------------------------------

PROGRAMS = sorted(p for p in POSTS.iterdir() if p.suffix in rp.SUFFIXES)


def _words(text: str) -> list[tuple[str, float]]:
    """(letter, value) of every word outside comments."""
    text = re.sub(r"\([^)]*\)|;.*", " ", text)
    return [(m[1].upper(), float(m[2]))
            for m in re.finditer(r"([A-Za-z])\s*([-+]?\d*\.?\d+)", text)]


def test_there_are_six_to_ten_imitations_each_in_the_readme():
    readme = (POSTS / "README.md").read_text()
    assert 6 <= len(PROGRAMS) <= 10
    for p in PROGRAMS:
        n = len(p.read_text().splitlines())
        assert 20 <= n <= 80, (p.name, n)
        assert f"`{p.name}` | {n} |" in readme, p.name


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.name)
def test_imitation_is_a_plausible_6mm_job(program):
    text = program.read_text()
    words = _words(text)
    scale = 25.4 if any(w == ("G", 20.0) for w in words) else 1.0
    feeds = [v * scale for k, v in words if k == "F"]
    speeds = [v for k, v in words if k == "S"]
    depths = [v * scale for k, v in words if k == "Z"]
    assert feeds and all(300 - 1 <= f <= 1200 + 1 for f in feeds), feeds
    assert speeds and all(10000 <= s <= 18000 for s in speeds), speeds
    assert -2.0 - 1e-3 <= min(depths) <= -1.0 + 1e-3, min(depths)
    assert {v for k, v in words if k == "T"} <= {1.0}  # one tool (bCNC names none)


def test_template_is_a_valid_scenario(capsys):
    from feedopt.cli import main

    assert main(["validate", str(TEMPLATE)]) == 0
    assert "real_program" in capsys.readouterr().out
