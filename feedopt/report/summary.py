"""summary.json: the resolved inputs of a run and, per law, its numbers and verdicts.

Everything here is in user units (mm, mm/s, deg) as design.md asks of summary.json.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np

from feedopt.process.dexel_material import DexelMaterialAlongPath
from feedopt.process.program import unmodelled_plunge_moves
from feedopt.units import MM

if TYPE_CHECKING:
    from feedopt.run_data import LawResult, Prepared
    from feedopt.schedule.checks import Ramp


def _finite(x) -> float | None:
    """``x`` as a float, or None when it is NaN or infinite (JSON has no NaN)."""
    x = float(x)
    return x if np.isfinite(x) else None


def _material(prepared: Prepared) -> dict:
    """Name, coefficient source and calibrated speeds of the scenario's material file."""
    sc = prepared.scenario
    table = prepared.coefficient_table
    rpm = float(sc.cut.spindle_rpm)
    lo, hi = float(table.rpm[0]), float(table.rpm[-1])
    return {
        "name": table.material or None,
        "file": sc.material,
        "coefficient_source": table.source or None,
        "coefficient_tool": table.tool or None,
        "calibrated_rpm": table.rpm.tolist(),
        "coefficients_at_rpm": ("calibrated" if np.any(np.isclose(table.rpm, rpm, rtol=1e-9))
                                else "interpolated" if lo <= rpm <= hi else "extrapolated"),
    }


def program_summary(prepared: Prepared) -> dict | None:
    """For a G-code program path: the file, its moves, where the feed bound is lowest (by
    program line) and how far the smoothed path deviates from the program; None otherwise."""
    path = prepared.path
    moves = path.moves
    if moves is None:
        return None
    v = prepared.bound.v_max
    s = prepared.samples.s
    low, move = moves.lowest_cut(s, v)
    junctions = path.junctions
    worst = None
    if junctions is not None and len(junctions):
        k = int(np.argmax(junctions.deviation / junctions.tolerance))
        worst = {"junction": junctions.labels[k], "deviation_mm": junctions.deviation[k] / MM,
                 "tolerance_mm": junctions.tolerance[k] / MM}
    return {
        "file": prepared.scenario.path.file,
        "moves": len(moves),
        "moves_by_category": {c: int(np.sum(moves.category == c))
                              for c in ("cut", "plunge", "retract", "rapid")},
        "lowest_bound": {"line": int(moves.line[move]),
                         "n": None if moves.n_number[move] < 0 else int(moves.n_number[move]),
                         "label": moves.label(move), "s_mm": s[low] / MM,
                         "v_max_mm_s": v[low] / MM},
        "largest_deviation": worst,
        "stops": _stops(prepared.problem),
        "unmodelled_plunges": [
            {"label": moves.label(i), "line": int(moves.line[i])}
            for i in unmodelled_plunge_moves(moves, s, prepared.process.unmodelled_plunge)],
    }


def _stops(problem) -> list[dict]:
    """summary.json ``program.stops``: where the path stops, why and for how long."""
    stops = problem.stops
    if stops is None:
        return []
    return [{"kind": stops.kind[k], "label": stops.label[k],
             "s_mm": float(problem.s[stops.index[k]]) / MM, "hold_s": float(stops.hold_s[k])}
            for k in range(len(stops))]


def _redundancy(result) -> dict | None:
    """summary.json ``scenario.redundancy`` (robot.redundancy: optimise), or None."""
    if result is None:
        return None
    if hasattr(result, "summary"):  # feedopt.robot.extra_axis.ExtraAxisResult
        return result.summary()
    return {"status": result.status.value, "reason": result.reason,
            "objective": result.objective, "t_star_nearest_s": result.t_star_nearest,
            "t_star_s": result.t_star, "gain": result.gain,
            "knots_mm": (result.knot_s / MM).tolist(),
            "knots_psi_deg": np.degrees(result.knot_psi).tolist(),
            "evaluations": result.evaluations, "infeasible": result.infeasible,
            "seconds": result.seconds}


