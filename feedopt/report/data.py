"""What the report needs, in report units (mm, mm/s, deg/s, s), and the summary.json reader.

The scenario runner fills :class:`ReportData` from the verified trajectories; the report
never imports the planning stages. ``summary.json`` (``shared/design.md``, "Files other tools
read") is validated by :func:`validate_summary` before a table is printed from it.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.textio import read_user_text
from feedopt.units import MM, MM_PER_M
from feedopt.yamlio import excerpt

# Per-law keys of summary.json and their kinds: "pos" a number > 0 or null, "num" a number
# >= 0 or null, "bool" true, false or null. A run writes nothing negative, NaN or infinite
# there (report/summary.py writes null instead), so a summary holding such a value was edited.
LAW_KEYS: dict[str, str] = {
    "cycle_time_s": "pos",
    "lower_bound_s": "pos",
    "max_deflection_mm": "num",
    "max_feed_mm_s": "pos",
    "min_feed_mm_s": "num",
    "max_accel_mm_s2": "num",
    "max_jerk_mm_s3": "num",
    "c2": "bool",
    "verified": "bool",
    "planning_time_s": "num",
}
OPTIONAL_LAW_KEYS: dict[str, str] = {"deflection_ratio": "num", "exported": "bool"}
# Optional per-law objects (start/stop ramps, schedule/checks.py) and their numeric keys.
RAMP_KEYS = ("length_mm", "duration_s", "feed_mm_s", "s_from_mm", "s_to_mm")
#: Why a ramp ends (schedule/checks.py Ramp.reason).
RAMP_REASONS = ("flat", "bound", "path")
#: Largest magnitude of any number in summary.json: far above what a run writes (times of
#: days, km of path, feeds, accelerations and jerks of any robot), far below 1e308.
MAX_SUMMARY_NUMBER = 1e15
#: Largest summary.json read (a run writes tens of KiB).
MAX_SUMMARY_BYTES = 16 * 2**20
_LAW_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9._-]{0,63}$")


def _joints(a) -> int:
    """The joint count of an (m, joints) array (6 when it is not one: the check then says)."""
    shape = np.shape(a)
    return shape[1] if len(shape) == 2 and 1 <= shape[1] <= 12 else 6


def _ro(a, shape_tail: tuple[int, ...] = (), name: str = "") -> np.ndarray:
    arr = np.array(a, dtype=np.float64)
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        raise ValueError(f"{name} must have shape (n{''.join(f', {d}' for d in shape_tail)}), "
                         f"got {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class LawSeries:
    """One timing law's curves for the report.

    Path-sample curves (length k, the verifier's samples): ``s_mm``, ``feed_mm_s``,
    ``deflection_mm`` (predicted at the commanded feed). Time curves (length m, e.g. the RSI
    cycle): ``t_s``, ``feed_t_mm_s``, ``accel_mm_s2``, ``jerk_mm_s3``, ``joint_velocity_deg_s``
    (m, joints).
    """

    law: str
    s_mm: np.ndarray
    feed_mm_s: np.ndarray
    deflection_mm: np.ndarray
    t_s: np.ndarray
    feed_t_mm_s: np.ndarray
    accel_mm_s2: np.ndarray
    jerk_mm_s3: np.ndarray
    joint_velocity_deg_s: np.ndarray
    verified: bool = True
    notes: tuple[str, ...] = ()
    path_t_s: np.ndarray | None = None  # (k,) time at each path sample [s]; None: not given

    def __post_init__(self) -> None:
        for name in ("s_mm", "feed_mm_s", "deflection_mm", "t_s", "feed_t_mm_s",
                     "accel_mm_s2", "jerk_mm_s3"):
            object.__setattr__(self, name, _ro(getattr(self, name), name=f"{self.law}.{name}"))
        if self.path_t_s is not None:
            object.__setattr__(self, "path_t_s", _ro(self.path_t_s, name=f"{self.law}.path_t_s"))
        object.__setattr__(
            self,
            "joint_velocity_deg_s",
            _ro(self.joint_velocity_deg_s, (_joints(self.joint_velocity_deg_s),),
                f"{self.law}.joint_velocity_deg_s"),
        )
        k, m = self.s_mm.shape[0], self.t_s.shape[0]
        for name in ("feed_mm_s", "deflection_mm", "path_t_s"):
            if getattr(self, name) is not None and getattr(self, name).shape[0] != k:
                raise ValueError(f"{self.law}.{name} has {getattr(self, name).shape[0]} "
                                 f"samples, s_mm has {k}")
        for name in ("feed_t_mm_s", "accel_mm_s2", "jerk_mm_s3", "joint_velocity_deg_s"):
            if getattr(self, name).shape[0] != m:
                raise ValueError(f"{self.law}.{name} has {getattr(self, name).shape[0]} "
                                 f"samples, t_s has {m}")
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))


@dataclass(frozen=True)
class PathCurvesSI:
    """One law's curves on the path samples (k,), SI: arc length [m], feed [m/s] and the
    deflection predicted at that feed [m]."""

    s_m: np.ndarray
    feed_m_s: np.ndarray
    deflection_m: np.ndarray


@dataclass(frozen=True)
class TimeCurvesSI:
    """One law's curves in time (m,), SI: time [s], feed [m/s], tangential acceleration
    [m/s^2] and jerk [m/s^3], joint velocities (m, joints) [rad/s]."""

    t_s: np.ndarray
    feed_m_s: np.ndarray
    accel_m_s2: np.ndarray
    jerk_m_s3: np.ndarray
    joint_velocity_rad_s: np.ndarray


def law_series_from_si(
    law: str,
    path: PathCurvesSI,
    timed: TimeCurvesSI,
    verified: bool = True,
    notes: Sequence[str] = (),
) -> LawSeries:
    """:class:`LawSeries` from SI curves (m, m/s, m/s^2, m/s^3, rad/s); converts to mm, deg."""
    return LawSeries(
        law=law,
        s_mm=np.asarray(path.s_m, dtype=float) * MM_PER_M,
        feed_mm_s=np.asarray(path.feed_m_s, dtype=float) * MM_PER_M,
        deflection_mm=np.asarray(path.deflection_m, dtype=float) * MM_PER_M,
        t_s=np.asarray(timed.t_s, dtype=float),
        feed_t_mm_s=np.asarray(timed.feed_m_s, dtype=float) * MM_PER_M,
        accel_mm_s2=np.asarray(timed.accel_m_s2, dtype=float) * MM_PER_M,
        jerk_mm_s3=np.asarray(timed.jerk_m_s3, dtype=float) * MM_PER_M,
        joint_velocity_deg_s=np.rad2deg(np.asarray(timed.joint_velocity_rad_s, dtype=float)),
        verified=bool(verified),
        notes=tuple(notes),
    )


@dataclass(frozen=True)
class EngagementSeries:
    """What the stock gave along the path, for the engagement figure (workpiece frame, mm).

    s_mm, radial_mm, axial_mm, entry_deg, exit_deg : (n,) per sample (NaN angles in air);
        the angles are the first and last engaged ones, radial_mm the radial depth of the
        widest engaged interval, axial_mm the largest axial depth
    intervals : (n,) number of separate engaged intervals (0 in air)
    xy_mm : (n, 2) tool tip in the workpiece frame
    stock_top_mm : (nx, ny) height of the stock after the run (a view, not a copy)
    extent_mm : (x0, x1, y0, y1) of the stock grid
    """

    s_mm: np.ndarray
    xy_mm: np.ndarray
    radial_mm: np.ndarray
    axial_mm: np.ndarray
    entry_deg: np.ndarray
    exit_deg: np.ndarray
    stock_top_mm: np.ndarray
    extent_mm: tuple[float, float, float, float]
    intervals: np.ndarray


def engagement_series(samples, material) -> EngagementSeries | None:
    """The :class:`EngagementSeries` of a run's samples and its
    :class:`~feedopt.process.material.MaterialAlongPath`; None for a tri-dexel stock (its
    figure draws a Z-map's top)."""
    if not hasattr(material.after, "heights"):
        return None
    found = material.found
    air = found.in_air
    after = material.after
    nx, ny = after.shape
    x0, y0 = after.origin
    count, widest = found.interval_summary()
    return EngagementSeries(
        s_mm=samples.s / MM,
        xy_mm=samples.position[:, :2] / MM,
        radial_mm=np.where(air, 0.0, widest) / MM,
        intervals=np.where(air, 0, count),
        axial_mm=found.axial_depth / MM,
        entry_deg=np.where(air, np.nan, np.degrees(found.engagement.entry)),
        exit_deg=np.where(air, np.nan, np.degrees(found.engagement.exit)),
        stock_top_mm=after.heights / MM,
        extent_mm=(x0 / MM, (x0 + nx * after.cell) / MM, y0 / MM, (y0 + ny * after.cell) / MM),
    )


@dataclass(frozen=True)
class RedundancySeries:
    """``robot.redundancy: optimise`` along the path, for its report figure.

    s_mm, psi_deg : (n,) the rotation about the tool axis chosen, relative to the nearest IK
    stiffness_before, stiffness_after : (n, 2) principal in-plane stiffness [N/um], stiffest
        first, with the nearest IK and with psi(s)
    angle_before_deg, angle_after_deg : (n,) stiffest direction from the feed direction
    t_star_before, t_star_after : T* [s]
    status : what the optimisation did (feedopt.robot.redundancy.RedundancyStatus value)
    profile_label : the top panel's quantity: psi, or a 7-axis robot's held extra axis
    profile_nearest : (n,) that quantity with the nearest IK (None: zero, psi)
    title : the top panel's title
    """

    s_mm: np.ndarray
    psi_deg: np.ndarray
    stiffness_before: np.ndarray
    stiffness_after: np.ndarray
    angle_before_deg: np.ndarray
    angle_after_deg: np.ndarray
    t_star_before: float
    t_star_after: float
    status: str
    profile_label: str = "psi [deg]"
    profile_nearest: np.ndarray | None = None
    title: str = ""


def redundancy_series(result, nearest_compliance: np.ndarray, placement) -> RedundancySeries:
    """The :class:`RedundancySeries` of a :class:`feedopt.robot.redundancy.RedundancyResult`,
    the nearest IK's compliance (n, 3, 3) and the run's placement (tool axes, feed frames)."""
    from feedopt.robot.redundancy import stiffness_ellipses

    axes, feed = placement.tool_axes, placement.frames[:, :, 0]
    before = stiffness_ellipses(nearest_compliance, axes)
    after = stiffness_ellipses(result.along.compliance, axes)
    profile = {}
    if hasattr(result, "joint_name"):  # feedopt.robot.extra_axis.ExtraAxisResult
        held = result.along.q[:, result.joint]
        profile = dict(profile_label=f"{result.joint_name} [{result.unit}]",
                       profile_nearest=result.display(result.value_nearest),
                       title=f"extra axis {result.joint_name} ({result.status.value}), held "
                       f"(purple) against the nearest IK (grey): T* {result.t_star_nearest:.2f}"
                       f" s nearest -> {result.t_star:.2f} s")
        shown = result.display(held)
    else:
        shown = np.degrees(result.psi)
    return RedundancySeries(
        s_mm=result.s / MM, psi_deg=shown,
        stiffness_before=before.stiffness * 1e-6, stiffness_after=after.stiffness * 1e-6,
        angle_before_deg=np.degrees(before.angle_to(feed, axes)),
        angle_after_deg=np.degrees(after.angle_to(feed, axes)),
        t_star_before=result.t_star_nearest, t_star_after=result.t_star,
        status=result.status.value, **profile)


def _ro_as(a, dtype, name: str) -> np.ndarray:
    """A read-only 1-d array of ``dtype`` (ValueError naming ``name`` otherwise)."""
    arr = np.array(a, dtype=dtype)
    if arr.ndim != 1:
        raise ValueError(f"{name} must have shape (n,), got {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class SampleInfo:
    """Per path sample (k,) what the interactive figures show beside the laws' curves.

    v_max_mm_s : (k,) the feed bound v_max(s) [mm/s]
    active : (k,) uint8, index into ``constraints`` of the bound's tightest part
    constraints : the bound's constraint names (``FeedBound.names``)
    air : (k,) bool, samples that do not cut (a program's rapids, plunges, retracts)
    program_line : (k,) int32, source line of each sample's program move (0: no program)
    line_numbers, line_labels : (u,) the distinct program lines, increasing, and their
        labels (``"line 88 (N880)"``): a small table instead of k strings
    """

    v_max_mm_s: np.ndarray
    active: np.ndarray
    constraints: tuple[str, ...]
    air: np.ndarray
    program_line: np.ndarray
    line_numbers: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    line_labels: np.ndarray = field(default_factory=lambda: np.zeros(0, str))

    def __post_init__(self) -> None:
        object.__setattr__(self, "constraints", tuple(str(c) for c in self.constraints))
        if not 1 <= len(self.constraints) <= 255:
            raise ValueError(f"constraints must name 1-255 constraints, got "
                             f"{len(self.constraints)}")
        for name, dtype in (("v_max_mm_s", np.float64), ("active", np.int64), ("air", bool),
                            ("program_line", np.int64), ("line_numbers", np.int64),
                            ("line_labels", str)):
            object.__setattr__(self, name, _ro_as(getattr(self, name), dtype, name))
        k = self.v_max_mm_s.shape[0]
        for name in ("active", "air", "program_line"):
            if getattr(self, name).shape[0] != k:
                raise ValueError(f"{name} has {getattr(self, name).shape[0]} samples, "
                                 f"v_max_mm_s has {k}")
        if self.active.size and not (0 <= self.active.min() and self.active.max()
                                     < len(self.constraints)):
            raise ValueError(f"active must index the {len(self.constraints)} constraints")
        if self.line_labels.shape != self.line_numbers.shape:
            raise ValueError(f"{self.line_labels.size} line_labels for "
                             f"{self.line_numbers.size} line_numbers")
        if np.any(np.diff(self.line_numbers) <= 0) or np.any(self.line_numbers <= 0):
            raise ValueError("line_numbers must be positive and increasing")
        known = np.isin(self.program_line, self.line_numbers) | (self.program_line == 0)
        if not known.all():
            raise ValueError(f"program_line {self.program_line[~known][0]} has no label in "
                             "line_numbers")
        for name, dtype in (("active", np.uint8), ("program_line", np.int32),
                            ("line_numbers", np.int32)):
            object.__setattr__(self, name, _ro_as(getattr(self, name), dtype, name))

    def labels_at(self, idx: np.ndarray) -> np.ndarray:
        """(m,) str: the program line label of the samples ``idx`` ("" without a program)."""
        line = self.program_line[idx]
        if not self.line_numbers.size:
            return np.full(line.shape, "", dtype=str)
        pos = np.clip(np.searchsorted(self.line_numbers, line), 0, self.line_numbers.size - 1)
        return np.where(line > 0, self.line_labels[pos], "")

    def active_names_at(self, idx: np.ndarray) -> np.ndarray:
        """(m,) str: the name of the bound's active constraint at the samples ``idx``."""
        return np.asarray(self.constraints)[self.active[idx]]


@dataclass(frozen=True)
class PartSeries:
    """The predicted part (:mod:`feedopt.part`) of the laws drawn [mm]: per law the dexels'
    arc length and material left on the left and right walls (mean over the heights) and on
    the floor (mean across the cut), NaN where there is no such surface; and the floor of
    ``map_law`` at every floor dexel, ``map_xy_mm`` (m, 2) base-frame x/y."""

    laws: tuple[str, ...]
    s_mm: tuple[np.ndarray, ...]
    left_mm: tuple[np.ndarray, ...]
    right_mm: tuple[np.ndarray, ...]
    floor_mm: tuple[np.ndarray, ...]
    map_law: str
    map_xy_mm: np.ndarray
    map_floor_mm: np.ndarray


@dataclass(frozen=True)
class ReportData:
    """Everything :func:`feedopt.report.html.write_report` draws.

    Attributes
    ----------
    scenario : scenario name (report title).
    summary : the ``summary.json`` content (``{"scenario": {...}, "laws": {law: {...}}}``);
        the comparison table is made from it.
    path_xyz_mm : (k, 3) path samples in the robot base frame [mm].
    segment_kind : (k,) kind of segment each sample lies on (``"line"``, ``"blend"``, ...);
        samples whose kind is not ``"line"`` are drawn as blends.
    laws : one :class:`LawSeries` per law, in the order to report them.
    joint_velocity_limit_deg_s : (joints,) joint speed limits [deg/s; mm/s for a prismatic
        joint], as many as the laws' joint velocity columns.
    deflection_limit_mm : the user's deflection limit [mm].
    samples : per path sample the feed bound, its active constraint, the air samples and
        the program lines (:class:`SampleInfo`); None: not known (the figures go without).
    """

    scenario: str
    summary: Mapping
    path_xyz_mm: np.ndarray
    segment_kind: np.ndarray
    laws: tuple[LawSeries, ...]
    joint_velocity_limit_deg_s: np.ndarray
    deflection_limit_mm: float
    notes: tuple[str, ...] = field(default=())
    engagement: EngagementSeries | None = None
    redundancy: RedundancySeries | None = None
    part: PartSeries | None = None
    joint_units: tuple[str, ...] = ()  # per joint "deg" or "mm" (prismatic); () = all deg
    samples: SampleInfo | None = None  # per path sample bound, constraint, air, program line

    def joint_unit(self, j: int) -> str:
        """The display unit of joint ``j`` ("deg", or "mm" for a prismatic joint)."""
        return self.joint_units[j] if j < len(self.joint_units) else "deg"

    def __post_init__(self) -> None:
        xyz = _ro(self.path_xyz_mm, (3,), "path_xyz_mm")
        object.__setattr__(self, "path_xyz_mm", xyz)
        kind = np.asarray(self.segment_kind, dtype=str)
        if kind.shape != (xyz.shape[0],):
            raise ValueError(f"segment_kind has shape {kind.shape}, expected ({xyz.shape[0]},)")
        object.__setattr__(self, "segment_kind", kind)
        lim = np.array(self.joint_velocity_limit_deg_s, dtype=float).reshape(-1)
        if not 1 <= lim.size <= 12:
            raise ValueError(f"joint_velocity_limit_deg_s must have 1-12 values, got {lim.shape}")
        lim.flags.writeable = False
        object.__setattr__(self, "joint_velocity_limit_deg_s", lim)
        object.__setattr__(self, "laws", tuple(self.laws))
        if not self.laws:
            raise ValueError("ReportData needs at least one law")
        for ls in self.laws:
            if ls.s_mm.shape[0] != xyz.shape[0]:
                raise ValueError(
                    f"law {ls.law!r} has {ls.s_mm.shape[0]} path samples, the path has "
                    f"{xyz.shape[0]}: give its curves at the path samples"
                )
            if ls.joint_velocity_deg_s.shape[1] != lim.size:
                raise ValueError(
                    f"law {ls.law!r} has {ls.joint_velocity_deg_s.shape[1]} joint_velocity_deg_s "
                    f"columns, the robot {lim.size} joint_velocity_limit_deg_s")
        if self.samples is not None and self.samples.v_max_mm_s.shape[0] != xyz.shape[0]:
            raise ValueError(f"samples has {self.samples.v_max_mm_s.shape[0]} path samples, "
                             f"the path has {xyz.shape[0]}")
        object.__setattr__(self, "deflection_limit_mm", float(self.deflection_limit_mm))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))


def _check_value(kind: str, value, where: str) -> None:
    """InputError unless ``value`` is null or of ``kind`` (see :data:`LAW_KEYS`)."""
    if value is None:
        return
    if kind == "bool":
        if not isinstance(value, bool):
            raise InputError(f"{where} must be true, false or null, got {excerpt(value)}")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where} must be a number or null, got {excerpt(value)}")
    if abs(value) > MAX_SUMMARY_NUMBER or not math.isfinite(value):  # ints beyond float too
        raise InputError(f"{where} = {excerpt(value)}: a run writes a finite number of at most "
                         f"{MAX_SUMMARY_NUMBER:.0e} here (or null); the file was edited or "
                         "damaged")
    if value < 0 or (kind == "pos" and value == 0):
        bound = "> 0" if kind == "pos" else ">= 0"
        raise InputError(f"{where} = {value!r}: a run writes a number {bound} here (or null); "
                         "the file was edited or damaged")


