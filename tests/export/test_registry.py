"""The exporter registry: built-ins, early blockers, and a toy exporter registered here
writes for every exported law of a run."""

import json

import pytest

from feedopt.export.job import EXPORTERS, Exporter, register_exporter
from feedopt.runner import run_scenario

quiet = lambda _m: None  # noqa: E731


def test_builtin_exporters() -> None:
    assert list(EXPORTERS)[:2] == ["rsi", "krl"]
    with pytest.raises(ValueError, match="already registered"):
        register_exporter(EXPORTERS["rsi"])


def _write_toy(job, out_dir):
    name = f"{job.law}.toy.json"
    (out_dir / name).write_text(json.dumps({
        "law": job.law, "duration_s": job.trajectory.duration,
        "rows": int(job.samples.motion.t.size), "cycle_s": job.cycle}))
    return {"toy_file": name}


@pytest.fixture
def toy_exporter():
    register_exporter(Exporter(name="toy", file_pattern="{law}.toy.json", export=_write_toy,
                               description="test exporter",
                               for_law=lambda job: job.law != "convex"))
    yield
    del EXPORTERS["toy"]


def test_toy_exporter_writes_for_exported_laws(toy_exporter, quick_scenario, tmp_path) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["constant", "jerk", "convex"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
    out = tmp_path / "out"
    doc = json.loads((out / "jerk.toy.json").read_text())
    assert doc["duration_s"] == pytest.approx(result.laws["jerk"].trajectory.duration)
    assert doc["rows"] == len((out / "jerk.csv").read_text().splitlines()) - sum(
        1 for line in (out / "jerk.csv").read_text().splitlines() if line.startswith("#")) - 1
    assert result.summary["laws"]["jerk"]["toy_file"] == "jerk.toy.json"
    assert not (out / "convex.toy.json").exists()  # for_law excludes it
    assert not (out / "constant.toy.json").exists()  # not exported (over the limit)
    marker = json.loads((out / ".feedopt-output.json").read_text())
    assert "jerk.toy.json" in marker["files"]


def test_early_blocker_costs_only_its_own_export(quick_scenario, tmp_path) -> None:
    register_exporter(Exporter(name="never", file_pattern="{law}.never", description="x",
                               export=lambda job, d: {},
                               early_check=lambda robot, path: "never: this cell has none"))
    try:
        messages = []
        p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["jerk"])
        result = run_scenario(p, out_dir=tmp_path / "out", progress=messages.append,
                              report=False)
        assert "warning: never: this cell has none" in messages
        assert result.summary["laws"]["jerk"]["never_not_written"] == "never: this cell has none"
        assert (tmp_path / "out" / "jerk.csv").is_file()
    finally:
        del EXPORTERS["never"]
