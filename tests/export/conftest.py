"""Fixtures shared by the export tests."""

from __future__ import annotations

import pytest
import yaml

from feedopt.runner import run_scenario
from tests.conftest import ROOT


def run_triangle_at_1mm(tmp, laws: list[str]):
    """The default triangle slot at 1 mm with ``laws``, exported into ``tmp / "out"`` (no
    report); the scenario's files by absolute path."""
    doc = yaml.safe_load((ROOT / "scenarios" / "triangle_slot.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(ROOT / "scenarios" / doc["tool"])
    doc["material"] = str(ROOT / "scenarios" / doc["material"])
    doc["path"]["spacing_mm"] = 1.0
    doc["schedule"]["laws"] = list(laws)
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    return run_scenario(p, out_dir=tmp / "out", progress=lambda _m: None, report=False)


@pytest.fixture(scope="package")
def thesis_triangle_run(tmp_path_factory):
    """The default triangle slot at 1 mm, thesis law only, exported (no report): one run for
    the KRL and frames tests."""
    return run_triangle_at_1mm(tmp_path_factory.mktemp("tri"), ["thesis"])
