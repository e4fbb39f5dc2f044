"""Robot description: URDF kinematics (pinocchio) + ``robot.yaml`` (stiffness, limits, tool).

A robot directory holds a URDF and a ``robot.yaml``::

    name: kuka_kr500_3
    urdf: kr500_3.urdf
    flange_frame: flange            # or tcp_frame: <frame already in the URDF>
    tool: {tcp_xyz_mm: [400, 0, 0], tcp_rpy_deg: [0, -90, 0], source: "..."}
    joint_stiffness_mnm_per_rad: {cp: [6 values], dpp: [6 values], source: "..."}
    joint_velocity_deg_s: {values: [6 values], source: "..."}
    joint_acceleration_deg_s2: {values: [6 values], source: "..."}
    kinematics_source: "..."        # optional: where the URDF numbers come from
    joint_limits_source: "..."      # optional: where the URDF joint ranges come from

Units are converted to SI here, once. The TCP frame sits at the tool tip with +z along the
tool axis, pointing into the spindle (shared/design.md); ``tool.tcp_rpy_deg`` are URDF-style
fixed-axis roll-pitch-yaw angles of the TCP frame in the flange frame.
"""

from __future__ import annotations

import difflib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError
from feedopt.robot.axes import AxisConvention, axis_convention
from feedopt.robot.frames import transform_from_xyz_rpy
from feedopt.robot.robot_file import (
    CONTROLLERS,
    RobotFile,
    SourcedValues,
    ToolSection,
    parse_robot_file,
    stiffness_unit_mistake,
)
from feedopt.robot.urdf_chain import chain_model, check_arm, is_prismatic, mimic_joints
from feedopt.textio import read_user_bytes
from feedopt.units import MM
from feedopt.yamlio import read_yaml

TCP_FRAME_NAME = "feedopt_tcp"
__all__ = ["CONTROLLERS", "RobotModel", "load_robot"]
#: robot.yaml gives joint stiffness in MN m/rad, speeds and accelerations in deg.
_NM_PER_MNM = 1e6
_RAD_PER_DEG = np.pi / 180.0
#: Ranges a robot.yaml number must lie in (beyond them it is a typo or garbage, and its SI
#: value overflows downstream): speed [deg/s], acceleration [deg/s^2], TCP offset [mm] and
#: angles [deg]. Joint stiffness: feedopt.robot.robot_file.STIFFNESS_PLAUSIBLE_MNM.
VELOCITY_RANGE_DEG_S = (1e-3, 1e5)
ACCELERATION_RANGE_DEG_S2 = (1e-3, 1e7)
MAX_TCP_OFFSET_MM = 1e4
MAX_TCP_ANGLE_DEG = 360.0


