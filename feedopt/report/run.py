"""The report of one run, assembled from the stages' results (the runner only calls this)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from feedopt.report.data import (
    EngagementSeries,
    LawSeries,
    PartSeries,
    PathCurvesSI,
    RedundancySeries,
    ReportData,
    SampleInfo,
    TimeCurvesSI,
    law_series_from_si,
)
from feedopt.units import MM

if TYPE_CHECKING:
    from feedopt.geometry.program_tables import MoveTable
    from feedopt.schedule.problem import ScheduleProblem
    from feedopt.schedule.trajectory import Trajectory


@dataclass(frozen=True)
class SampleSources:
    """What the report child computes the per-sample hover from (a fork shares it; the
    prestarted child gets a copy: the arrays, not the whole feed bound).

    active : (n,) index into ``constraints`` of the feed bound's tightest part per sample
        (``FeedBound.active``); ``constraints`` its names (``FeedBound.names``)
    moves : the program's moves (None: the path is not a program, every sample cuts)
    trajectories : each law's trajectory, for the time at every sample (``time_at``)
    """

    active: np.ndarray
    constraints: tuple[str, ...]
    moves: MoveTable | None = None
    trajectories: Mapping[str, Trajectory] = field(default_factory=dict)


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
    sources : SampleSources or None
        The per-sample bound, program and times of the interactive figures (None: without).
    """

    positions: np.ndarray
    sample_segment: np.ndarray
    problem: ScheduleProblem
    joint_unit: np.ndarray | None = None
    sources: SampleSources | None = None


@dataclass(frozen=True)
class ExtraFigures:
    """The series of the figures only some runs have (None: no such figure)."""

    engagement: EngagementSeries | None = None
    redundancy: RedundancySeries | None = None
    part: PartSeries | None = None


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


def program_lines(moves: MoveTable, s: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray]:
    """Per sample at arc length ``s`` [m] its move's source line (n,), and the distinct
    lines (u,) with their labels (u,), as :meth:`MoveTable.label` writes them."""
    lines, first = np.unique(np.asarray(moves.line, dtype=np.int64), return_index=True)
    n_word = np.asarray(moves.n_number, dtype=np.int64)[first]
    text = np.strings.add("line ", lines.astype(str))
    with_n = np.strings.add(np.strings.add(text, " (N"),
                            np.strings.add(n_word.astype(str), ")"))
    labels = np.where(n_word >= 0, with_n, text)
    return np.asarray(moves.line)[moves.index_at(s)], lines, labels


def sample_info(problem: ScheduleProblem, sources: SampleSources) -> SampleInfo:
    """The :class:`SampleInfo` of a run's samples: bound, active constraint, air, lines."""
    s = problem.s
    if sources.moves is None or not len(sources.moves):
        air, line = np.zeros(s.size, bool), np.zeros(s.size, np.int32)
        numbers, labels = np.zeros(0, np.int32), np.zeros(0, str)
    else:
        moves = sources.moves
        air = moves.category[moves.index_at(s)] != "cut"  # geometry.stage.air_samples
        line, numbers, labels = program_lines(moves, s)
    return SampleInfo(v_max_mm_s=problem.v_max / MM, active=sources.active,
                      constraints=sources.constraints or ("bound",), air=air, program_line=line,
                      line_numbers=numbers, line_labels=labels)


def with_sample_times(series: list[LawSeries], s: np.ndarray,
                      trajectories: Mapping[str, Trajectory]) -> list[LawSeries]:
    """``series`` with the time at each path sample ``s`` [m] of the laws that have a
    trajectory in ``trajectories`` (earliest time, :meth:`Trajectory.time_at`)."""
    return [ls if ls.law not in trajectories
            else replace(ls, path_t_s=trajectories[ls.law].time_at(s)) for ls in series]


def write_run_report(out_dir: Path, scenario_name: str, summary: dict, path: ReportPath,
                     series: list[LawSeries], limit_mm: float,
                     extra: ExtraFigures | None = None) -> None:
    """report.md / report.html and their figures for one run."""
    from feedopt.report.html import write_report

    problem, joint_unit = path.problem, path.joint_unit
    extra = ExtraFigures() if extra is None else extra
    samples = None
    if path.sources is not None:
        samples = sample_info(problem, path.sources)
        series = with_sample_times(series, problem.s, path.sources.trajectories)
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
        part=extra.part,
        joint_units=() if joint_unit is None else tuple(
            "mm" if u == MM else "deg" for u in joint_unit),
        samples=samples,
    )
    write_report(out_dir, data)
