"""Laws planned in a child started before planning (LawSpec.slow_imports, planning.law_workers):
the same trajectory as planned here, declines and bad input as if planned here."""

import dataclasses
import os
import sys
import types

import numpy as np
import pytest

from feedopt import background
from feedopt.errors import InputError, LawNotApplicable
from feedopt.planning import law_workers, plan_and_verify
from feedopt.runner import prepare, run_scenario
from feedopt.scenario import load_scenario
from feedopt.schedule.laws import LAWS, LawSpec, register_law

pytestmark = pytest.mark.skipif(not background.fork_available(), reason="needs os.fork")
quiet = lambda _m: None  # noqa: E731


@pytest.fixture
def child_law():
    """Law ``child``: topp's trajectory, noting the process that planned it; its behaviour
    is chosen by ``module.mode`` ("plan", "decline", "bad input")."""
    module = types.ModuleType("feedopt_test_child_law")
    module.mode = "plan"

    def plan_child(problem, options=None):
        from feedopt.schedule.topp import plan_topp

        if module.mode == "decline":
            raise LawNotApplicable("child law: this path is not for me")
        if module.mode == "bad input":
            raise InputError("child law: v_start = 9 mm/s is outside [0, 4] mm/s")
        traj = plan_topp(problem)
        return dataclasses.replace(traj, law="child", notes=(f"pid {os.getpid()}",))

    module.plan_child = plan_child
    module.ChildOptions = LAWS["jerk"].options_model()
    sys.modules[module.__name__] = module
    register_law(LawSpec("child", module.__name__, continuity=1, slow_imports=("json",)))
    yield module
    del LAWS["child"]
    del sys.modules[module.__name__]


def test_convex_in_its_worker_is_the_convex_planned_here(quick_scenario) -> None:
    path = quick_scenario("triangle_slot", path__spacing_mm=2.0,
                          schedule__laws=["topp", "convex"])
    scenario, base = load_scenario(path)
    prepared = prepare(scenario, base, quiet)
    workers = law_workers(["topp", "convex"])
    assert list(workers) == ["convex"]  # cvxpy: the one slow import
    there = plan_and_verify(prepared, ["topp", "convex"], quiet, workers)
    here = plan_and_verify(prepared, ["topp", "convex"], quiet)
    assert list(there) == list(here) == ["topp", "convex"]
    a, b = there["convex"].trajectory.timing, here["convex"].trajectory.timing
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.c, b.c)
    assert there["convex"].verification.verified


def test_a_law_is_planned_in_its_child(child_law, quick_scenario, tmp_path) -> None:
    path = quick_scenario("triangle_slot", path__spacing_mm=2.0, schedule__laws=["child"])
    result = run_scenario(path, out_dir=tmp_path / "o", progress=quiet, report=False)
    note = result.laws["child"].trajectory.notes[0]
    assert note.startswith("pid ") and int(note[4:]) != os.getpid()


def test_a_law_that_declines_in_its_child_is_declined(child_law, quick_scenario,
                                                      tmp_path) -> None:
    child_law.mode = "decline"
    path = quick_scenario("triangle_slot", path__spacing_mm=2.0,
                          schedule__laws=["child", "jerk"])
    messages = []
    result = run_scenario(path, out_dir=tmp_path / "o", progress=messages.append,
                          report=False)
    assert list(result.laws) == ["jerk"]
    assert result.prepared.declined["child"] == "child law: this path is not for me"
    assert "[5/5] child: declined: child law: this path is not for me" in messages


def test_bad_input_found_in_the_child_is_the_same_input_error(child_law, quick_scenario,
                                                              tmp_path) -> None:
    child_law.mode = "bad input"
    path = quick_scenario("triangle_slot", path__spacing_mm=2.0, schedule__laws=["child"])
    with pytest.raises(InputError, match=r"v_start = 9 mm/s is outside \[0, 4\] mm/s"):
        run_scenario(path, out_dir=tmp_path / "o", progress=quiet, report=False)
    assert not (tmp_path / "o").exists()


def test_a_long_path_is_planned_here(child_law, quick_scenario, tmp_path, monkeypatch) -> None:
    """Above CHILD_COPY_MAX_SAMPLES the worker is let go and the law planned in this process
    (its memory is not held next to ours)."""
    import feedopt.outputs as outputs

    monkeypatch.setattr(outputs, "CHILD_COPY_MAX_SAMPLES", 10)
    path = quick_scenario("triangle_slot", path__spacing_mm=2.0, schedule__laws=["child"])
    result = run_scenario(path, out_dir=tmp_path / "o", progress=quiet)
    assert result.laws["child"].trajectory.notes[0] == f"pid {os.getpid()}"
    assert (tmp_path / "o" / "report.html").is_file()  # the report, forked late