def scenario_summary(prepared: Prepared) -> dict:
    """The resolved inputs, in user units, for summary.json (design.md).

    Everything a reader of the report needs to know what job was planned: robot, stiffness,
    TCP, tool, material, cut, placement, feeds, limits and sampling (the report's inputs
    table is built from this dictionary alone).
    """
    from feedopt.export.frames import frames_summary
    from feedopt.schedule.tool_share import tool_bending_summary, tool_shape_summary

    sc, tool, model, robot = prepared.scenario, prepared.tool, prepared.model, prepared.robot
    c = model.coefficients
    problem = prepared.problem
    n = int(problem.n)
    cut = sc.cut
    profile = cut.radial_depth_profile
    return {
        "name": sc.name,
        "description": sc.description,
        "fits": sc.fit_notes(),
        "frames": frames_summary(robot),
        "redundancy": _redundancy(prepared.redundancy),
        "robot": {"name": robot.name, "directory": sc.robot.directory,
                  "stiffness_source": robot.sources.get("stiffness"),
                  "tool_source": robot.sources.get("tool")},
        "tool": {"name": tool.name, "diameter_mm": tool.diameter / MM, "teeth": tool.teeth,
                 "helix_deg": float(np.rad2deg(tool.helix)),
                 "flute_length_mm": tool.flute_length / MM, "file": sc.tool,
                 **tool_shape_summary(tool),
                 "bending": tool_bending_summary(tool, model, sc.feed.nominal_mm_s * MM)},
        "material": _material(prepared),
        "cut": {"type": cut.type, "axial_depth_mm": cut.axial_depth_mm,
                "radial_depth_mm": cut.radial_depth_mm,  # null: slot (full) or profile
                "radial_depth_profile": (None if profile is None
                                         else profile.model_dump(exclude_none=True)),
                "milling": cut.milling, "rpm": cut.spindle_rpm},
        "coefficients": {"ktc_n_m2": c.ktc, "krc_n_m2": c.krc, "kac_n_m2": c.kac,
                         "kte_n_m": c.kte, "kre_n_m": c.kre, "kae_n_m": c.kae},
        "deflection_limit_mm": sc.deflection.limit_mm,
        "limit_mode": sc.deflection.mode,
        "limit_direction": (None if sc.deflection.direction is None
                            else list(sc.deflection.direction)),
        "stiffness_set": sc.robot.stiffness,
        "stiffness_mnm_per_rad": (robot.stiffness[sc.robot.stiffness] / 1e6).tolist(),
        "tcp_offset_mm": (robot.tcp_offset[:3, 3] / MM).tolist(),
        "workpiece_position_mm": list(sc.workpiece.position_mm),
        "workpiece_rpy_deg": list(sc.workpiece.rpy_deg),
        "tool_axis": list(sc.workpiece.tool_axis) if prepared.path.orientation is None else None,
        "orientation": orientation_summary(prepared),
        "nominal_feed_mm_s": sc.feed.nominal_mm_s,
        "max_feed_mm_s": (sc.feed.max_mm_s if sc.feed.max_mm_s is not None
                          else sc.feed.nominal_mm_s),
        "max_feed_is_default": sc.feed.max_mm_s is None,
        "start_feed_mm_s": sc.feed.start_mm_s,
        "end_feed_mm_s": sc.feed.end_mm_s,
        "tangential_acceleration_mm_s2": sc.limits.tangential_acceleration_mm_s2,
        "tangential_jerk_mm_s3": sc.limits.tangential_jerk_mm_s3,
        "joint_velocity_scale": sc.limits.joint_velocity_scale,
        "joint_acceleration_scale": sc.limits.joint_acceleration_scale,
        "path": {"generator": sc.path.generator, "blend": sc.path.blend,
                 "blend_size_mm": sc.path.blend_size_mm, "segments": len(prepared.path.segments)},
        "program": program_summary(prepared),
        "stock": stock_summary(prepared),
        "path_length_mm": problem.length / MM,
        "samples": n,
        "sample_spacing_mm": problem.length / MM / max(n - 1, 1),
        "lower_bound_s": problem.lower_bound_time(),
        "active_constraints": prepared.bound.active_fraction(),
        "max_condition_number": float(np.max(prepared.ik.condition_number)),
        "stage_times_s": dict(prepared.stage_times),
    }


