"""FANUC TP program of a law in ASCII form: ``<law>.ls`` (R-30iA/R-30iB, load with ASCII Upload).

Like the RAPID module (:mod:`feedopt.export.rapid`), the law goes to the controller as
linear moves through the path's key points, each at the law's feed there:

1. ``UFRAME_NUM=0`` (the robot's world = its base: the poses are in it) and ``UTOOL_NUM=1``,
   which must hold the TCP on the faceplate (the header gives X, Y, Z, W, P, R; an LS file
   cannot set a tool frame);
2. ``J P[1]`` to :data:`~feedopt.export.frames.APPROACH_MM` above the lead-in point
   (:func:`feedopt.export.frames.entry_exit`, the other programs' entry and exit), ``FINE``;
3. the spindle on: a digital output and a wait, or by default ``PAUSE`` for the operator
   (:class:`FanucSpindle`);
4. ``L`` moves down to the lead-in point, the lead-in, the key points (blends cut into chords
   within :data:`~feedopt.export.rapid.CHORD_TOLERANCE_MM`, as in RAPID), the lead-out and
   the retract, each at ``R[n]mm/sec`` with the register set to the law's feed just before
   (a TP speed is a whole number of mm/sec; a register holds the real feed), ``CNT100``
   through the path, ``FINE`` at its ends;
5. the spindle off.

Every position is written in joint representation (``J1= .. J6= .. deg``: the controller's
axis values, robot.yaml ``controller.axes``; a FANUC arm reports J3 from the horizontal:
``coupled: [{axis: 3, joint: 2, factor: 1}]``, ROS-Industrial's ``J23_factor = 1``), so no
configuration string (``'N U T, 0, 0, 0'``) has to be guessed: the controller computes the
pose with the active UTOOL. Not verified on a controller or ROBOGUIDE: the layout follows
the ASCII TP format of public ``.ls`` files; the tests read it back and check every position by
a hand-read URDF FK.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import APPROACH_MM, LEAD_IN_MM, LEAD_OUT_MM, cell_frames, entry_exit
from feedopt.export.job import (
    Blocker,
    Exporter,
    ExportJob,
    controller_blocker,
    header_notes,
    status_line,
)
from feedopt.export.orientation import gap_notes, orientation_gap_deg
from feedopt.export.rapid import rapid_arc_lengths
from feedopt.units import MM

#: Register holding the speed of the next moves [mm/sec].
SPEED_REGISTER = 1
#: Speed of the moves to and from the path [mm/sec] and of the joint move [%].
APPROACH_SPEED_MM_S = 10.0
JOINT_SPEED_PERCENT = 10
_NAME_RE = re.compile(r"^[A-Z][A-Z0-9_]{0,7}$")


@dataclass(frozen=True)
class FanucSpindle:
    """How the program switches the spindle: ``output`` a ``DO[n]`` with a ``WAIT`` of
    ``run_up_s``; None: a ``PAUSE`` for the operator."""

    output: int | None = None
    run_up_s: float = 3.0

    def lines(self, on: bool) -> list[str]:
        what = "on" if on else "off"
        if self.output is None:
            return [f"! spindle {what}: switch it {what}, then resume ;", "PAUSE ;"]
        out = [f"DO[{self.output}]={'ON' if on else 'OFF'} ;"]
        return out + ([f"WAIT {self.run_up_s:.2f}(sec) ;"] if on else [])


def _position(n: int, axes_deg: np.ndarray) -> str:
    j = [f"J{i + 1}= {round(float(v), 4) + 0.0:10.4f} deg" for i, v in enumerate(axes_deg)]
    return (f"P[{n}]{{\n   GP1:\n\tUF : 0, UT : 1,\t\n\t{j[0]},\t{j[1]},\t{j[2]},\n"
            f"\t{j[3]},\t{j[4]},\t{j[5]}\n}};")


def _header(name: str, lines: int, comment: str) -> list[str]:
    # a fixed stamp: the same plan writes the same file (the controller sets its own)
    stamp = time.strftime("DATE %y-%m-%d  TIME %H:%M:%S", time.gmtime(0))
    return [f"/PROG  {name}", "/ATTR", "OWNER\t\t= MNEDITOR;", f'COMMENT\t\t= "{comment}";',
            "PROG_SIZE\t= 0;", f"CREATE\t\t= {stamp};", f"MODIFIED\t= {stamp};",
            "FILE_NAME\t= ;", "VERSION\t\t= 0;", f"LINE_COUNT\t= {lines};",
            "MEMORY_SIZE\t= 0;", "PROTECT\t\t= READ_WRITE;",
            "TCD:  STACK_SIZE\t= 0,", "      TASK_PRIORITY\t= 50,", "      TIME_SLICE\t= 0,",
            "      BUSY_LAMP_OFF\t= 0,", "      ABORT_REQUEST\t= 0,",
            "      PAUSE_REQUEST\t= 0;", "DEFAULT_GROUP\t= 1,*,*,*,*;",
            "CONTROL_CODE\t= 00000000 00000000;"]


def utool(robot) -> str:
    """The UTOOL the positions need: the TCP in the faceplate frame as X, Y, Z [mm], W, P, R
    [deg] (R = Rz(R) Ry(P) Rx(W)), the faceplate being the URDF's ``tool0``
    (ROS-Industrial's REP-199 frame of the controller's flange); without a ``tool0`` only
    the TCP's position on the flange's axis is stated."""
    import pinocchio as pin

    from feedopt.robot.kuka import abc_from_rotation

    model = robot.model
    if not model.existFrame("tool0"):
        x, y, z = cell_frames(robot).tool.xyz_mm
        return (f"the TCP {x:g}, {y:g}, {z:g} mm from the faceplate centre, +Z along the "
                "tool (the URDF has no tool0 frame to state W, P, R in)")
    data = model.createData()
    pin.forwardKinematics(model, data, np.zeros(robot.dof))
    face = pin.updateFramePlacement(model, data, model.getFrameId("tool0")).homogeneous
    tcp = pin.updateFramePlacement(model, data, robot.tcp_frame_id).homogeneous
    rel = np.linalg.inv(face) @ tcp
    a, b, c = np.round(abc_from_rotation(rel[:3, :3]), 4) + 0.0
    x, y, z = np.round(rel[:3, 3] / MM, 4) + 0.0
    return f"X {x:g}, Y {y:g}, Z {z:g} mm, W {c:g}, P {b:g}, R {a:g} deg (URDF tool0)"


def _notes(job: ExportJob) -> list[str]:
    """The program's comment lines (``!``, at most 29 characters each on a pendant, so the
    long notes are cut into pieces)."""
    text = [f"feedopt {job.law}: {status_line(job)}",
            "positions: joint representation (controller axes, deg) of the TCP poses in the "
            "robot base frame (UFRAME 0)",
            f"UTOOL 1 must be the TCP on the faceplate: {utool(job.robot)}",
            f"speeds: R[{SPEED_REGISTER}] mm/sec, the law's feed on each stretch",
            *header_notes(job),
            *gap_notes(orientation_gap_deg(job, rapid_arc_lengths(job)[0]), "positions"),
            "not verified on a controller or ROBOGUIDE"]
    out = []
    for t in text:
        t = t.encode("ascii", "replace").decode("ascii").replace(";", ",")
        out += [f"! {t[i:i + 60]} ;" for i in range(0, len(t), 60)]
    return out


def fanuc_program(job: ExportJob, name: str, spindle: FanucSpindle | None = None) -> str:
    """The LS text of ``job`` (InputError where it cannot be written)."""
    if not _NAME_RE.match(name):
        raise InputError(f"FANUC program name {name!r}: a capital letter, then at most 7 "
                         "capitals, digits or '_'")
    spindle = FanucSpindle() if spindle is None else spindle
    axes = job.robot.axis_convention
    entry = entry_exit(job)
    s_pts, feeds = rapid_arc_lengths(job)
    q_path = axes.to_controller(job.q_of_s(s_pts))
    q_io = axes.to_controller(np.stack([entry.q_lead_in, entry.q_lead_out, entry.q_retract]))
    positions = [entry.approach_axes_deg, q_io[0], *q_path, q_io[1], q_io[2]]
    reg = f"R[{SPEED_REGISTER}]"
    body = [*_notes(job), "UFRAME_NUM=0 ;", "UTOOL_NUM=1 ;",
            f"! {APPROACH_MM:g} mm above the lead-in point ;",
            f"J P[1] {JOINT_SPEED_PERCENT}% FINE ;", *spindle.lines(True),
            f"{reg}={APPROACH_SPEED_MM_S:g} ;", f"L P[2] {reg}mm/sec FINE ;",
            f"! lead-in {LEAD_IN_MM:g} mm, the path, lead-out {LEAD_OUT_MM:g} mm ;"]
    speed = None
    for k, n in enumerate(range(3, 3 + s_pts.size)):
        v = float(feeds[max(k - 1, 0)]) / MM  # into P[3]: the lead-in at the first feed
        if v != speed:
            body.append(f"{reg}={v:.4f} ;")
            speed = v
        body.append(f"L P[{n}] {reg}mm/sec CNT100 ;")
    n_out = 3 + s_pts.size
    body += [f"{reg}={float(feeds[-1]) / MM:.4f} ;", f"L P[{n_out}] {reg}mm/sec FINE ;",
             f"{reg}={APPROACH_SPEED_MM_S:g} ;", f"L P[{n_out + 1}] {reg}mm/sec FINE ;",
             *spindle.lines(False)]
    comment = f"feedopt {job.law}"[:16]
    out = _header(name, len(body), comment) + ["/MN"]
    out += [f"{i:4d}:  {line}" for i, line in enumerate(body, start=1)]
    out += ["/POS", *(_position(i, q) for i, q in enumerate(positions, start=1)), "/END"]
    return "\n".join(out) + "\n"


def parse_ls_positions(text: str) -> dict[int, np.ndarray]:
    """The joint-representation positions of an LS file: ``{n: (6,) deg}``."""
    out = {}
    for m in re.finditer(r"P\[(\d+)\]\{(.*?)\};", text, re.S):
        values = re.findall(r"J\d=\s*([-0-9.]+) deg", m.group(2))
        out[int(m.group(1))] = np.array([float(v) for v in values])
    return out


def early_check(robot, path) -> Blocker | None:
    """Why no FANUC program can be written for this robot, known before planning."""
    del path
    return controller_blocker(robot, "fanuc", "FANUC program", "LS")


def export_fanuc(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>.ls`` (or record why not as ``fanuc_not_written``)."""
    name = re.sub(r"[^A-Z0-9_]", "_", f"FO_{job.law.upper()}")[:8]
    try:
        text = fanuc_program(job, name)
    except InputError as exc:
        return {"fanuc_program": None, "fanuc_not_written": f"no FANUC program: {exc}"}
    (out_dir / f"{job.law}.ls").write_text(text, encoding="ascii")
    gap = orientation_gap_deg(job, rapid_arc_lengths(job)[0])
    return {"fanuc_program": f"{job.law}.ls",
            **({} if gap is None else {"fanuc_orientation_gap_deg": gap})}


EXPORTER = Exporter(
    name="fanuc", file_pattern="{law}.ls", export=export_fanuc, early_check=early_check,
    description="FANUC TP program (ASCII .ls): UFRAME 0 / UTOOL 1, J move above the lead-in "
                "point, spindle, L moves through the key points at R[1] mm/sec set to the "
                "law's feed (CNT100), lead-out, retract; positions in joint representation",
)
