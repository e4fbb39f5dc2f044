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

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError
from feedopt.robot.frames import transform_from_xyz_rpy
from feedopt.textio import read_user_bytes
from feedopt.units import MM
from feedopt.yamlio import read_yaml

TCP_FRAME_NAME = "feedopt_tcp"
#: Controller families a robot.yaml may name (``controller:``); ``generic`` gets no native
#: program, only the RSI-style setpoint CSV.
CONTROLLERS = ("kuka", "ur", "generic")
#: robot.yaml gives joint stiffness in MN m/rad, speeds and accelerations in deg.
_NM_PER_MNM = 1e6
_RAD_PER_DEG = np.pi / 180.0
#: Ranges a robot.yaml number must lie in (beyond them it is a typo or garbage, and its SI
#: value or reciprocal overflows downstream): joint stiffness [MNm/rad] (a small cobot's
#: ~0.01 to a large robot's ~10), speed [deg/s], acceleration [deg/s^2], TCP offset [mm]
#: and angles [deg].
STIFFNESS_RANGE_MNM = (1e-6, 1e6)
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


def _values(doc: dict, key: str, dof: int, scale: float, where: Path,
            bounds: tuple[float, float], unit: str) -> tuple[np.ndarray, str]:
    """Read ``key`` as ``{values: [...], source: ...}`` (or a bare list) within ``bounds``,
    scaled to SI."""
    if key not in doc:
        raise InputError(f"{where}: missing field '{key}' ({dof} values with a 'source:' line)")
    entry = doc[key]
    source = ""
    if isinstance(entry, dict):
        source = str(entry.get("source", ""))
        entry = entry.get("values")
    arr = _as_vector(entry, dof, f"{where}: {key}")
    if np.any(arr <= 0):
        raise InputError(f"{where}: {key} must be positive, got {arr.tolist()}")
    _in_range(arr, bounds, f"{where}: {key}", unit)
    return arr * scale, source


def _as_vector(entry: object, dof: int, what: str) -> np.ndarray:
    try:
        arr = np.asarray(entry, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what}: expected {dof} numbers, got {entry!r}") from exc
    if arr.shape != (dof,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{what}: expected {dof} finite numbers, got {entry!r}")
    return arr


def _tool_transform(tool: dict, where: Path) -> np.ndarray:
    """Flange -> TCP transform (4, 4) [m] from ``tool.tcp_xyz_mm`` and ``tool.tcp_rpy_deg``."""
    xyz = _as_vector(tool.get("tcp_xyz_mm", [0, 0, 0]), 3, f"{where}: tool.tcp_xyz_mm") * MM
    rpy = _as_vector(tool.get("tcp_rpy_deg", [0, 0, 0]), 3, f"{where}: tool.tcp_rpy_deg")
    _in_range(xyz / MM, (-MAX_TCP_OFFSET_MM, MAX_TCP_OFFSET_MM), f"{where}: tool.tcp_xyz_mm",
              "mm")
    _in_range(rpy, (-MAX_TCP_ANGLE_DEG, MAX_TCP_ANGLE_DEG), f"{where}: tool.tcp_rpy_deg", "deg")
    return transform_from_xyz_rpy(xyz, rpy)


def _read_robot_yaml(directory: Path) -> tuple[dict, Path]:
    """``robot.yaml`` of ``directory`` as a mapping, and its path."""
    yaml_path = directory / "robot.yaml"
    if not os.path.lexists(yaml_path):  # a FIFO, a loop, a folder: the reader says which
        raise InputError(f"{directory}: no robot.yaml found (a robot directory needs one)")
    doc = read_yaml(yaml_path, "robot file") or {}
    if not isinstance(doc, dict):
        raise InputError(f"{yaml_path}: expected a mapping at the top level")
    return doc, yaml_path


def _read_kinematics(doc: dict, directory: Path, yaml_path: Path) -> tuple[pin.Model, Path]:
    """The pinocchio model of the URDF that ``robot.yaml`` names, and its path."""
    if "urdf" not in doc:
        raise InputError(f"{yaml_path}: missing field 'urdf' (file name of the URDF)")
    urdf = doc["urdf"]
    if not isinstance(urdf, str) or not urdf.strip():
        raise InputError(f"{yaml_path}: urdf must be the file name of the URDF, got {urdf!r}")
    urdf_path = directory / urdf
    try:
        found = urdf_path.is_file()
    except OSError as exc:  # e.g. a name too long for the file system
        raise InputError(f"{yaml_path}: urdf {urdf!r}: {exc.strerror or exc}") from None
    if not found and not os.path.lexists(urdf_path):
        raise InputError(f"{yaml_path}: urdf file '{urdf_path}' does not exist")
    read_user_bytes(urdf_path, "URDF")  # a FIFO, device, loop or oversized file: its message
    try:
        model = pin.buildModelFromUrdf(str(urdf_path))
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"{urdf_path}: pinocchio could not read the URDF: {exc}") from exc
    if model.nv != model.nq:
        raise InputError(f"{urdf_path}: only revolute/prismatic joints are supported (nq != nv)")
    return model, urdf_path


