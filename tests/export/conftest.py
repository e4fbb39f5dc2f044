"""Fixtures shared by the export tests."""

from __future__ import annotations

import pytest
import yaml

from feedopt.runner import run_scenario
from tests.conftest import ROOT


@pytest.fixture(scope="package")
def thesis_triangle_run(tmp_path_factory):
    """The default triangle slot at 1 mm, thesis law only, exported (no report): one run for
    the KRL and frames tests."""
    tmp = tmp_path_factory.mktemp("tri")
    doc = yaml.safe_load((ROOT / "scenarios" / "triangle_slot.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(ROOT / "scenarios" / doc["tool"])
    doc["material"] = str(ROOT / "scenarios" / doc["material"])
    doc["path"]["spacing_mm"] = 1.0
    doc["schedule"]["laws"] = ["thesis"]
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    return run_scenario(p, out_dir=tmp / "out", progress=lambda _m: None, report=False)
