"""`feedopt run` never destroys a user's files and leaves nothing behind when stopped
(issue 19): end to end through the CLI, with real signals."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from feedopt.cli import main

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"


@pytest.fixture
def job(tmp_path) -> Path:
    """A quick copy of the chapter-4 cut in its own folder, with a user file beside it."""
    doc = yaml.safe_load((SCENARIOS / "linear_peripheral.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(SCENARIOS / doc["tool"])
    doc["material"] = str(SCENARIOS / doc["material"])
    doc["path"]["spacing_mm"] = 2.0
    doc["schedule"]["laws"] = ["constant", "jerk"]
    folder = tmp_path / "job"
    folder.mkdir()
    (folder / "job.yaml").write_text(yaml.safe_dump(doc))
    (folder / "notes.txt").write_text("my notes")
    return folder / "job.yaml"


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_folder_with_user_file_survives_run(job, capsys) -> None:
    mine = job.parent / "results"
    mine.mkdir()
    (mine / "keep.txt").write_text("precious")
    assert main(["run", str(job), "--out", str(mine), "--no-report"]) == 2
    assert "keep.txt" in capsys.readouterr().err
    assert _listing(mine) == ["keep.txt"]
    assert main(["run", str(job), "--out", str(mine), "--no-report", "--overwrite"]) == 0
    assert (mine / "keep.txt").read_text() == "precious"
    assert (mine / "summary.json").is_file()


def test_rerun_replaces_its_own_output(job) -> None:
    out = job.parent / "out" / "run"
    assert main(["run", str(job), "--out", str(out), "--no-report"]) == 0
    first = _listing(out)
    assert main(["run", str(job), "--out", str(out), "--no-report"]) == 0
    assert _listing(out) == first
    assert _listing(out.parent) == ["run", *[f"run/{n}" for n in first]]


@pytest.mark.parametrize("where", [".", "scenario folder", "parent of the scenario folder"])
def test_out_at_or_above_cwd_or_scenario_folder_is_refused(job, monkeypatch, capsys,
                                                           where) -> None:
    monkeypatch.chdir(job.parent)
    out = {".": ".", "scenario folder": str(job.parent),
           "parent of the scenario folder": str(job.parent.parent)}[where]
    before = _listing(job.parent.parent)
    assert main(["run", str(job), "--out", out, "--overwrite"]) == 2
    assert "holds your files" in capsys.readouterr().err
    assert _listing(job.parent.parent) == before


def test_out_that_is_a_file_is_refused_before_planning(job, capsys) -> None:
    target = job.parent / "notes.txt"
    assert main(["run", str(job), "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert "existing file" in err and "[1/5]" not in err
    assert target.read_text() == "my notes"


def _run_and_signal(job: Path, out: Path, sig: int, after: str) -> tuple[int, str]:
    """Start `feedopt run`, send ``sig`` once a stderr line starts with ``after``."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "feedopt.cli", "run", str(job), "--out", str(out)],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, cwd=job.parent,
    )
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if line.startswith(after):
            os.kill(proc.pid, sig)
            break
    rest = proc.stderr.read()
    code = proc.wait(timeout=120)
    return code, "".join(seen) + rest


@pytest.mark.parametrize(("sig", "after"), [
    (signal.SIGTERM, "[1/5]"),
    (signal.SIGHUP, "[3/5]"),
    (signal.SIGINT, "[4/5]"),
    (signal.SIGTERM, "[5/5] jerk"),  # the last law: the outputs are being written now
])
def test_signal_at_any_stage_leaves_no_staging_folder(job, sig, after) -> None:
    out = job.parent / "out" / "run"
    code, err = _run_and_signal(job, out, sig, after)
    if code == 0:  # the run finished before the signal landed: a complete output, nothing else
        assert (out / "summary.json").is_file()
        assert _listing(out.parent)[0] == "run"
    else:
        assert code == 128 + sig, err
        assert "nothing was written" in err, err
        assert not out.parent.exists() or _listing(out.parent) == [], _listing(out.parent)
    assert _listing(job.parent) == sorted(
        ["job.yaml", "notes.txt"] + (["out", *[f"out/{p}" for p in _listing(out.parent)]]
                                     if out.parent.exists() else []))


def test_sigkilled_run_staging_is_removed_by_the_next_run(job) -> None:
    out = job.parent / "out" / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "feedopt.cli", "run", str(job), "--out", str(out)],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    for line in proc.stderr:
        if line.startswith("[2/5]"):
            proc.kill()
            break
    proc.wait(timeout=60)
    time.sleep(0.1)
    assert any(p.name.startswith(".run.feedopt-") for p in out.parent.iterdir())
    assert main(["run", str(job), "--out", str(out), "--no-report"]) == 0
    assert [p.name for p in out.parent.iterdir()] == ["run"]
