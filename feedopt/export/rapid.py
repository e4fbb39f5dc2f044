"""ABB RAPID module of a law for the native controller (IRC5 / OmniCore): ``<law>.mod``.

ABB controllers take no per-cycle corrections without the EGM option, so the planned law
goes to the robot the way a CAM post writes it: ``MoveL`` through the path's key points
with the law's feed as each move's ``speeddata`` (``[v_tcp, v_ori, v_leax, v_reax]``, mm/s
and deg/s), one ``PROC main()`` in a ``MODULE``:

1. ``PERS tooldata`` (the TCP on ABB's ``tool0`` flange frame: position [mm] and orientation
   quaternion; its ``tload`` a labelled placeholder of 1 kg, which RAPID requires > 0),
   ``PERS wobjdata`` (the robot base: the poses are written in it), ``ConfL \\Off``;
2. ``MoveAbsJ`` to the approach joints (the controller's axis values, robot.yaml
   ``controller.axes``) :data:`~feedopt.export.frames.APPROACH_MM` above the lead-in point
   (:func:`feedopt.export.frames.entry_exit`, the KUKA programs' entry and exit), ``fine``;
3. the spindle on: a digital output and a run-up wait, or by default a ``Stop`` for the
   operator (:class:`RapidSpindle`);
4. ``MoveL`` down to the lead-in point, the lead-in along the start tangent, then the key
   points (:func:`feedopt.export.krl.key_arc_lengths`: segment ends, feed changes, the
   chapter-4 key points), with the blends between lines cut into chords within
   :data:`CHORD_TOLERANCE_MM` of the path, each at the law's feed there, zone ``z0``;
5. the lead-out, the retract up the tool axis (``fine``) and the spindle off.

Robot targets (``robtarget``): position [mm], orientation as the unit quaternion
``[q1, q2, q3, q4]`` (scalar first, q1 >= 0; Shepperd's method, Shepperd 1978, J. Guidance
Control 1(3)), ``confdata [cf1, cf4, cf6, cfx]`` with cf1, cf4, cf6 the quadrants of axes 1,
4 and 6 (``floor(angle / 90 deg)``) and cfx 0: with ``ConfL \\Off`` linear moves keep the
configuration the ``MoveAbsJ`` set, so cfx is not checked (the header says so). External
axes ``9E+09`` (none).

Not verified on a controller or RobotStudio here: the module follows the RAPID reference's
syntax (MODULE/PROC/ENDPROC/ENDMODULE, PERS/CONST declarations, MoveAbsJ/MoveL with
``\\WObj``, inline speeddata aggregates) and is read back by :func:`parse_rapid_targets` in the
tests, whose independent FK checks every target against the URDF.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import (
    APPROACH_MM,
    LEAD_IN_MM,
    LEAD_OUT_MM,
    cell_frames,
    entry_exit,
)
from feedopt.export.job import (
    Blocker,
    Exporter,
    ExportJob,
    controller_blocker,
    header_notes,
    status_line,
)
from feedopt.export.orientation import gap_notes, orientation_gap_deg
from feedopt.robot.model import forward_kinematics
from feedopt.units import MM

#: Largest distance of the path from a chord through a blend [mm].
CHORD_TOLERANCE_MM = 0.01
#: Speed of the moves to and from the path [mm/s].
APPROACH_SPEED_MM_S = 10.0
#: v_ori, v_leax, v_reax of every speeddata (deg/s, mm/s, deg/s): RAPID's v-data defaults.
SPEED_TAIL = (500.0, 5000.0, 1000.0)
#: Placeholder tool load [kg] (RAPID requires a mass > 0), labelled in the module.
PLACEHOLDER_MASS_KG = 1.0
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,15}$")
_EXTAX = "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]"


@dataclass(frozen=True)
class RapidSpindle:
    """How the module switches the spindle: ``output`` a digital output (``SetDO``) with a
    ``WaitTime`` of ``run_up_s``; None: a ``Stop`` for the operator."""

    output: str | None = None
    run_up_s: float = 3.0

    def lines(self, on: bool) -> list[str]:
        what = "on" if on else "off"
        if self.output is None:
            return [f"    ! spindle {what}: no output configured; switch it {what}, then "
                    "press Start", "    Stop;"]
        out = [f"    SetDO {self.output}, {int(on)};"]
        return out + ([f"    WaitTime {self.run_up_s:g};"] if on else [])


def quaternion_from_rotation(r: np.ndarray) -> np.ndarray:
    """Unit quaternions ``[q1, q2, q3, q4]`` (scalar first, q1 >= 0) of rotations (..., 3, 3)
    (Shepperd's method: the largest of the four squared components is taken first)."""
    r = np.asarray(r, dtype=float)
    t = np.stack([1 + r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2],
                  1 + r[..., 0, 0] - r[..., 1, 1] - r[..., 2, 2],
                  1 - r[..., 0, 0] + r[..., 1, 1] - r[..., 2, 2],
                  1 - r[..., 0, 0] - r[..., 1, 1] + r[..., 2, 2]], axis=-1)
    k = np.argmax(t, axis=-1)
    big = 0.5 * np.sqrt(np.take_along_axis(t, k[..., None], axis=-1)[..., 0])
    off = np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
                    r[..., 1, 0] - r[..., 0, 1], r[..., 2, 1] + r[..., 1, 2],
                    r[..., 0, 2] + r[..., 2, 0], r[..., 1, 0] + r[..., 0, 1]], axis=-1)
    f = 0.25 / big
    w, x, y, z = (np.empty(k.shape) for _ in range(4))
    cases = ((0, (big, off[..., 0] * f, off[..., 1] * f, off[..., 2] * f)),
             (1, (off[..., 0] * f, big, off[..., 5] * f, off[..., 4] * f)),
             (2, (off[..., 1] * f, off[..., 5] * f, big, off[..., 3] * f)),
             (3, (off[..., 2] * f, off[..., 4] * f, off[..., 3] * f, big)))
    for case, values in cases:
        m = k == case
        for dest, v in zip((w, x, y, z), values, strict=True):
            dest[m] = v[m]
    q = np.stack([w, x, y, z], axis=-1)
    return np.where(q[..., :1] < 0, -q, q)


