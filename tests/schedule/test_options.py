"""Law options (pydantic models with today's defaults) and typed law stats (summary keys)."""

from __future__ import annotations

import importlib
import json

import pytest
from pydantic import BaseModel, ValidationError

from feedopt.schedule.trajectory import LawStats
from tests.schedule.conftest import wave_problem

# The tunables each law had as arguments / module constants before the options models.
DEFAULTS = {
    "constant": {"ramp": "quintic"},
    "thesis": {"key_points": True, "lower_feeds": True, "max_iterations": 200,
               "ramp_room": 0.45, "lowering_margin": 1e-9, "handoff_reset_factor": 4.0,
               "max_stretches": 2000, "decline_reversal": True},
    "topp": {"max_gridpoints": None, "use_accel_limit": True, "use_joint_limits": True},
    "convex": {"max_gridpoints": 3000, "rest_gridpoints": 61, "jerk_margin": 0.02,
               "reach_margin": 0.05, "max_resolves": 3, "reversal_jerk_scale": 0.9,
               "compare_topp": True, "solver_options": {}},
    "jerk": {"tolerance": 0.005, "joint_acceleration_split": 0.5, "margin": 1e-9},
    "programmed": {"max_gridpoints": 3000, "rest_gridpoints": 61, "jerk_margin": 0.02,
                   "reach_margin": 0.05, "max_resolves": 3, "reversal_jerk_scale": 0.9,
                   "compare_topp": False, "solver_options": {}},
}

# What summary.json got per law before stats were typed (in order; times included).
SUMMARY_KEYS = {
    "constant": ["cruise_feed_mm_s", "ramp", "ramp_lengths_mm", "max_feed_ratio"],
    "thesis": ["iterations", "max_feed_ratio", "max_accel_m_s2", "max_jerk_m_s3",
               "stretch_feeds_mm_s", "n_pieces", "handoff_resets"],
    "topp": ["gridpoints", "solver", "toppra_time_s", "planning_time_s",
             "max_accel_jump_m_s2", "lower_bound_s", "joint_acceleration_ratio"],
    "convex": ["gridpoints", "solver", "status", "resolves", "attempts", "solver_time_s",
               "socp_time_s", "feed_ratio", "max_jerk_m_s3", "max_accel_m_s2", "lower_bound_s",
               "planning_time_s", "topp_time_s", "topp_duration_s", "gap_to_topp"],
    "jerk": ["n_sections", "tolerance", "time_sections_passes_s", "time_ruckig_s",
             "time_assemble_s", "length_error_m"],
}


def _module(law: str):
    return importlib.import_module(f"feedopt.schedule.{law}")


def _options(law: str) -> type[BaseModel]:
    return getattr(_module(law), f"{law.capitalize()}Options")


@pytest.mark.parametrize("law", list(DEFAULTS))
def test_options_defaults_are_the_previous_values_and_described(law):
    model = _options(law)
    assert model().model_dump() == DEFAULTS[law]
    for name, field in model.model_fields.items():
        assert field.description, f"{law}.{name} has no description"
    cfg = model.model_config
    assert cfg["extra"] == "forbid" and cfg["frozen"] and cfg["strict"]


@pytest.mark.parametrize("law", list(DEFAULTS))
def test_options_are_strict_frozen_and_closed(law):
    model = _options(law)
    with pytest.raises(ValidationError):
        model(no_such_option=1)
    opts = model()
    name = next(iter(model.model_fields))
    with pytest.raises(ValidationError):
        setattr(opts, name, getattr(opts, name))
    with pytest.raises(ValidationError):  # strict: no "3" for a number, no 1 for a flag
        model(**{name: "3"})


def test_options_validate_ranges():
    from feedopt.schedule.convex import ConvexOptions
    from feedopt.schedule.jerk import JerkOptions
    from feedopt.schedule.topp import ToppOptions

    for bad in (lambda: JerkOptions(tolerance=0.5), lambda: JerkOptions(tolerance=0.0),
                lambda: ToppOptions(max_gridpoints=1), lambda: ConvexOptions(jerk_margin=1.0),
                lambda: ConvexOptions(max_resolves=-1)):
        with pytest.raises(ValidationError):
            bad()
    assert ConvexOptions(jerk_margin=0.0).jerk_margin == 0.0


@pytest.mark.parametrize("law", list(SUMMARY_KEYS))  # programmed: convex's stats
def test_stats_are_typed_and_as_dict_keeps_the_summary_keys(law):
    problem = wave_problem(601)
    plan = getattr(_module(law), f"plan_{law}")
    traj = plan(problem)
    assert isinstance(traj.stats, LawStats)
    stats_cls = getattr(_module(law), f"{law.capitalize()}Stats")
    assert type(traj.stats) is stats_cls
    summary = traj.stats.as_dict()
    assert list(summary) == SUMMARY_KEYS[law]
    json.dumps(summary)  # summary.json writes all of it
    assert dict(traj.stats.items()) == summary  # the mapping interface reads the same
    # options reach the law: explicit defaults plan the same trajectory
    again = plan(problem, _options(law)(**({"compare_topp": False} if law == "convex" else {})))
    assert again.duration == traj.duration