def _check_law(law: str, row, source: str) -> None:
    """One entry of ``laws``: the keys compare prints, each of its kind."""
    if not _LAW_NAME.match(law):
        raise InputError(f"{source}: laws: {excerpt(law)} is not a timing law name (letters, "
                         "digits, '_', '.', '-'; at most 64)")
    if not isinstance(row, dict):
        raise InputError(f"{source}: laws.{law} must be an object, got {excerpt(row)}")
    missing = [k for k in LAW_KEYS if k not in row]
    if missing:
        raise InputError(f"{source}: laws.{law} lacks {', '.join(missing)}")
    for key, kind in {**LAW_KEYS, **OPTIONAL_LAW_KEYS}.items():
        _check_value(kind, row.get(key), f"{source}: laws.{law}.{key}")
    for ramp in ("start_ramp", "stop_ramp"):
        value = row.get(ramp)
        if value is None:
            continue
        if not isinstance(value, dict):
            raise InputError(f"{source}: laws.{law}.{ramp} must be an object or null, "
                             f"got {excerpt(value)}")
        for key in RAMP_KEYS:
            _check_value("num", value.get(key), f"{source}: laws.{law}.{ramp}.{key}")
        if value.get("ends_by") not in (None, *RAMP_REASONS):
            raise InputError(f"{source}: laws.{law}.{ramp}.ends_by must be one of "
                             f"{', '.join(RAMP_REASONS)} or null, got "
                             f"{excerpt(value.get('ends_by'))}")


