"""The report of one run, assembled from the stages' results (the runner only calls this)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from feedopt.report.data import (
    EngagementSeries,
    LawSeries,
    PathCurvesSI,
    RedundancySeries,
    ReportData,
    TimeCurvesSI,
    law_series_from_si,
)
from feedopt.units import MM

if TYPE_CHECKING:
    from feedopt.schedule.problem import ScheduleProblem


@dataclass(frozen=True)
class ReportPath:
    """The run's path and robot as the report draws them.

    Attributes
    ----------
    positions : (n, 3) array
        TCP positions in the robot base frame [m].
    sample_segment : (n,) int array
        Segment index of each sample.
    problem : ScheduleProblem
        The planning problem: its segment kinds and joint velocity limits.
    joint_unit : (dof,) array or None
        SI per display unit of each joint (as in :func:`law_series`); None: deg.
    """

    positions: np.ndarray
    sample_segment: np.ndarray
    problem: ScheduleProblem
    joint_unit: np.ndarray | None = None


@dataclass(frozen=True)
class ExtraFigures:
    """The series of the figures only some runs have (None: no such figure)."""

    engagement: EngagementSeries | None = None
    redundancy: RedundancySeries | None = None


def law_series(law: str, s: np.ndarray, verification, samples,
               joint_unit: np.ndarray | None = None) -> LawSeries:
    """One law's curves: the replay on the path samples and the law at the controller cycle
    (``samples``: :class:`feedopt.export.job.ControllerSamples`). ``joint_unit``: SI per
    display unit of each joint (rad per deg; m per mm for a prismatic joint), default deg."""
    ver, motion = verification, samples.motion
    qdot = samples.joint_velocity
    if joint_unit is not None:  # law_series_from_si converts rad -> deg: pre-scale the rest
        qdot = qdot * (np.deg2rad(1.0) / np.asarray(joint_unit))
    return law_series_from_si(
        law, PathCurvesSI(s, ver.feed, ver.deflection),
        TimeCurvesSI(motion.t, motion.sdot, motion.sddot, samples.jerk, qdot),
        verified=ver.verified,
        notes=list(ver.problems) + [f"not exported: {b}" for b in ver.export_blockers]
        + list(ver.warnings),
    )


def write_run_report(out_dir: Path, scenario_name: str, summary: dict, path: ReportPath,
                     series: list[LawSeries], limit_mm: float,
                     extra: ExtraFigures | None = None) -> None:
    """report.md / report.html and their figures for one run."""
    from feedopt.report.html import write_report

    problem, joint_unit = path.problem, path.joint_unit
    extra = ExtraFigures() if extra is None else extra
    kinds = np.asarray(problem.segment_kind or ("line",))
    seg = np.asarray(path.sample_segment)
    data = ReportData(
        scenario=scenario_name,
        summary=summary,
        path_xyz_mm=path.positions / MM,
        segment_kind=kinds[seg] if kinds.size > 1 else np.full(seg.size, kinds[0]),
        laws=tuple(series),
        joint_velocity_limit_deg_s=np.rad2deg(problem.joint_velocity_max) * (
            np.deg2rad(1.0) / np.asarray(joint_unit) if joint_unit is not None else 1.0),
        deflection_limit_mm=limit_mm,
        engagement=extra.engagement,
        redundancy=extra.redundancy,
        joint_units=() if joint_unit is None else tuple(
            "mm" if u == MM else "deg" for u in joint_unit),
    )
    write_report(out_dir, data)
