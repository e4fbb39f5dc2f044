"""What the runner passes from stage to stage and returns: the prepared run (everything
upstream of the timing laws), each law's result and the run's result. Plain dataclasses of
the stages' own results, so that the summary and the report can name them without importing
the runner (:mod:`feedopt.runner` wires the stages)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from feedopt.cell import Placement
from feedopt.geometry.path import Path as ToolPath
from feedopt.geometry.path import PathPoints
from feedopt.process.stage import ProcessAlongPath
from feedopt.profiling import RunProfile
from feedopt.robot.model import RobotModel
from feedopt.robot.stage import RobotAlongPath
from feedopt.scenario import Scenario
from feedopt.schedule.compensation import CompensatedPath, CompensationCheck
from feedopt.schedule.stage import ScheduleInputs
from feedopt.schedule.trajectory import Trajectory
from feedopt.verify import Verification

__all__ = ["Compensated", "Front", "LawResult", "Prepared", "RunResult"]


@dataclass
class Prepared:
    """Everything upstream of the timing laws: each stage's result, SI units."""

    scenario: Scenario
    base_dir: Path
    path: ToolPath
    samples: PathPoints  # workpiece frame
    placement: Placement
    process: ProcessAlongPath
    robot: RobotModel
    along: RobotAlongPath
    schedule: ScheduleInputs
    stage_times: dict[str, float] = field(default_factory=dict)
    # What the run does that the user should know (placeholder robot data, tight radii, an
    # export that will be skipped...): printed, in summary.json and in the report.
    warnings: list[str] = field(default_factory=list)
    # {exporter: why it cannot write for this run}, known before planning.
    export_blockers: dict = field(default_factory=dict)  # {exporter: export.job.Blocker}
    # {law: why it declined this problem} (feedopt.errors.LawNotApplicable), set by planning.
    declined: dict[str, str] = field(default_factory=dict)
    # robot.redundancy: optimise: the psi(s) profile (feedopt.robot.redundancy.RedundancyResult)
    # and the nearest IK's compliance it is compared with
    redundancy: object | None = None
    nearest_compliance: np.ndarray | None = None

    # Shorthands for what the summary, the report and tests read most.
    @property
    def problem(self):
        return self.schedule.problem

    @property
    def model(self):
        return self.schedule.model

    @property
    def bound(self):
        return self.schedule.bound

    @property
    def limit(self) -> float:
        return self.schedule.limit

    @property
    def q_of_s(self):
        return self.along.q_of_s

    @property
    def ik(self):
        return self.along.ik

    @property
    def positions(self) -> np.ndarray:
        return self.placement.positions

    @property
    def tool(self):
        return self.process.tool

    @property
    def coefficient_table(self):
        return self.process.table


@dataclass
class LawResult:
    trajectory: Trajectory
    verification: Verification
    planning_time: float
    verification_time: float = 0.0
    # residual mode: the commanded path, the robot and schedule along it, and the check
    compensation: Compensated | None = None


@dataclass(frozen=True, eq=False)
class Compensated:
    """A law planned for ``deflection.mode: residual`` on its compensated path."""

    path: CompensatedPath  # commanded = nominal - mean deflection (fixed point)
    along: RobotAlongPath  # IK and compliance along the commanded path
    schedule: ScheduleInputs  # bound and problem on that compliance
    check: CompensationCheck


@dataclass
class Front:
    """The geometry, cell and process stages of a run (what ``feedopt engagement`` needs)."""

    scenario: Scenario  # with a program's F and S filled in
    path: ToolPath
    samples: PathPoints
    placement: Placement
    process: ProcessAlongPath | None  # None only between the cell and process stages (runner)
    warnings: list[str]
    times: dict[str, float]


@dataclass
class RunResult:
    out_dir: Path
    prepared: Prepared
    laws: dict[str, LawResult]
    summary: dict
    table: str
    profile: RunProfile | None = None
