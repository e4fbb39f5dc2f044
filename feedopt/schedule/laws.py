"""Registry of the timing laws: name -> ``plan_<law>(problem) -> Trajectory``."""

from __future__ import annotations

import importlib

from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory

LAW_MODULES = {
    "constant": "feedopt.schedule.constant",
    "thesis": "feedopt.schedule.thesis",
    "topp": "feedopt.schedule.topp",
    "convex": "feedopt.schedule.convex",
    "jerk": "feedopt.schedule.jerk",
}


def plan_law(name: str, problem: ScheduleProblem, context: dict | None = None) -> Trajectory:
    """Plan ``problem`` with the law ``name``.

    ``context`` carries results of laws run before (``topp_duration``), used to report the
    convex law's optimality gap to toppra.
    """
    module = importlib.import_module(LAW_MODULES[name])
    trajectory: Trajectory = getattr(module, f"plan_{name}")(problem)
    context = context or {}
    if name == "convex" and "topp_duration" in context:
        trajectory.stats["gap_to_topp"] = trajectory.duration / context["topp_duration"] - 1.0
    return trajectory
