"""The ``programmed`` timing law: a G-code program's own feeds (the CNC baseline).

A CNC runs every move at its programmed F (rapids at the machine's rapid limit) and only slows
down where its axes cannot follow. This law does the same for the robot: the fastest
jerk-limited C2 trajectory (the ``convex`` law's SOCP, Verscheure et al. 2009) under
v <= the programmed feed of each sample, capped by the joint velocity limits, ignoring the
deflection limit on purpose. It is the baseline a program is compared with, as ``constant``
is for the thesis's paths (which have one nominal feed); replay verification measures how
far it exceeds the deflection bound.
"""

from __future__ import annotations

import dataclasses

from pydantic import BaseModel, ConfigDict, Field

from feedopt.errors import LawNotApplicable
from feedopt.schedule.convex import ConvexOptions, plan_convex
from feedopt.schedule.problem import ScheduleProblem
from feedopt.schedule.trajectory import Trajectory


class ProgrammedOptions(ConvexOptions):
    """Tunables of the ``programmed`` law: those of the convex solver it uses."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    compare_topp: bool = Field(False, description="run toppra on the programmed feeds to "
                               "report the gap to it")


def plan_programmed(problem: ScheduleProblem, options: BaseModel | None = None) -> Trajectory:
    """The program's feeds as fast as the robot's limits allow (deflection ignored).

    Raises :class:`~feedopt.errors.LawNotApplicable` for a path without a program (one
    nominal feed: its baseline is ``constant``).
    """
    if problem.programmed_feed is None:
        raise LawNotApplicable("the path is not a G-code program (one nominal feed): its "
                               "baseline is the constant law")
    options = ProgrammedOptions() if options is None else options
    capped = dataclasses.replace(problem, v_max=problem.programmed_feed)
    convex = plan_convex(capped, ConvexOptions(**options.model_dump()))
    return dataclasses.replace(
        convex, law="programmed",
        notes=("the program's own feeds (F per move, rapids at the robot's limits), "
               "ignoring the deflection limit", *convex.notes))
