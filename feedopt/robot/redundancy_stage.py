"""The redundancy stage of a run (``robot.redundancy: optimise``): which robots it can search
(:func:`check_redundancy`), and the search itself on the path sampled twice, coarse and at
the run's spacing (:func:`optimise_along_path`).

The sampled paths are duck-typed (the attributes of :class:`feedopt.run_data.Front`:
scenario, path, samples, placement, process) and so is the scenario's ``robot`` section:
the robot package imports neither the runner's data nor the scenario module.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel
from feedopt.robot.stage import RobotAlongPath, TcpPath, robot_along_path
from feedopt.robot.start import five_axis_x_axes, start_joints
from feedopt.schedule.stage import schedule_problem

__all__ = ["check_redundancy", "optimise_along_path"]


def check_redundancy(robot: RobotModel, redundancy: str) -> None:
    """InputError for ``robot.redundancy: optimise`` on a robot it cannot search: a 6-axis
    arm's is the rotation about the tool axis, a 7-axis robot's its extra axis
    (:meth:`RobotModel.held_axis`), which a 7-joint arm must name."""
    if redundancy != "optimise" or robot.dof == 6:
        return
    if robot.dof == 7 and robot.held_axis() is None:
        raise InputError(f"robot.redundancy: optimise holds the extra axis of a 7-axis robot; "
                         f"robot {robot.name} does not say which joint it is: add "
                         f"'extra_axis: <joint>' to its robot.yaml (one of "
                         f"{', '.join(robot.joint_names)}; a KUKA LBR: its third joint, the "
                         "controller's E1), or use redundancy: nearest")
    if robot.dof > 7:
        raise InputError(f"robot.redundancy: optimise searches one extra axis (6- and 7-axis "
                         f"robots); robot {robot.name} has {robot.dof} joints: use redundancy: "
                         "nearest (its extra axes follow the weighted nearest IK)")


def _task(robot: RobotModel, front: Any, along: RobotAlongPath):
    """The :class:`~feedopt.robot.redundancy.RedundancyTask` of one sampled path: its bound
    is the schedule stage with everything but the robot stage fixed."""
    from feedopt.robot.redundancy import RedundancyTask

    return RedundancyTask(
        front.samples.s, front.placement.positions, front.placement.tool_axes,
        lambda a: schedule_problem(front.scenario, front.process, robot, a, front.placement,
                                   front.samples, front.path), along)


def optimise_along_path(robot: RobotModel, coarse: Any, front: Any, nearest: RobotAlongPath,
                        progress: Callable[[int, int], None] | None = None):
    """The rotation about the tool axis psi(s) that lowers T*
    (:func:`feedopt.robot.redundancy.optimise_redundancy`; a 7-axis robot: its extra axis,
    :func:`feedopt.robot.extra_axis.choose_extra_axis`), searched on ``coarse`` (the path at
    the search spacing) and confirmed on ``front`` (the run's, with its ``nearest`` robot
    stage)."""
    from feedopt.robot.redundancy import RedundancyOptions, optimise_redundancy

    sc = front.scenario.robot
    opts = sc.redundancy_options
    q0 = start_joints(robot, sc.start_configuration_deg)
    axes = coarse.placement.tool_axes
    coarse_nearest = robot_along_path(robot, TcpPath(coarse.samples.s,
                                                     coarse.placement.positions, axes,
                                                     x_axes=five_axis_x_axes(robot, q0, axes)),
                                      q0, sc.stiffness)
    options = RedundancyOptions(objective=opts.objective, knots=opts.knots,
                                max_evaluations=opts.max_evaluations,
                                path_acceleration=opts.path_acceleration)
    search, final = _task(robot, coarse, coarse_nearest), _task(robot, front, nearest)
    if robot.dof == 7:
        from feedopt.robot.extra_axis import choose_extra_axis

        return choose_extra_axis(robot, robot.held_axis(), search, final, sc.stiffness,
                                 options, progress)
    return optimise_redundancy(robot, search, final, sc.stiffness, options, progress=progress)