def _add_tcp_frame(
    model: pin.Model, doc: dict, yaml_path: Path, urdf_path: Path
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
    tool = doc.get("tool") or {}
    if not isinstance(tool, dict):
        raise InputError(f"{yaml_path}: 'tool' must be a mapping")
    if "tcp_frame" in doc:
        name = str(doc["tcp_frame"])
        if not model.existFrame(name):
            raise InputError(f"{yaml_path}: tcp_frame '{name}' is not a frame of {urdf_path.name}")
        source = str(tool.get("source", f"TCP frame '{name}' of the URDF"))
        return int(model.getFrameId(name)), np.eye(4), source
    flange = str(doc.get("flange_frame", ""))
    if not flange or not model.existFrame(flange):
        raise InputError(
            f"{yaml_path}: give 'tcp_frame' or a 'flange_frame' that exists in "
            f"{urdf_path.name} (got {flange!r})"
        )
    fid = int(model.getFrameId(flange))
    tcp_offset = _tool_transform(tool, yaml_path)
    parent = model.frames[fid]
    placement = parent.placement * pin.SE3(tcp_offset[:3, :3], tcp_offset[:3, 3])
    frame = pin.Frame(TCP_FRAME_NAME, parent.parentJoint, fid, placement, pin.FrameType.OP_FRAME)
    return int(model.addFrame(frame)), tcp_offset, str(tool.get("source", "not stated"))


def _read_stiffness(doc: dict, dof: int, yaml_path: Path) -> tuple[dict[str, np.ndarray], str]:
    """Joint stiffness sets [N m/rad] by name, and their source."""
    stiff_doc = doc.get("joint_stiffness_mnm_per_rad")
    if not isinstance(stiff_doc, dict):
        raise InputError(
            f"{yaml_path}: missing 'joint_stiffness_mnm_per_rad' mapping "
            "(e.g. cp: [...], dpp: [...])"
        )
    stiffness = {}
    for key, val in stiff_doc.items():
        if key == "source":
            continue
        arr = _as_vector(val, dof, f"{yaml_path}: joint_stiffness_mnm_per_rad.{key}")
        if np.any(arr <= 0):
            raise InputError(f"{yaml_path}: joint_stiffness_mnm_per_rad.{key} must be > 0")
        _in_range(arr, STIFFNESS_RANGE_MNM, f"{yaml_path}: joint_stiffness_mnm_per_rad.{key}",
                  "MNm/rad")
        stiffness[str(key)] = arr * _NM_PER_MNM
    if not stiffness:
        raise InputError(f"{yaml_path}: joint_stiffness_mnm_per_rad has no stiffness set")
    return stiffness, str(stiff_doc.get("source", "not stated"))


def _read_position_limits(model: pin.Model, urdf_path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Joint position limits [rad] from the URDF's ``<limit>``."""
    q_lower = np.asarray(model.lowerPositionLimit, dtype=float).copy()
    q_upper = np.asarray(model.upperPositionLimit, dtype=float).copy()
    if np.any(~np.isfinite(q_lower)) or np.any(~np.isfinite(q_upper)) or np.any(q_lower >= q_upper):
        raise InputError(f"{urdf_path}: every joint needs a finite <limit lower upper>")
    return q_lower, q_upper


def _read_controller_and_warnings(doc: dict, yaml_path: Path) -> tuple[str, tuple[str, ...]]:
    """Controller family and the data warnings (whitespace collapsed)."""
    controller = doc.get("controller", "generic")
    if controller not in CONTROLLERS:
        raise InputError(f"{yaml_path}: controller must be one of {', '.join(CONTROLLERS)}, "
                         f"got {controller!r}")
    warnings = doc.get("warnings", [])
    if not isinstance(warnings, list) or not all(isinstance(w, str) for w in warnings):
        raise InputError(f"{yaml_path}: warnings must be a list of sentences (strings)")
    return controller, tuple(" ".join(w.split()) for w in warnings)


def load_robot(directory: str | Path) -> RobotModel:
    """Load a robot directory (``robot.yaml`` + the URDF it names) into a :class:`RobotModel`.

    Phases: read ``robot.yaml``; kinematics (URDF); TCP frame; joint stiffness; joint limits
    (speed, acceleration, position); controller and data warnings.

    Raises
    ------
    InputError
        Missing files or fields, wrong vector lengths, non-positive stiffness or limits.
    """
    directory = Path(directory)
    doc, yaml_path = _read_robot_yaml(directory)
    model, urdf_path = _read_kinematics(doc, directory, yaml_path)
    dof = int(model.nq)
    sources: dict[str, str] = {
        "kinematics": str(doc.get("kinematics_source", f"URDF {urdf_path.name}")),
        "joint_limits": str(doc.get("joint_limits_source", f"URDF {urdf_path.name} <limit>")),
    }
    tcp_frame_id, tcp_offset, sources["tool"] = _add_tcp_frame(model, doc, yaml_path, urdf_path)
    stiffness, sources["stiffness"] = _read_stiffness(doc, dof, yaml_path)
    vel, sources["joint_velocity"] = _values(doc, "joint_velocity_deg_s", dof, _RAD_PER_DEG,
                                             yaml_path, VELOCITY_RANGE_DEG_S, "deg/s")
    acc, sources["joint_acceleration"] = _values(doc, "joint_acceleration_deg_s2", dof,
                                                 _RAD_PER_DEG, yaml_path,
                                                 ACCELERATION_RANGE_DEG_S2, "deg/s^2")
    q_lower, q_upper = _read_position_limits(model, urdf_path)
    controller, data_warnings = _read_controller_and_warnings(doc, yaml_path)
    return RobotModel(
        name=str(doc.get("name", directory.name)),
        model=model,
        tcp_frame_id=tcp_frame_id,
        q_lower=q_lower,
        q_upper=q_upper,
        joint_velocity_max=vel,
        joint_acceleration_max=acc,
        stiffness=stiffness,
        tcp_offset=tcp_offset,
        sources=sources,
        joint_names=tuple(model.names[i] for i in range(1, model.njoints)),
        controller=controller,
        data_warnings=data_warnings,
    )


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