@dataclass(frozen=True)
class RobotModel:
    """A serial robot with its tool, joint limits and joint stiffness (SI units, radians).

    Attributes
    ----------
    name : str
        Robot name (from ``robot.yaml``).
    model : pin.Model
        Pinocchio kinematic model; ``tcp_frame_id`` names the TCP frame in it.
    tcp_frame_id : int
        Frame index of the TCP (added to ``model`` for the tool when needed).
    q_lower, q_upper : (dof,) arrays
        Joint position limits [rad].
    joint_velocity_max, joint_acceleration_max : (dof,) arrays
        Symmetric joint speed [rad/s] and acceleration [rad/s^2] limits.
    stiffness : dict[str, (dof,) array]
        Joint stiffness sets, e.g. ``{"cp": ..., "dpp": ...}`` [N m/rad] (thesis Table 3.4).
    tcp_offset : (4, 4) array
        Homogeneous transform flange -> TCP [m] (identity when ``tcp_frame`` is used and no
        flange is named).
    sources : dict[str, str]
        Where each group of numbers comes from.
    joint_names : tuple of str
        Names of the actuated joints, in configuration order.
    controller : str
        Controller family from ``robot.yaml`` (one of :data:`CONTROLLERS`): which native
        programs can be exported (a KRL program only for ``kuka``).
    data_warnings : tuple of str
        ``robot.yaml``'s ``warnings:``: caveats on its numbers (placeholders, unverified
        sources) that every run with this robot repeats in its output, summary and report.
    extra_axis : int or None
        ``robot.yaml``'s ``extra_axis``: the index of the joint of a 7-axis robot that
        ``robot.redundancy: optimise`` holds (:mod:`feedopt.robot.extra_axis`); None: not
        stated (an arm on a track: its prismatic joint, :meth:`held_axis`).
    """

    name: str
    model: pin.Model
    tcp_frame_id: int
    q_lower: np.ndarray
    q_upper: np.ndarray
    joint_velocity_max: np.ndarray
    joint_acceleration_max: np.ndarray
    stiffness: dict[str, np.ndarray]
    tcp_offset: np.ndarray
    sources: dict[str, str]
    joint_names: tuple[str, ...] = field(default=())
    controller: str = "generic"
    data_warnings: tuple[str, ...] = field(default=())
    axes: AxisConvention | None = None
    extra_axis: int | None = None

    def held_axis(self) -> int | None:
        """The joint a 7-axis robot holds for ``robot.redundancy: optimise``: robot.yaml's
        ``extra_axis``, else the one prismatic joint of an arm on a track; None for a
        6-axis arm or when it is not stated."""
        if self.dof != 7:
            return None
        if self.extra_axis is not None:
            return self.extra_axis
        prismatic = np.flatnonzero(self.axis_convention.prismatic)
        return int(prismatic[0]) if prismatic.size == 1 else None

    @property
    def axis_convention(self) -> AxisConvention:
        """The controller's axis convention (identity in deg when robot.yaml states none)."""
        if self.axes is not None:
            return self.axes
        return AxisConvention.identity(np.full(self.dof, np.pi / 180.0))

    @property
    def dof(self) -> int:
        """Number of joints."""
        return int(self.model.nq)


# --------------------------------------------------------------------------- loading


def _in_range(arr: np.ndarray, bounds: tuple[float, float], what: str, unit: str) -> None:
    """InputError naming ``what`` unless every value of ``arr`` lies in ``bounds``."""
    lo, hi = bounds
    if not np.all((arr >= lo) & (arr <= hi)):
        raise InputError(f"{what}: every value must be between {lo:g} and {hi:g} {unit}, got "
                         f"{arr.tolist()}")


def _per_joint(values: list[float], robot_joints: tuple[str, ...], what: str) -> np.ndarray:
    """``values`` as an array, InputError unless there is one per joint (named)."""
    arr = np.asarray(values, dtype=float)
    if arr.shape != (len(robot_joints),):
        raise InputError(f"{what}: expected {len(robot_joints)} values, one per joint "
                         f"({', '.join(robot_joints)}), got {len(values)}")
    return arr


def _scales(model: pin.Model) -> tuple[np.ndarray, tuple[str, ...]]:
    """Per joint, robot.yaml unit -> SI (deg -> rad for revolute, mm -> m for prismatic
    joints) and the joints' names."""
    names, scale = [], []
    for j in range(1, model.njoints):
        names.append(model.names[j])
        scale.append(MM if is_prismatic(model, j) else _RAD_PER_DEG)
    return np.asarray(scale), tuple(names)


def _limit_values(entry: SourcedValues, key: str, names: tuple[str, ...], scale: np.ndarray,
                  where: Path, bounds: tuple[float, float], unit: str) -> tuple[np.ndarray, str]:
    """A speed or acceleration list, one per joint within ``bounds``, scaled to SI."""
    arr = _per_joint(entry.values, names, f"{where}: {key}")
    _in_range(arr, bounds, f"{where}: {key}", unit)
    return arr * scale, entry.source


def _tool_transform(tool: ToolSection, where: Path) -> np.ndarray:
    """Flange -> TCP transform (4, 4) [m] from ``tool.tcp_xyz_mm`` and ``tool.tcp_rpy_deg``."""
    xyz = np.asarray(tool.tcp_xyz_mm, dtype=float)
    rpy = np.asarray(tool.tcp_rpy_deg, dtype=float)
    _in_range(xyz, (-MAX_TCP_OFFSET_MM, MAX_TCP_OFFSET_MM), f"{where}: tool.tcp_xyz_mm", "mm")
    _in_range(rpy, (-MAX_TCP_ANGLE_DEG, MAX_TCP_ANGLE_DEG), f"{where}: tool.tcp_rpy_deg", "deg")
    return transform_from_xyz_rpy(xyz * MM, rpy)


