"""KUKA KRL program of a path for the native controller (KRC4, KSS 8.x spline motions).

The thesis (section 3.7) compares its closed-loop RSI trajectory with the controller's own
planner fed with key points of the path in a ``SPLINE ... ENDSPLINE`` block, using ``SLIN``
for the straight lines and ``SPL`` for the corners. :func:`write_krl_program` writes such a
program with a per-segment ``WITH $VEL.CP = ...`` (m/s), so the feed schedule of a timing law
can be replayed natively at the key points, and a comment block says what the controller will
do differently from the RSI trajectory. :func:`parse_krl_spline` reads the block back.

What the file contains (no BAS calls, every setting explicit):

- ``$BWDSTART``, ``$ADVANCE``, ``$TOOL``, ``$BASE``, ``$IPO_MODE``, ``$ORI_TYPE``;
- ``$VEL_AXIS[i]`` / ``$ACC_AXIS[i]`` (percent) for the approach, then
  ``PTP {A1 ..., A6 ...}`` to the start configuration (the joint angles of the first point);
- ``$VEL.CP`` / ``$ACC.CP`` (m/s, m/s^2), ``$VEL.ORI1/2`` / ``$ACC.ORI1/2`` (deg/s, deg/s^2);
- one ``SPLINE ... ENDSPLINE`` block with one ``SLIN``/``SPL`` per point after the first.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.job import Blocker, Exporter, ExportJob
from feedopt.units import MM

MOTIONS = ("SLIN", "SPL")
# KSS 8.x: a spline block holds at most 1000 segments (pass key points, not dense samples).
MAX_SEGMENTS = 1000
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


def _fmt(x: float, decimals: int) -> str:
    s = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _fmt_vel(v: float) -> str:
    """Velocity [m/s], 7 significant digits (KRL REAL is single precision), never exponent."""
    return np.format_float_positional(float(v), precision=7, unique=False, fractional=False,
                                      trim="-")


def _validate(name, points, motion, velocity_m_s, start_axis_deg):
    if not _NAME_RE.match(name):
        fixed = re.sub(r"[^A-Za-z0-9_]", "_", name)[:24] or "feedopt"
        if not re.match(r"[A-Za-z_]", fixed):
            fixed = "P" + fixed[:23]
        raise InputError(
            f"KRL program name {name!r} is not valid: use at most 24 letters, digits or '_' "
            f"starting with a letter (e.g. {fixed!r})"
        )
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 6 or pts.shape[0] < 2:
        raise InputError(
            f"KRL points must be an (n, 6) array [x, y, z mm, a, b, c deg] with n >= 2, "
            f"got shape {pts.shape}"
        )
    n = pts.shape[0]
    if n - 1 > MAX_SEGMENTS:
        raise InputError(
            f"KRL spline block would have {n - 1} segments; KSS 8.x allows {MAX_SEGMENTS} per "
            "block: pass the key points of the path (line ends, blend ends), not dense samples"
        )
    bad = np.argwhere(~np.isfinite(pts))
    if bad.size:
        i, j = bad[0]
        axis = "XYZABC"[j]
        raise InputError(f"KRL point {i} has a non-finite {axis} = {float(pts[i, j])!r}")
    motion = [str(m).upper() for m in motion]
    if len(motion) != n - 1:
        raise InputError(
            f"KRL motion must give one of {MOTIONS} per point after the first "
            f"({n - 1} values), got {len(motion)}"
        )
    for i, m in enumerate(motion):
        if m not in MOTIONS:
            raise InputError(f"KRL motion of point {i + 1} is {m!r}; use one of {MOTIONS}")
    vel = np.asarray(velocity_m_s, dtype=float).reshape(-1)
    if vel.shape[0] == n:
        vel = vel[1:]
    if vel.shape[0] != n - 1:
        raise InputError(
            f"KRL velocity_m_s must have one value per point ({n}) or per point after the "
            f"first ({n - 1}), got {vel.shape[0]}"
        )
    bad_v = np.flatnonzero(~(np.isfinite(vel) & (vel > 0)))
    if bad_v.size:
        i = int(bad_v[0])
        raise InputError(
            f"KRL velocity to point {i + 1} is {float(vel[i])!r} m/s; $VEL.CP must be positive "
            "and finite"
        )
    q0 = np.asarray(start_axis_deg, dtype=float).reshape(-1)
    if q0.shape != (6,) or not np.isfinite(q0).all():
        raise InputError(f"KRL start_axis_deg must be 6 finite joint angles [deg], got {q0}")
    return pts, motion, vel, q0


def write_krl_program(
    path: str | Path,
    name: str | None,
    points: np.ndarray,
    motion: Sequence[str],
    velocity_m_s: np.ndarray,
    start_axis_deg: np.ndarray,
    comments: Sequence[str] = (),
    *,
    tool: str = "TOOL_DATA[1]",
    base: str = "$NULLFRAME",
    accel_cp_m_s2: float = 1.0,
    approach_percent: float = 10.0,
) -> Path:
    """Write a KRL ``.src`` program that runs ``points`` natively in a spline block.

    Parameters
    ----------
    path : file to write; KRL requires the program name to equal the file stem.
    name : program name (``DEF name()``); ``None`` takes the file stem.
    points : (n, 6) TCP poses in the robot base frame, X, Y, Z [mm], A, B, C [deg] (KUKA
        Z-Y'-X''). The first point is where the robot already is after the PTP.
    motion : ``"SLIN"`` or ``"SPL"`` for each point after the first (n - 1 values).
    velocity_m_s : ``$VEL.CP`` [m/s] of the segment that reaches each point; n - 1 values, or n
        values of which the first (the start point) is ignored.
    start_axis_deg : (6,) joint angles A1..A6 [deg] of the start pose (IK of ``points[0]``).
    comments : extra lines for the header comment (scenario, law, ...).
    tool, base : KRL expressions assigned to ``$TOOL`` and ``$BASE``. ``$NULLFRAME`` is the
        robot base only when ``$ROBROOT`` = ``$WORLD`` (the default installation); the tool
        must be the TCP the path was planned for.
    accel_cp_m_s2 : ``$ACC.CP`` [m/s^2] for the spline block.
    approach_percent : ``$VEL_AXIS`` / ``$ACC_AXIS`` [%] for the PTP to the start.

    Returns the path written. Raises :class:`InputError` for an invalid name, shape or value.
    """
    path = Path(path)
    name = path.stem if name is None else name
    if name.lower() != path.stem.lower():
        raise InputError(
            f"KRL program name {name!r} must equal the file name stem {path.stem!r} "
            "(the controller looks the program up by its file name)"
        )
    pts, motion, vel, q0 = _validate(name, points, motion, velocity_m_s, start_axis_deg)
    if not (np.isfinite(accel_cp_m_s2) and accel_cp_m_s2 > 0):
        raise InputError(f"$ACC.CP must be positive, got {accel_cp_m_s2!r} m/s^2")
    if not (0 < approach_percent <= 100):
        raise InputError(f"approach_percent must be in (0, 100], got {approach_percent!r}")

    out = [f"DEF {name}()"]
    out.append(";FOLD feedopt header")
    out.append("; Generated by feedopt: native KUKA spline program of the path key points.")
    for c in comments:
        ascii_text = str(c).encode("ascii", "backslashreplace").decode("ascii")
        out.extend(f"; {part}" for part in ascii_text.splitlines() or [""])
    out.append(";")
    out.extend(f"; {line}" for line in NATIVE_CONTROLLER_NOTE)
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
    out.append(
        "; Start pose X,Y,Z,A,B,C = "
        + ", ".join(_fmt(v, 4) for v in pts[0])
        + " (robot must reach it with the PTP below)."
    )
    out.append(";ENDFOLD")
    out.append("")
    out.append(";FOLD settings (explicit, no BAS)")
    out.append("$BWDSTART = FALSE")
    out.append("$ADVANCE = 3")
    out.append(f"$TOOL = {tool}")
    out.append(f"$BASE = {base}")
    out.append("$IPO_MODE = #BASE")
    out.append("$ORI_TYPE = #VAR")
    for i in range(1, 7):
        out.append(f"$VEL_AXIS[{i}] = {_fmt(approach_percent, 3)}")
    for i in range(1, 7):
        out.append(f"$ACC_AXIS[{i}] = {_fmt(approach_percent, 3)}")
    out.append(f"$VEL.CP = {_fmt_vel(vel[0])}")
    out.append("$VEL.ORI1 = 200")
    out.append("$VEL.ORI2 = 200")
    out.append(f"$ACC.CP = {_fmt(accel_cp_m_s2, 6)}")
    out.append("$ACC.ORI1 = 100")
    out.append("$ACC.ORI2 = 100")
    out.append(";ENDFOLD")
    out.append("")
    out.append("; approach: joint move to the start configuration (robot stops here)")
    out.append("PTP {" + ", ".join(f"A{i + 1} {_fmt(q, 4)}" for i, q in enumerate(q0)) + "}")
    out.append("")
    out.append("SPLINE")
    for k, (m, p, v) in enumerate(zip(motion, pts[1:], vel, strict=True), start=1):
        pos = ", ".join(f"{ax} {_fmt(x, 4)}" for ax, x in zip("XYZABC", p, strict=True))
        out.append(f"  {m} {{{pos}}} WITH $VEL.CP = {_fmt_vel(v)} ; point {k}")
    out.append("ENDSPLINE")
    out.append("END")
    path.write_text("\n".join(out) + "\n", encoding="ascii")
    return path


_SEG_RE = re.compile(
    r"^(?P<motion>SLIN|SPL)\s*\{(?P<pos>[^}]*)\}\s*(?:WITH\s+(?P<with>.*))?$", re.IGNORECASE
)
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_VEL_RE = re.compile(rf"\$VEL\.CP\s*=\s*(?P<v>{_NUM})", re.IGNORECASE)
_AX_RE = re.compile(rf"^\s*(?P<ax>[A-Za-z]+)\s+(?P<v>{_NUM})\s*$")


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


def key_points(job: ExportJob) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """Key points for the native-controller program: segment ends (thesis section 3.7).

    Lines end in an ``SLIN`` at the law's feed in the middle of the line; blends get two
    ``SPL`` points (middle and end) at the law's lowest feed through the blend. Returns the
    (n, 6) poses (mm, deg), motions, ``$VEL.CP`` [m/s] and the start joints [deg].
    """
    from feedopt.robot.kuka import abc_from_rotation
    from feedopt.robot.model import forward_kinematics

    s_pts, motions, vels = [0.0], [], []
    feed_at = job.trajectory.feed_at
    for a, b, kind in job.problem.segments():
        if kind == "line":
            s_pts.append(b)
            motions.append("SLIN")
            vels.append(float(feed_at(np.array([0.5 * (a + b)]))[0]))
        else:  # blends: the controller's spline through the blend middle and end
            v = float(np.min(feed_at(np.linspace(a, b, 9))))
            s_pts += [0.5 * (a + b), b]
            motions += ["SPL", "SPL"]
            vels += [v, v]
    s_arr = np.asarray(s_pts)
    q = job.q_of_s(s_arr)
    pose = forward_kinematics(job.robot, q)
    points = np.column_stack([pose[:, :3, 3] / MM, abc_from_rotation(pose[:, :3, :3])])
    return points, motions, np.maximum(np.asarray(vels), 1e-6), np.rad2deg(q[0])


def segment_count(path) -> int:
    """Spline segments :func:`key_points` makes for ``path`` (one per line, two per blend)."""
    return sum(1 if seg.kind == "line" else 2 for seg in path.segments)


def early_check(robot, path) -> Blocker | None:
    """Why no KRL program can be written for this robot and path, known before planning."""
    if robot.controller != "kuka":  # the format does not apply: no warning
        return Blocker(f"no KRL program: robot {robot.name} has controller "
                       f"'{robot.controller}' (robot.yaml), KRL is for KUKA controllers",
                       warn=False)
    n_segments = segment_count(path)
    if n_segments > MAX_SEGMENTS:
        return Blocker(f"no KRL program: the path's key points make {n_segments} spline "
                       f"segments, more than the {MAX_SEGMENTS} a KSS 8.x SPLINE block holds; "
                       "the RSI CSVs are written as usual")
    return None


def export_krl(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>.src``: the law's segment feeds as ``$VEL.CP`` at the key points."""
    ver = job.verification
    pts, motions, vels, q0 = key_points(job)
    write_krl_program(out_dir / f"{job.law}.src", None, pts, motions, vels, q0, comments=[
        f"feedopt scenario {job.scenario_name}, law {job.law}: key points of the path with the "
        "law's segment feeds as $VEL.CP",
        *([] if ver.exportable else [f"NOT EXPORTABLE: {b}" for b in ver.export_blockers]),
    ])
    return {"krl_program": f"{job.law}.src"}


EXPORTER = Exporter(
    name="krl", file_pattern="{law}.src", export=export_krl,
    for_law=lambda job: job.native_program, early_check=early_check,
    description="KUKA KRL program (SPLINE with SLIN/SPL key points, per-segment $VEL.CP) for "
                "the native-controller comparison of thesis 3.7",
)
