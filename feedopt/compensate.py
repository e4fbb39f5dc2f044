"""The compensation stage (``deflection.mode: residual``): each law planned again on the path
commanded so that the predicted mean deflection brings the tool back onto the nominal one,
replayed and checked (:func:`compensate`; the runner calls it after planning)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from feedopt.cell import fixed_x_axes
from feedopt.profiling import Progress, stderr_progress
from feedopt.robot.model import forward_kinematics
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes, start_joints
from feedopt.run_data import Compensated, LawResult, Prepared
from feedopt.schedule.compensation import check_compensation, compensation_fixed_point
from feedopt.schedule.laws import plan_law
from feedopt.schedule.stage import interior_stop_indices, schedule_problem, tip_compliance
from feedopt.units import MM
from feedopt.verify import replay_all

__all__ = ["compensate"]


def compensate(prepared: Prepared, results: dict[str, LawResult],
               progress: Progress = stderr_progress) -> dict[str, LawResult]:
    """``deflection.mode: residual``: plan each law on its compensated path.

    The commanded path is ``nominal - mean deflection`` at the law's feed, a fixed point
    (:func:`feedopt.schedule.compensation.compensation_fixed_point`) through the robot stage
    (IK and compliance at the commanded pose), the schedule stage (residual bound) and the
    law; the result is replayed on that compliance and checked: FK of the commanded joints
    plus the predicted mean deflection gives the nominal path.
    """
    sc, samples = prepared.scenario, prepared.samples
    nominal = prepared.placement.positions
    q_start = start_joints(prepared.robot, sc.robot.start_configuration_deg)
    x_axes = fixed_x_axes(prepared.placement, sc.robot.fix_tool_rotation)
    if x_axes is None:  # a five-axis path: as the run's robot stage (feedopt/runner.py)
        x_axes = five_axis_x_axes(prepared.robot, q_start, prepared.placement.tool_axes)
    red, ik_options = prepared.redundancy, None
    if getattr(red, "x_axes", None) is not None:  # keep the optimised psi(s)
        x_axes, q_start = red.x_axes, red.q_start
    if getattr(red, "ik_options", None) is not None:  # keep the held extra axis
        ik_options, q_start = red.ik_options, red.q_start
    out: dict[str, LawResult] = {}

    def along_at(commanded: np.ndarray) -> RobotAlongPath:
        path = TcpPath(samples.s, commanded, prepared.placement.tool_axes, x_axes=x_axes,
                       breaks=interior_stop_indices(prepared.path.stops, samples.s))
        return robot_along_path(prepared.robot, path, q_start, sc.robot.stiffness,
                                ik_options=ik_options)

    for law, res in results.items():
        t0 = time.perf_counter()

        def plan(commanded: np.ndarray, law: str = law):
            schedule = schedule_problem(sc, prepared.process, prepared.robot,
                                        along_at(commanded), prepared.placement, samples,
                                        prepared.path)
            traj = plan_law(law, schedule.problem, {}, options=sc.schedule.options_for(law))
            return traj.feed_at(samples.s), (schedule, traj)

        def mean_deflection(commanded: np.ndarray, planned):
            schedule, traj = planned
            along = along_at(commanded)
            model = dataclasses.replace(schedule.model, compliance=tip_compliance(
                along.compliance, prepared.process.tool, schedule.model.frames))
            return model.mean_deflection(traj.feed_at(samples.s)), (along, model)

        path = compensation_fixed_point(nominal, plan, mean_deflection)
        (schedule, traj), (along, model) = path.plan_state, path.pose_state
        ver, dt = replay_all({law: traj}, schedule.problem, model, schedule.limit,
                             tolerances=(schedule.wall_limit, schedule.floor_limit))[law]
        fk = forward_kinematics(prepared.robot, along.ik.q)[:, :3, 3]
        check = check_compensation(fk, model.mean_deflection(ver.feed), nominal)
        problems = list(ver.problems)
        if not path.converged:
            problems.append(f"compensation: the offset still changed by {path.change / MM:.3g} "
                            f"mm after {path.iterations} iterations")
        if check.problem():
            problems.append(check.problem())
        notes = list(ver.warnings)
        if path.feed_change > 0:
            notes.append(f"compensation: the law's plan still changed its feed by "
                         f"{path.feed_change:.2g} (relative) at its last re-plan; the exported "
                         "plan is the last one and the pose is solved for it")
        ver = dataclasses.replace(ver, problems=tuple(problems), warnings=tuple(notes),
                                  verified=ver.verified and len(problems) == len(ver.problems))
        out[law] = LawResult(trajectory=traj, verification=ver,
                             planning_time=res.planning_time + time.perf_counter() - t0 - dt,
                             verification_time=dt,
                             compensation=Compensated(path, along, schedule, check))
        progress(f"[5/5] {law}: compensated ({path.plans} plans, {path.iterations} pose "
                 f"iterations, last change {path.change / MM:.1e} mm), offset up to "
                 f"{check.max_offset / MM:.4f} mm, {traj.duration:.2f} s cycle, residual "
                 f"deflection {ver.max_deflection / MM:.4f} mm, FK + mean deflection - nominal "
                 f"{check.max_error / MM:.1e} mm, {ver.verdict.value}")
    return out