def confdata(q_deg: np.ndarray) -> np.ndarray:
    """ABB ``[cf1, cf4, cf6, cfx]`` of axis values (..., 6) [deg]: the quadrants of axes 1, 4
    and 6 (0: 0..90 deg, -1: -90..0 deg ...) and cfx 0 (not checked with ``ConfL \\Off``)."""
    q = np.asarray(q_deg, dtype=float)
    quad = np.floor(q[..., [0, 3, 5]] / 90.0 + 1e-9).astype(int)
    return np.concatenate([quad, np.zeros(q.shape[:-1] + (1,), dtype=int)], axis=-1)


def _num(x: float, decimals: int = 4) -> str:
    text = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _chord_points(p: np.ndarray, tol: float) -> np.ndarray:
    """Indices into the points ``p`` (m, 3) of chords within ``tol`` of every point between
    (the fewest of strides 2^k, the ends kept)."""
    m = p.shape[0]
    for stride in (2 ** k for k in range(int(math.log2(max(m - 1, 1))) + 1, -1, -1)):
        ends = np.unique(np.append(np.arange(0, m, stride), m - 1))
        chord = np.searchsorted(ends, np.arange(m), side="right") - 1
        chord = np.clip(chord, 0, ends.size - 2) if ends.size > 1 else np.zeros(m, dtype=int)
        a, b = p[ends[chord]], p[ends[np.minimum(chord + 1, ends.size - 1)]]
        d = b - a
        L2 = np.einsum("ij,ij->i", d, d)
        u = np.clip(np.einsum("ij,ij->i", p - a, d) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        err = np.linalg.norm(p - (a + u[:, None] * d), axis=1)
        if err.max(initial=0.0) <= tol:
            return ends
    return np.arange(m)


def rapid_arc_lengths(job: ExportJob) -> tuple[np.ndarray, np.ndarray]:
    """Arc lengths [m] of the module's path targets and the feed into each [m/s] (n - 1):
    the KRL key points, with each blend (two ``SPL`` points) cut into chords within
    :data:`CHORD_TOLERANCE_MM` of the path samples."""
    from feedopt.export.krl import key_arc_lengths

    s_key, motions, vels = key_arc_lengths(job)
    s = job.problem.s
    pos = job.path_in_base(s)
    out_s, out_v = [s_key[:1]], []
    for i, (motion, v) in enumerate(zip(motions, vels, strict=True)):
        if motion == "SPL":
            lo, hi = np.searchsorted(s, [s_key[i], s_key[i + 1]])
            idx = np.arange(lo, min(hi + 1, s.size))
            pts = np.vstack([job.path_in_base(s_key[i:i + 1]), pos[idx],
                             job.path_in_base(s_key[i + 1:i + 2])])
            ss = np.concatenate([[s_key[i]], s[idx], [s_key[i + 1]]])
            keep = _chord_points(pts, CHORD_TOLERANCE_MM * MM)[1:]
            out_s.append(ss[keep])
            out_v.append(np.full(keep.size, v))
        else:
            out_s.append(s_key[i + 1:i + 2])
            out_v.append([v])
    s_all = np.concatenate(out_s)
    v_all = np.concatenate([np.asarray(v, dtype=float) for v in out_v])
    keep = np.concatenate([[True], np.diff(s_all) > 1e-9])  # no repeated target
    return s_all[keep], v_all[keep[1:]]


def _speed(feed_m_s: float) -> str:
    """An inline speeddata of a path feed [m/s]."""
    return f"[{_num(feed_m_s / MM, 3)},{','.join(_num(v) for v in SPEED_TAIL)}]"


def _target(name: str, pose: np.ndarray, conf: np.ndarray) -> str:
    """``CONST robtarget`` of a (4, 4) pose [m] with its confdata."""
    q = quaternion_from_rotation(pose[:3, :3])
    p = ",".join(_num(v / MM) for v in pose[:3, 3])
    return (f"  CONST robtarget {name} := [[{p}],[{','.join(_num(v, 9) for v in q)}],"
            f"[{','.join(str(int(c)) for c in conf)}],{_EXTAX}];")


def _tool(frames) -> str:
    from feedopt.robot.kuka import rotation_from_abc

    q = quaternion_from_rotation(rotation_from_abc(np.asarray(frames.tool.abc_deg)))
    p = ",".join(_num(v) for v in frames.tool.xyz_mm)
    return (f"  PERS tooldata fo_tool := [TRUE,[[{p}],[{','.join(_num(v, 9) for v in q)}]],"
            f"[{_num(PLACEHOLDER_MASS_KG)},[0,0,1],[1,0,0,0],0,0,0]];")


def rapid_module(job: ExportJob, name: str, spindle: RapidSpindle | None = None) -> str:
    """The module text of ``job`` (InputError where it cannot be written: an unreachable
    entry, a name RAPID refuses)."""
    if not _NAME_RE.match(name):
        raise InputError(f"RAPID module name {name!r}: a letter, then at most 15 letters, "
                         "digits or '_'")
    spindle = RapidSpindle() if spindle is None else spindle
    axes = job.robot.axis_convention
    entry = entry_exit(job)
    s_pts, feeds = rapid_arc_lengths(job)
    q = job.q_of_s(s_pts)
    pose = forward_kinematics(job.robot, q)
    conf = confdata(axes.to_controller(q))
    q_io = np.stack([entry.q_lead_in, entry.q_lead_out, entry.q_retract])
    io_pose = forward_kinematics(job.robot, q_io)
    io_conf = confdata(axes.to_controller(q_io))
    frames = cell_frames(job.robot)
    lines = [f"MODULE {name}", f"  ! Generated by feedopt: {status_line(job)}",
             f"  ! law {job.law} of scenario {job.scenario_name}: MoveL through {s_pts.size} "
             "path targets with the law's feed as each move's speeddata (mm/s).",
             "  ! targets: the TCP in the robot base frame (fo_wobj: no user frame), mm, "
             "orientation as quaternions [q1,q2,q3,q4] (scalar first);",
             f"  ! fo_tool: the TCP on {frames.flange_name} (+Z out of the flange): "
             + ", ".join(_num(v) for v in frames.tool.xyz_mm) + " mm.",
             *(f"  ! {n}" for n in header_notes(job)),
             *(f"  ! {n}" for n in gap_notes(orientation_gap_deg(job, s_pts), "targets")),
             f"  ! Entry and exit: MoveAbsJ {APPROACH_MM:g} mm above the lead-in point, spindle "
             f"on, MoveL down, lead-in {LEAD_IN_MM:g} mm, the path, lead-out "
             f"{LEAD_OUT_MM:g} mm, retract, spindle off.",
             f"  ! tooldata load {_num(PLACEHOLDER_MASS_KG)} kg is a PLACEHOLDER (RAPID needs a "
             "mass > 0): enter the spindle's measured load (LoadIdentify) before cutting.",
             "  ! confdata: cf1, cf4, cf6 from the planned axes; cfx 0, not checked "
             "(ConfL \\Off keeps the branch MoveAbsJ sets). Not verified on a controller.",
             _tool(frames),
             "  PERS wobjdata fo_wobj := [FALSE,TRUE,\"\",[[0,0,0],[1,0,0,0]],"
             "[[0,0,0],[1,0,0,0]]];",
             "  CONST jointtarget fo_approach := [["
             + ",".join(_num(v) for v in entry.approach_axes_deg) + f"],{_EXTAX}];",
             _target("fo_lead_in", io_pose[0], io_conf[0]),
             _target("fo_lead_out", io_pose[1], io_conf[1]),
             _target("fo_retract", io_pose[2], io_conf[2])]
    lines += [_target(f"fo_p{i}", pose[i], conf[i]) for i in range(s_pts.size)]
    slow = f"[{_num(APPROACH_SPEED_MM_S)},{','.join(_num(v) for v in SPEED_TAIL)}]"
    tool = "fo_tool\\WObj:=fo_wobj"
    lines += ["", "  PROC main()", "    ConfJ \\On;", "    ConfL \\Off;",
              f"    MoveAbsJ fo_approach, {slow}, fine, {tool};", *spindle.lines(True),
              f"    MoveL fo_lead_in, {slow}, fine, {tool};",
              f"    MoveL fo_p0, {_speed(feeds[0])}, z0, {tool};  ! lead-in at the cut's feed"]
    lines += [f"    MoveL fo_p{i}, {_speed(feeds[i - 1])}, z0, {tool};"
              for i in range(1, s_pts.size)]
    lines += [f"    MoveL fo_lead_out, {_speed(feeds[-1])}, z0, {tool};",
              f"    MoveL fo_retract, {slow}, fine, {tool};", *spindle.lines(False),
              "  ENDPROC", "ENDMODULE"]
    return "\n".join(lines) + "\n"


def parse_rapid_targets(text: str) -> dict[str, dict]:
    """The ``robtarget`` and ``jointtarget`` declarations of a module: per name its
    ``pos`` (3,) [mm], ``orient`` (4,), ``conf`` (4,), or ``axes`` (6,) [deg]."""
    out: dict[str, dict] = {}
    number = r"[-+0-9.Ee]+"
    vec = rf"\[({number}(?:,{number})*)\]"
    for m in re.finditer(rf"robtarget (\w+) := \[{vec},{vec},{vec},", text):
        out[m.group(1)] = {k: np.array([float(v) for v in g.split(",")])
                           for k, g in zip(("pos", "orient", "conf"), m.groups()[1:],
                                           strict=True)}
    for m in re.finditer(rf"jointtarget (\w+) := \[{vec},", text):
        out[m.group(1)] = {"axes": np.array([float(v) for v in m.group(2).split(",")])}
    return out


def early_check(robot, path) -> Blocker | None:
    """Why no RAPID module can be written for this robot, known before planning."""
    del path
    return controller_blocker(robot, "abb", "RAPID module", "RAPID")


def export_rapid(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>.mod`` (or record why not as ``rapid_not_written``)."""
    name = f"fo_{job.law}"
    try:
        text = rapid_module(job, name)
    except InputError as exc:
        return {"rapid_module": None, "rapid_not_written": f"no RAPID module: {exc}"}
    (out_dir / f"{job.law}.mod").write_text(text, encoding="ascii")
    gap = orientation_gap_deg(job, rapid_arc_lengths(job)[0])
    return {"rapid_module": f"{job.law}.mod",
            **({} if gap is None else {"rapid_orientation_gap_deg": gap})}


EXPORTER = Exporter(
    name="rapid", file_pattern="{law}.mod", export=export_rapid, early_check=early_check,
    description="ABB RAPID module: tooldata/wobjdata, MoveAbsJ approach, spindle, MoveL "
                "lead-in, the path's key points (blends within 0.01 mm by chords) with the "
                "law's feed as speeddata, lead-out, retract",
)
