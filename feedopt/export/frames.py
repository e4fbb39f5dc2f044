"""The frames every export refers to, stated once: TCP, flange, base and load of the cell,
and the moves onto and off the path along them (approach and retract up the TCP +z).

What an exported pose means (RSI CSV, KRL, URScript, G-code): the TCP frame of
``robot.yaml`` (:mod:`feedopt.robot.model`: at the tool tip, +z along the tool axis pointing
into the spindle, shared/design.md) in the robot base frame (the URDF's ``base_link``), in mm,
with KUKA A, B, C = intrinsic Z-Y'-X'' angles in deg (:mod:`feedopt.robot.kuka`). A controller
reproduces those poses only with the tool, base and load data written here.

KUKA (KSS 8.x), what the numbers refer to:

- ``$ROBROOT``: the robot foot, = the URDF's ``base_link`` (ROS-Industrial KUKA models: the
  ``base`` frame "base_link to KUKA $ROBROOT" is the identity).
- ``$FLANGE``: origin at the centre of the mounting flange, **+Z out of the flange** along
  A6 (ROS-Industrial's ``tool0``; ``kuka_experimental`` ``kr420r3330_macro.xacro``, the arm
  the KR500-3 model shares: "This frame corresponds to the $FLANGE coordinate system in KUKA
  KRC controllers", ``tool0`` = ``link_6`` turned by rpy (0, 90 deg, 0)). The URDF's ``flange``
  link follows ROS-Industrial's ``flange`` convention instead: **+X out of the flange**. So
  $FLANGE = URDF flange * Ry(+90 deg). :func:`controller_flange` finds which axis of the
  URDF flange points out of the flange from the kinematics, not from a name.
- ``TOOL_DATA[n]``: the TCP frame in $FLANGE. For the bundled KR500-3 (tool 400 mm along A6,
  TCP +z into the spindle): ``{X 0, Y 0, Z 400, A 180, B 0, C 180}``. KUKA's tool direction
  (``$TOOL_DIRECTION``, default #X) is then across the tool, not along it: jogging "in tool
  direction" moves sideways; programmed motions are unaffected.
- ``BASE_DATA[n]``: the poses are in $ROBROOT, so ``{X 0, Y 0, Z 0, A 0, B 0, C 0}``
  ($NULLFRAME) when $ROBROOT = $WORLD (KUKA's default for a floor-mounted robot without a
  linear unit); otherwise BASE_DATA must be $ROBROOT's pose in $WORLD.
- ``LOAD_DATA[n]``: ``{M, CM {X, Y, Z, A, B, C}, J {X, Y, Z}}`` (kg, mm/deg in $FLANGE,
  kg m^2). robot.yaml gives no load data: the values written are a labelled PLACEHOLDER,
  ``M -1`` (KUKA's value for "no load data entered": the controller's default load), which
  must be replaced by the measured spindle load (KUKA.LoadDataDetermination) before cutting.

Universal Robots: the base is the controller's base frame (DH frame 0, the URDF's
``base_link``), the flange the tool flange (DH frame 6, +z out of the flange, the URDF's
``flange``); the TCP is ``set_tcp(p[x, y, z, rx, ry, rz])`` in metres and a rotation vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError
from feedopt.export.job import ExportJob
from feedopt.robot.kuka import abc_from_rotation
from feedopt.robot.model import RobotModel, forward_kinematics
from feedopt.units import MM

#: $FLANGE in a URDF flange whose +x points out of the flange (ROS-Industrial ``flange`` ->
#: ``tool0``): a rotation by +90 deg about y, so that $FLANGE +Z = URDF flange +x.
_RY90 = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
#: |cos| above which the out-of-flange direction counts as along a flange axis.
_ALIGNED = 1.0 - 1e-9
#: A joint origin this close to the flange origin [m] does not tell where "out" is.
_SAME_POINT = 1e-3


@dataclass(frozen=True)
class Frame6:
    """A frame as KUKA writes it: X, Y, Z [mm] and A, B, C [deg] (intrinsic Z-Y'-X'')."""

    xyz_mm: tuple[float, float, float]
    abc_deg: tuple[float, float, float]

    @classmethod
    def from_transform(cls, t: np.ndarray) -> Frame6:
        """The frame of a homogeneous transform (4, 4) [m] (angles cleaned of -0 and 1e-15)."""
        xyz = np.round(np.asarray(t[:3, 3]) / MM, 9) + 0.0
        abc = np.round(abc_from_rotation(np.asarray(t[:3, :3])), 9) + 0.0
        return cls(tuple(map(float, xyz)), tuple(map(float, abc)))

    def values(self) -> tuple[float, ...]:
        """(X, Y, Z, A, B, C)."""
        return self.xyz_mm + self.abc_deg

    def krl(self) -> str:
        """KRL FRAME aggregate, e.g. ``{X 0.0,Y 0.0,Z 400.0,A 180.0,B 0.0,C 180.0}``."""
        return "{" + ",".join(f"{k} {_krl_real(v)}" for k, v in zip("XYZABC", self.values(),
                                                                    strict=True)) + "}"


@dataclass(frozen=True)
class LoadData:
    """KUKA LOAD: mass [kg] (-1: no data, the controller's default), centre of mass frame in
    $FLANGE, principal inertias [kg m^2]; ``placeholder`` says the numbers are not measured."""

    mass_kg: float
    centre_of_mass: Frame6
    inertia_kgm2: tuple[float, float, float]
    placeholder: bool
    source: str

    def krl(self) -> str:
        """KRL LOAD aggregate ``{M ..,CM {X ..,..},J {X ..,Y ..,Z ..}}``."""
        j = ",".join(f"{k} {_krl_real(v)}" for k, v in zip("XYZ", self.inertia_kgm2,
                                                          strict=True))
        return f"{{M {_krl_real(self.mass_kg)},CM {self.centre_of_mass.krl()},J {{{j}}}}}"


#: robot.yaml has no load data: KUKA's "not entered" value, labelled as such everywhere.
PLACEHOLDER_LOAD = LoadData(
    mass_kg=-1.0, centre_of_mass=Frame6((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    inertia_kgm2=(0.0, 0.0, 0.0), placeholder=True,
    source="PLACEHOLDER: robot.yaml gives no load data; M -1 is KUKA's 'no load data entered' "
           "(the controller uses its default load). Enter the spindle's measured mass, centre "
           "of mass and inertia (KUKA.LoadDataDetermination) before cutting.")


@dataclass(frozen=True)
class CellFrames:
    """The frames and data that make the exported poses right (see the module docstring).

    controller : robot.yaml's controller family
    flange_name : the controller's name of its flange frame ($FLANGE, tool flange, flange)
    flange_in_urdf : (4, 4) the controller's flange frame in the URDF flange frame
    urdf_flange_out_axis : "+x" or "+z": the URDF flange axis pointing out of the flange
    tool : TCP frame in the controller's flange (KUKA TOOL_DATA)
    base : robot base in the controller's reference (KUKA BASE_DATA, $ROBROOT = $WORLD)
    load : KUKA LOAD_DATA (a placeholder unless measured)
    tcp_pose_ur : UR ``set_tcp`` pose: x, y, z [m], rotation vector [rad]
    """

    controller: str
    flange_name: str
    flange_in_urdf: np.ndarray
    urdf_flange_out_axis: str
    tool: Frame6
    base: Frame6
    load: LoadData
    tcp_pose_ur: tuple[float, ...]


def _krl_real(x: float) -> str:
    """A KRL REAL literal: fixed point, at most 6 decimals, always with a decimal point."""
    text = f"{float(x):.6f}".rstrip("0")
    text = text + "0" if text.endswith(".") else text
    return "0.0" if text in ("-0.0", "0.0") else text


def controller_flange(robot: RobotModel) -> tuple[np.ndarray, str]:
    """The controller's flange frame (+Z out of the flange) in the URDF flange frame.

    "Out of the flange" is measured on the kinematics at q = 0: the direction from the last
    joint origin that is not at the flange origin (the wrist centre of a KUKA, wrist 3 of a
    UR) to the flange origin, which must lie along the last joint's axis. When it is the URDF
    flange's +x (ROS-Industrial KUKA ``flange``) the controller flange is that frame turned by
    Ry(+90 deg) (ROS-Industrial ``tool0``); when it is +z (UR's DH frame 6) they coincide.

    Returns the (4, 4) rotation-only transform and ``"+x"`` or ``"+z"``. Raises InputError
    for any other flange convention (the TOOL_DATA would be a guess).
    """
    model = robot.model
    data = model.createData()
    q = np.zeros(robot.dof)
    pin.forwardKinematics(model, data, q)
    tcp = pin.updateFramePlacement(model, data, robot.tcp_frame_id).homogeneous
    flange = tcp @ np.linalg.inv(robot.tcp_offset)
    origin = flange[:3, 3]
    out = None
    for j in range(model.njoints - 1, 0, -1):
        d = origin - data.oMi[j].translation
        if np.linalg.norm(d) > _SAME_POINT:
            out = d / np.linalg.norm(d)
            break
    jac = pin.computeJointJacobians(model, data, q)
    axis = jac[3:, model.joints[model.njoints - 1].idx_v]
    if out is None or abs(float(out @ axis)) < _ALIGNED * np.linalg.norm(axis):
        raise InputError(f"robot {robot.name}: cannot tell which way its flange frame points "
                         "out of the flange (no joint origin behind the flange on the last "
                         "joint's axis at q = 0); state the TCP with tcp_frame in robot.yaml")
    local = flange[:3, :3].T @ out
    rot = np.eye(4)
    if local[0] > _ALIGNED:
        rot[:3, :3] = _RY90
        return rot, "+x"
    if local[2] > _ALIGNED:
        return rot, "+z"
    raise InputError(
        f"robot {robot.name}: its flange frame points out of the flange along "
        f"{np.round(local, 6).tolist()} (flange axes), neither +x (ROS-Industrial 'flange') nor "
        "+z ('tool0', UR); feedopt cannot state the controller's tool data for it")


def _rotation_vector(r: np.ndarray) -> np.ndarray:
    """Axis-angle vector [rad] of a rotation matrix (UR pose convention)."""
    return np.asarray(pin.log3(np.asarray(r, dtype=float)))


def cell_frames(robot: RobotModel) -> CellFrames:
    """The :class:`CellFrames` of ``robot`` (its controller family from robot.yaml)."""
    flange_rot, out_axis = controller_flange(robot)
    tool_in_flange = np.linalg.inv(flange_rot) @ robot.tcp_offset
    rv = _rotation_vector(tool_in_flange[:3, :3])
    tcp_ur = tuple(float(v) for v in np.round(np.concatenate([tool_in_flange[:3, 3], rv]), 9))
    name = {"kuka": "$FLANGE", "ur": "tool flange", "abb": "tool0",
            "fanuc": "faceplate"}.get(robot.controller, "flange")
    return CellFrames(
        controller=robot.controller, flange_name=name, flange_in_urdf=flange_rot,
        urdf_flange_out_axis=out_axis, tool=Frame6.from_transform(tool_in_flange),
        base=Frame6((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), load=PLACEHOLDER_LOAD,
        tcp_pose_ur=tcp_ur)


def frames_header_lines(robot: RobotModel) -> list[str]:
    """The lines every export header carries (without comment marks): what the poses are
    and the tool, base and load data that make them right on the controller."""
    return header_lines(cell_frames(robot))


def header_lines(f: CellFrames) -> list[str]:
    """:func:`frames_header_lines` of already computed :class:`CellFrames`."""
    x, y, z = f.tool.xyz_mm
    lines = [
        "frames: poses are the TCP in the robot base frame (URDF base_link"
        + (" = KUKA $ROBROOT" if f.controller == "kuka" else "")
        + "), mm; A,B,C = KUKA intrinsic Z-Y'-X'' angles, deg (R = Rz(A) Ry(B) Rx(C)).",
        "TCP frame: origin at the tool tip, +z along the tool axis pointing into the spindle "
        "(robot.yaml tool.tcp_xyz_mm / tcp_rpy_deg on the URDF flange frame).",
        f"URDF flange frame: +{f.urdf_flange_out_axis[1]} out of the flange; the controller's "
        f"{f.flange_name} has +Z out of the flange"
        + (" ($FLANGE = URDF flange turned by Ry(+90 deg), ROS-Industrial tool0)."
           if f.urdf_flange_out_axis == "+x" else " (the same frame)."),
    ]
    if f.controller == "ur":
        tx, ty, tz, rx, ry, rz = f.tcp_pose_ur
        lines.append(f"UR TCP: set_tcp(p[{tx:g}, {ty:g}, {tz:g}, {rx:.6f}, {ry:.6f}, {rz:.6f}]) "
                     "(m, rotation vector, in the tool flange frame). Poses are in the URDF's "
                     "base_link: the controller's Base when the URDF is built on UR's DH frame "
                     "0 (the bundled UR10); ur_description's base_link is turned 180 deg about "
                     "z from the controller's Base (its 'base' frame), so there X and Y change "
                     "sign.")
        return lines
    if f.controller != "kuka":  # generic: no controller data to write, no KUKA names
        lines.append(f"tool: TCP at {x:g}, {y:g}, {z:g} mm from the flange centre in "
                     f"{f.flange_name} (the controller's own tool, base and load data are "
                     "yours to set).")
        return lines
    lines += [
        f"TOOL_DATA = {f.tool.krl()} (TCP in {f.flange_name}: {x:g}, {y:g}, {z:g} mm from the "
        "flange centre).",
        f"BASE_DATA = {f.base.krl()} ($NULLFRAME: right when $ROBROOT = $WORLD; otherwise "
        "BASE_DATA = $ROBROOT in $WORLD).",
        f"LOAD_DATA = {f.load.krl()} ({f.load.source})",
    ]
    return lines


def frames_summary(robot: RobotModel) -> dict:
    """The frames as a JSON-ready dict for summary.json (``"frames"``)."""
    f = cell_frames(robot)
    return {
        "pose": "TCP in the robot base frame (URDF base_link), mm; A,B,C = KUKA Z-Y'-X'' deg",
        "tcp": "tool tip, +z along the tool axis into the spindle",
        "controller": f.controller,
        "controller_flange": f.flange_name,
        "urdf_flange_out_of_flange_axis": f.urdf_flange_out_axis,
        "flange_in_urdf_flange_rpy_deg": [
            float(v) + 0.0 for v in np.round(abc_from_rotation(f.flange_in_urdf[:3, :3])[::-1],
                                             9)],
        "tool_data": dict(zip("XYZABC", f.tool.values(), strict=True)),
        "base_data": dict(zip("XYZABC", f.base.values(), strict=True)),
        "base_data_valid_when": "$ROBROOT = $WORLD",
        "load_data": {"M": f.load.mass_kg,
                      "CM": dict(zip("XYZABC", f.load.centre_of_mass.values(), strict=True)),
                      "J": dict(zip("XYZ", f.load.inertia_kgm2, strict=True)),
                      "placeholder": f.load.placeholder, "source": f.load.source},
        "ur_tcp_pose": list(f.tcp_pose_ur) if f.controller == "ur" else None,
    }


def joints_at_offsets(robot: RobotModel, q_start: np.ndarray, offsets_m: np.ndarray,
                      step_m: float = 1e-3) -> np.ndarray:
    """Joint angles that move the TCP from its pose at ``q_start`` by each of ``offsets_m``.

    The TCP keeps its orientation and travels in straight lines start -> offset 1 -> offset 2
    ... (base frame, [m]), solved by the path IK every ``step_m`` from ``q_start`` so the
    configuration stays on the start's branch (what a CP motion between them would do).

    Returns (k, dof) joint angles [rad], one row per offset. Raises InputError (from the IK)
    when a pose is out of reach, past a joint limit or through a singularity.
    """
    from feedopt.robot.ik import solve_path_ik

    offsets = np.atleast_2d(np.asarray(offsets_m, dtype=float))
    pose = forward_kinematics(robot, np.asarray(q_start, dtype=float))
    corners = np.vstack([np.zeros(3), offsets])
    pieces, ends = [], []
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step_m)) + 1)
        pieces.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    points = pieces[0]
    for piece in pieces[1:]:
        ends.append(points.shape[0] - 1)
        points = np.vstack([points, piece[1:]])
    ends.append(points.shape[0] - 1)
    k = points.shape[0]
    ik = solve_path_ik(robot, pose[:3, 3] + points, np.tile(pose[:3, 2], (k, 1)),
                       np.asarray(q_start, dtype=float), x_axes=np.tile(pose[:3, 0], (k, 1)))
    return np.asarray(ik.q)[ends]


#: Approach / retract height above the lead-in / lead-out point along the tool axis [mm] and
#: the lead-in / lead-out lengths along the path tangent [mm] of the native programs.
APPROACH_MM = 50.0
LEAD_IN_MM = 10.0
LEAD_OUT_MM = 10.0


@dataclass(frozen=True)
class EntryExit:
    """How the tool gets to the path and away from it: poses X, Y, Z [mm], A, B, C [deg] in
    the robot base frame and their joints [rad] (on the path ends' configuration branch).

    above_lead_in : :data:`APPROACH_MM` above the lead-in point along the tool axis
    lead_in : the path start moved back :data:`LEAD_IN_MM` along the start tangent
    lead_out : the path end moved on :data:`LEAD_OUT_MM` along the end tangent
    retract : :data:`APPROACH_MM` above the lead-out point
    approach_axes_deg : the controller's axis values of ``q_above_lead_in`` [deg] (robot.yaml
        ``controller.axes``), what a PTP to it writes
    """

    above_lead_in: np.ndarray
    lead_in: np.ndarray
    lead_out: np.ndarray
    retract: np.ndarray
    q_above_lead_in: np.ndarray
    q_lead_in: np.ndarray
    q_lead_out: np.ndarray
    q_retract: np.ndarray
    approach_axes_deg: np.ndarray


def entry_exit(job: ExportJob) -> EntryExit:
    """The :class:`EntryExit` of ``job``'s path: "up" is the TCP +z (into the spindle, away
    from the work), the orientations those of the path ends. InputError (from the IK) when a
    pose is out of reach, past a joint limit or through a singularity."""
    length = job.problem.length
    ds = min(1e-4, 0.5 * length)
    p = job.path_in_base(np.array([0.0, ds, length - ds, length]))
    t0 = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    t1 = (p[3] - p[2]) / np.linalg.norm(p[3] - p[2])
    q_ends = job.q_of_s(np.array([0.0, length]))
    fk = forward_kinematics(job.robot, q_ends)
    back = -LEAD_IN_MM * MM * t0
    on = LEAD_OUT_MM * MM * t1
    up0, up1 = APPROACH_MM * MM * fk[0, :3, 2], APPROACH_MM * MM * fk[1, :3, 2]
    q_in = joints_at_offsets(job.robot, q_ends[0], np.array([back, back + up0]))
    q_out = joints_at_offsets(job.robot, q_ends[1], np.array([on, on + up1]))

    def pose(t: np.ndarray, d_m: np.ndarray) -> np.ndarray:
        return np.concatenate([(t[:3, 3] + d_m) / MM, abc_from_rotation(t[:3, :3])])

    return EntryExit(above_lead_in=pose(fk[0], back + up0), lead_in=pose(fk[0], back),
                     lead_out=pose(fk[1], on), retract=pose(fk[1], on + up1),
                     q_above_lead_in=q_in[1], q_lead_in=q_in[0], q_lead_out=q_out[0],
                     q_retract=q_out[1],
                     approach_axes_deg=job.robot.axis_convention.to_controller(q_in[1]))


def entry_exit_or_retract(job: ExportJob) -> tuple[EntryExit | None, np.ndarray, str | None]:
    """:func:`entry_exit` where it is reachable (None otherwise), the fallback retract of a
    program without it (:data:`APPROACH_MM` up the tool axis at the last controller sample
    [mm, base frame]) and why there is no entry (None when there is one)."""
    q_end = job.q_of_s(np.array([job.samples.motion.s[-1]]))[0]
    end = forward_kinematics(job.robot, q_end)
    try:
        return entry_exit(job), APPROACH_MM * end[:3, 2], None
    except InputError as exc:
        return None, APPROACH_MM * end[:3, 2], str(exc)
