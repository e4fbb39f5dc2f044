"""RSI cell files of a law: the corrections, the RSI host program and the Ethernet configuration.

RSI does not replay absolute poses: the KRL host program drives to the trajectory's start,
switches RSI on and hands the motion to the sensor (``RSI_MOVECORR()``), which sends each
cycle's correction from the pose at ``RSI_ON`` (:mod:`feedopt.rsi.corrections`). Per exported
law this writes

- ``<law>_rsi.csv``: the RKorr of every cycle, absolute mode (the total correction from the
  pose at RSI_ON), with that pose, the frame and the cycle in its header;
- ``<law>_rsi.src``: the host program (KSS 8.x, RSI 3.x/4.x): INI, ``$TOOL`` / ``$BASE`` /
  ``$LOAD`` (the TOOL_DATA / BASE_DATA / LOAD_DATA of :mod:`feedopt.export.frames`, whose
  header lines both files carry), the native KRL program's entry
  (:func:`feedopt.export.frames.entry_exit`: a PTP ``APPROACH_MM`` above the lead-in point,
  the spindle on by the same :class:`feedopt.export.krl.SpindleControl`, a slow LIN down
  and the lead-in LIN along the start tangent to the pose at RSI_ON),
  ``RSI_CREATE`` / ``RSI_SETPUBLICPAR`` (correction limits sized for this trajectory) /
  ``RSI_ON(#ABSOLUTE, #IPO_FAST)`` (``#IPO`` at 12 ms) / ``RSI_MOVECORR()`` / ``RSI_OFF`` /
  ``RSI_DELETE``, then the native program's exit: lead-out, retract up the tool axis,
  spindle off (where the entry is out of reach: a PTP to the start and a ``LIN_REL``
  retract, the reason in the header);
- ``feedopt_rsi_ethernet.xml``: the ETHERNET object's configuration (``IP_NUMBER`` / ``PORT``
  of the PC running ``feedopt stream``, ``SENTYPE``, SEND: ``DEF_RIst`` ``DEF_RSol``
  ``DEF_AIPos`` ``DEF_ASPos`` ``DEF_Delay``; RECEIVE: ``RKorr.X..C`` with ``HOLDON="1"`` and
  ``Stop``). The same for every law; ``feedopt_rsi_ethernet_axis.xml`` the same with axis
  corrections ``AK.A1..A6`` (``feedopt stream --correction axis``; the host program's
  correction limits are set on the POSCORR objects, so a context with an AXISCORR object
  sets its limits in RSI Visual).

Followed: KUKA Hungaria's kuka-external-control-sdk (``krc_setup/kss/KRC/R1/Program/RSI/
rsi_joint_pos_4ms.src`` and ``_12ms.src``: ``RSI_ON(#ABSOLUTE, #IPO_FAST)`` / ``#IPO``,
``RSI_DELETE``; ``rsi_helper.src``: ``RSI_SetPublicPar`` on correction limits;
``rsi_ethernet.xml``: the ``Stop`` element) and ROS-Industrial kuka_experimental
(``kuka_rsi_hw_interface/krl/KR_C4/ros_rsi.src``, ``ros_rsi_ethernet.xml``: INI,
``RSI_CREATE`` / ``RSI_ON`` / ``RSI_MOVECORR`` / ``RSI_OFF``, the configuration's elements
and HOLDON). The RSI context itself (``feedopt_rsi.rsix``, made with RSI Visual) is not
generated: the program's header lists the objects it needs.

The corrections are those of ``<law>.csv``: the same poses, computed the same way
(:func:`law_plan`), so ``feedopt stream <law>.csv`` and ``<law>_rsi.csv`` agree.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import (
    APPROACH_MM,
    LEAD_IN_MM,
    LEAD_OUT_MM,
    EntryExit,
    cell_frames,
    entry_exit_or_retract,
    header_lines,
)
from feedopt.export.job import Blocker, Exporter, ExportJob, header_notes, status_line
from feedopt.export.krl import SpindleControl
from feedopt.robot.axes import UNSTATED_AXES
from feedopt.robot.model import six_axes_only
from feedopt.rsi.corrections import (
    CorrectionMode,
    CorrectionPlan,
    plan_from_poses,
    step_sizes,
    wrap_deg,
    write_corrections_csv,
)
from feedopt.rsi.protocol import DEFAULT_SEN_TYPE, AnswerFormat, CorrectionSpace
from feedopt.units import MM_PER_M

#: Name of the RSI context the host program creates (RSI_CREATE; the user's .rsix).
RSI_CONTEXT = "feedopt_rsi"
#: The Ethernet configuration file (the context's ETHERNET object's ConfigFile).
ETHERNET_CONFIG = "feedopt_rsi_ethernet.xml"
#: The same for axis corrections (``feedopt stream --correction axis``, an AXISCORR object).
ETHERNET_CONFIG_AXIS = "feedopt_rsi_ethernet_axis.xml"
#: Port written into the configuration: ``feedopt stream``'s default ``--listen`` port.
DEFAULT_PORT = 49152
#: Placeholder for the IP of the PC running ``feedopt stream`` (RSI_CREATE fails until set).
IP_PLACEHOLDER = "ip.of.the.stream.pc"
#: Names of the context's correction objects the host program sets limits on.
POSCORR_OBJECT = "PosCorr_1"
POSCORRMON_OBJECT = "PosCorrMon_1"
#: Speed of the LIN from above the start down to it [m/s] (the distance is frames.APPROACH_MM).
APPROACH_VEL_M_S = 0.01
#: Margin added to the trajectory's correction range in the limits (room for the PID).
LIMIT_MARGIN_MM = 5.0
LIMIT_MARGIN_DEG = 2.0
_PROGRAM_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,23}$")


def ethernet_config_xml(ip: str = IP_PLACEHOLDER, port: int = DEFAULT_PORT,
                        sen_type: str = DEFAULT_SEN_TYPE,
                        mode: CorrectionMode = CorrectionMode.ABSOLUTE,
                        space: CorrectionSpace = CorrectionSpace.CARTESIAN) -> str:
    """The ETHERNET object's configuration (``RSI_EthernetConfig.xml`` format).

    ``HOLDON="1"`` (a late answer keeps the last correction) for absolute mode; ``"0"`` for
    relative mode, where holding would repeat the last increment every late cycle. Axis
    corrections are ``AK.A1`` .. ``AK.A6`` (ROS-Industrial's ``ros_rsi_ethernet.xml``) for a
    context whose outputs feed an AXISCORR object; Cartesian ones ``RKorr.X`` .. ``.C``.
    """
    holdon = 1 if mode is CorrectionMode.ABSOLUTE else 0
    fmt = AnswerFormat.default(space, sen_type)
    how = ": stream with correction axis" if space is CorrectionSpace.AXIS else ""
    rkorr = "\n".join(
        f'         <ELEMENT TAG="{fmt.element}.{a}" TYPE="DOUBLE" INDX="{i}" '
        f'HOLDON="{holdon}" />' for i, a in enumerate(fmt.names, start=1))
    return f"""<ROOT>
   <!-- Generated by feedopt: RSI Ethernet configuration for feedopt stream ({mode.value} mode,
        {space.value} corrections{how}).
        Copy to C:\\KRC\\ROBOTER\\Config\\User\\Common\\SensorInterface and name it as the
        ConfigFile of the ETHERNET object in the RSI context {RSI_CONTEXT}.rsix. -->
   <CONFIG>
      <IP_NUMBER>{ip}</IP_NUMBER>   <!-- the PC running feedopt stream: its listen IP -->
      <PORT>{port}</PORT>   <!-- and its listen port -->
      <SENTYPE>{sen_type}</SENTYPE>   <!-- the Type of its answers (feedopt stream sen-type) -->
      <ONLYSEND>FALSE</ONLYSEND>
   </CONFIG>
   <SEND>
      <ELEMENTS>
         <ELEMENT TAG="DEF_RIst" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_RSol" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_AIPos" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_ASPos" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_Delay" TYPE="LONG" INDX="INTERNAL" />
      </ELEMENTS>
   </SEND>
   <RECEIVE>
      <ELEMENTS>
         <ELEMENT TAG="DEF_EStr" TYPE="STRING" INDX="INTERNAL" />
{rkorr}
         <ELEMENT TAG="Stop" TYPE="BOOL" INDX="7" HOLDON="0" />
      </ELEMENTS>
   </RECEIVE>
</ROOT>
"""


def _num(x: float, decimals: int = 4) -> str:
    text = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "", "-") else text


def _checked(call: str) -> list[str]:
    return [f"ret = {call}", "IF (ret <> RSIOK) THEN", "  HALT", "ENDIF"]


def correction_limits(plan: CorrectionPlan) -> dict[tuple[str, str], float]:
    """``{(object, parameter): value}``: POSCORR limits covering the trajectory's corrections
    plus a margin, and the POSCORRMON totals (translation norm, rotation angle)."""
    lo = plan.absolute.min(axis=0)
    hi = plan.absolute.max(axis=0)
    out: dict[tuple[str, str], float] = {}
    for i, axis in enumerate("XYZ"):
        out[(POSCORR_OBJECT, f"LowerLim{axis}")] = float(np.floor(lo[i] - LIMIT_MARGIN_MM))
        out[(POSCORR_OBJECT, f"UpperLim{axis}")] = float(np.ceil(hi[i] + LIMIT_MARGIN_MM))
    rot = float(np.ceil(np.abs(plan.absolute[:, 3:]).max(initial=0.0) + LIMIT_MARGIN_DEG))
    out[(POSCORR_OBJECT, "MaxRotAngle")] = rot
    trans = float(np.linalg.norm(plan.absolute[:, :3], axis=1).max(initial=0.0))
    out[(POSCORRMON_OBJECT, "MaxTrans")] = float(np.ceil(trans + LIMIT_MARGIN_MM))
    out[(POSCORRMON_OBJECT, "MaxRotAngle")] = rot
    return out


def _axes(q_deg: np.ndarray) -> str:
    return "{" + ", ".join(f"A{i + 1} {_num(q)}" for i, q in enumerate(q_deg)) + "}"


def _frame(pose: np.ndarray) -> str:
    p = np.concatenate([pose[:3], wrap_deg(pose[3:])])
    return "{" + ", ".join(f"{a} {_num(v)}" for a, v in zip("XYZABC", p, strict=True)) + "}"


def _header(name: str, law: str, plan: CorrectionPlan, comments: tuple[str, ...]) -> list[str]:
    cycle_ms = round(plan.cycle_s * 1e3)
    return [f"DEF {name}( )", ";FOLD feedopt header",
            "; Generated by feedopt: RSI host program, sensor-guided motion (thesis 3.6.2).",
            *(f"; {line}" for c in comments for line in str(c).encode(
                "ascii", "backslashreplace").decode("ascii").splitlines()),
            f"; The motion comes from the sensor: feedopt stream {law}.csv --listen IP:PORT",
            f"; (or your own program sending {name}.csv), absolute mode, every {cycle_ms} ms.",
            "; On the controller, C:\\KRC\\ROBOTER\\Config\\User\\Common\\SensorInterface needs:",
            f";  - {ETHERNET_CONFIG} (written beside this file; set IP_NUMBER);",
            f";  - the RSI context {RSI_CONTEXT}.rsix (RSI Visual): an ETHERNET object with",
            f";    ConfigFile {ETHERNET_CONFIG}, outputs 1-6 (RKorr X..C) into a POSCORR object",
            f";    {POSCORR_OBJECT} (RefCorrSys #BASE; LowerLim/UpperLim X Y Z and MaxRotAngle",
            ";    public), output 7 (Stop) into a STOP object, and a POSCORRMON",
            f";    {POSCORRMON_OBJECT} (MaxTrans, MaxRotAngle public). The limits are set below",
            ";    for this trajectory.",
            f"; Pose at RSI_ON (row 0 of {law}.csv): {_frame(plan.start_pose)[1:-1]}.",
            "; feedopt stream checks RIst against it before the motion starts.",
            "; Entry and exit as in the native KRL program (feedopt.export.frames.entry_exit):",
            f"; PTP {APPROACH_MM:g} mm above the lead-in point, spindle on, LIN down, LIN along "
            f"the start tangent ({LEAD_IN_MM:g} mm)",
            f"; to the pose at RSI_ON; after RSI_OFF the lead-out ({LEAD_OUT_MM:g} mm), the "
            f"retract {APPROACH_MM:g} mm up the tool axis, spindle off.",
            ";ENDFOLD", "DECL INT ret", "DECL INT CONTID", ""]


def host_program(law: str, plan: CorrectionPlan, *, entry: EntryExit | None,
                 retract_mm: np.ndarray, comments: tuple[str, ...] = (),
                 frames: tuple[str, str, str] = ("TOOL_DATA[1]", "$NULLFRAME", "LOAD_DATA[1]"),
                 spindle: SpindleControl | None = None) -> str:
    """The KRL host program ``<law>_rsi`` (``DEF <law>_rsi()``); see the module docstring.

    ``entry``: the approach, lead-in, lead-out and retract the native KRL program has
    (:func:`feedopt.export.frames.entry_exit`; None where they are out of reach: a PTP to the
    start joints and a ``LIN_REL`` retract ``retract_mm`` (3,) [mm, base frame] after
    RSI_OFF). ``frames``: the KRL values of $TOOL, $BASE and $LOAD; ``spindle``: how the
    spindle is switched (:class:`feedopt.export.krl.SpindleControl`, the native program's).
    """
    name = f"{law}_rsi"
    if not _PROGRAM_RE.match(name):
        raise ValueError(f"KRL program name {name!r}: at most 24 letters, digits or '_'")
    cycle_ms = round(plan.cycle_s * 1e3)
    if cycle_ms not in (4, 12):
        raise InputError(f"RSI host program: the cycle is {plan.cycle_s * 1e3:g} ms; RSI runs "
                         "4 ms (IPO_FAST) or 12 ms (IPO)")
    sensor_mode = "#IPO_FAST" if cycle_ms == 4 else "#IPO"
    tool, base, load = frames
    spindle = SpindleControl() if spindle is None else spindle
    out = [*_header(name, law, plan, comments),
           ";FOLD INI",
           "  GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )",
           "  INTERRUPT ON 3", "  BAS (#INITMOV,0 )", ";ENDFOLD (INI)", "",
           f"$TOOL = {tool}", f"$BASE = {base}", f"$LOAD = {load}", "$IPO_MODE = #BASE",
           "$ORI_TYPE = #VAR",
           *(f"$VEL_AXIS[{i}] = 10" for i in range(1, 7)),
           *(f"$ACC_AXIS[{i}] = 10" for i in range(1, 7)),
           f"$VEL.CP = {_num(APPROACH_VEL_M_S, 6)}", "$ACC.CP = 0.5", ""]
    if entry is not None:
        out += [f"; approach: joint move to {APPROACH_MM:g} mm above the lead-in point",
                f"PTP {_axes(entry.approach_axes_deg)}", "WAIT SEC 0",
                *spindle.lines(True), "",
                "; down to the lead-in point, then the lead-in to the pose at RSI_ON",
                f"LIN {_frame(entry.lead_in)}", f"LIN {_frame(plan.start_pose)}"]
    else:
        out += ["; approach: joint move to the start (no reachable approach pose above it)",
                f"PTP {_axes(plan.start_q_deg)}", "WAIT SEC 0", *spindle.lines(True)]
    out += ["", *_checked(f'RSI_CREATE("{RSI_CONTEXT}", CONTID, TRUE)'),
            "; correction limits of this trajectory (from the pose at RSI_ON, with a margin)"]
    for (obj, par), value in correction_limits(plan).items():
        out += _checked(f'RSI_SETPUBLICPAR(CONTID, "{obj}", "{par}", {_num(value)})')
    out += [*_checked(f"RSI_ON(#ABSOLUTE, {sensor_mode})"),
            "; sensor-guided motion until the stream sends Stop", "RSI_MOVECORR()",
            *_checked("RSI_OFF()"), *_checked("RSI_DELETE(CONTID)"), ""]
    if entry is not None:
        out += [f"; lead-out along the end tangent, then the retract {APPROACH_MM:g} mm up the "
                "tool axis", f"LIN {_frame(entry.lead_out)}", f"LIN {_frame(entry.retract)}"]
    else:
        out += [f"; retract {APPROACH_MM:g} mm along the tool axis",
                "LIN_REL {" + ", ".join(f"{a} {_num(v)}" for a, v in zip(
                    "XYZ", retract_mm, strict=True)) + "} #BASE"]
    out += ["WAIT SEC 0", *spindle.lines(False), "END"]
    return "\n".join(out) + "\n"


def law_plan(job: ExportJob) -> CorrectionPlan:
    """The corrections of the law's RSI CSV: its poses as the ``rsi`` exporter computes them
    (pinocchio FK of the joints at the controller samples, KUKA A, B, C), from the job rather
    than by reading the file back (an 11 h job's CSV is 2.5 GB)."""
    from feedopt.robot.kuka import abc_from_rotation

    motion = job.samples.motion
    q, pose = job.controller_joints, job.controller_pose
    poses = np.column_stack([pose[:, :3, 3] * MM_PER_M, abc_from_rotation(pose[:, :3, :3])])
    return plan_from_poses(motion.t, poses, job.robot.axis_convention.to_controller(q[0]),
                           job.cycle, f"{job.law}.csv")


def export_rsi_program(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>_rsi.csv``, ``<law>_rsi.src`` and ``feedopt_rsi_ethernet.xml``."""
    csv = out_dir / f"{job.law}.csv"
    plan = law_plan(job)
    name = f"{job.law}_rsi"
    status = status_line(job)
    frames = cell_frames(job.robot)
    frame_lines = (*header_lines(frames), *header_notes(job))
    write_corrections_csv(out_dir / f"{name}.csv", plan, CorrectionMode.ABSOLUTE, comments=[
        status, *frame_lines,
        f"from {csv.name}; stream it with: feedopt stream {csv.name} --listen IP:PORT"])
    entry, retract, why = entry_exit_or_retract(job)
    comments = (status, *frame_lines) + (() if why is None else (f"no approach pose: {why}",))
    (out_dir / f"{name}.src").write_text(
        host_program(job.law, plan, entry=entry, retract_mm=retract, comments=comments,
                     frames=(frames.tool.krl(), frames.base.krl(), frames.load.krl())),
        encoding="ascii")
    (out_dir / ETHERNET_CONFIG).write_text(ethernet_config_xml(), encoding="ascii")
    (out_dir / ETHERNET_CONFIG_AXIS).write_text(
        ethernet_config_xml(space=CorrectionSpace.AXIS), encoding="ascii")
    trans, ang = step_sizes(plan.absolute)
    return {"rsi_corrections": f"{name}.csv", "rsi_host_program": f"{name}.src",
            "rsi_ethernet_config": ETHERNET_CONFIG,
            "rsi_ethernet_config_axis": ETHERNET_CONFIG_AXIS,
            "rsi_mode": CorrectionMode.ABSOLUTE.value,
            "rsi_max_step_mm": float(trans.max(initial=0.0)),
            "rsi_max_step_deg": float(ang.max(initial=0.0))}


def early_check(robot, path) -> Blocker | None:
    """RSI is a KUKA option: no host files for other controllers (not worth a warning)."""
    if robot.controller != "kuka":
        return Blocker(f"no RSI host program: robot {robot.name} has controller "
                       f"'{robot.controller}' (robot.yaml); RSI is a KUKA controller option",
                       warn=False)
    if not robot.axis_convention.stated:
        return Blocker(f"no RSI host program: {UNSTATED_AXES}")
    why = six_axes_only(robot, "RSI host program")
    if why is not None:
        return Blocker(why)
    return None


EXPORTER = Exporter(
    name="rsi_host", file_pattern="{law}_rsi.csv, {law}_rsi.src, " + ETHERNET_CONFIG,
    export=export_rsi_program, early_check=early_check,
    description="KUKA RSI cell files: RKorr corrections from the pose at RSI_ON (absolute), "
                "the RSI host KRL program and the Ethernet configuration XML",
)
