"""The bundled G-code scenarios (pocket, profile) run end to end: every law verified, the
optimised ones exported, the program's F words as the baseline, provenance in the outputs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.runner import run_scenario
from feedopt.units import MM
from tests.conftest import ROOT

quiet = lambda _m: None  # noqa: E731


@pytest.fixture(scope="module", params=["pocket", "profile"])
def program_run(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(request.param) / "out"
    return request.param, run_scenario(ROOT / "scenarios" / f"{request.param}.yaml", out,
                                       progress=quiet, report=False)


def test_every_law_is_verified_and_the_optimised_ones_exported(program_run):
    name, res = program_run
    assert set(res.laws) == {"programmed", "topp", "convex", "jerk"}
    for law, r in res.laws.items():
        assert r.verification.verified, (law, r.verification.problems)
    exported = {law for law, r in res.laws.items() if r.verification.exportable}
    assert exported == {"convex", "jerk"}
    limit = res.prepared.limit
    for law in ("convex", "jerk"):
        assert res.laws[law].verification.deflection.max() <= limit * (1 + 1e-6)
    # the program's own feeds exceed the limit: that is what the optimised laws fix
    assert res.laws["programmed"].verification.deflection.max() > limit


def test_the_programs_feeds_and_speed_drive_the_run(program_run):
    name, res = program_run
    p = res.prepared
    assert p.scenario.cut.spindle_rpm == 2500  # the program's S
    moves = p.path.moves
    cat = moves.category[moves.index_at(p.samples.s)]
    cutting = p.process.engagement.exit > p.process.engagement.entry
    assert not np.any(cutting & (cat != "cut"))  # only cut moves cut
    assert cutting.mean() > 0.5
    # rapids: no force, bounded by the rapid limit and the joint velocities only
    rapid = cat == "rapid"
    assert np.all(p.bound.v_max[rapid] <= 500 * MM * (1 + 1e-12))
    # feed moves: never above their programmed F
    feed = moves.feed[moves.index_at(p.samples.s)]
    assert np.all(p.bound.v_max[~rapid] <= feed[~rapid] * (1 + 1e-12))
    summary = json.loads((res.out_dir / "summary.json").read_text())
    assert any("smoothed" in w for w in summary["warnings"]) == (name == "profile")


def test_a_scenario_nominal_feed_with_a_program_is_refused(quick_scenario):
    bad = quick_scenario("profile", feed__nominal_mm_s=4.0)
    with pytest.raises(InputError, match="the program's F words are the nominal feed"):
        run_scenario(bad, bad.parent / "out", progress=quiet)


def test_a_spindle_speed_that_disagrees_with_the_program_is_refused(quick_scenario):
    bad = quick_scenario("profile", cut__spindle_rpm=3000)
    with pytest.raises(InputError, match=r"cut.spindle_rpm = 3000 disagrees with the program's "
                                         r"S2500"):
        run_scenario(bad, bad.parent / "out", progress=quiet)
    assert not (bad.parent / "out").exists()


def test_a_tool_the_scenario_does_not_describe_is_refused(quick_scenario):
    bad = quick_scenario("profile", path__tool_number=2)
    with pytest.raises(InputError, match=r"line \d+: the program cuts with T1, but "
                                         r"path.tool_number is 2"):
        run_scenario(bad, bad.parent / "out", progress=quiet)
