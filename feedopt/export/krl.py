"""KUKA KRL program of a path for the native controller: a ``.src`` + ``.dat`` pair (KRC4, KSS 8.x).

The thesis (section 3.7) compares its closed-loop RSI trajectory with the controller's own
planner fed with key points of the path in a ``SPLINE ... ENDSPLINE`` block, ``SLIN`` for the
straight lines and ``SPL`` for the corners, each with the law's feed as ``WITH $VEL.CP``
(m/s). :func:`write_krl_program` writes the whole cell program around that block:

1. ``;FOLD INI``: the standard KSS 8.x initialisation (``GLOBAL INTERRUPT DECL 3 WHEN
   $STOPMESS==TRUE DO IR_STOPM ( )``, ``INTERRUPT ON 3``, ``BAS (#INITMOV,0 )``: velocities,
   accelerations, approximation and $JERK back to the defaults, whatever ran before);
2. ``$TOOL``, ``$BASE``, ``$LOAD`` from the module's ``.dat`` (``FO_TOOL``, ``FO_BASE``,
   ``FO_LOAD``: the TOOL_DATA / BASE_DATA / LOAD_DATA of :mod:`feedopt.export.frames`),
   ``$IPO_MODE``, ``$ORI_TYPE``, ``$ADVANCE``, PTP and CP velocities and accelerations;
3. ``PTP FO_APPROACH``: a joint move to ``APPROACH_MM`` above the lead-in point along the
   tool axis (an ``AXIS`` in the ``.dat``, on the start configuration's branch;
   :func:`feedopt.export.frames.entry_exit`);
4. spindle on (:class:`SpindleControl`: an output ``$OUT[n]`` with a run-up wait, a call of the
   user's own subprogram, or by default a ``HALT`` for the operator), after ``WAIT SEC 0``
   (an advance-run stop: the robot has arrived above the part when it happens);
5. ``SLIN`` down to the lead-in point, at :data:`APPROACH_VEL_M_S`;
6. the ``SPLINE`` block: an ``SLIN`` lead-in of ``LEAD_IN_MM`` along the start tangent to
   the path start (collinear with a first line, so no stop there), the key points, an
   ``SLIN`` lead-out of ``LEAD_OUT_MM`` along the end tangent;
7. ``SLIN`` retract up the tool axis; ``WAIT SEC 0``; spindle off.

Limits checked before writing (:class:`InputError` otherwise; the exporter then writes no
program and says why in summary.json): at most :data:`MAX_SEGMENTS` segments in the block;
every ``$VEL.CP`` in [:data:`VEL_CP_MIN`, :data:`VEL_CP_MAX`] m/s (the range of the SLIN/SPL
inline forms of KSS 8.x; the controller caps at its machine datum $VEL_MA.CP); no segment
shorter than :data:`MIN_SEGMENT_MM` (points closer than the file's 4 decimals resolve are
the same point to the controller); names of at most 24 characters.

Followed: the KSS 8.x INI fold and DEFDAT/DECL forms as KUKA's editor writes them (public KRL
in robot-integration repositories: ``BAS (#INITMOV,0 )``, ``DEFDAT name PUBLIC`` / ``DECL
E6AXIS HOME={A1 0,A2 -90,...}``, ``LOAD_DATA[1]={M -1.0,CM {X 0.0,...},J {X 0.0,...}}``) and
the spline syntax the thesis used (``SPLINE``/``SLIN``/``SPL``/``ENDSPLINE``, ``WITH
$VEL.CP``). KUKA's own manuals were not available here: the segment cap and the $VEL.CP range
are as stated above, not checked against them. :func:`parse_krl_spline` and
:func:`parse_krl_dat` read the files back.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import (
    APPROACH_MM,
    CellFrames,
    EntryExit,
    cell_frames,
    entry_exit,
    header_lines,
)
from feedopt.export.job import Blocker, Exporter, ExportJob, header_notes, status_line
from feedopt.export.orientation import gap_notes, orientation_gap_deg
from feedopt.robot.axes import UNSTATED_AXES
from feedopt.robot.model import six_axes_only
from feedopt.units import MM

MOTIONS = ("SLIN", "SPL")
#: KSS 8.x: a spline block holds at most 1000 segments (pass key points, not dense samples).
MAX_SEGMENTS = 1000
#: $VEL.CP range [m/s] of the KSS 8.x SLIN/SPL inline forms.
VEL_CP_MIN = 0.001
VEL_CP_MAX = 2.0
#: Shortest segment written [mm] (the positions have 4 decimals).
MIN_SEGMENT_MM = 0.01
#: Speed of the SLIN down to the lead-in point and of the retract [m/s].
APPROACH_VEL_M_S = 0.02
#: Relative feed tolerance of the pieces lines are split into (see feedopt.export.gcode_out).
FEED_TOLERANCE = 0.02
#: Names declared in the .dat.
TOOL_VAR, BASE_VAR, LOAD_VAR, APPROACH_VAR = "FO_TOOL", "FO_BASE", "FO_LOAD", "FO_APPROACH"
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,23}$")

NATIVE_CONTROLLER_NOTE = (
    "What the native controller does differently from the RSI trajectory (thesis section 3.7):",
    "- It plans its own velocity profile. $VEL.CP is the programmed path velocity of each",
    "  segment, not a timing law: the controller ramps between segment velocities with its own",
    "  (proprietary) acceleration and jerk limits ($ACC.CP, machine data), and slows down where",
    "  axis limits or the spline curvature require it. Our C2 timing law s(t), its cycle time and",
    "  its acceleration/jerk bounds are not reproduced; only the per-segment target speeds are.",
    "- SPL segments are the controller's own splines through the points: their shape between",
    "  points (and so the corner geometry, curvature and G2 continuity of our blends) is not",
    "  ours. SLIN segments are straight lines. Two successive non-collinear SLIN segments make",
    "  the robot stop at the point between them.",
    "- The robot stops at the start of the SPLINE block (block planning) and at ENDSPLINE.",
    "- It runs open loop: no RSI correction of the measured pose, so deflection and kinematic",
    "  errors are not compensated (the thesis saw the axial depth of cut drift, Fig. 3.29).",
    "- Predicted deflections in the RSI CSV assume the RSI timing; they do not hold here.",
)


@dataclass(frozen=True)
class SpindleControl:
    """How the program switches the spindle.

    output : ``$OUT[output]`` TRUE to run, FALSE to stop (None: no output)
    run_up_s : wait after switching on [s] (the spindle reaching its speed)
    on_call, off_call : names of the user's global subprograms to call instead (``NAME()``)
    With neither an output nor calls (the default) the program stops with ``HALT`` before the
    cut (start the spindle, then continue) and after it (stop the spindle).
    """

    output: int | None = None
    run_up_s: float = 5.0
    on_call: str | None = None
    off_call: str | None = None

    def lines(self, on: bool) -> list[str]:
        """KRL lines that switch the spindle on (``on``) or off, after an advance-run stop."""
        call = self.on_call if on else self.off_call
        what = "on" if on else "off"
        out = ["WAIT SEC 0 ; advance-run stop: the motions above are finished"]
        if call is not None:
            return out + [f"{call}() ; spindle {what}: your subprogram"]
        if self.output is not None:
            out.append(f"$OUT[{self.output}] = {'TRUE' if on else 'FALSE'} ; spindle {what}")
            if on:
                out.append(f"WAIT SEC {_fmt(self.run_up_s, 3)} ; spindle run-up")
            return out
        return out + [f"; spindle {what}: no output or subprogram configured: the program "
                      f"stops here; switch the spindle {what}, then press Start", "HALT"]

    def check(self) -> None:
        """InputError for an output number or a subprogram name KRL cannot take."""
        if self.output is not None and not (isinstance(self.output, int)
                                            and 1 <= self.output <= 8192):
            raise InputError(f"spindle output {self.output!r}: use an $OUT number 1-8192")
        if not (np.isfinite(self.run_up_s) and 0 <= self.run_up_s <= 600):
            raise InputError(f"spindle run_up_s {self.run_up_s!r}: use 0-600 s")
        for call in (self.on_call, self.off_call):
            if call is not None and not _NAME_RE.match(call):
                raise InputError(f"spindle subprogram {call!r}: use a KRL name (at most 24 "
                                 "letters, digits or '_', starting with a letter)")


def _fmt(x: float, decimals: int) -> str:
    s = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _fmt_vel(v: float) -> str:
    """Velocity [m/s], 7 significant digits (KRL REAL is single precision), never exponent."""
    return np.format_float_positional(float(v), precision=7, unique=False, fractional=False,
                                      trim="-")


def _pose(p: np.ndarray) -> str:
    return "{" + ", ".join(f"{ax} {_fmt(x, 4)}" for ax, x in zip("XYZABC", p, strict=True)) + "}"


def _check_name(name: str) -> None:
    if not _NAME_RE.match(name):
        fixed = re.sub(r"[^A-Za-z0-9_]", "_", name)[:24] or "feedopt"
        if not re.match(r"[A-Za-z_]", fixed):
            fixed = "P" + fixed[:23]
        raise InputError(
            f"KRL program name {name!r} is not valid: use at most 24 letters, digits or '_' "
            f"starting with a letter (e.g. {fixed!r})"
        )


def _check_velocity(what: str, v: float, vel_max: float) -> None:
    if not (np.isfinite(v) and VEL_CP_MIN <= v <= vel_max):
        raise InputError(
            f"KRL {what} is {float(v)!r} m/s; $VEL.CP must be in [{VEL_CP_MIN}, {vel_max}] m/s "
            "(KSS 8.x SLIN/SPL range)")


def _check_points(pts: np.ndarray, extra: int = 0, names: Sequence[str] = ()) -> None:
    """Finite points, at most MAX_SEGMENTS segments (``extra`` more will be added), none
    shorter than MIN_SEGMENT_MM; ``names`` name the segments (default "segment to point i")."""
    n = pts.shape[0] + extra
    if n - 1 > MAX_SEGMENTS:
        raise InputError(
            f"KRL spline block would have {n - 1} segments; KSS 8.x allows {MAX_SEGMENTS} per "
            "block: pass the key points of the path (line ends, blend ends), not dense samples"
        )
    bad = np.argwhere(~np.isfinite(pts))
    if bad.size:
        i, j = bad[0]
        raise InputError(f"KRL point {i} has a non-finite {'XYZABC'[j]} = {float(pts[i, j])!r}")
    length = np.linalg.norm(np.diff(pts[:, :3], axis=0), axis=1)
    short = np.flatnonzero(length < MIN_SEGMENT_MM)
    if short.size:
        i = int(short[0])
        what = names[i] if names else f"segment to point {i + 1}"
        raise InputError(
            f"KRL {what} is {length[i]:.3g} mm long; segments must be at least "
            f"{MIN_SEGMENT_MM} mm (merge the points)")


@dataclass(frozen=True)
class KeyPoints:
    """The path as the program's spline block runs it.

    points : (n, 6) TCP poses in the robot base frame, X, Y, Z [mm], A, B, C [deg] (KUKA
        Z-Y'-X''): the path start, then its key points.
    motion : ``"SLIN"`` or ``"SPL"`` for each point after the first (n - 1 values).
    velocity_m_s : ``$VEL.CP`` [m/s] of the segment that reaches each point; n - 1 values, or n
        values of which the first (the start point) is ignored.
    start_axis_deg : (6,) joint angles A1..A6 [deg] of the start pose (IK of ``points[0]``).
    """

    points: np.ndarray
    motion: Sequence[str]
    velocity_m_s: np.ndarray
    start_axis_deg: np.ndarray


@dataclass(frozen=True)
class KrlSpeeds:
    """The program's speeds outside the spline block, and the cell's cap.

    accel_cp_m_s2 : ``$ACC.CP`` [m/s^2]
    approach_percent : PTP ``$VEL_AXIS`` / ``$ACC_AXIS`` [%]
    approach_vel_m_s : ``$VEL.CP`` of the SLIN down to the lead-in point and of the retract
    vel_cp_max_m_s : the cell's largest $VEL.CP (at most :data:`VEL_CP_MAX`)
    """

    accel_cp_m_s2: float = 1.0
    approach_percent: float = 10.0
    approach_vel_m_s: float = APPROACH_VEL_M_S
    vel_cp_max_m_s: float = VEL_CP_MAX


def _validate(name: str, keys: KeyPoints, vel_max: float) -> KeyPoints:
    """``keys`` as arrays, one velocity per segment (InputError naming what is wrong)."""
    _check_name(name)
    pts = np.asarray(keys.points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 6 or pts.shape[0] < 2:
        raise InputError(
            f"KRL points must be an (n, 6) array [x, y, z mm, a, b, c deg] with n >= 2, "
            f"got shape {pts.shape}"
        )
    n = pts.shape[0]
    motion = [str(m).upper() for m in keys.motion]
    if len(motion) != n - 1:
        raise InputError(
            f"KRL motion must give one of {MOTIONS} per point after the first "
            f"({n - 1} values), got {len(motion)}"
        )
    for i, m in enumerate(motion):
        if m not in MOTIONS:
            raise InputError(f"KRL motion of point {i + 1} is {m!r}; use one of {MOTIONS}")
    vel = np.asarray(keys.velocity_m_s, dtype=float).reshape(-1)
    if vel.shape[0] == n:
        vel = vel[1:]
    if vel.shape[0] != n - 1:
        raise InputError(
            f"KRL velocity_m_s must have one value per point ({n}) or per point after the "
            f"first ({n - 1}), got {vel.shape[0]}"
        )
    for i, v in enumerate(vel):
        _check_velocity(f"velocity to point {i + 1}", v, vel_max)
    q0 = np.asarray(keys.start_axis_deg, dtype=float).reshape(-1)
    if q0.shape != (6,) or not np.isfinite(q0).all():
        raise InputError(f"KRL start_axis_deg must be 6 finite joint angles [deg], got {q0}")
    return KeyPoints(pts, motion, vel, q0)


def _comment_lines(comments: Sequence[str]) -> list[str]:
    out = []
    for c in comments:
        ascii_text = str(c).encode("ascii", "backslashreplace").decode("ascii")
        out.extend(f"; {part}" for part in ascii_text.splitlines() or [""])
    return out


def dat_text(name: str, frames: CellFrames, approach_axis_deg: np.ndarray,
             comments: Sequence[str] = ()) -> str:
    """The ``.dat`` module data: FO_TOOL / FO_BASE (FRAME), FO_LOAD (LOAD), FO_APPROACH (AXIS)."""
    axis = ",".join(f"A{i + 1} {_fmt(q, 4)}" for i, q in enumerate(approach_axis_deg))
    return "\n".join([
        f"DEFDAT {name} PUBLIC",
        "; Generated by feedopt: tool, base and load data of the program "
        f"{name}.src (see its header).",
        *_comment_lines(comments),
        *(f"; {line}" for line in header_lines(frames)),
        f"DECL FRAME {TOOL_VAR}={frames.tool.krl()}",
        f"DECL FRAME {BASE_VAR}={frames.base.krl()}",
        f"DECL LOAD {LOAD_VAR}={frames.load.krl()}",
        f"DECL AXIS {APPROACH_VAR}={{{axis}}}",
        "ENDDAT",
    ]) + "\n"


def _checked(path: Path, name: str | None, keys: KeyPoints, entry: EntryExit | None,
             spindle: SpindleControl, speeds: KrlSpeeds) -> tuple[str, KeyPoints]:
    """The program name and the validated key points, or InputError for a name, shape or value
    the controller refuses (checked before anything is written)."""
    name = path.stem if name is None else name
    if name.lower() != path.stem.lower():
        raise InputError(
            f"KRL program name {name!r} must equal the file name stem {path.stem!r} "
            "(the controller looks the program up by its file name)"
        )
    vel_max = min(float(speeds.vel_cp_max_m_s), VEL_CP_MAX)
    keys = _validate(name, keys, vel_max)
    spindle.check()
    _check_velocity("approach velocity", speeds.approach_vel_m_s, vel_max)
    if not (np.isfinite(speeds.accel_cp_m_s2) and speeds.accel_cp_m_s2 > 0):
        raise InputError(f"$ACC.CP must be positive, got {speeds.accel_cp_m_s2!r} m/s^2")
    if not (0 < speeds.approach_percent <= 100):
        raise InputError(
            f"approach_percent must be in (0, 100], got {speeds.approach_percent!r}")
    pts = keys.points
    _check_points(pts, extra=0 if entry is None else 2)
    if entry is not None:
        _check_points(np.vstack([entry.above_lead_in, entry.lead_in, pts[0]]),
                      names=("approach down to the lead-in point", "lead-in"))
        _check_points(np.vstack([pts[-1], entry.lead_out, entry.retract]),
                      names=("lead-out", "retract"))
    return name, keys


def _summary_lines(keys: KeyPoints, entry: EntryExit | None) -> list[str]:
    """Header comments on the block: stops between SLINs, the counts and feeds, the entry."""
    pts, motion, vel = keys.points, keys.motion, keys.velocity_m_s
    out = []
    n_slin_pairs = sum(
        1 for a, b in zip(motion[:-1], motion[1:], strict=True) if a == b == "SLIN"
    )
    if n_slin_pairs:
        out.append(
            f"; NOTE: {n_slin_pairs} pair(s) of successive SLIN segments below: the robot stops "
            "between them unless they are collinear."
        )
    out.append(
        f"; Points: {len(pts)} (start + {len(motion)} segments: "
        f"{motion.count('SLIN')} SLIN, {motion.count('SPL')} SPL); $VEL.CP from "
        f"{_fmt_vel(vel.min())} to {_fmt_vel(vel.max())} m/s."
    )
    out.append("; Start pose X,Y,Z,A,B,C = " + ", ".join(_fmt(v, 4) for v in pts[0]) + ".")
    if entry is None:
        out.append("; No approach, lead-in, lead-out or retract: the PTP goes straight to the "
                   "start joints.")
    else:
        out.append(f"; Entry: PTP to {APPROACH_MM:g} mm above the lead-in point, SLIN down, "
                   f"SLIN lead-in of {_fmt(np.linalg.norm(pts[0, :3] - entry.lead_in[:3]), 3)} mm "
                   "to the start; exit: SLIN lead-out, SLIN retract up the tool axis.")
    return out


def _header_fold(name: str, keys: KeyPoints, comments: Sequence[str], frames: CellFrames,
                 entry: EntryExit | None) -> list[str]:
    """``DEF`` and the header fold: what the program is, its frames, what it does not do."""
    out = [f"DEF {name}( )", ";FOLD feedopt header",
           "; Generated by feedopt: native KUKA spline program of the path key points "
           f"(KRC4, KSS 8.x); data in {name}.dat.", *_comment_lines(comments), ";"]
    out.extend(f"; {line}" for line in header_lines(frames))
    out.append(f"; In {name}.dat: {TOOL_VAR} = the TOOL_DATA, {BASE_VAR} = the BASE_DATA, "
               f"{LOAD_VAR} = the LOAD_DATA above, {APPROACH_VAR} = the approach joints.")
    out.append(";")
    out.extend(f"; {line}" for line in NATIVE_CONTROLLER_NOTE)
    return out + _summary_lines(keys, entry) + [";ENDFOLD", ""]


def _settings_fold(name: str, speeds: KrlSpeeds) -> list[str]:
    """The KSS 8.x INI fold, then $TOOL / $BASE / $LOAD from the .dat and the speeds."""
    out = [";FOLD INI",
           "  ;FOLD BASISTECH INI",
           "    GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )",
           "    INTERRUPT ON 3",
           "    BAS (#INITMOV,0 )",
           "  ;ENDFOLD (BASISTECH INI)",
           ";ENDFOLD (INI)", "",
           f";FOLD settings (tool, base and load from {name}.dat)",
           "$BWDSTART = FALSE",
           f"$TOOL = {TOOL_VAR}", f"$BASE = {BASE_VAR}", f"$LOAD = {LOAD_VAR}",
           "$IPO_MODE = #BASE", "$ORI_TYPE = #VAR", "$ADVANCE = 3"]
    out += [f"$VEL_AXIS[{i}] = {_fmt(speeds.approach_percent, 3)}" for i in range(1, 7)]
    out += [f"$ACC_AXIS[{i}] = {_fmt(speeds.approach_percent, 3)}" for i in range(1, 7)]
    return out + [f"$VEL.CP = {_fmt_vel(speeds.approach_vel_m_s)}", "$VEL.ORI1 = 200",
                  "$VEL.ORI2 = 200", f"$ACC.CP = {_fmt(speeds.accel_cp_m_s2, 6)}",
                  "$ACC.ORI1 = 100", "$ACC.ORI2 = 100", ";ENDFOLD", ""]


def _entry_lines(entry: EntryExit | None, spindle: SpindleControl, speeds: KrlSpeeds
                 ) -> list[str]:
    """PTP to the approach joints, spindle on, SLIN down to the lead-in point (with an entry)."""
    if entry is None:
        return ["; approach: joint move to the start configuration (robot stops here)",
                f"PTP {APPROACH_VAR}", "", *spindle.lines(on=True)]
    return [f"; approach: joint move to {APPROACH_MM:g} mm above the lead-in point",
            f"PTP {APPROACH_VAR}", "", *spindle.lines(on=True),
            "", "; down to the lead-in point (in the air)",
            f"SLIN {_pose(entry.lead_in)} WITH $VEL.CP = {_fmt_vel(speeds.approach_vel_m_s)}"]


def _spline_block(keys: KeyPoints, entry: EntryExit | None) -> list[str]:
    """``SPLINE ... ENDSPLINE``: the lead-in, the key points and the lead-out (with an entry)."""
    pts, motion, vel = keys.points, keys.motion, keys.velocity_m_s
    block = pts if entry is None else np.vstack([entry.lead_in, pts, entry.lead_out])
    seg_motion = motion if entry is None else ["SLIN", *motion, "SLIN"]
    seg_vel = vel if entry is None else np.concatenate([vel[:1], vel, vel[-1:]])
    out = ["", "SPLINE"]
    last = len(seg_motion)
    for k, (m, p, v) in enumerate(zip(seg_motion, block[1:], seg_vel, strict=True), start=1):
        what = ("lead-in" if entry is not None and k == 1 else
                "lead-out" if entry is not None and k == last else
                f"point {k - (entry is not None)}")
        out.append(f"  {m} {_pose(p)} WITH $VEL.CP = {_fmt_vel(v)} ; {what}")
    return out + ["ENDSPLINE"]


def _exit_lines(entry: EntryExit | None, spindle: SpindleControl, speeds: KrlSpeeds
                ) -> list[str]:
    """The retract up the tool axis (with an entry), spindle off, ``END``."""
    out = []
    if entry is not None:
        out += ["", f"; retract {APPROACH_MM:g} mm up the tool axis",
                f"SLIN {_pose(entry.retract)} WITH $VEL.CP = {_fmt_vel(speeds.approach_vel_m_s)}"]
    return out + ["", *spindle.lines(on=False), "END"]


def write_krl_program(
    path: str | Path,
    name: str | None,
    keys: KeyPoints,
    comments: Sequence[str] = (),
    *,
    frames: CellFrames,
    entry: EntryExit | None = None,
    spindle: SpindleControl = SpindleControl(),
    speeds: KrlSpeeds = KrlSpeeds(),
) -> tuple[Path, Path]:
    """Write the KRL ``.src`` and ``.dat`` that run ``keys`` natively (module docstring).

    Parameters
    ----------
    path : the ``.src`` to write (the ``.dat`` goes beside it); KRL requires the program name
        to equal the file stem.
    name : program name (``DEF name( )``); ``None`` takes the file stem.
    keys : the path start, its key points, their motions and ``$VEL.CP`` and the start joints
        (:class:`KeyPoints`).
    comments : extra lines for the header comment (scenario, law, ...).
    frames : tool, base and load data (:func:`feedopt.export.frames.cell_frames`).
    entry : approach, lead-in, lead-out and retract; ``None``: a PTP straight to the start
        joints and none of them (for a program that starts in the air).
    spindle : how the spindle is switched (:class:`SpindleControl`).
    speeds : ``$ACC.CP``, the PTP percentage, the approach ``$VEL.CP`` and the cell's largest
        ``$VEL.CP`` (:class:`KrlSpeeds`).

    Returns the ``.src`` and ``.dat`` paths. Raises :class:`InputError` for an invalid name,
    shape or value and for a violated controller limit; nothing is written then.
    """
    path = Path(path)
    name, keys = _checked(path, name, keys, entry, spindle, speeds)
    out = [*_header_fold(name, keys, comments, frames, entry), *_settings_fold(name, speeds),
           *_entry_lines(entry, spindle, speeds), *_spline_block(keys, entry),
           *_exit_lines(entry, spindle, speeds)]
    approach = keys.start_axis_deg if entry is None else entry.approach_axes_deg
    dat = dat_text(name, frames, approach, comments)
    dat_path = path.with_suffix(".dat")
    path.write_text("\n".join(out) + "\n", encoding="ascii")
    dat_path.write_text(dat, encoding="ascii")
    return path, dat_path


_SEG_RE = re.compile(
    r"^(?P<motion>SLIN|SPL)\s*\{(?P<pos>[^}]*)\}\s*(?:WITH\s+(?P<with>.*))?$", re.IGNORECASE
)
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_VEL_RE = re.compile(rf"\$VEL\.CP\s*=\s*(?P<v>{_NUM})", re.IGNORECASE)
_AX_RE = re.compile(rf"^\s*(?P<ax>[A-Za-z]+[0-9]?)\s+(?P<v>{_NUM})\s*$")
_DECL_RE = re.compile(r"^DECL\s+(?P<type>\w+)\s+(?P<name>\w+)\s*=\s*(?P<value>\{.*\})\s*$",
                      re.IGNORECASE)


def parse_krl_spline(text: str) -> list[dict]:
    """Parse the first ``SPLINE ... ENDSPLINE`` block of a KRL program.

    Returns one dict per motion: ``{"motion": "SLIN"|"SPL", "X", "Y", "Z" [mm], "A", "B",
    "C" [deg], "vel_m_s": float | None}`` (``None`` when the segment has no
    ``WITH $VEL.CP``). Comments (``;``) are ignored. Raises :class:`InputError` naming the line
    for a missing block, an unknown statement inside it or a malformed position.
    """
    lines = text.splitlines()
    start = None
    for i, raw in enumerate(lines):
        code = raw.split(";", 1)[0].strip()
        if re.match(r"^SPLINE\b", code, re.IGNORECASE):
            start = i
            break
    if start is None:
        raise InputError("no SPLINE block found in the KRL text")
    result: list[dict] = []
    for i in range(start + 1, len(lines)):
        code = lines[i].split(";", 1)[0].strip()
        if not code:
            continue
        if re.match(r"^ENDSPLINE\b", code, re.IGNORECASE):
            return result
        m = _SEG_RE.match(code)
        if not m:
            raise InputError(f"KRL line {i + 1}: expected SLIN/SPL {{...}} or ENDSPLINE: {code!r}")
        seg: dict = {"motion": m["motion"].upper()}
        for item in m["pos"].split(","):
            am = _AX_RE.match(item)
            if not am or am["ax"].upper() not in ("X", "Y", "Z", "A", "B", "C", "S", "T"):
                raise InputError(f"KRL line {i + 1}: cannot read position component {item!r}")
            seg[am["ax"].upper()] = float(am["v"])
        missing = [ax for ax in "XYZABC" if ax not in seg]
        if missing:
            raise InputError(f"KRL line {i + 1}: position lacks {', '.join(missing)}")
        seg["vel_m_s"] = None
        if m["with"]:
            vm = _VEL_RE.search(m["with"])
            seg["vel_m_s"] = float(vm["v"]) if vm else None
        result.append(seg)
    raise InputError(f"KRL SPLINE block opened on line {start + 1} has no ENDSPLINE")


def _aggregate(text: str, where: str) -> dict:
    """``{X 1.0,Y 2.0,CM {X 0.0}}`` -> ``{"X": 1.0, "Y": 2.0, "CM": {"X": 0.0}}``."""
    inner = text.strip()[1:-1]
    out: dict = {}
    depth, item, items = 0, "", []
    for ch in inner:
        depth += ch == "{"
        depth -= ch == "}"
        if ch == "," and depth == 0:
            items.append(item)
            item = ""
        else:
            item += ch
    items.append(item)
    for it in items:
        it = it.strip()
        if "{" in it:
            key, rest = it.split("{", 1)
            out[key.strip().upper()] = _aggregate("{" + rest, where)
            continue
        am = _AX_RE.match(it)
        if not am:
            raise InputError(f"{where}: cannot read {it!r}")
        out[am["ax"].upper()] = float(am["v"])
    return out


def parse_krl_dat(text: str) -> dict[str, dict]:
    """The ``DECL TYPE NAME={...}`` aggregates of a ``.dat`` as ``{NAME: {"type": TYPE, ...}}``
    (nested aggregates as dicts). Raises InputError naming the line for one it cannot read."""
    out = {}
    for i, raw in enumerate(text.splitlines(), start=1):
        code = raw.split(";", 1)[0].strip()
        m = _DECL_RE.match(code)
        if m:
            out[m["name"].upper()] = {"type": m["type"].upper(),
                                      **_aggregate(m["value"], f"KRL .dat line {i}")}
    return out


def key_points(job: ExportJob) -> KeyPoints:
    """Key points for the native-controller program (:func:`key_arc_lengths`): their (n, 6)
    poses (mm, deg), motions, ``$VEL.CP`` [m/s] and the start joints [deg]."""
    from feedopt.robot.kuka import abc_from_rotation
    from feedopt.robot.model import forward_kinematics

    s_arr, motions, vels = key_arc_lengths(job)
    q = job.q_of_s(s_arr)
    pose = forward_kinematics(job.robot, q)
    points = np.column_stack([pose[:, :3, 3] / MM, abc_from_rotation(pose[:, :3, :3])])
    return KeyPoints(points, motions, vels, job.robot.axis_convention.to_controller(q[0]))


def key_arc_lengths(job: ExportJob) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Key points for the native-controller program: segment ends (thesis section 3.7).

    Lines end in an ``SLIN``; a line is also cut at the chapter-4 key points (every
    ``key_point_spacing``, thesis 4.2) and where the law's feed changes by more than
    :data:`FEED_TOLERANCE`, so each SLIN's ``$VEL.CP`` is the lowest feed the law aims for on
    it (:func:`feedopt.export.gcode_out.law_feed_targets`: the law's feed without its
    boundary ramps, capped by the feed bound for a law that keeps it). Blends get two ``SPL``
    points (middle and end) at the lowest such feed through the blend. Returns their arc
    lengths (n,) [m] (the first 0), the motion into each (``SLIN`` / ``SPL``; n - 1) and its
    feed [m/s].
    """
    from feedopt.export.gcode_out import feed_pieces, law_feed_targets

    problem = job.problem
    s = problem.s
    target = law_feed_targets(job.verification.feed, problem.v_max, job.verification.exportable)
    s_pts, motions, vels = [0.0], [], []
    for a, b, kind in problem.segments():
        inside = np.arange(np.searchsorted(s, a, side="left"), np.searchsorted(s, b, side="right"))
        if inside.size < 2:
            inside = np.unique(np.clip(np.searchsorted(s, [a, b]), 0, s.size - 1))
        g = target[inside]
        if kind != "line":
            v = float(g.min())
            s_pts += [0.5 * (a + b), b]
            motions += ["SPL", "SPL"]
            vels += [v, v]
            continue
        breaks = []
        if problem.key_point_spacing > 0:
            marks = np.arange(a + problem.key_point_spacing, b - 0.5 * problem.key_point_spacing,
                              problem.key_point_spacing)
            breaks = np.unique(np.searchsorted(s[inside], marks)).tolist()
        if g.size < 2:
            bounds = np.array([0, max(g.size - 1, 0)])
        else:
            bounds = feed_pieces(g, FEED_TOLERANCE, breaks)
        for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
            s_pts.append(b if hi == bounds[-1] else float(s[inside[hi]]))
            motions.append("SLIN")
            vels.append(float(g[lo:hi + 1].min()))
    return np.asarray(s_pts), motions, np.asarray(vels)


def segment_count(path) -> int:
    """Spline segments :func:`key_points` makes for ``path`` at least (one per line, two per
    blend), plus the lead-in and the lead-out."""
    return sum(1 if seg.kind == "line" else 2 for seg in path.segments) + 2


def early_check(robot, path) -> Blocker | None:
    """Why no KRL program can be written for this robot and path, known before planning."""
    if robot.controller != "kuka":  # the format does not apply: no warning
        return Blocker(f"no KRL program: robot {robot.name} has controller "
                       f"'{robot.controller}' (robot.yaml), KRL is for KUKA controllers",
                       warn=False)
    if not robot.axis_convention.stated:
        return Blocker(f"no KRL program: {UNSTATED_AXES}")
    why = six_axes_only(robot, "KRL program")
    if why is not None:
        return Blocker(why)
    n_segments = segment_count(path)
    if n_segments > MAX_SEGMENTS:
        return Blocker(f"no KRL program: the path's key points make {n_segments} spline "
                       f"segments, more than the {MAX_SEGMENTS} a KSS 8.x SPLINE block holds; "
                       "the RSI CSVs are written as usual")
    return None


def export_krl(job: ExportJob, out_dir: Path, spindle: SpindleControl = SpindleControl()
               ) -> dict:
    """Write ``<law>.src`` and ``<law>.dat``, or record why not (a controller limit, an
    unreachable approach) as ``krl_program: None`` and ``krl_not_written``."""
    try:
        frames = cell_frames(job.robot)
        keys = key_points(job)
        entry = entry_exit(job)
        gap = orientation_gap_deg(job, key_arc_lengths(job)[0])
        five = gap_notes(gap, "key points")
        write_krl_program(out_dir / f"{job.law}.src", None, keys, comments=[
            status_line(job),
            f"feedopt scenario {job.scenario_name}, law {job.law}: key points of the path with "
            "the law's feeds as $VEL.CP",
            *five, *header_notes(job),
        ], frames=frames, entry=entry, spindle=spindle)
    except InputError as exc:
        return {"krl_program": None, "krl_not_written": f"no KRL program: {exc}"}
    return {"krl_program": f"{job.law}.src", "krl_data": f"{job.law}.dat",
            **({} if gap is None else {"krl_orientation_gap_deg": gap})}


EXPORTER = Exporter(
    name="krl", file_pattern="{law}.src, {law}.dat", export=export_krl,
    for_law=lambda job: job.native_program, early_check=early_check,
    description="KUKA KRL program + data (INI, $TOOL/$BASE/$LOAD, approach, spindle, lead-in, "
                "SPLINE with SLIN/SPL key points and per-segment $VEL.CP, lead-out, retract) for "
                "the native-controller comparison of thesis 3.7",
)
