"""``feedopt run --profile`` (feedopt.profiling.RunProfile) and the progress bars of long stages."""

from __future__ import annotations

import io
import time
from pathlib import Path

import pytest

from feedopt import profiling, runner
from feedopt.cli import main
from feedopt.profiling import RunProfile, StageTiming
from feedopt.runner import run_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


def test_profile_has_every_stage_and_law_and_adds_up(tmp_path):
    t0 = time.perf_counter()
    result = run_scenario(SCENARIOS / "triangle_slot.yaml", out_dir=tmp_path / "out",
                          laws=["constant", "jerk"], spacing_mm=2.0, progress=lambda _m: None)
    wall = time.perf_counter() - t0
    prof = result.profile
    assert isinstance(prof, RunProfile) and prof.samples == result.prepared.problem.n
    keys = [(r.stage, r.law) for r in prof.rows]
    assert keys == [("geometry", ""), ("process", ""), ("robot", ""), ("bounds", ""),
                    ("plan", "constant"), ("verify", "constant"), ("export", "constant"),
                    ("plan", "jerk"), ("verify", "jerk"), ("export", "jerk"),
                    ("part", ""), ("report", ""), ("other", "")]
    assert all(r.seconds >= 0 for r in prof.rows)
    # the rows (with "other") add up to the run's wall time, measured here from outside
    assert sum(r.seconds for r in prof.rows) == pytest.approx(prof.total_s, rel=1e-9)
    assert prof.total_s <= wall
    assert prof.rows[2].seconds == result.prepared.stage_times["robot"]
    assert prof.rows[4].seconds == result.laws["constant"].planning_time
    assert prof.peak_memory_bytes > 50 * 2**20  # numpy, scipy, pinocchio, matplotlib


def test_profile_table_lists_rows_shares_and_total():
    prof = RunProfile(rows=(StageTiming("robot", 1.0), StageTiming("plan", 3.0, "jerk")),
                      total_s=4.0, peak_memory_bytes=3 * 2**30, samples=1000)
    lines = prof.table().splitlines()
    assert [c.strip() for c in lines[0].split("|")[1:-1]] == ["stage", "law", "time [s]",
                                                               "share"]
    assert any("robot" in ln and "1.000" in ln and "25.0%" in ln for ln in lines)
    assert any("plan" in ln and "jerk" in ln and "75.0%" in ln for ln in lines)
    assert any("total" in ln and "4.000" in ln for ln in lines)
    assert lines[-1] == "1000 path samples; peak memory 3072 MiB"
    with_child = RunProfile(rows=prof.rows, total_s=4.0, peak_memory_bytes=3 * 2**30,
                            samples=1000, child_peak_memory_bytes=200 * 2**20)
    assert with_child.table().splitlines()[-1] == ("1000 path samples; peak memory 3072 MiB "
                                                   "(largest child process 200 MiB)")


def test_cli_profile_prints_the_table(tmp_path, capsys):
    code = main(["run", str(SCENARIOS / "triangle_slot.yaml"), "--out", str(tmp_path / "o"),
                 "--laws", "jerk", "--spacing-mm", "2", "--no-report", "--profile"])
    out = capsys.readouterr().out
    assert code == 0
    assert "profile (wall time per stage and law)" in out
    assert "| export   | jerk" in out and "peak memory" in out
    code = main(["run", str(SCENARIOS / "triangle_slot.yaml"), "--out", str(tmp_path / "p"),
                 "--laws", "jerk", "--spacing-mm", "2", "--no-report"])
    assert "wall time per stage" not in capsys.readouterr().out


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_for_the_console_on_a_terminal(monkeypatch):
    monkeypatch.setattr(profiling, "_BAR_DELAY_S", 0.0)
    tty = _Tty()
    monkeypatch.setattr(profiling.sys, "stderr", tty)
    with profiling.progress_bar(runner._stderr_progress, "[3/5] robot IK") as update:
        assert update is not None
        update(50, 200)
        update(200, 200)
    assert "[3/5] robot IK" in tty.getvalue() and "/200 [" in tty.getvalue()
    with profiling.progress_bar(lambda _m: None, "x") as update:  # a caller's own progress
        assert update is None
    monkeypatch.setattr(profiling.sys, "stderr", io.StringIO())  # redirected: no terminal
    with profiling.progress_bar(runner._stderr_progress, "x") as update:
        assert update is None


def test_planning_and_export_show_bars_over_the_laws(monkeypatch, tmp_path):
    """The two stages without a per-sample loop (each law is one call) count laws."""
    monkeypatch.setattr(profiling, "_BAR_DELAY_S", 0.0)
    tty = _Tty()
    monkeypatch.setattr(profiling.sys, "stderr", tty)
    runner.run_scenario(SCENARIOS / "triangle_slot.yaml", out_dir=tmp_path / "o",
                        laws=["constant", "jerk"], spacing_mm=2.0, report=False)
    text = tty.getvalue()
    assert "[5/5] planning:" in text and "/2 [" in text and " laws/s" in text
    assert "[5/5] export:" in text and "/1 [" in text  # jerk only: constant is not exported
