"""summary.json: the resolved inputs of a run and, per law, its numbers and verdicts.

Everything here is in user units (mm, mm/s, deg) as design.md asks of summary.json.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np

from feedopt.units import MM

if TYPE_CHECKING:
    from feedopt.runner import LawResult, Prepared


def scenario_summary(prepared: Prepared) -> dict:
    """The resolved inputs, in user units, for summary.json (design.md)."""
    sc, tool, model = prepared.scenario, prepared.tool, prepared.model
    c = model.coefficients
    return {
        "name": sc.name,
        "tool": {"name": tool.name, "diameter_mm": tool.diameter / MM, "teeth": tool.teeth,
                 "helix_deg": float(np.rad2deg(tool.helix))},
        "cut": {"type": sc.cut.type, "axial_depth_mm": sc.cut.axial_depth_mm,
                "radial_depth_mm": sc.cut.radial_depth_mm, "milling": sc.cut.milling,
                "rpm": sc.cut.spindle_rpm},
        "coefficients": {"ktc_n_m2": c.ktc, "krc_n_m2": c.krc, "kac_n_m2": c.kac,
                         "kte_n_m": c.kte, "kre_n_m": c.kre, "kae_n_m": c.kae},
        "deflection_limit_mm": sc.deflection.limit_mm,
        "limit_mode": sc.deflection.mode,
        "stiffness_set": sc.robot.stiffness,
        "stiffness_mnm_per_rad": (prepared.robot.stiffness[sc.robot.stiffness] / 1e6).tolist(),
        "tcp_offset_mm": (prepared.robot.tcp_offset[:3, 3] / MM).tolist(),
        "workpiece_position_mm": list(sc.workpiece.position_mm),
        "workpiece_rpy_deg": list(sc.workpiece.rpy_deg),
        "nominal_feed_mm_s": sc.feed.nominal_mm_s,
        "path_length_mm": prepared.problem.length / MM,
        "samples": int(prepared.problem.n),
        "lower_bound_s": prepared.problem.lower_bound_time(),
        "active_constraints": prepared.bound.active_fraction(),
        "max_condition_number": float(np.max(prepared.ik.condition_number)),
        "stage_times_s": dict(prepared.stage_times),
    }


def _json_ready(value: object) -> bool:
    try:
        json.dumps(value)
    except (TypeError, ValueError):
        return False
    return True


def law_summary(prepared: Prepared, result: LawResult) -> dict:
    ver, timing = result.verification, result.verification.timing
    traj = result.trajectory
    return {
        "cycle_time_s": traj.duration,
        "lower_bound_s": prepared.problem.lower_bound_time(),
        "time_over_lower_bound": traj.duration / prepared.problem.lower_bound_time(),
        "max_deflection_mm": ver.max_deflection / MM,
        "deflection_ratio": ver.deflection_ratio,
        "meets_limit": ver.meets_limit,
        "max_feed_mm_s": timing.max_feed / MM,
        "min_feed_mm_s": timing.min_feed_interior / MM,
        "max_accel_mm_s2": timing.max_accel / MM,
        "max_jerk_mm_s3": timing.max_jerk / MM if traj.continuity >= 2 else None,
        "accel_jump_mm_s2": timing.accel_jump / MM,
        "c2": timing.c2,
        "joint_velocity_ratio": timing.joint_velocity_ratio,
        "joint_acceleration_ratio": timing.joint_acceleration_ratio,
        "verified": ver.verified,
        "problems": list(ver.problems),
        "notes": list(ver.warnings),
        "planning_time_s": result.planning_time,
        "verification_time_s": result.verification_time,
        "stats": {k: v for k, v in traj.stats.items() if _json_ready(v)},
    }
