"""RSI CSV: the trajectory a closed-loop KUKA RSI program replays, one row per controller cycle.

Columns (``shared/design.md``, in this order)::

    t_s, x_mm, y_mm, z_mm, a_deg, b_deg, c_deg, q1_deg..q6_deg,
    s_mm, feed_mm_s, accel_mm_s2, jerk_mm_s3, deflection_mm

The pose is the TCP in the robot base frame; A, B, C are KUKA intrinsic Z-Y'-X'' angles
(:mod:`feedopt.robot.kuka`). The file starts with ``#`` comment lines (units, frames, cycle),
then the header row, then the data rows. Floats are written as their shortest round-trip
decimals (:mod:`feedopt.floattext`), so :func:`write_rsi_csv` then :func:`read_rsi_csv` gives
back the same bits.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.job import ControllerSamples, Exporter, ExportJob, header_notes, status_line
from feedopt.floattext import refuse_non_finite, write_float_rows
from feedopt.robot.kuka import abc_from_rotation
from feedopt.textio import read_user_text
from feedopt.units import MM, MM_PER_M

#: Most joint columns an RSI CSV may have (a 6-axis arm on a track and a turntable is 8).
MAX_JOINTS = 12


def columns(joints: int = 6) -> tuple[str, ...]:
    """The header of an RSI CSV of a robot with ``joints`` joints (q1_deg..qN_deg)."""
    return ("t_s", "x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg",
            *(f"q{i}_deg" for i in range(1, joints + 1)),
            "s_mm", "feed_mm_s", "accel_mm_s2", "jerk_mm_s3", "deflection_mm")


#: The header of a 6-axis robot's RSI CSV (what RSI streaming reads).
COLUMNS: tuple[str, ...] = columns(6)

_HEADER_DOC = (
    "feedopt RSI trajectory: one row per RSI cycle.",
    "t_s: time [s] from the start of the cut.",
    "x_mm, y_mm, z_mm: TCP position in the robot base frame [mm].",
    "a_deg, b_deg, c_deg: TCP orientation, KUKA A,B,C = intrinsic Z-Y'-X'' Euler angles [deg]"
    " (R = Rz(A) Ry(B) Rx(C)); A and C are unwrapped along the trajectory (continuous).",
    "q1_deg..qN_deg: joint values [deg; mm for a prismatic joint] whose forward kinematics "
    "gives the pose above (one column per joint; the convention is stated below).",
    "s_mm: arc length along the tool path [mm]; feed_mm_s = ds/dt [mm/s];"
    " accel_mm_s2 = d2s/dt2; jerk_mm_s3 = d3s/dt3.",
    "deflection_mm: predicted static TCP deflection at the commanded feed [mm].",
    "Floats are shortest round-trip decimal representations; lines starting with # are comments.",
)


@dataclass(frozen=True)
class RsiTable:
    """The columns of an RSI CSV in file units (mm, deg, s); ``q_deg`` is (n, joints)."""

    t_s: np.ndarray
    x_mm: np.ndarray
    y_mm: np.ndarray
    z_mm: np.ndarray
    a_deg: np.ndarray
    b_deg: np.ndarray
    c_deg: np.ndarray
    q_deg: np.ndarray
    s_mm: np.ndarray
    feed_mm_s: np.ndarray
    accel_mm_s2: np.ndarray
    jerk_mm_s3: np.ndarray
    deflection_mm: np.ndarray

    def __post_init__(self) -> None:
        n = np.shape(self.t_s)[0] if np.ndim(self.t_s) == 1 else -1
        if n < 0:
            raise ValueError(f"RsiTable.t_s must be 1-D, got shape {np.shape(self.t_s)}")
        for f in fields(self):
            arr = np.array(getattr(self, f.name), dtype=np.float64)  # private, read-only copy
            want = (n,)
            if f.name == "q_deg":
                joints = arr.shape[1] if arr.ndim == 2 else 0
                want = (n, joints if 1 <= joints <= MAX_JOINTS else 6)
            if arr.shape != want:
                raise ValueError(f"RsiTable.{f.name} has shape {arr.shape}, expected {want}")
            arr.flags.writeable = False
            object.__setattr__(self, f.name, arr)

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    def as_matrix(self) -> np.ndarray:
        """All columns as an (n, 12 + joints) float array in :func:`columns` order."""
        return np.column_stack(
            [
                self.t_s,
                self.x_mm,
                self.y_mm,
                self.z_mm,
                self.a_deg,
                self.b_deg,
                self.c_deg,
                self.q_deg,
                self.s_mm,
                self.feed_mm_s,
                self.accel_mm_s2,
                self.jerk_mm_s3,
                self.deflection_mm,
            ]
        )

    @classmethod
    def from_matrix(cls, m: np.ndarray) -> RsiTable:
        """Inverse of :meth:`as_matrix`."""
        m = np.asarray(m, dtype=np.float64)
        joints = m.shape[1] - 12 if m.ndim == 2 else 0
        if not 1 <= joints <= MAX_JOINTS:
            raise ValueError(f"expected an (n, 12 + joints) matrix, got {np.shape(m)}")
        c = [m[:, i] for i in range(m.shape[1])]
        return cls(*c[:7], m[:, 7:7 + joints], *c[7 + joints:])

    def equals(self, other: RsiTable) -> bool:
        """Bit-exact equality of every column (``-0.0 != 0.0`` here, NaN == NaN)."""
        a, b = self.as_matrix(), other.as_matrix()
        return a.shape == b.shape and a.view(np.uint64).tobytes() == b.view(np.uint64).tobytes()


def rsi_table_from_si(
    samples: ControllerSamples,
    position_m: np.ndarray,
    rotation: np.ndarray,
    q_rad: np.ndarray,
    deflection_m: np.ndarray,
) -> RsiTable:
    """Build an :class:`RsiTable` from SI arrays (s, m, rad, m/s, m/s^2, m/s^3).

    ``samples`` gives t, s, feed (``motion.sdot``), acceleration (``motion.sddot``) and
    ``jerk``; ``position_m`` is (n, 3) and ``rotation`` (n, 3, 3): the TCP pose in the robot
    base frame.
    A, B, C come from :func:`feedopt.robot.kuka.abc_from_rotation`, then A and C are unwrapped
    along the rows (``np.unwrap`` with period 360 deg) so a tool pointing down (C near 180 deg)
    does not flip between +180 and -180 from one cycle to the next; the rotation is unchanged.
    """
    motion = samples.motion
    t = np.asarray(motion.t, dtype=float)
    p = np.asarray(position_m, dtype=float)
    r = np.asarray(rotation, dtype=float)
    n = t.shape[0]
    if p.shape != (n, 3) or r.shape != (n, 3, 3):
        raise ValueError(
            f"position_m must be ({n}, 3) and rotation ({n}, 3, 3); got {p.shape} and {r.shape}"
        )
    abc = abc_from_rotation(r)
    if n:
        abc[:, 0] = np.unwrap(abc[:, 0], period=360.0)
        abc[:, 2] = np.unwrap(abc[:, 2], period=360.0)
    return RsiTable(
        t_s=t,
        x_mm=p[:, 0] * MM_PER_M,
        y_mm=p[:, 1] * MM_PER_M,
        z_mm=p[:, 2] * MM_PER_M,
        a_deg=abc[:, 0],
        b_deg=abc[:, 1],
        c_deg=abc[:, 2],
        q_deg=np.rad2deg(np.asarray(q_rad, dtype=float)),
        s_mm=np.asarray(motion.s, dtype=float) * MM_PER_M,
        feed_mm_s=np.asarray(motion.sdot, dtype=float) * MM_PER_M,
        accel_mm_s2=np.asarray(motion.sddot, dtype=float) * MM_PER_M,
        jerk_mm_s3=np.asarray(samples.jerk, dtype=float) * MM_PER_M,
        deflection_mm=np.asarray(deflection_m, dtype=float) * MM_PER_M,
    )


def _cycle_comment(t: np.ndarray) -> str:
    if t.shape[0] < 2:
        return "cycle: single sample"
    dt = np.diff(t)
    med = float(np.median(dt))
    spread = float(np.max(np.abs(dt - med)))
    return f"cycle_s: {med!r} (largest deviation from it {spread:.3g} s; {t.shape[0]} rows)"


def write_rsi_csv(path: str | Path, table: RsiTable, comments: Sequence[str] = ()) -> Path:
    """Write ``table`` as an RSI CSV; ``comments`` are extra ``#`` lines (scenario, law, ...).

    Refuses (``ValueError``) non-finite values: a controller file must not contain NaN/inf.
    Returns the path written.
    """
    m = table.as_matrix()
    if m.shape[0] == 0:
        raise ValueError(f"RSI table is empty; refusing to write {path}")
    header = columns(table.q_deg.shape[1])
    refuse_non_finite(m, header, "RSI table", path)
    lines = [f"# {c}" for c in _HEADER_DOC]
    lines.append(f"# {_cycle_comment(table.t_s)}")
    for c in comments:
        ascii_text = str(c).encode("ascii", "backslashreplace").decode("ascii")
        lines.extend(f"# {part}" for part in ascii_text.splitlines() or [""])
    lines.append(",".join(header))
    # Blocks of rows are written as they are formatted: the file is never held in memory
    # (11 h at 4 ms is 2.5 GB).
    path = Path(path)
    with path.open("w", encoding="ascii", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
        write_float_rows(f, m)
    return path


def _raise_bad_field(path: Path, lineno: int, parts: list[str],
                     header: tuple[str, ...]) -> None:
    """Say which field of a data row is not a finite number."""
    for i, p in enumerate(parts):
        try:
            v = float(p)
        except ValueError:
            raise InputError(
                f"{path}:{lineno}: column {header[i]!r} (field {i + 1}) is {p!r}, not a number"
            ) from None
        if not math.isfinite(v):
            raise InputError(
                f"{path}:{lineno}: column {header[i]!r} (field {i + 1}) is {p!r}; "
                "values must be finite"
            )


def _check_header(path: Path, lineno: int, parts: list[str], expected: tuple[str, ...]
                  ) -> None:
    """InputError naming the first header column that differs from ``expected``."""
    if tuple(parts) == expected:
        return
    for i, (got, want) in enumerate(zip(parts, expected, strict=False)):
        if got != want:
            raise InputError(
                f"{path}:{lineno}: header column {i + 1} is {got!r}, expected {want!r} "
                f"(header must be: {','.join(expected)})")
    raise InputError(f"{path}:{lineno}: header has {len(parts)} columns, expected "
                     f"{len(expected)} ({','.join(expected)})")


def read_rsi_csv(path: str | Path) -> RsiTable:
    """Read an RSI CSV written by :func:`write_rsi_csv` (or by hand in the same format).

    Raises
    ------
    InputError
        Missing file, wrong header, a row with the wrong number of fields, a field that is not
        a finite number, or times that do not increase; the message names the line and column.
    """
    path = Path(path)
    text = read_user_text(path, "RSI CSV")
    header_line = None
    rows: list[list[float]] = []
    line_numbers: list[int] = []
    expected = COLUMNS
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        parts = [p.strip() for p in line.split(",")]
        if header_line is None:
            header_line = lineno
            joints = sum(1 for p in parts if re.fullmatch(r"q\d+_deg", p))
            expected = columns(joints) if 1 <= joints <= MAX_JOINTS else COLUMNS
            _check_header(path, lineno, parts, expected)
            continue
        if len(parts) != len(expected):
            raise InputError(
                f"{path}:{lineno}: row has {len(parts)} fields, expected {len(expected)} "
                f"(one per column {','.join(expected)})"
            )
        try:
            values = list(map(float, parts))
        except ValueError:
            values = None
        if values is None or not all(map(math.isfinite, values)):
            _raise_bad_field(path, lineno, parts, expected)
        rows.append(values)
        line_numbers.append(lineno)
    if header_line is None:
        raise InputError(f"{path}: no header row found (expected: {','.join(COLUMNS)})")
    if not rows:
        raise InputError(f"{path}: header found on line {header_line} but no data rows")
    m = np.array(rows, dtype=np.float64)
    dt = np.diff(m[:, 0])
    if (dt <= 0).any():
        k = int(np.argmax(dt <= 0)) + 1
        raise InputError(
            f"{path}:{line_numbers[k]}: column 't_s' is {float(m[k, 0])!r}, not greater "
            f"than the previous row's {float(m[k - 1, 0])!r}; time must increase strictly"
        )
    return RsiTable.from_matrix(m)


def export_rsi(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>.csv``: the law at the RSI cycle, pose = pinocchio FK of the q columns
    (q interpolated along s between the IK samples)."""
    from feedopt.export.frames import frames_header_lines

    motion = job.samples.motion
    q, pose = job.controller_joints, job.controller_pose
    # How far FK of the interpolated joints is from the exact path point (for the record).
    exact = job.path_in_base(motion.s)
    interp_error = float(np.max(np.linalg.norm(pose[:, :3, 3] - exact, axis=1)))
    deflection = np.interp(motion.s, job.problem.s, job.verification.deflection)
    table = rsi_table_from_si(job.samples, pose[:, :3, 3], pose[:, :3, :3], q, deflection)
    axes = job.robot.axis_convention
    table = dataclasses.replace(table, q_deg=axes.to_controller(q))
    ver = job.verification
    write_rsi_csv(out_dir / f"{job.law}.csv", table, comments=[
        status_line(job),
        f"cycle time {job.trajectory.duration:.4f} s, max predicted deflection "
        f"{ver.max_deflection / MM:.4f} mm (limit {job.limit_mm} mm)",
        "pose: TCP in the robot base frame, A,B,C = KUKA Z-Y'-X'' (deg); q from IK; "
        "deflection = predicted static deflection at the commanded feed",
        f"q1..q{q.shape[1]}: {axes.describe()}",
        *frames_header_lines(job.robot),
        *header_notes(job),
    ])
    return {"fk_vs_path_error_mm": interp_error / MM,
            "fk_vs_path_axis_error_deg": axis_error_deg(job, pose), "rsi_csv": f"{job.law}.csv"}


def axis_error_deg(job: ExportJob, pose: np.ndarray) -> float:
    """Largest angle [deg] between the tool axis of the commanded poses (FK's z) and the
    path's tool axis at the controller samples (interpolated between the path samples,
    where the IK holds it exactly): the orientation the stream would leave the path by."""
    axes = job.sample_tool_axes
    s = job.samples.motion.s
    want = np.column_stack([np.interp(s, job.problem.s, axes[:, k]) for k in range(3)])
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    got = pose[:, :3, 2]
    cross = np.linalg.norm(np.cross(got, want), axis=1)
    return float(np.degrees(np.max(np.arctan2(cross, np.einsum("ij,ij->i", got, want)))))


EXPORTER = Exporter(
    name="rsi", file_pattern="{law}.csv", export=export_rsi,
    description="RSI CSV: one row per controller cycle (t, TCP pose, q, s, feed, acceleration, "
                "jerk, predicted deflection)",
)
