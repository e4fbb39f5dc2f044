"""A robot directory from a published URDF (``feedopt robot init URDF --out DIR``).

What a URDF tells: the serial chain, the joints' ranges and speeds, and the frames at the end
of the arm. What it does not: which frame is the flange and which way it points out of the
flange, the joint stiffness, the accelerations, the tool and the controller's axis
convention. :func:`inspect_urdf` finds the flange (a frame fixed to the last joint; its
outward direction is the last joint's axis, signed to point away from the wrist) and measures
how far it sits off that axis (CAD offsets, e.g. 0.24 mm on ROS-Industrial's KR210 tool0, are
tolerated below :data:`OFF_AXIS_TOLERANCE_MM`); :func:`robot_yaml_text` writes a robot.yaml
whose every guessed number is labelled a placeholder and repeated as a run warning.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError
from feedopt.robot.robot_file import CONTROLLERS
from feedopt.robot.urdf_chain import chain_model, check_arm, is_prismatic, mimic_joints
from feedopt.textio import read_user_bytes

#: Largest distance of the flange frame's origin from the last joint's axis that is taken for
#: a CAD offset [mm] (beyond it the frame is not on the flange).
OFF_AXIS_TOLERANCE_MM = 1.0
#: Preferred flange frame names, in order (ROS-Industrial: ``flange`` has +x out of the
#: flange, ``tool0`` +z; UR: ``tool0``, ``flange``; others: ``ee_link``).
FLANGE_NAMES = ("flange", "tool0", "ee_link", "link_ee", "end_effector")
#: Joint speeds robot init accepts from a URDF [deg/s or mm/s] (feedopt.robot.model's range).
SPEED_RANGE = (1e-3, 1e5)
#: The placeholder joint stiffness written [MN m/rad]: the order of a mid-size industrial
#: arm's (thesis Table 3.4: 0.14-3.93), labelled as such.
PLACEHOLDER_STIFFNESS = 1.0


@dataclass(frozen=True)
class UrdfSummary:
    """What :func:`inspect_urdf` read: ``joints`` (names), ``kinds`` ("revolute" or
    "prismatic"), ``lower``/``upper`` [deg or mm], ``speed`` [deg/s or mm/s] (0: not given),
    the ``flange`` frame, its ``outward`` unit vector (flange frame), ``off_axis_mm``, and the
    joints ``locked`` because they do not move the flange (:mod:`feedopt.robot.urdf_chain`)."""

    name: str
    joints: tuple[str, ...]
    kinds: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    speed: np.ndarray
    flange: str
    outward: np.ndarray
    off_axis_mm: float
    locked: tuple[str, ...] = ()


def _model(urdf: Path) -> pin.Model:
    try:
        model = pin.buildModelFromUrdf(str(urdf))
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"{urdf}: pinocchio could not read the URDF: {exc}") from None
    if model.njoints < 2:
        raise InputError(f"{urdf}: the URDF has no moving joint")
    return model


def _depth(model: pin.Model, joint: int) -> int:
    depth = 0
    while joint > 0:
        joint, depth = model.parents[joint], depth + 1
    return depth


def _flange_name(model: pin.Model, urdf: Path, flange: str | None) -> str:
    """The flange frame's name: ``flange`` if given (it must exist and move), else the first
    of :data:`FLANGE_NAMES` on a moving joint, else a frame on the deepest joint."""
    moving = [f for f in model.frames if f.parentJoint > 0 and f.type != pin.FrameType.JOINT]
    if flange is not None:
        if not model.existFrame(flange):
            names = ", ".join(f.name for f in moving[-12:])
            raise InputError(f"{urdf}: no frame '{flange}' (frames on moving links include "
                             f"{names})")
        if model.frames[int(model.getFrameId(flange))].parentJoint == 0:
            raise InputError(f"{urdf}: frame '{flange}' is fixed to the base; name the frame "
                             "at the end of the arm")
        return flange
    if not moving:
        raise InputError(f"{urdf}: no frame moves with a joint")
    for name in FLANGE_NAMES:
        if any(f.name == name for f in moving):
            return name
    # the last frame on the deepest joint (fixed frames follow their link's in the list)
    return max(reversed(moving), key=lambda f: _depth(model, f.parentJoint)).name


def _outward(model: pin.Model, fid: int, urdf: Path) -> tuple[np.ndarray, float]:
    """The last joint's axis in the flange frame, signed away from the wrist, and the
    flange origin's distance from that axis [mm], at the zero pose (clipped to the limits)."""
    data = model.createData()
    q = np.clip(np.zeros(model.nq), model.lowerPositionLimit, model.upperPositionLimit)
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    last = model.njoints - 1
    joint = data.oMi[last]
    if is_prismatic(model, last):
        raise InputError(f"{urdf}: the last joint '{model.names[last]}' is prismatic; a flange "
                         "turns with a revolute last joint (name the flange with --flange)")
    # the axis from the motion of a small turn of the last joint (any URDF axis, either sign)
    turned = q.copy()
    turned[model.joints[last].idx_q] += 1e-3
    moved = model.createData()
    pin.forwardKinematics(model, moved, turned)
    axis = pin.log3(joint.rotation.T @ moved.oMi[last].rotation) / 1e-3
    axis = joint.rotation @ (axis / np.linalg.norm(axis))
    flange = data.oMf[fid]
    wrist = data.oMi[last - 1].translation if last > 1 else joint.translation
    along = float((flange.translation - wrist) @ axis)
    if abs(along) < 1e-6:
        raise InputError(f"{urdf}: frame '{model.frames[fid].name}' sits at the wrist, not out "
                         "along the last joint's axis; name the flange with --flange FRAME")
    axis = axis * np.sign(along)
    rel = flange.translation - joint.translation
    off = float(np.linalg.norm(rel - (rel @ axis) * axis)) * 1e3
    if off > OFF_AXIS_TOLERANCE_MM:
        raise InputError(
            f"{urdf}: frame '{model.frames[fid].name}' sits {off:.2f} mm off the axis of the "
            f"last joint '{model.names[last]}' (more than the {OFF_AXIS_TOLERANCE_MM:g} mm a CAD "
            "offset may be): it is not the flange; name it with --flange FRAME")
    return flange.rotation.T @ axis, off