def validate_summary(obj, source: str = "summary.json") -> dict:
    """Check the structure of a summary.json object; return it. Raises :class:`InputError`.

    Strict about what ``feedopt compare`` and the report print: every per-law number is
    finite, not negative and not absurdly large (:data:`MAX_SUMMARY_NUMBER`), each flag a
    boolean, ``scenario.name`` a string and ``scenario.deflection_limit_mm`` a number > 0.
    """
    if not isinstance(obj, dict):
        raise InputError(f"{source}: top level must be an object with 'laws', got "
                         f"{type(obj).__name__}")
    laws = obj.get("laws")
    if not isinstance(laws, dict) or not laws:
        raise InputError(f"{source}: missing or empty 'laws' object (one entry per timing law)")
    for law, row in laws.items():
        _check_law(law, row, source)
    warnings = obj.get("warnings", [])
    if not isinstance(warnings, list) or not all(isinstance(w, str) for w in warnings):
        raise InputError(f"{source}: 'warnings' must be a list of strings, got "
                         f"{excerpt(warnings)}")
    scen = obj.get("scenario", {})
    if not isinstance(scen, dict):
        raise InputError(f"{source}: 'scenario' must be an object, got {excerpt(scen)}")
    if not isinstance(scen.get("name", ""), str):
        raise InputError(f"{source}: scenario.name must be a string, got "
                         f"{excerpt(scen.get('name'))}")
    _check_value("pos", scen.get("deflection_limit_mm"), f"{source}: scenario.deflection_limit_mm")
    return obj