def orientation_summary(prepared: Prepared) -> dict | None:
    """A five-axis path's tool vectors in summary.json: how many, the angle tolerance and the
    largest deviation of the blends, the tilt from the workpiece's z, the range of the feed's
    lean along the tool axis while cutting (+: towards the spindle, the force model's
    ``Engagement.feed_axial``), the orientation limits; None on three-axis paths."""
    o = prepared.path.orientation
    if o is None:
        return None
    sc, samples = prepared.scenario, prepared.samples
    tilt = np.degrees(np.arccos(np.clip(samples.axis[:, 2], -1.0, 1.0)))
    lean = prepared.process.engagement.feed_axial  # the force model's, on cutting samples
    cutting = prepared.process.engagement.exit > prepared.process.engagement.entry
    lean_deg = (np.degrees(np.arcsin(lean[cutting])) if lean is not None and cutting.any()
                else np.zeros(1))
    return {"tool_vectors": int(o.knots.s.size), "blended": int(np.count_nonzero(o.half_window)),
            "tolerance_deg": sc.path.orientation_tolerance_deg,
            "largest_deviation_deg": float(np.degrees(o.deviation().max(initial=0.0))),
            "tilt_from_workpiece_z_deg": [float(tilt.min()), float(tilt.max())],
            "feed_lean_deg": [float(lean_deg.min()), float(lean_deg.max())],
            "rate_limit_deg_s": sc.limits.orientation_rate_deg_s,
            "acceleration_limit_deg_s2": sc.limits.orientation_acceleration_deg_s2}


def _orientation_replay(e) -> dict | None:
    """The replay's largest orientation rate and acceleration of a law (five-axis paths)."""
    if e is None:
        return None
    return {"max_rate_deg_s": float(np.degrees(e.rate)),
            "max_acceleration_deg_s2": float(np.degrees(e.acceleration)),
            "rate_ratio": _finite(e.rate_ratio),
            "acceleration_ratio": _finite(e.acceleration_ratio)}


def _json_ready(value: object) -> bool:
    try:
        json.dumps(value)
    except (TypeError, ValueError):
        return False
    return True


def _ramp(ramp: Ramp) -> dict:
    """A start or stop ramp in user units; ``feed_mm_s`` is the feed it reaches (start) or
    leaves from (stop), ``ends_by`` why it ends there (``flat``, ``bound``, ``path``)."""
    return {
        "length_mm": _finite(ramp.length / MM),
        "duration_s": _finite(ramp.duration),
        "feed_mm_s": _finite(ramp.feed / MM),
        "s_from_mm": _finite(ramp.s_from / MM),
        "s_to_mm": _finite(ramp.s_to / MM),
        "ends_by": ramp.reason,
    }


#: window over which the peak removal rate is averaged [m] (per sample the removed volume
#: fluctuates with the Z-map cells)
RATE_WINDOW = 1.0 * MM


def removal_rates(prepared: Prepared, feed: np.ndarray) -> np.ndarray | None:
    """Material removal rate [mm^3/s] per sample at the path feed ``feed`` [m/s]: the volume
    each sample's sweep step removed (over its arc length ds) times the feed, averaged over
    :data:`RATE_WINDOW`; its time integral is the removed volume. None without a stock."""
    material = prepared.process.material
    if material is None:
        return None
    s = prepared.samples.s
    removed = material.found.removed
    ds = np.diff(s, prepend=s[0])
    width = max(1, int(round(RATE_WINDOW / max(float(np.median(ds[1:])) if s.size > 1
                                               else RATE_WINDOW, 1e-12))))
    kernel = np.ones(width) / width
    per_length = np.convolve(removed, kernel, mode="same") / np.convolve(
        np.maximum(ds, 1e-300), kernel, mode="same")
    return per_length * np.asarray(feed, dtype=float) / MM**3


def stock_summary(prepared: Prepared) -> dict | None:
    """The stock of the run: shape, cells, volumes and how much of the path cuts."""
    material = prepared.process.material
    if material is None:
        return None
    sec = prepared.scenario.stock
    found = material.found
    dexel = isinstance(material, DexelMaterialAlongPath)
    grid = ({"model": "tri-dexel", "rays": list(material.before.rays),
             "dexel_mb": material.before.nbytes / 1e6} if dexel else
            {"model": "z-map", "cells": list(material.before.shape),
             "zmap_mb": material.before.nbytes / 1e6})
    return {
        "box_mm": None if sec.box_mm is None else list(sec.box_mm),
        "mesh": sec.mesh,
        "cell_mm": sec.cell_mm,
        **grid,
        "volume_before_mm3": material.before.volume() / MM**3,
        "volume_after_mm3": material.after.volume() / MM**3,
        "removed_mm3": material.removed_volume / MM**3,
        "cutting_fraction": float(np.mean(~found.in_air)),
        "max_axial_depth_mm": float(np.max(found.axial_depth)) / MM,
    }