def inspect_urdf(urdf: Path, flange: str | None = None) -> UrdfSummary:
    """Read a URDF as :func:`feedopt.robot.model.load_robot` will: InputError naming the joint
    or frame for what feedopt cannot use."""
    model = _model(urdf)
    flange_name = _flange_name(model, urdf, flange)
    raw = read_user_bytes(urdf, "URDF")
    model, locked = chain_model(model, flange_name, urdf, mimic_joints(raw))
    check_arm(model, flange_name, urdf, locked, raw)
    joints, kinds, scale = [], [], []
    for j in range(1, model.njoints):
        prismatic = is_prismatic(model, j)
        joints.append(model.names[j])
        kinds.append("prismatic" if prismatic else "revolute")
        scale.append(1e3 if prismatic else 180.0 / np.pi)
    scale_arr = np.asarray(scale)
    lower = np.asarray(model.lowerPositionLimit) * scale_arr
    upper = np.asarray(model.upperPositionLimit) * scale_arr
    for name, lo, hi in zip(joints, lower, upper, strict=True):
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo >= hi:
            raise InputError(f"{urdf}: joint '{name}' has limits {lo:g} .. {hi:g}; it needs a "
                             "finite <limit lower upper> with lower < upper")
    fid = int(model.getFrameId(flange_name))
    if model.frames[fid].parentJoint != model.njoints - 1:  # a frame inside the arm
        raise InputError(f"{urdf}: frame '{flange_name}' is on joint "
                         f"'{model.names[model.frames[fid].parentJoint]}', not on the last "
                         f"joint '{model.names[model.njoints - 1]}' of its chain")
    outward, off = _outward(model, fid, urdf)
    return UrdfSummary(name=model.name or urdf.stem, joints=tuple(joints), kinds=tuple(kinds),
                       lower=lower, upper=upper,
                       speed=np.asarray(model.velocityLimit) * scale_arr,
                       flange=flange_name, outward=outward, off_axis_mm=off, locked=locked)


