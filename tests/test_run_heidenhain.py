"""A five-axis HEIDENHAIN Klartext program end to end (issue 35): a short tilted ball-nose
saddle (benchmarks/five_axis_paths.py) as an APT CL file and the same points written as LN
blocks (tests/gcode/test_heidenhain.apt_as_klartext) plan to the same path and the same times
on the KR500-3, verified and exported."""

from __future__ import annotations

import subprocess
import sys

import pytest

from feedopt.runner import run_scenario
from tests.conftest import ROOT
from tests.gcode.test_heidenhain import apt_as_klartext

quiet = lambda _m: None  # noqa: E731


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("klartext")
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / "five_axis_paths.py"), "--kind",
                    "ball", "--width-mm", "20", "--length-mm", "3", "--out",
                    str(d / "p.cls")], check=True, capture_output=True)
    (d / "p.h").write_text(apt_as_klartext((d / "p.cls").read_text()))
    sc = ROOT / "scenarios"
    base = ((sc / "five_axis_ball.yaml").read_text()
            .replace("../robots", str(ROOT / "robots"))
            .replace("tool: tools/", f"tool: {sc}/tools/")
            .replace("material: materials/", f"material: {sc}/materials/"))
    out = {}
    for kind, file in (("apt", "p.cls"), ("heidenhain", "p.h")):
        text = (base.replace("generator: apt", f"generator: {kind}")
                .replace("file: five_axis/ball_saddle.cls", f"file: {d / file}"))
        (d / f"{kind}.yaml").write_text(text)
        out[kind] = run_scenario(d / f"{kind}.yaml", d / kind, laws=["jerk"], progress=quiet,
                                 report=False).summary
    return out


def test_the_klartext_program_plans_like_its_cl_file(runs):
    apt, hh = runs["apt"], runs["heidenhain"]
    row = hh["laws"]["jerk"]
    assert row["verified"] and row["exported"], row["problems"]
    assert hh["scenario"]["path_length_mm"] == pytest.approx(apt["scenario"]["path_length_mm"],
                                                             rel=1e-9)
    assert row["cycle_time_s"] == pytest.approx(apt["laws"]["jerk"]["cycle_time_s"], rel=1e-6)
    assert (hh["scenario"]["orientation"]["tool_vectors"]
            == apt["scenario"]["orientation"]["tool_vectors"])