def sample_place(prepared: Prepared, sample: int) -> dict:
    """Where path sample ``sample`` lies: its index, arc length [mm] and, on a G-code program
    path, the program line and label of its move (None otherwise)."""
    s = float(prepared.problem.s[sample])
    place = {"sample": int(sample), "s_mm": s / MM, "line": None, "label": None}
    moves = prepared.path.moves
    if moves is not None:
        move = int(moves.index_at(np.array([s]))[0])
        place.update(line=int(moves.line[move]), label=moves.label(move))
    return place


def surface_summary(ver) -> dict | None:
    """The replayed surface location errors of a law [mm] and the part tolerances: at every
    sample in mode surface, else at the samples where the part is measured (``samples``)."""
    surface = ver.surface
    if surface is None:
        return None

    def largest(values: np.ndarray) -> float | None:
        return float(np.nanmax(values)) / MM if np.any(np.isfinite(values)) else None

    wall_limit, floor_limit = ver.tolerances
    return {"max_wall_error_mm": largest(surface.worst_wall()),
            "max_floor_error_mm": largest(np.abs(surface.floor)),
            "wall_limit_mm": _finite(wall_limit / MM), "floor_limit_mm": _finite(floor_limit / MM),
            "samples": int(surface.index.size)}


def law_summary(prepared: Prepared, result: LawResult) -> dict:
    ver, timing = result.verification, result.verification.timing
    traj = result.trajectory
    mrr = removal_rates(prepared, ver.feed)
    removal = None if mrr is None else {
        "mean_mm3_s": prepared.process.material.removed_volume / MM**3 / traj.duration,
        "max_mm3_s": float(np.max(mrr)) + 0.0,
    }
    comp = result.compensation
    compensation = None if comp is None else {
        "iterations": comp.path.iterations, "converged": comp.path.converged,
        "last_change_mm": comp.path.change / MM, "max_offset_mm": comp.check.max_offset / MM,
        "fk_plus_mean_minus_nominal_mm": comp.check.max_error / MM,
        "lower_bound_s": comp.schedule.problem.lower_bound_time(),
    }
    return {
        "compensation": compensation,
        "material_removal_rate": removal,
        "cycle_time_s": traj.duration,
        "lower_bound_s": prepared.problem.lower_bound_time(),
        "time_over_lower_bound": traj.duration / prepared.problem.lower_bound_time(),
        "max_deflection_mm": ver.max_deflection / MM,
        "deflection_ratio": ver.deflection_ratio,
        # where the largest deflection is predicted (program line on a G-code path)
        "worst_deflection": sample_place(prepared, ver.worst_sample),
        "meets_limit": ver.meets_limit,
        # surface location error at the samples (feedopt.schedule.surface), material left > 0
        "surface": surface_summary(ver),
        "max_feed_mm_s": timing.max_feed / MM,
        # smallest feed between the start and stop ramps (schedule/checks.py find_ramps)
        "min_feed_mm_s": _finite(timing.min_cutting_feed / MM),
        "start_ramp": _ramp(timing.start_ramp),
        "stop_ramp": _ramp(timing.stop_ramp),
        "max_accel_mm_s2": timing.max_accel / MM,
        "max_jerk_mm_s3": timing.max_jerk / MM if traj.continuity >= 2 else None,
        "accel_jump_mm_s2": timing.accel_jump / MM,
        "c2": timing.c2,
        "joint_velocity_ratio": timing.joint_velocity_ratio,
        "joint_acceleration_ratio": timing.joint_acceleration_ratio,
        "orientation": _orientation_replay(timing.orientation),
        "verified": ver.verified,
        "problems": list(ver.problems),
        "notes": list(ver.warnings),
        "planning_time_s": result.planning_time,
        "verification_time_s": result.verification_time,
        "stats": {k: v for k, v in traj.stats.items() if _json_ready(v)},
    }