def _read_robot_yaml(directory: Path) -> tuple[RobotFile, Path]:
    """``robot.yaml`` of ``directory``, validated, and its path."""
    yaml_path = directory / "robot.yaml"
    if not os.path.lexists(yaml_path):  # a FIFO, a loop, a folder: the reader says which
        raise InputError(f"{directory}: no robot.yaml found (a robot directory needs one)")
    return parse_robot_file(read_yaml(yaml_path, "robot file") or {}, yaml_path), yaml_path


def _read_kinematics(doc: RobotFile, directory: Path, yaml_path: Path
                     ) -> tuple[pin.Model, Path, tuple[str, ...]]:
    """The pinocchio model of the arm in the URDF that ``robot.yaml`` names (joints that do
    not move the flange or TCP frame locked, :mod:`feedopt.robot.urdf_chain`), the URDF's
    path and the names of the locked joints."""
    urdf = doc.urdf
    if not urdf.strip():
        raise InputError(f"{yaml_path}: urdf must be the file name of the URDF, got {urdf!r}")
    urdf_path = directory / urdf
    try:
        found = urdf_path.is_file()
    except OSError as exc:  # e.g. a name too long for the file system
        raise InputError(f"{yaml_path}: urdf {urdf!r}: {exc.strerror or exc}") from None
    if not found and not os.path.lexists(urdf_path):
        raise InputError(f"{yaml_path}: urdf file '{urdf_path}' does not exist")
    raw = read_user_bytes(urdf_path, "URDF")  # a FIFO, device, loop, oversized: its message
    try:
        model = pin.buildModelFromUrdf(str(urdf_path))
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"{urdf_path}: pinocchio could not read the URDF: {exc}") from exc
    frame = doc.tcp_frame or doc.flange_frame or ""
    locked: tuple[str, ...] = ()
    if model.existFrame(frame):  # else _add_tcp_frame names the frames there are
        if model.frames[int(model.getFrameId(frame))].parentJoint == 0:
            raise InputError(f"{yaml_path}: frame '{frame}' is fixed to the base (no joint moves "
                             "it); name the frame at the end of the arm (e.g. 'flange' or "
                             "'tool0')")
        model, locked = chain_model(model, frame, urdf_path, mimic_joints(raw))
        check_arm(model, frame, urdf_path, locked, raw)
    if model.nv != model.nq:
        odd = [model.names[j] for j in range(1, model.njoints)
               if model.joints[j].nq != model.joints[j].nv]
        raise InputError(f"{urdf_path}: joint(s) {', '.join(odd)} are continuous (unbounded "
                         "revolute); only revolute joints with <limit lower upper> and "
                         "prismatic joints are supported: give each a finite range")
    return model, urdf_path, locked


def _add_tcp_frame(
    model: pin.Model, doc: RobotFile, yaml_path: Path, urdf_path: Path
) -> tuple[int, np.ndarray, str]:
    """The TCP frame, either one already in the URDF (``tcp_frame``) or the flange
    frame + the tool transform (added to ``model`` as :data:`TCP_FRAME_NAME`).

    Returns
    -------
    tcp_frame_id : int
    tcp_offset : (4, 4) array
        Flange -> TCP [m] (identity for ``tcp_frame``).
    source : str
        Where the tool numbers come from.
    """
    frames = [f.name for f in model.frames]
    if doc.tcp_frame is not None:
        name = doc.tcp_frame
        if not model.existFrame(name):
            raise InputError(f"{yaml_path}: tcp_frame '{name}' is not a frame of "
                             f"{urdf_path.name}{_nearest(name, frames)}")
        return int(model.getFrameId(name)), np.eye(4), doc.tool.source
    flange = doc.flange_frame or ""
    if not model.existFrame(flange):
        raise InputError(f"{yaml_path}: flange_frame '{flange}' is not a frame of "
                         f"{urdf_path.name}{_nearest(flange, frames)}")
    fid = int(model.getFrameId(flange))
    parent = model.frames[fid]
    if parent.parentJoint == 0:
        raise InputError(f"{yaml_path}: flange_frame '{flange}' is fixed to the base (no joint "
                         "moves it); name the frame at the end of the arm (e.g. 'flange' or "
                         "'tool0')")
    tcp_offset = _tool_transform(doc.tool, yaml_path)
    placement = parent.placement * pin.SE3(tcp_offset[:3, :3], tcp_offset[:3, 3])
    frame = pin.Frame(TCP_FRAME_NAME, parent.parentJoint, fid, placement, pin.FrameType.OP_FRAME)
    return int(model.addFrame(frame)), tcp_offset, doc.tool.source


