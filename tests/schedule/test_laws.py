"""The timing-law registry: metadata of the built-ins, and a toy law registered here runs end
to end (scenario options, planning, verification, export, report)."""

import dataclasses
import json
import sys
import types

import numpy as np
import pytest
from pydantic import BaseModel, ConfigDict, Field

from feedopt.errors import InputError
from feedopt.runner import run_scenario
from feedopt.scenario import load_scenario
from feedopt.schedule.laws import LAWS, LawSpec, plan_law, planning_order, register_law
from feedopt.verify import is_baseline

quiet = lambda _m: None  # noqa: E731


def test_builtin_laws_and_their_promises() -> None:
    assert list(LAWS)[:5] == ["constant", "thesis", "topp", "convex", "jerk"]
    assert [n for n, s in LAWS.items() if s.baseline] == ["constant", "programmed"]
    assert LAWS["topp"].continuity == 1
    assert all(LAWS[n].continuity == 2
               for n in ("constant", "thesis", "convex", "jerk", "programmed"))
    assert {n for n, s in LAWS.items() if s.native_program} == {"constant", "thesis"}
    assert planning_order(["jerk", "convex", "topp"])[0] == "topp"
    for spec in LAWS.values():
        assert issubclass(spec.options_model(), BaseModel)
        spec.options_model()()  # defaults are valid


def test_duplicate_registration_is_refused() -> None:
    with pytest.raises(ValueError, match="already registered"):
        register_law(LAWS["jerk"])


class ToyOptions(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)
    fraction: float = Field(0.9, gt=0, le=1, description="fraction of the lowest bound")


def plan_toy(problem, options: ToyOptions | None = None):
    """Constant feed at a fraction of the lowest v_max: always within the bound."""
    from feedopt.schedule.constant import plan_constant

    options = options or ToyOptions()
    slow = dataclasses.replace(problem, nominal_feed=options.fraction * float(problem.v_max.min()))
    return dataclasses.replace(plan_constant(slow), law="toy")


@pytest.fixture
def toy_law():
    module = types.ModuleType("feedopt_test_toy_law")
    module.plan_toy, module.ToyOptions = plan_toy, ToyOptions
    sys.modules[module.__name__] = module
    spec = register_law(LawSpec("toy", module.__name__, continuity=2, colour="tab:red",
                                description="test law"))
    yield spec
    del LAWS["toy"]
    del sys.modules[module.__name__]


def test_toy_law_runs_end_to_end_with_its_options(toy_law, quick_scenario, tmp_path) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["toy", "jerk"],
                       schedule__law_options={"toy": {"fraction": 0.5}})
    result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet)
    entry = result.summary["laws"]["toy"]
    assert entry["verified"] and entry["exported"], entry["problems"]
    v_min = float(result.prepared.problem.v_max.min())
    assert entry["max_feed_mm_s"] == pytest.approx(0.5 * v_min * 1e3, rel=1e-9)
    assert (tmp_path / "out" / "toy.csv").is_file()
    assert not (tmp_path / "out" / "toy.src").exists()  # no native program for it
    assert "toy" in (tmp_path / "out" / "report.md").read_text()
    assert not is_baseline("toy")
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert saved["laws"]["toy"]["cycle_time_s"] > saved["laws"]["jerk"]["cycle_time_s"]


def test_bad_law_options_name_the_field(toy_law, quick_scenario) -> None:
    p = quick_scenario(schedule__law_options={"toy": {"fraction": 2.0}})
    with pytest.raises(InputError, match=r"law_options\.toy\.fraction"):
        load_scenario(p)
    p = quick_scenario(schedule__law_options={"toy": {"fractoin": 0.5}})
    with pytest.raises(InputError, match=r"law_options\.toy\.fractoin.*valid: fraction"):
        load_scenario(p)
    p = quick_scenario(schedule__law_options={"nosuch": {}})
    with pytest.raises(InputError, match=r"law_options\.nosuch: unknown law"):
        load_scenario(p)


def test_unknown_law_lists_the_registered_ones(quick_scenario) -> None:
    with pytest.raises(InputError, match=r"unknown law\(s\) 'fast'.*constant, thesis"):
        load_scenario(quick_scenario(schedule__laws=["fast"]))


def test_a_law_breaking_its_continuity_promise_fails_verification(quick_scenario,
                                                                 tmp_path) -> None:
    def plan_liar(problem, options=None):
        from feedopt.schedule.topp import plan_topp

        return dataclasses.replace(plan_topp(problem), law="liar")

    module = types.ModuleType("feedopt_test_liar")
    module.plan_liar, module.LiarOptions = plan_liar, ToyOptions
    sys.modules[module.__name__] = module
    register_law(LawSpec("liar", module.__name__, continuity=2))
    try:
        p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["liar"])
        result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
        ver = result.laws["liar"].verification
        assert not ver.verified
        assert any("promises C2 but returned a C1" in m for m in ver.problems)
    finally:
        del LAWS["liar"]
        del sys.modules[module.__name__]


def test_plan_law_adds_to_the_context(quick_scenario) -> None:
    from feedopt.runner import prepare

    scenario, base = load_scenario(quick_scenario(path__spacing_mm=2.0))
    prepared = prepare(scenario, base, progress=quiet)
    context = {}
    plan_law("topp", prepared.problem, context)
    convex = plan_law("convex", prepared.problem, context)
    assert set(context) == {"topp", "convex"}
    assert np.isfinite(convex.duration)