def tcp_rpy_deg(outward: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw [deg] of a TCP frame whose +z is ``-outward`` (from the tool tip
    into the spindle), its x the flange's x (or y) made perpendicular."""
    z = -np.asarray(outward, dtype=float) / np.linalg.norm(outward)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - (ref @ z) * z
    x /= np.linalg.norm(x)
    r = np.column_stack([x, np.cross(z, x), z])
    pitch = np.arcsin(np.clip(-r[2, 0], -1.0, 1.0))
    roll = np.arctan2(r[2, 1], r[2, 2])
    yaw = np.arctan2(r[1, 0], r[0, 0])
    return np.rad2deg([roll, pitch, yaw])


def _quoted(text: str) -> str:
    """``text`` as a YAML scalar that reads back as the same string (a JSON string is one):
    names like ``#1``, ``null``, ``a: b`` or ``123`` stay what they are."""
    return json.dumps(text, ensure_ascii=False)


def _numbers(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{round(float(v), 3) + 0.0:g}" for v in values) + "]"


def robot_yaml_text(summary: UrdfSummary, urdf_name: str, tool_length_mm: float,
                    controller: str) -> str:
    """robot.yaml for ``summary``: the URDF's numbers, every guess labelled a placeholder and
    repeated as a warning (:data:`PLACEHOLDER_STIFFNESS`, speed reached in 1 s, the tool)."""
    if controller not in CONTROLLERS:
        raise InputError(f"--controller must be one of {', '.join(CONTROLLERS)}, got "
                         f"{controller!r}")
    n = len(summary.joints)
    speed = summary.speed
    bad = [f"{j} ({s:g} {'mm/s' if k == 'prismatic' else 'deg/s'})"
           for j, s, k in zip(summary.joints, speed, summary.kinds, strict=True)
           if not SPEED_RANGE[0] <= round(float(s), 3) <= SPEED_RANGE[1]]
    if bad:
        raise InputError(f"{urdf_name}: <limit velocity> of {', '.join(bad)} is not a joint's "
                         f"speed ({SPEED_RANGE[0]:g} to {SPEED_RANGE[1]:g} deg/s or mm/s): "
                         "put the data sheet's speeds in the URDF (rad/s, m/s) before robot init")
    tcp = summary.outward * tool_length_mm
    units = "deg and deg/s" if "prismatic" not in summary.kinds else (
        "deg, deg/s for revolute joints; mm, mm/s for prismatic joints")
    lines = [
        f"# Written by feedopt robot init from {urdf_name}. Units: mm, {units}, MN m/rad.",
        "# Every number marked PLACEHOLDER must be replaced before its predictions mean anything.",
        f"name: {_quoted(summary.name)}",
        f"urdf: {_quoted(urdf_name)}",
        "controller:",
        f"  type: {controller}",
        "  # axes: the controller's convention (controller axis = sign * URDF joint + offset),",
        "  # e.g. a ROS-Industrial KUKA URDF: sign [-1, 1, 1, -1, 1, -1] or [1, ...],",
        "  # offset_deg [0, -90, 90, 0, 0, 0]. Check one pose against the pendant, then state it:",
        f"  # axes: {{sign: {[1] * n}, offset_deg: {[0] * n}}}",
        "warnings:",
        "  - >-",
        "    PLACEHOLDER joint stiffness (the same guess for every joint, not this robot's):",
        "    identify it (feedopt calibrate-stiffness) before trusting any deflection.",
        "  - >-",
        "    PLACEHOLDER joint accelerations (each joint reaches its URDF speed in 1 s).",
        "  - >-",
        f"    PLACEHOLDER tool: {tool_length_mm:g} mm coaxial with the last joint; measure yours.",
        f"kinematics_source: {urdf_name} (feedopt robot init)",
        f"joint_limits_source: {urdf_name} <limit>",
        f"# {summary.flange}: the flange frame; out of the flange is {_numbers(summary.outward)}"
        f" in it (the last joint's axis); its origin is {summary.off_axis_mm:.3f} mm off that "
        "axis.",
        f"flange_frame: {_quoted(summary.flange)}",
        "tool:",
        f"  tcp_xyz_mm: {_numbers(tcp)}",
        f"  tcp_rpy_deg: {_numbers(tcp_rpy_deg(summary.outward))}",
        "  source: PLACEHOLDER (feedopt robot init), a coaxial tool; TCP +z into the spindle",
        "joint_stiffness_mnm_per_rad:",
        f"  dpp: {_numbers(np.full(n, PLACEHOLDER_STIFFNESS))}",
        "  source: PLACEHOLDER (feedopt robot init); not this robot's stiffness",
        "joint_velocity_deg_s:",
        f"  values: {_numbers(speed)}",
        f"  source: {urdf_name} <limit velocity>",
        "joint_acceleration_deg_s2:",
        f"  values: {_numbers(speed)}",
        "  source: PLACEHOLDER (speed reached in 1 s)",
    ]
    return "\n".join(lines) + "\n"


def still_to_fill(summary: UrdfSummary, controller: str) -> list[str]:
    """What the user must still give, one line each (printed by the command)."""
    todo = ["joint_stiffness_mnm_per_rad: identify it (feedopt calibrate-stiffness)",
            "joint_acceleration_deg_s2: the data sheet's or measured accelerations",
            "tool: tcp_xyz_mm / tcp_rpy_deg of your spindle and tool on "
            f"'{summary.flange}', and its source",
            "warnings: remove each placeholder line once its numbers are real"]
    if controller == "kuka":
        todo.insert(0, "controller.axes: KUKA's axis convention for this URDF (no KRL or RSI "
                    "program is written without it)")
    if controller in ("abb", "fanuc"):
        todo.insert(0, f"controller.axes: {controller.upper()}'s axis convention for this URDF "
                    "(no program is written without it; an arm with a parallel linkage, e.g. "
                    "IRB 2400, M-20iA: coupled: [{axis: 3, joint: 2, factor: 1}])")
    return todo
