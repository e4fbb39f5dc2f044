"""The output stage (feedopt/outputs.py): laws exported in forked children side by side on
a long path write the same files as one after another, and a law whose export fails in its
child fails the run and leaves nothing behind."""

import json
from pathlib import Path

import pytest
import yaml

from feedopt import outputs
from feedopt.errors import InputError
from feedopt.export.job import EXPORTERS, Exporter, register_exporter
from feedopt.runner import run_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"


@pytest.fixture
def job(tmp_path) -> Path:
    """The chapter-4 cut, two exported laws (convex is slow to import; jerk and thesis)."""
    doc = yaml.safe_load((SCENARIOS / "linear_peripheral.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(SCENARIOS / doc["tool"])
    doc["material"] = str(SCENARIOS / doc["material"])
    doc["path"]["spacing_mm"] = 1.0
    doc["schedule"]["laws"] = ["thesis", "jerk"]
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.name != "summary.json"}


def _untimed(entry):
    """``entry`` without its wall times (they differ from run to run), at every depth."""
    if not isinstance(entry, dict):
        return entry
    return {k: _untimed(v) for k, v in entry.items()
            if k in ("cycle_time_s", "lower_bound_s") or not k.endswith("_s") or "time" not in k}


def _laws(folder: Path) -> dict:
    return _untimed(json.loads((folder / "summary.json").read_text())["laws"])


def test_laws_exported_in_children_write_what_one_process_writes(job, tmp_path, monkeypatch):
    quiet = dict(progress=lambda _m: None, report=False)
    run_scenario(job, tmp_path / "serial", **quiet)
    monkeypatch.setattr(outputs, "PARALLEL_EXPORT_MIN_SAMPLES", 0)
    monkeypatch.setattr(outputs, "worker_threads", lambda: 2)  # a core per law
    calls = []
    monkeypatch.setattr(outputs.background, "start",
                        lambda f, what, real=outputs.background.start: calls.append(what)
                        or real(f, what))
    run_scenario(job, tmp_path / "forked", **quiet)
    assert calls == ["exporting thesis", "exporting jerk"]
    serial, forked = _files(tmp_path / "serial"), _files(tmp_path / "forked")
    assert {n for n in serial if n.startswith(("thesis.", "jerk."))} >= {"jerk.csv", "jerk.nc"}
    assert forked == serial
    assert _laws(tmp_path / "forked") == _laws(tmp_path / "serial")


def _refuse_jerk(job, out_dir):
    if job.law == "jerk":
        raise InputError("toy exporter: jerk refused")
    (out_dir / f"{job.law}.toy").write_text("ok")
    return {"toy_program": f"{job.law}.toy"}


def test_an_export_failing_in_its_child_fails_the_run_and_leaves_nothing(job, tmp_path,
                                                                          monkeypatch):
    monkeypatch.setattr(outputs, "PARALLEL_EXPORT_MIN_SAMPLES", 0)
    monkeypatch.setattr(outputs, "worker_threads", lambda: 2)
    register_exporter(Exporter(name="toy", file_pattern="{law}.toy", export=_refuse_jerk,
                               description="refuses the jerk law"))
    try:
        with pytest.raises(InputError, match="jerk refused"):
            run_scenario(job, tmp_path / "out", progress=lambda _m: None, report=False)
    finally:
        del EXPORTERS["toy"]
    assert not (tmp_path / "out").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["job.yaml"]


def test_with_a_report_on_two_cores_the_laws_are_exported_here(job, tmp_path, monkeypatch):
    """The report's child takes a core: a child per law would be a third process on two."""
    monkeypatch.setattr(outputs, "PARALLEL_EXPORT_MIN_SAMPLES", 0)
    monkeypatch.setattr(outputs, "worker_threads", lambda: 2)
    calls = []
    monkeypatch.setattr(outputs.background, "start",
                        lambda f, what, real=outputs.background.start: calls.append(what)
                        or real(f, what))
    run_scenario(job, tmp_path / "out", progress=lambda _m: None, report=True)
    assert not [c for c in calls if c.startswith("exporting")]
    assert (tmp_path / "out" / "jerk.csv").is_file()
