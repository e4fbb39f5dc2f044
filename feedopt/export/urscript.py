"""URScript of a law for Universal Robots: the joint path as ``servoj`` set-points, one per cycle.

``<law>.script`` is one URScript program (``def feedopt_<law>(): ... end``) that a UR
controller runs by itself: send it to the controller's secondary interface (port 30002), or
load it in a PolyScope Script node (file) followed by a call of ``feedopt_<law>()``. Chosen
over an RTDE streaming client because it needs no PC in the loop, no real-time network and no
further software: the whole trajectory is in the file, and the controller's real-time machine
steps through it.

``servoj(q, 0, 0, t, lookahead_time, gain)`` blocks for ``t`` seconds while the robot servos
to ``q`` (UR's URScript manual, module motion); one call per cycle of the law sampled at ``t``
reproduces its timing. :data:`CYCLE_S` is 8 ms: the CB3 controller of the bundled UR10 runs its
real-time machine at 125 Hz, and ``t = 0.008`` is also valid on e-Series controllers (500 Hz),
which accept ``t = 0.002`` too (``cycle_s=0.002``; a CB3 would then run the trajectory up to
four times slower). ``lookahead_time`` and ``gain`` are UR's defaults (0.1 s, 300): the
lookahead smooths the set-points with a lag; at milling feeds (mm/s) that is far below a
micrometre of path, but it is the controller's, not the law's.

Around the path (:func:`feedopt.export.frames.entry_exit`, the same entry and exit as the KRL
program): ``set_tcp`` (:mod:`feedopt.export.frames`), ``movej`` to 50 mm above the lead-in
point, ``movel`` down to it and along the lead-in to the start (given as joints: the
controller's own kinematics turns them into the poses), spindle on, the servoj set-points,
the last one held for the lookahead time, ``stopj``, ``movel`` lead-out and retract, spindle
off. The payload is not set: the installation's applies (set it to the spindle's).

A program of more than :data:`MAX_SETPOINTS` set-points (about 33 min at 125 Hz, a script
of about 20 MB) is not written: a controller loads the whole script before it runs it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import APPROACH_MM, EntryExit, cell_frames, entry_exit, header_lines
from feedopt.export.job import Blocker, Exporter, ExportJob, header_notes, status_line
from feedopt.robot.axes import AxisConvention
from feedopt.robot.model import six_axes_only

#: servoj time per set-point [s]: the CB3 real-time cycle (125 Hz), valid on e-Series too.
CYCLE_S = 0.008
#: servoj lookahead [s] and gain: UR's defaults.
LOOKAHEAD_S = 0.1
GAIN = 300
#: Largest number of servoj set-points written (our choice, see the module docstring).
MAX_SETPOINTS = 250_000
#: movej to the approach pose: joint acceleration [rad/s^2] and speed [rad/s]; movel in the
#: air: tool acceleration [m/s^2] and speed [m/s].
MOVEJ_A, MOVEJ_V = 0.5, 0.25
MOVEL_A, MOVEL_V = 0.1, 0.02
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class UrSpindle:
    """How the script switches the spindle.

    output : standard digital output 0-7 set True to run, False to stop (None: none)
    run_up_s : wait after switching on [s]
    on_call, off_call : names of functions of your own (defined in the robot program or the
        installation) called instead
    With neither (the default) a blocking popup asks the operator before and after the cut.
    """

    output: int | None = None
    run_up_s: float = 5.0
    on_call: str | None = None
    off_call: str | None = None

    def lines(self, on: bool) -> list[str]:
        """URScript lines (without indentation) that switch the spindle on or off."""
        call = self.on_call if on else self.off_call
        what = "on" if on else "off"
        if call is not None:
            return [f"{call}()  # spindle {what}: your function"]
        if self.output is not None:
            out = [f"set_standard_digital_out({self.output}, {'True' if on else 'False'})"
                   f"  # spindle {what}"]
            return out + ([f"sleep({self.run_up_s:g})  # spindle run-up"] if on else [])
        return [f'popup("feedopt: switch the spindle {what}, then press Continue", '
                f'"feedopt", False, False, blocking=True)']

    def check(self) -> None:
        """InputError for an output or a function name a UR controller cannot take."""
        if self.output is not None and not (isinstance(self.output, int)
                                            and 0 <= self.output <= 7):
            raise InputError(f"UR spindle output {self.output!r}: use a standard digital "
                             "output 0-7")
        if not (np.isfinite(self.run_up_s) and 0 <= self.run_up_s <= 600):
            raise InputError(f"UR spindle run_up_s {self.run_up_s!r}: use 0-600 s")
        for call in (self.on_call, self.off_call):
            if call is not None and not _NAME_RE.match(call):
                raise InputError(f"UR spindle function {call!r}: use a URScript name")


@dataclass(frozen=True)
class UrEntryExit:
    """The moves onto and off the path: UR joint values [rad] of the entry and exit poses
    (:class:`feedopt.export.frames.EntryExit`) and the tool speed of the lead-in and of the
    lead-out [m/s] (the law's feeds at the path ends, without its ramps)."""

    q_above_lead_in: np.ndarray
    q_lead_in: np.ndarray
    q_lead_out: np.ndarray
    q_retract: np.ndarray
    lead_speed_m_s: tuple[float, float]

    @classmethod
    def of(cls, entry: EntryExit, axes: AxisConvention,
           lead_speed_m_s: tuple[float, float]) -> UrEntryExit:
        """``entry``'s joints as the controller's (``axes``: robot.yaml's axis convention)."""
        return cls(q_above_lead_in=axes.to_controller_si(entry.q_above_lead_in),
                   q_lead_in=axes.to_controller_si(entry.q_lead_in),
                   q_lead_out=axes.to_controller_si(entry.q_lead_out),
                   q_retract=axes.to_controller_si(entry.q_retract),
                   lead_speed_m_s=lead_speed_m_s)


def _joints(q: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:.7f}" for v in np.asarray(q, dtype=float)) + "]"


