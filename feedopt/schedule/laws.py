"""The registry of timing laws: the one place a new law is registered.

A law is a module ``feedopt/schedule/<law>.py`` with a function ``plan_<law>(problem,
options=None, ...) -> Trajectory`` and a pydantic options model; :data:`LAWS` maps its name to
a :class:`LawSpec` that says what it promises (continuity, whether it is a baseline that
ignores the deflection bound), what it gets (native controller program or only the RSI CSV)
and how it is drawn. The scenario's allowed law names and options, the CLI's ``--laws``
choices, verification's baseline rule and the report's colours all come from here.

Modules are imported when a law is first planned (toppra and cvxpy are slow to import).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from feedopt.registry import add_unique

if TYPE_CHECKING:  # the registry itself imports no numerics (it is read by every command)
    from pydantic import BaseModel

    from feedopt.schedule.problem import ScheduleProblem
    from feedopt.schedule.trajectory import Trajectory


@dataclass(frozen=True)
class LawSpec:
    """What the rest of feedopt needs to know about a timing law.

    Attributes
    ----------
    name : str
        Name in scenarios (``schedule.laws``), on the command line and in output files.
    module : str
        Module holding ``plan_<name>`` (``plan``) and the options model (``options``).
    continuity : int
        Order of parametric continuity of s(t) the law promises (2: C2, jerk bounded).
    baseline : bool
        True for a reference law that ignores the deflection bound by design (the thesis's
        constant feed): its exceedance is reported, not a failure.
    native_program : bool
        The law's feeds are also exported as a native controller program (KRL), for the
        thesis's native-controller comparison (section 3.7).
    colour : str
        Matplotlib colour of the law in every plot.
    description : str
        One line for ``feedopt validate --schema`` and ``--help``.
    order : int
        Planning order (lower first): ``topp`` runs before ``convex``, which reports its gap
        to toppra from the context.
    plan, options : str
        Attribute names of the planning function and options model in ``module``.
    uses_context : tuple of str
        Names of earlier laws' trajectories the plan function accepts as keyword arguments.
    slow_imports : tuple of str
        Modules whose import costs a noticeable part of a run (cvxpy: ~0.5 s): the runner
        imports them in a child process started before planning, which then plans this law
        beside the others (:func:`feedopt.planning.plan_and_verify`).
    """

    name: str
    module: str
    continuity: int
    baseline: bool = False
    native_program: bool = False
    colour: str = "tab:gray"
    description: str = ""
    order: int = 10
    plan: str = ""
    options: str = ""
    uses_context: tuple[str, ...] = field(default=())
    slow_imports: tuple[str, ...] = field(default=())

    def _module(self) -> Any:
        return importlib.import_module(self.module)

    def plan_function(self) -> Callable[..., Trajectory]:
        return getattr(self._module(), self.plan or f"plan_{self.name}")

    def options_model(self) -> type[BaseModel]:
        return getattr(self._module(), self.options or f"{self.name.capitalize()}Options")


LAWS: dict[str, LawSpec] = {}


def register_law(spec: LawSpec) -> LawSpec:
    """Add ``spec`` to :data:`LAWS` (ValueError for a name already registered)."""
    return add_unique(LAWS, spec.name, spec, "timing law")


def law_names() -> tuple[str, ...]:
    """Registered law names, in registration order."""
    return tuple(LAWS)


def planning_order(names: list[str]) -> list[str]:
    """``names`` sorted by :attr:`LawSpec.order` (stable)."""
    return sorted(names, key=lambda n: LAWS[n].order)


def plan_law(name: str, problem: ScheduleProblem, context: dict[str, Trajectory] | None = None,
             options: BaseModel | None = None) -> Trajectory:
    """Plan ``problem`` with the law ``name``.

    ``context`` holds the trajectories of laws planned before (``{name: Trajectory}``); a law
    gets those it declares in :attr:`LawSpec.uses_context` (convex reports its optimality gap
    to ``topp`` without re-running toppra). The new trajectory is added to ``context``.

    A problem with stops inside the path or holds (``problem.stops``) is planned piece by
    piece between them and stitched (:func:`feedopt.schedule.stops.plan_through_stops`); a
    law that declines one piece declines the problem.
    """
    context = {} if context is None else context
    trajectory = None
    if problem.stops is not None:
        from feedopt.schedule.stops import needs_stitching, plan_through_stops

        if needs_stitching(problem):
            trajectory = plan_through_stops(name, problem, context, options,
                                            planner=_plan_whole,
                                            uses_context=LAWS[name].uses_context)
    if trajectory is None:
        trajectory = _plan_whole(name, problem, context, options)
    context[name] = trajectory
    return trajectory


def _plan_whole(name: str, problem: ScheduleProblem, context: dict[str, Trajectory],
                options: BaseModel | None) -> Trajectory:
    """The law's own plan function on ``problem`` (its stops ignored), with the context
    trajectories it declares."""
    spec = LAWS[name]
    extra = {k: context.get(k) for k in spec.uses_context}
    return spec.plan_function()(problem, options=options, **extra)


for _spec in (
    LawSpec("constant", "feedopt.schedule.constant", continuity=2, baseline=True,
            native_program=True, colour="0.35", order=1,
            description="the thesis baseline: the nominal feed everywhere, ignoring the limit"),
    LawSpec("thesis", "feedopt.schedule.thesis", continuity=2, native_program=True,
            colour="tab:blue", order=1,
            description="the thesis's law: one feed per line, quintic blends (Eq. 3.21-3.22); "
                        "chapter-4 key points with the section 4.3 hand-off"),
    LawSpec("topp", "feedopt.schedule.topp", continuity=1, colour="tab:orange", order=0,
            description="time-optimal path parameterisation (toppra), C1"),
    LawSpec("convex", "feedopt.schedule.convex", continuity=2, colour="tab:green", order=1,
            uses_context=("topp",), slow_imports=("cvxpy", "clarabel"),
            description="convex SOCP with a jerk limit (Verscheure et al. 2009; cvxpy + "
                        "Clarabel), quintic Hermite output"),
    LawSpec("jerk", "feedopt.schedule.jerk", continuity=2, colour="tab:purple", order=1,
            description="jerk-limited sections (ruckig) with backward/forward junction passes"),
    LawSpec("programmed", "feedopt.schedule.programmed", continuity=2, baseline=True,
            colour="0.6", order=1,
            description="a G-code program's own feeds (F per move, rapids at the robot's "
                        "limits), ignoring the deflection limit: the CNC baseline"),
):
    register_law(_spec)