def _no_duplicate_keys(pairs: list[tuple[str, object]]) -> dict:
    """``object_pairs_hook`` of :func:`json.loads`: an object, refusing a key given twice."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"the key {key!r} is given twice in one object (JSON readers "
                             "would silently keep one of them)")
        out[key] = value
    return out


def load_summary(path: str | Path) -> dict:
    """Read and validate ``summary.json``; ``path`` may be the file or its run directory.

    The file is refused before parsing when larger than :data:`MAX_SUMMARY_BYTES` (or not a
    regular file); JSON that is malformed, nested too deeply or holds a key twice is refused
    naming the file, and the values :func:`validate_summary` checks name their field.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "summary.json"
    text = read_user_text(path, "run summary", max_bytes=MAX_SUMMARY_BYTES,
                          missing_hint=" (give a directory written by `feedopt run`)")
    try:  # NaN and Infinity are read: the fields compare uses refuse them by name
        obj = json.loads(text, object_pairs_hook=_no_duplicate_keys)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise InputError(f"{path}: the JSON is nested too deeply to be a run summary (a run "
                         "writes a few levels)") from None
    except ValueError as exc:  # a key given twice, an integer of thousands of digits
        if "integer string conversion" in str(exc):
            raise InputError(f"{path}: holds an integer of more than 4300 digits, which no run "
                             "writes; the file was edited or damaged") from None
        raise InputError(f"{path}: invalid JSON: {exc}") from None
    return validate_summary(obj, str(path))