def urscript_text(name: str, q_setpoints: np.ndarray, *, cycle_s: float,
                  tcp_pose: tuple[float, ...], entry: UrEntryExit,
                  comments: tuple[str, ...] = (), spindle: UrSpindle = UrSpindle()) -> str:
    """The URScript program (see the module docstring).

    q_setpoints : (m, 6) joints [rad], one per ``cycle_s``, the first at the path start
    tcp_pose : ``set_tcp`` pose x, y, z [m], rotation vector [rad]
    entry : joints of the entry and exit poses [rad] and the lead-in / lead-out speeds
    """
    if not _NAME_RE.match(name):
        raise InputError(f"URScript program name {name!r}: use letters, digits and '_'")
    q = np.asarray(q_setpoints, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6 or q.shape[0] < 2 or not np.isfinite(q).all():
        raise InputError(f"URScript set-points must be a finite (m, 6) array with m >= 2, got "
                         f"{q.shape}")
    if q.shape[0] > MAX_SETPOINTS:
        raise InputError(f"URScript: {q.shape[0]} servoj set-points, more than the "
                         f"{MAX_SETPOINTS} written in one script; stream the trajectory instead")
    if not (0.002 <= cycle_s <= 0.1):
        raise InputError(f"URScript servoj time {cycle_s!r} s: use 0.008 (CB3 and e-Series) or "
                         "0.002 (e-Series)")
    lead_speed_m_s = entry.lead_speed_m_s
    for v in lead_speed_m_s:
        if not (np.isfinite(v) and 0 < v <= 1.0):
            raise InputError(f"URScript lead-in/out speed {v!r} m/s: use (0, 1] m/s")
    spindle.check()
    hold = int(np.ceil(LOOKAHEAD_S / cycle_s)) + 1
    tx, ty, tz, rx, ry, rz = tcp_pose
    body = [f"def feedopt_{name}():"]
    body += [f"  # {c}" for c in comments]
    body += [
        f"  set_tcp(p[{tx:.6f}, {ty:.6f}, {tz:.6f}, {rx:.6f}, {ry:.6f}, {rz:.6f}])",
        f"  def sj(q):",  # noqa: F541 - URScript
        f"    servoj(q, 0, 0, {cycle_s:g}, {LOOKAHEAD_S:g}, {GAIN})",
        "  end",
        f"  # approach: joint move to {APPROACH_MM:g} mm above the lead-in point, down, lead-in "
        "to the start",
        f"  movej({_joints(entry.q_above_lead_in)}, a={MOVEJ_A:g}, v={MOVEJ_V:g})",
        *(f"  {line}" for line in spindle.lines(on=True)),
        f"  movel({_joints(entry.q_lead_in)}, a={MOVEL_A:g}, v={MOVEL_V:g})",
        f"  movel({_joints(q[0])}, a={MOVEL_A:g}, v={lead_speed_m_s[0]:.6f})",
        f"  # the law: {q.shape[0]} set-points every {cycle_s:g} s",
    ]
    body += [f"  sj({_joints(row)})" for row in q]
    body += [
        "  # hold the last set-point for the lookahead time, then stop",
        "  k = 0",
        f"  while k < {hold}:",
        f"    sj({_joints(q[-1])})",
        "    k = k + 1",
        "  end",
        "  stopj(2.0)",
        f"  movel({_joints(entry.q_lead_out)}, a={MOVEL_A:g}, v={lead_speed_m_s[1]:.6f})",
        f"  movel({_joints(entry.q_retract)}, a={MOVEL_A:g}, v={MOVEL_V:g})",
        *(f"  {line}" for line in spindle.lines(on=False)),
        "end",
    ]
    return "\n".join(body) + "\n"


def early_check(robot, path) -> Blocker | None:
    """URScript is for UR controllers only (not worth a warning elsewhere)."""
    if robot.controller != "ur":
        return Blocker(f"no URScript: robot {robot.name} has controller '{robot.controller}' "
                       "(robot.yaml); URScript is for Universal Robots controllers", warn=False)
    why = six_axes_only(robot, "URScript")
    return None if why is None else Blocker(why)


def export_urscript(job: ExportJob, out_dir: Path, cycle_s: float = CYCLE_S,
                    spindle: UrSpindle = UrSpindle()) -> dict:
    """Write ``<law>.script``, or record why not (``urscript_not_written``)."""
    from feedopt.export.gcode_out import law_feed_targets

    motion = job.trajectory.sample_uniform(cycle_s)
    axes = job.robot.axis_convention  # UR joint values [rad] of the URDF's joints
    q = axes.to_controller_si(job.q_of_s(np.clip(motion.s, 0.0, job.problem.length)))
    target = law_feed_targets(job.verification.feed, job.problem.v_max,
                              job.verification.exportable)
    try:
        frames = cell_frames(job.robot)
        entry = UrEntryExit.of(entry_exit(job), axes, (float(target[0]), float(target[-1])))
        text = urscript_text(
            job.law, q, cycle_s=cycle_s, tcp_pose=frames.tcp_pose_ur, entry=entry,
            spindle=spindle,
            comments=(status_line(job), *header_lines(frames), *header_notes(job),
                      f"servoj every {cycle_s:g} s: {job.trajectory.duration:.4f} s of cutting"))
    except InputError as exc:
        return {"urscript_program": None, "urscript_not_written": f"no URScript: {exc}"}
    name = f"{job.law}.script"
    (out_dir / name).write_text(text, encoding="ascii")
    return {"urscript_program": name, "urscript_cycle_s": cycle_s}


EXPORTER = Exporter(
    name="urscript", file_pattern="{law}.script", export=export_urscript,
    early_check=early_check,
    description="URScript for Universal Robots: servoj joint set-points every 8 ms (the law's "
                "timing), with approach, lead-in, spindle hooks, lead-out and retract",
)
