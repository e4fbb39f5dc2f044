"""What an exporter is given, and the registry of exporters: the one place a new one goes.

An exporter (RSI CSV, KRL program, and later ABB RAPID, URScript, G-code) is a module with a
function ``export(job, out_dir) -> dict`` and an :class:`Exporter` entry in :data:`EXPORTERS`
saying which laws and robots it applies to. The runner builds one :class:`ExportJob` per law
and calls every exporter whose ``applies`` returns ``None`` (a reason string otherwise, which
goes into summary.json). Exporters never see the runner's internals.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from feedopt.registry import add_unique

if TYPE_CHECKING:  # types only: exporters import this module, it imports no stage
    from scipy.interpolate import CubicSpline

    from feedopt.geometry.path import Path as GeometricPath
    from feedopt.robot.model import RobotModel
    from feedopt.schedule.problem import ScheduleProblem
    from feedopt.schedule.trajectory import Motion, Trajectory
    from feedopt.verify import Verification


@dataclass(frozen=True)
class ControllerSamples:
    """The timing law sampled at the controller cycle, with joint velocities.

    ``jerk`` is the law's own jerk for a C2 law; for a law that is only C1 (toppra) it is
    the finite difference of the sampled acceleration, i.e. what a controller stepping at
    this cycle would see, not the zero inside the polynomial pieces.
    """

    motion: Motion
    jerk: np.ndarray  # (m,) [m/s^3]
    joint_velocity: np.ndarray  # (m, dof) [rad/s]


def controller_samples(trajectory: Trajectory, cycle: float, q_of_s: CubicSpline,
                       length: float) -> ControllerSamples:
    """Sample ``trajectory`` every ``cycle`` seconds (see :class:`ControllerSamples`)."""
    motion = trajectory.sample_uniform(cycle)
    jerk = motion.sdddot
    if trajectory.continuity < 2:
        jerk = np.gradient(motion.sddot, motion.t) if motion.t.size > 1 else motion.sdddot
    s = np.clip(motion.s, 0.0, length)
    qd = q_of_s(s, 1) * motion.sdot[:, None]
    return ControllerSamples(motion=motion, jerk=jerk, joint_velocity=qd)


@dataclass(frozen=True, eq=False)
class ExportJob:
    """One law's trajectory and everything an exporter may need to write it.

    Attributes
    ----------
    law, scenario_name : names for file headers.
    trajectory, verification : the planned law and its replay.
    problem : the schedule problem (samples, segments, limits).
    robot : the robot (kinematics, controller family).
    q_of_s : joint path as a cubic spline of arc length [rad].
    path_in_base : ``s -> (m, 3)`` exact TCP path positions in the base frame [m].
    samples : the law at the controller cycle.
    cycle : controller cycle [s].
    limit_mm : deflection limit for headers.
    unverified_on_request : written although not exportable (``--export-unverified``).
    native_program : the law's registry entry asks for a native controller program.
    blockers : exporters the run already knows cannot write (``{exporter: Blocker}``).
    compensation : with ``deflection.mode: residual``, the nominal and commanded paths at the
        path samples (:class:`feedopt.schedule.compensation.CompensatedSamples`); the pose
        columns and ``path_in_base`` are then the commanded path.
    tool_axes : (n, 3) unit tool axis at the path samples in the base frame (what the IK
        holds), shared by every law's job; None: from the FK of ``problem.q``.
    notes : what every file's header must say about the run beyond the law (moves that are
        not deflection-limited, e.g. plunges without plunge coefficients).
    """

    law: str
    scenario_name: str
    trajectory: Trajectory
    verification: Verification
    problem: ScheduleProblem
    robot: RobotModel
    q_of_s: CubicSpline
    path_in_base: Callable[[np.ndarray], np.ndarray]
    samples: ControllerSamples
    cycle: float
    limit_mm: float
    unverified_on_request: bool = False
    native_program: bool = False
    blockers: dict[str, Blocker] = field(default_factory=dict)
    compensation: object | None = None
    tool_axes: np.ndarray | None = None
    notes: tuple[str, ...] = ()

    @cached_property
    def controller_joints(self) -> np.ndarray:
        """Joints at the controller samples (m, dof) [rad], ``q_of_s(motion.s)`` (computed once
        for every exporter of the job)."""
        return self.q_of_s(self.samples.motion.s)

    @cached_property
    def controller_pose(self) -> np.ndarray:
        """TCP poses (m, 4, 4) at the controller samples: pinocchio FK of
        :attr:`controller_joints`, shared by the exporters (the RSI CSV, its corrections)."""
        from feedopt.robot.model import forward_kinematics

        return forward_kinematics(self.robot, self.controller_joints)

    @cached_property
    def sample_tool_axes(self) -> np.ndarray:
        """(n, 3) tool axis at the path samples, base frame: :attr:`tool_axes` or the FK of
        the path joints."""
        if self.tool_axes is not None:
            return self.tool_axes
        from feedopt.robot.model import forward_kinematics

        return forward_kinematics(self.robot, self.problem.q)[:, :3, 2]


#: Stops listed one per header line up to this many; more are summarised.
MAX_STOP_LINES = 20


def header_notes(job: ExportJob) -> list[str]:
    """The lines every exported file's header carries about the plan (without comment
    marks): the run's :attr:`ExportJob.notes`, then the stops of the path with the time the
    law reaches each (feed, acceleration zero there; held for a dwell). At an M0/M1 the
    operator presses Start on a CNC; an exported stream or program does not wait there."""
    out = list(job.notes)
    stops = job.problem.stops
    if stops is None or not len(stops):
        return out
    t = job.trajectory.time_at(job.problem.s[stops.index])
    out.append(f"{len(stops)} stop(s) in the path (feed, acceleration zero; a dwell holds "
               "its time; M0/M1: the exported motion does NOT wait for the operator's Start)")
    for k in range(min(len(stops), MAX_STOP_LINES)):
        hold = f", held {stops.hold_s[k]:g} s" if stops.hold_s[k] > 0 else ""
        out.append(f"  stop at t = {t[k]:.3f} s, s = {job.problem.s[stops.index[k]] * 1e3:.3f}"
                   f" mm: {stops.kind[k]}{hold} ({stops.label[k]})")
    if len(stops) > MAX_STOP_LINES:
        out.append(f"  ... and {len(stops) - MAX_STOP_LINES} more (summary.json: stops)")
    return out


@dataclass(frozen=True)
class Blocker:
    """Why an exporter cannot write for a run. ``warn``: worth a warning (the user expected
    the file: a size cap); False where the format simply does not apply (no KRL for a UR)."""

    reason: str
    warn: bool = True


def controller_blocker(robot: RobotModel, controller: str, what: str, language: str
                       ) -> Blocker | None:
    """Why a controller's own program (``what``, e.g. "RAPID module") cannot be written for
    ``robot``: another controller family (no warning: the format does not apply), an axis
    convention robot.yaml does not state (axis values would be URDF angles), or not 6 axes."""
    from feedopt.robot.axes import UNSTATED_AXES
    from feedopt.robot.model import six_axes_only

    if robot.controller != controller:
        return Blocker(f"no {what}: robot {robot.name} has controller '{robot.controller}' "
                       f"(robot.yaml), {language} is for {controller.upper()} controllers",
                       warn=False)
    if not robot.axis_convention.stated:
        return Blocker(f"no {what}: {UNSTATED_AXES}")
    why = six_axes_only(robot, what)
    return None if why is None else Blocker(why)


@dataclass(frozen=True)
class Exporter:
    """A registered output format.

    ``for_law(job)`` says whether the format is meant for this law at all (the KRL program
    only for laws with a native program); ``early_check(robot, path)`` runs before any
    planning and returns the reason the exporter will not be able to write for this run
    (wrong controller, a size cap), which is printed at once, kept in summary.json and costs
    no other export; ``export(job, out_dir)`` writes and returns the summary entries it adds
    (file names, figures such as the FK error). ``file_pattern`` documents the file it writes
    (``{law}`` is replaced by the law name).
    """

    name: str
    file_pattern: str
    description: str
    export: Callable[[ExportJob, Path], dict]
    for_law: Callable[[ExportJob], bool] = lambda job: True
    early_check: Callable[[RobotModel, GeometricPath], Blocker | str | None] = (
        lambda robot, path: None)


EXPORTERS: dict[str, Exporter] = {}


def register_exporter(exporter: Exporter) -> Exporter:
    """Add ``exporter`` to :data:`EXPORTERS` (ValueError for a name already registered)."""
    return add_unique(EXPORTERS, exporter.name, exporter, "exporter")


def early_blockers(robot: RobotModel, path: GeometricPath) -> dict[str, Blocker]:
    """``{exporter: Blocker}`` for every exporter that cannot write for this robot and path
    (a plain string from ``early_check`` is a :class:`Blocker` worth a warning)."""
    out = {}
    for exporter in EXPORTERS.values():
        found = exporter.early_check(robot, path)
        if found is not None:
            out[exporter.name] = Blocker(found) if isinstance(found, str) else found
    return out


def run_exporters(job: ExportJob, out_dir: Path) -> dict:
    """Every registered exporter meant for ``job``'s law; the summary entries they add.

    An exporter blocked for this run (:func:`early_blockers`) writes nothing and records
    ``<name>_program: None`` and ``<name>_not_written: reason``.
    """
    entry: dict = {}
    for exporter in EXPORTERS.values():
        if not exporter.for_law(job):
            continue
        blocker = job.blockers.get(exporter.name)
        if blocker is None:
            entry.update(exporter.export(job, out_dir))
        else:
            entry[f"{exporter.name}_program"] = None
            entry[f"{exporter.name}_not_written"] = blocker.reason
    return entry


def status_line(job: ExportJob) -> str:
    """Header line every export starts with: the law, the scenario and its verdict."""
    ver = job.verification
    status = ("VERIFIED" if ver.exportable
              else "NOT EXPORTABLE, written on request (--export-unverified): "
              + "; ".join(ver.export_blockers + ver.problems))
    return f"feedopt {job.law} trajectory for scenario {job.scenario_name}: {status}"