def _nearest(name: str, names: list[str]) -> str:
    close = difflib.get_close_matches(name, names, n=1)
    return f" (did you mean '{close[0]}'?)" if close else f" (its frames: {', '.join(names[1:])})"


def _read_stiffness(doc: RobotFile, names: tuple[str, ...], yaml_path: Path
                    ) -> tuple[dict[str, np.ndarray], str]:
    """Joint stiffness sets [N m/rad, N/m for prismatic joints] by name, and their source
    (the plausible range is checked by the schema)."""
    stiffness = {}
    for key, values in doc.stiffness_sets().items():
        what = f"{yaml_path}: joint_stiffness_mnm_per_rad.{key}"
        arr = _per_joint(values, names, what)
        for name, v in zip(names, arr, strict=True):
            if v <= 0:
                raise InputError(f"{what}: joint {name} is {v:g}; stiffness must be > 0")
            hint = stiffness_unit_mistake(float(v))
            if hint:
                raise InputError(f"{what}: joint {name} is {v:g} MN m/rad, {hint}")
        stiffness[key] = arr * _NM_PER_MNM
    return stiffness, str(doc.joint_stiffness_mnm_per_rad.get("source", "not stated"))


def _read_position_limits(model: pin.Model, urdf_path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Joint position limits [rad, m] from the URDF's ``<limit>``, naming a bad joint."""
    q_lower = np.asarray(model.lowerPositionLimit, dtype=float).copy()
    q_upper = np.asarray(model.upperPositionLimit, dtype=float).copy()
    for j in range(q_lower.size):
        name = model.names[j + 1] if j + 1 < model.njoints else str(j)
        if not (np.isfinite(q_lower[j]) and np.isfinite(q_upper[j])):
            raise InputError(f"{urdf_path}: joint '{name}' needs a finite <limit lower upper>")
        if q_lower[j] >= q_upper[j]:
            raise InputError(f"{urdf_path}: joint '{name}' has lower limit {q_lower[j]:g} >= "
                             f"upper limit {q_upper[j]:g}: swap them (URDF units: rad, m)")
    return q_lower, q_upper


def load_robot(directory: str | Path) -> RobotModel:
    """Load a robot directory (``robot.yaml`` + the URDF it names) into a :class:`RobotModel`.

    Phases: read and validate ``robot.yaml`` (:mod:`feedopt.robot.robot_file`); kinematics
    (URDF); TCP frame; joint stiffness; joint limits (speed, acceleration, position);
    controller axis convention.

    Raises
    ------
    InputError
        Missing files or fields, wrong vector lengths, non-positive stiffness or limits.
    """
    directory = Path(directory)
    doc, yaml_path = _read_robot_yaml(directory)
    model, urdf_path, locked = _read_kinematics(doc, directory, yaml_path)
    scale, names = _scales(model)
    sources: dict[str, str] = {
        "kinematics": (doc.kinematics_source or f"URDF {urdf_path.name}") + (
            f"; joints locked (they do not move the tool): {', '.join(locked)}" if locked
            else ""),
        "joint_limits": doc.joint_limits_source or f"URDF {urdf_path.name} <limit>",
    }
    tcp_frame_id, tcp_offset, sources["tool"] = _add_tcp_frame(model, doc, yaml_path, urdf_path)
    stiffness, sources["stiffness"] = _read_stiffness(doc, names, yaml_path)
    vel, sources["joint_velocity"] = _limit_values(
        doc.joint_velocity_deg_s, "joint_velocity_deg_s", names, scale, yaml_path,
        VELOCITY_RANGE_DEG_S, "deg/s")
    acc, sources["joint_acceleration"] = _limit_values(
        doc.joint_acceleration_deg_s2, "joint_acceleration_deg_s2", names, scale, yaml_path,
        ACCELERATION_RANGE_DEG_S2, "deg/s^2")
    q_lower, q_upper = _read_position_limits(model, urdf_path)
    return RobotModel(
        name=doc.name or directory.name,
        model=model,
        tcp_frame_id=tcp_frame_id,
        q_lower=q_lower,
        q_upper=q_upper,
        joint_velocity_max=vel,
        joint_acceleration_max=acc,
        stiffness=stiffness,
        tcp_offset=tcp_offset,
        sources=sources,
        joint_names=names,
        controller=doc.controller.type,
        data_warnings=tuple(" ".join(w.split()) for w in doc.warnings),
        axes=axis_convention(doc.controller.axes, names, scale, yaml_path),
        extra_axis=_extra_axis(doc, names, yaml_path),
    )


def _extra_axis(doc: RobotFile, names: tuple[str, ...], yaml_path: Path) -> int | None:
    """robot.yaml's ``extra_axis`` as a joint index (InputError naming the joints)."""
    if doc.extra_axis is None:
        return None
    if len(names) != 7:
        raise InputError(f"{yaml_path}: extra_axis '{doc.extra_axis}' is for 7-axis robots; "
                         f"this one has {len(names)} joints ({', '.join(names)}): remove it")
    if doc.extra_axis not in names:
        close = difflib.get_close_matches(doc.extra_axis, list(names), n=1)
        hint = f"did you mean '{close[0]}'? " if close else ""
        raise InputError(f"{yaml_path}: extra_axis '{doc.extra_axis}' is not a joint; "
                         f"{hint}the joints are {', '.join(names)}")
    return names.index(doc.extra_axis)


def six_axes_only(robot: RobotModel, what: str) -> str | None:
    """Why ``what`` (a controller program) cannot be written for ``robot``: it has other than
    6 joints (a 7-axis arm, an arm on a track); None for a 6-axis robot."""
    if robot.dof == 6:
        return None
    return (f"no {what}: robot {robot.name} has {robot.dof} joints "
            f"({', '.join(robot.joint_names)}); it is written for 6-axis arms (external axes "
            "E1.. are not written); the setpoint CSV has every joint")


# --------------------------------------------------------------------------- kinematics


def _as_configs(robot: RobotModel, q: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (robot.dof,):
        raise InputError(f"joint configuration must have {robot.dof} values, got shape {q.shape}")
    lead = q.shape[:-1]
    return np.ascontiguousarray(q.reshape(-1, robot.dof)), lead


def forward_kinematics(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """TCP poses (..., 4, 4) in the base frame [m] for configurations ``q`` (..., dof) [rad]."""
    qs, lead = _as_configs(robot, q)
    model, data, fid = robot.model, robot.model.createData(), robot.tcp_frame_id
    out = np.empty((qs.shape[0], 4, 4))
    for i, qi in enumerate(qs):
        pin.forwardKinematics(model, data, qi)
        out[i] = pin.updateFramePlacement(model, data, fid).homogeneous
    return out.reshape(lead + (4, 4))


def tcp_jacobians(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """TCP Jacobians (..., 6, dof) in the base-aligned TCP frame (LOCAL_WORLD_ALIGNED).

    Rows are ``[v; w]``: linear velocity of the TCP point and angular velocity, both in base
    axes, so a base-frame wrench ``[f; m]`` at the TCP maps to joint torques ``J^T [f; m]``.
    """
    qs, lead = _as_configs(robot, q)
    model, data, fid = robot.model, robot.model.createData(), robot.tcp_frame_id
    out = np.empty((qs.shape[0], 6, robot.dof))
    for i, qi in enumerate(qs):
        out[i] = pin.computeFrameJacobian(model, data, qi, fid, pin.LOCAL_WORLD_ALIGNED)
    return out.reshape(lead + (6, robot.dof))


def jacobian_condition_number(jacobians: np.ndarray, length_scale: float = 1.0) -> np.ndarray:
    """Condition number sigma_max / sigma_min of Jacobians (..., 6, dof).

    The angular rows are multiplied by ``length_scale`` [m] so that both halves have units of
    length (thesis 3.4: K_c is negligible far from singularity, i.e. small condition number).
    """
    j = np.array(jacobians, dtype=float, copy=True)
    j[..., 3:, :] *= length_scale
    s = np.linalg.svd(j, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)
