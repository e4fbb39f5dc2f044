"""The report of one run, assembled from the stages' results (the runner only calls this)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feedopt.report.data import LawSeries, ReportData, law_series_from_si
from feedopt.units import MM


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
        law, s, ver.feed, ver.deflection, motion.t, motion.sdot, motion.sddot, samples.jerk,
        qdot, verified=ver.verified,
        notes=list(ver.problems) + [f"not exported: {b}" for b in ver.export_blockers]
        + list(ver.warnings),
    )


def write_run_report(out_dir: Path, scenario_name: str, summary: dict, positions: np.ndarray,
                     sample_segment: np.ndarray, problem, series: list[LawSeries],
                     limit_mm: float, engagement=None, redundancy=None,
                     joint_unit: np.ndarray | None = None) -> None:
    """report.md / report.html and their figures for one run (``joint_unit``: as in
    :func:`law_series`)."""
    from feedopt.report.html import write_report

    kinds = np.asarray(problem.segment_kind or ("line",))
    seg = np.asarray(sample_segment)
    data = ReportData(
        scenario=scenario_name,
        summary=summary,
        path_xyz_mm=positions / MM,
        segment_kind=kinds[seg] if kinds.size > 1 else np.full(seg.size, kinds[0]),
        laws=tuple(series),
        joint_velocity_limit_deg_s=np.rad2deg(problem.joint_velocity_max) * (
            np.deg2rad(1.0) / np.asarray(joint_unit) if joint_unit is not None else 1.0),
        deflection_limit_mm=limit_mm,
        engagement=engagement,
        redundancy=redundancy,
        joint_units=() if joint_unit is None else tuple(
            "mm" if u == MM else "deg" for u in joint_unit),
    )
    write_report(out_dir, data)
