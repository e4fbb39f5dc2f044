"""A feedopt RSI setpoint table as the corrections RSI applies to the pose at ``RSI_ON``.

RSI does not take absolute poses: in sensor-guided motion (``RSI_MOVECORR()``, the thesis's
SGM, section 3.6.2) the robot holds the pose it had at ``RSI_ON`` and the sensor's ``RKorr``
moves it. Row 0 of the table is that pose (the host program drives there before
``RSI_ON``); row k is sent k cycles later. Two modes, as ``RSI_ON`` takes them:

- ``absolute`` (``RSI_ON(#ABSOLUTE, ...)``): each answer is the total correction
  ``pose[k] - pose[0]``; with ``HOLDON="1"`` a late answer leaves the last one in place.
- ``relative`` (``RSI_ON(#RELATIVE, ...)``): each answer is the increment of this cycle
  ``pose[k] - pose[k-1]``, added up by the controller; a lost answer loses its increment.

X, Y, Z are differences of the TCP position in the base frame (``#BASE`` correction frame) [mm];
A, B, C differences of the KUKA A, B, C angles [deg], unwrapped along the table (the exported
tables keep B and C constant on tool-vertical paths, where this is the rotation about the base
z axis exactly; elsewhere it is a first-order correction, see the report of issue 16).
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from feedopt import floattext
from feedopt.errors import InputError
from feedopt.floattext import refuse_non_finite
from feedopt.rsi.protocol import CorrectionSpace

if TYPE_CHECKING:  # types only: the export package imports this module (rsi_program)
    from feedopt.export.rsi import RsiTable

#: Columns of ``<law>_rsi.csv``: the RKorr answer of every cycle.
COLUMNS = ("t_s", "rkorr_x_mm", "rkorr_y_mm", "rkorr_z_mm", "rkorr_a_deg", "rkorr_b_deg",
           "rkorr_c_deg")
#: Its columns in axis mode: the AK answer (axis corrections, controller axis values).
AXIS_COLUMNS = ("t_s", *(f"ak_a{i}_deg" for i in range(1, 7)))
#: Row times may differ from k * cycle by this much [s] (the exported tables: ~1e-14 s).
CYCLE_TOLERANCE_S = 1e-6


class CorrectionMode(enum.Enum):
    """How the controller combines the answers: ``RSI_ON(#ABSOLUTE)`` or ``#RELATIVE``."""

    ABSOLUTE = "absolute"
    RELATIVE = "relative"

    @property
    def krl(self) -> str:
        """The ``RSI_ON`` argument of this mode."""
        return f"#{self.name}"


@dataclass(frozen=True)
class CorrectionPlan:
    """A trajectory as corrections from the pose at ``RSI_ON`` (row 0).

    Attributes
    ----------
    t_s : (n,) row times [s], ``cycle_s`` apart.
    start_pose : (6,) X, Y, Z [mm], A, B, C [deg] of row 0: where the robot must be at RSI_ON.
    start_q_deg : (6,) joint angles of row 0 [deg].
    absolute : (n, 6) total correction of every row [mm, deg]; row 0 is zero. In axis
        mode (``space``) the controller's axis values less those of row 0 [deg].
    cycle_s : controller cycle the rows are spaced by [s].
    source : the file the plan was read from (for messages).
    space : what is corrected: the TCP pose (RKorr) or the axes (AK / AKorr).
    tcp_steps_mm : (n - 1,) TCP translation from row to row [mm] (the speed the stop and
        resume ramps are sized by; in Cartesian mode that of ``absolute``).
    """

    t_s: np.ndarray
    start_pose: np.ndarray
    start_q_deg: np.ndarray
    absolute: np.ndarray
    cycle_s: float
    source: str = ""
    space: CorrectionSpace = CorrectionSpace.CARTESIAN
    tcp_steps_mm: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    def tcp_steps(self) -> np.ndarray:
        """(n - 1,) TCP translation per cycle [mm]."""
        if self.tcp_steps_mm is not None:
            return self.tcp_steps_mm
        return step_sizes(self.absolute)[0]

    @property
    def relative(self) -> np.ndarray:
        """(n, 6) per-cycle increments; row 0 is zero. Their running sum is :attr:`absolute`."""
        return np.diff(self.absolute, axis=0, prepend=self.absolute[:1])

    def answers(self, mode: CorrectionMode) -> np.ndarray:
        """(n, 6) what is sent in each cycle's RKorr in ``mode``."""
        return self.absolute if mode is CorrectionMode.ABSOLUTE else self.relative

    def poses(self) -> np.ndarray:
        """(n, 6) the commanded poses: ``start_pose + absolute``."""
        return self.start_pose + self.absolute


def plan_from_poses(t_s: np.ndarray, pose: np.ndarray, start_q_deg: np.ndarray,
                    cycle_s: float, source: str = "RSI CSV") -> CorrectionPlan:
    """Corrections of the poses ``pose`` (n, 6: X, Y, Z [mm], A, B, C [deg]) at times ``t_s``.

    Raises InputError when the rows are not ``cycle_s`` apart (a trajectory planned for
    another RSI cycle, or not uniformly sampled), naming the row.
    """
    t = np.asarray(t_s, dtype=float)
    ms = 1e3 * cycle_s
    if t.shape[0] >= 2:
        dt = np.diff(t)
        median = float(np.median(dt))
        if abs(median - cycle_s) > CYCLE_TOLERANCE_S:
            raise InputError(
                f"{source}: its rows are {1e3 * median:g} ms apart, but the stream's cycle is "
                f"{ms:g} ms (--cycle-ms): plan the trajectory for this cycle "
                f"(export.rsi_cycle_ms: {ms:g}) or run RSI at {1e3 * median:g} ms "
                "(--cycle-ms, RSI_ON(..., #IPO) for 12 ms, #IPO_FAST for 4 ms)")
        bad = np.flatnonzero(np.abs(dt - cycle_s) > CYCLE_TOLERANCE_S)
        if bad.size:
            k = int(bad[0]) + 1
            raise InputError(
                f"{source}: data row {k} (t_s = {float(t[k])!r}) is {1e3 * dt[k - 1]:.6g} ms after "
                f"the previous row; every row must be one {ms:g} ms cycle after the last "
                "(a feedopt RSI CSV is sampled uniformly)")
    pose = np.array(pose, dtype=float)
    pose[:, 3:] = np.unwrap(pose[:, 3:], period=360.0, axis=0)
    absolute = pose - pose[0]
    absolute.flags.writeable = False
    return CorrectionPlan(t_s=t, start_pose=pose[0].copy(),
                          start_q_deg=np.array(start_q_deg, dtype=float), absolute=absolute,
                          cycle_s=float(cycle_s), source=source)


def plan_from_table(table: RsiTable, cycle_s: float, source: str = "RSI CSV",
                    space: CorrectionSpace = CorrectionSpace.CARTESIAN) -> CorrectionPlan:
    """Corrections of ``table`` (read with :func:`feedopt.export.rsi.read_rsi_csv`); see
    :func:`plan_from_poses`. In axis mode the corrections are of its q columns (the
    controller's axis values, robot.yaml's ``controller.axes``)."""
    joints = table.q_deg.shape[1]
    if joints != 6:
        raise InputError(f"{source}: {joints} joint columns (q1_deg..q{joints}_deg); RSI "
                         "corrections are streamed to a 6-axis KUKA: this CSV is from a "
                         f"{joints}-axis robot")
    pose = np.column_stack([table.x_mm, table.y_mm, table.z_mm, table.a_deg, table.b_deg,
                            table.c_deg])
    plan = plan_from_poses(table.t_s, pose, table.q_deg[0], cycle_s, source)
    if space is CorrectionSpace.CARTESIAN:
        return plan
    return axis_plan(plan, table.q_deg)


def axis_plan(plan: CorrectionPlan, q_deg: np.ndarray) -> CorrectionPlan:
    """``plan`` as axis corrections: the controller axis values ``q_deg`` (n, 6) [deg] less
    row 0's (AK / AKorr, ``RSI_ON`` with an AXISCORR object)."""
    q = np.asarray(q_deg, dtype=float)
    absolute = q - q[0]
    absolute.flags.writeable = False
    return dataclasses.replace(plan, absolute=absolute, space=CorrectionSpace.AXIS,
                               start_q_deg=q[0].copy(), tcp_steps_mm=plan.tcp_steps())


def step_sizes(absolute: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-cycle steps of a correction sequence (n, 6): translation norm [mm] and the largest
    angle change [deg], each (n - 1,)."""
    d = np.diff(np.asarray(absolute, dtype=float), axis=0)
    return np.linalg.norm(d[:, :3], axis=1), np.max(np.abs(d[:, 3:]), axis=1, initial=0.0)


def check_steps(plan: CorrectionPlan, max_step_mm: float, max_step_deg: float) -> None:
    """InputError naming the first row whose step from the previous one exceeds the per-cycle
    limits: the streamer would have to clip it, which would leave the planned path. In axis
    mode every axis's step is in deg (``max_step_deg``)."""
    trans, ang = step_sizes(plan.absolute)
    checks = [(trans, max_step_mm, "mm", "--max-step-mm"),
              (ang, max_step_deg, "deg", "--max-step-deg")]
    if plan.space is CorrectionSpace.AXIS:
        axis = np.max(np.abs(np.diff(plan.absolute, axis=0)), axis=1, initial=0.0)
        checks = [(axis, max_step_deg, "deg of an axis", "--max-step-deg")]
    for values, limit, unit, option in checks:
        bad = np.flatnonzero(values > limit)
        if bad.size:
            k = int(bad[0]) + 1
            raise InputError(
                f"{plan.source}: data row {k} (t_s = {float(plan.t_s[k])!r}) moves "
                f"{values[k - 1]:.6g} {unit} in one cycle, more than the per-cycle limit "
                f"{limit:g} {unit} ({option}; the largest step of the trajectory is "
                f"{values.max():.6g} {unit}): raise {option} if the cell allows that speed")


def limit_step(previous: np.ndarray, desired: np.ndarray, max_step_mm: float,
               max_step_deg: float,
               space: CorrectionSpace = CorrectionSpace.CARTESIAN) -> np.ndarray:
    """``desired`` moved towards ``previous`` so that the step between them is within the
    per-cycle limits (translation norm <= ``max_step_mm``, each angle <= ``max_step_deg``);
    the direction of each part is kept. In axis mode the whole step is scaled so that no
    axis moves more than ``max_step_deg`` (the direction in joint space is kept)."""
    step = np.asarray(desired, dtype=float) - previous
    out = step.copy()
    if space is CorrectionSpace.AXIS:
        largest = float(np.max(np.abs(step)))
        return previous + (out * (max_step_deg / largest) if largest > max_step_deg else out)
    norm = float(np.linalg.norm(step[:3]))
    if norm > max_step_mm:
        out[:3] *= max_step_mm / norm
    largest = float(np.max(np.abs(step[3:])))
    if largest > max_step_deg:
        out[3:] *= max_step_deg / largest
    return previous + out


def wrap_deg(angle: np.ndarray) -> np.ndarray:
    """Angles [deg] wrapped to [-180, 180)."""
    return (np.asarray(angle, dtype=float) + 180.0) % 360.0 - 180.0


def write_corrections_csv(path: str | Path, plan: CorrectionPlan, mode: CorrectionMode,
                          comments: Sequence[str] = ()) -> Path:
    """Write ``<law>_rsi.csv``: ``#`` lines (mode, start pose, units), header, one row per cycle
    with the RKorr of that cycle in ``mode`` (floats as shortest round-trip decimals)."""
    sp = plan.start_pose
    axis = plan.space is CorrectionSpace.AXIS
    lines = [
        "# feedopt RSI corrections: the " + ("AK (axis)" if axis else "RKorr")
        + " answer of every controller cycle.",
        f"# mode: {mode.value} (RSI_ON({mode.krl}, ...)): " + (
            "each row is the total correction from the pose at RSI_ON"
            if mode is CorrectionMode.ABSOLUTE else
            "each row is this cycle's increment, added up by the controller"),
        ("# ak_a1..a6_deg: difference of the controller's axis values A1..A6 from those at "
         "RSI_ON [deg] (an AXISCORR object)" if axis else
         "# correction frame: #BASE; rkorr_x/y/z_mm: TCP position difference in the robot base "
         "frame [mm]; rkorr_a/b/c_deg: difference of the KUKA A, B, C angles [deg]"),
        "# pose at RSI_ON (row 0 of the trajectory; the host program moves there first): "
        + ", ".join(f"{n} {v!r}" for n, v in zip("XYZABC", sp.tolist(), strict=True)),
        "# joints at RSI_ON [deg]: " + ", ".join(
            f"A{i + 1} {v!r}" for i, v in enumerate(plan.start_q_deg.tolist())),
        f"# cycle_s: {plan.cycle_s!r}; row k is the answer k cycles after RSI_ON's first "
        "packet; the trajectory ends at rest, hold the last row",
    ]
    for c in comments:
        text = str(c).encode("ascii", "backslashreplace").decode("ascii")
        lines.extend(f"# {part}" for part in text.splitlines() or [""])
    columns = AXIS_COLUMNS if axis else COLUMNS
    lines.append(",".join(columns))
    answers = plan.answers(mode)
    path = Path(path)
    refuse_non_finite(plan.t_s[:, None], columns[:1], "RSI corrections", path)
    refuse_non_finite(answers, columns[1:], "RSI corrections", path)
    with path.open("w", encoding="ascii", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
        for start in range(0, len(plan), floattext.ROWS_PER_BLOCK):
            stop = start + floattext.ROWS_PER_BLOCK
            f.write(floattext.format_float_rows(
                np.column_stack([plan.t_s[start:stop], answers[start:stop]])))
    return path
