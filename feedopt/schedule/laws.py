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

    ``context`` carries results of laws run before: with ``context["topp"]`` (a topp
    Trajectory) the convex law reports its optimality gap to it without re-running toppra;
    without it, convex runs toppra itself for the gap (outside its own planning time).
    """
    module = importlib.import_module(LAW_MODULES[name])
    plan = getattr(module, f"plan_{name}")
    context = {} if context is None else context
    if name == "convex":
        return plan(problem, topp=context.get("topp"))
    trajectory: Trajectory = plan(problem)
    if name == "topp":
        context["topp"] = trajectory
    return trajectory
