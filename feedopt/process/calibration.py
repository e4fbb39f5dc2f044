"""Cutting-coefficient calibration from average slotting forces (thesis Eq. 3.24-3.25).

At each spindle speed the average forces of full-immersion slots are regressed linearly on
the feed per tooth c, F_q = F_qc c + F_qe (Eq. 3.24), and the six coefficients follow from the
slot averages (Eq. 3.25)::

    Ktc = 4 Fyc / (N a)    Kte = pi Fye / (N a)
    Krc = -4 Fxc / (N a)   Kre = -pi Fxe / (N a)
    Kac = pi Fzc / (N a)   Kae = 2 Fze / (N a)

Plunge coefficients (optional, :mod:`feedopt.process.plunge`; Altintas, Manufacturing
Automation, 2nd ed., ch. 2): the mean thrust and torque of full straight plunges with a tool of
N teeth and radius R are linear in the axial feed per tooth c, F_z = N R (K_tc c + K_te) and
T = N R^2 / 2 (K_cc c + K_ce); at each speed the least-squares lines F_z = F_zc c + F_ze and
T = T_c c + T_e give::

    K_tc = F_zc / (N R)    K_te = F_ze / (N R)    K_cc = 2 T_c / (N R^2)    K_ce = 2 T_e / (N R^2)
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import CoefficientTable, CuttingCoefficients
from feedopt.process.forces import feed_per_tooth
from feedopt.process.plunge import PlungeCoefficients
from feedopt.textio import read_user_text
from feedopt.units import MM, MM_PER_M

CSV_COLUMNS = ("spindle_rpm", "feed_mm_s", "fx_n", "fy_n", "fz_n")
#: Columns of the plunge CSV (exactly these): the mean thrust on the tool along its axis,
#: > 0 pushing it back into the spindle, and the spindle's cutting torque, > 0.
PLUNGE_CSV_COLUMNS = ("spindle_rpm", "feed_mm_s", "thrust_n", "torque_nm")


@dataclass(frozen=True)
class SlotForceRow:
    """One calibration cut: average force on the tool in a full-immersion slot (SI)."""

    rpm: float
    feed: float  # [m/s]
    fx: float  # [N]
    fy: float
    fz: float


@dataclass(frozen=True)
class PlungeForceRow:
    """One plunge calibration cut: mean thrust on the tool [N] (+z, pushing it back) and
    spindle torque [N m] of a full straight plunge at axial feed ``feed`` [m/s]."""

    rpm: float
    feed: float  # [m/s]
    thrust: float  # [N]
    torque: float  # [N m]


@dataclass(frozen=True)
class PlungeCalibration:
    """The plunge fit at one spindle speed: coefficients (SI), R^2 of the thrust and torque
    lines (2,), feeds per tooth of the cuts [m], slopes [N/m, N m/m] and intercepts [N, N m]."""

    rpm: float
    coeffs: PlungeCoefficients
    r2: np.ndarray
    feed_per_tooth: np.ndarray
    slopes: np.ndarray
    intercepts: np.ndarray


@dataclass(frozen=True)
class SpeedCalibration:
    """The fit at one spindle speed.

    Attributes
    ----------
    rpm : spindle speed
    coeffs : fitted coefficients (SI)
    r2 : (3,) coefficient of determination of the x, y, z regressions (Eq. 3.24)
    feed_per_tooth : (k,) feeds per tooth of the cuts [m]
    slopes, intercepts : (3,) F_qc [N/m] and F_qe [N] of Eq. 3.24 for q = x, y, z
    """

    rpm: float
    coeffs: CuttingCoefficients
    r2: np.ndarray
    feed_per_tooth: np.ndarray
    slopes: np.ndarray
    intercepts: np.ndarray


def read_slot_forces(path: str | Path) -> list[SlotForceRow]:
    """Read ``spindle_rpm,feed_mm_s,fx_n,fy_n,fz_n`` (``#`` comment lines allowed)."""
    rows = _read_numeric_csv(path, CSV_COLUMNS, "forces CSV", strict=False)
    return [SlotForceRow(r["spindle_rpm"], r["feed_mm_s"] * MM, r["fx_n"], r["fy_n"], r["fz_n"])
            for r in rows]


def read_plunge_forces(path: str | Path) -> list[PlungeForceRow]:
    """Read ``spindle_rpm,feed_mm_s,thrust_n,torque_nm`` (mean thrust [N] and torque [N m]
    of straight plunges at axial feed ``feed_mm_s``; ``#`` comment lines allowed; no other
    column)."""
    rows = _read_numeric_csv(path, PLUNGE_CSV_COLUMNS, "plunge forces CSV", strict=True)
    return [PlungeForceRow(r["spindle_rpm"], r["feed_mm_s"] * MM, r["thrust_n"], r["torque_nm"])
            for r in rows]


def _read_numeric_csv(path: str | Path, columns: tuple[str, ...], what: str,
                      strict: bool) -> list[dict[str, float]]:
    """Rows of a CSV of finite numbers with the header ``columns`` (``strict``: no other
    column), ``spindle_rpm`` and ``feed_mm_s`` > 0; InputError naming the file and row."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what} {str(p)!r} does not exist")
    lines = [
        ln for ln in read_user_text(p, what, encoding="utf-8-sig").splitlines()
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        raise InputError(f"{what} {str(p)!r} has no header row")
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in columns if c not in header]
    unknown = [c for c in header if c not in columns] if strict else []
    if missing or unknown:
        why = (f"missing column(s) {', '.join(missing)}" if missing
               else f"unknown column(s) {', '.join(unknown)}")
        raise InputError(f"{what} {str(p)!r}: {why}; expected header {','.join(columns)}")
    rows = []
    for i, raw in enumerate(reader, start=1):
        if None in raw:  # DictReader files surplus fields under the key None
            raise InputError(
                f"{what} {str(p)!r}, data row {i}: {len(header) + len(raw[None])} fields, "
                f"but the header has {len(header)}"
            )
        rec = {(k or "").strip(): (v or "").strip() for k, v in raw.items()}
        vals = {}
        for col in columns:
            try:
                vals[col] = float(rec[col])
            except ValueError:
                raise InputError(
                    f"{what} {str(p)!r}, data row {i}: {col} = {rec[col]!r} is not a number"
                ) from None
            if not math.isfinite(vals[col]):
                raise InputError(f"{what} {str(p)!r}, data row {i}: {col} must be finite")
        if vals["spindle_rpm"] <= 0 or vals["feed_mm_s"] <= 0:
            raise InputError(
                f"{what} {str(p)!r}, data row {i}: spindle_rpm and feed_mm_s must be > 0, "
                f"got {vals['spindle_rpm']:g} rpm, {vals['feed_mm_s']:g} mm/s"
            )
        rows.append(vals)
    if not rows:
        raise InputError(f"{what} {str(p)!r} has no data rows")
    return rows


def _fit(c: np.ndarray, f: np.ndarray) -> tuple[float, float, float]:
    """Least-squares line f = slope c + intercept and its R^2."""
    A = np.stack([c, np.ones_like(c)], axis=1)
    (slope, intercept), *_ = np.linalg.lstsq(A, f, rcond=None)
    resid = f - (slope * c + intercept)
    ss_tot = float(np.sum((f - f.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else 1.0
    return float(slope), float(intercept), r2


def calibrate(rows: list[SlotForceRow], teeth: int, axial_depth: float) -> list[SpeedCalibration]:
    """Fit the six coefficients per spindle speed (Eq. 3.24-3.25), sorted by speed.

    Each speed needs cuts at >= 2 distinct feeds per tooth (3 or more for a meaningful R^2).
    """
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"teeth must be a whole number >= 1, got {teeth!r}")
    if not (math.isfinite(axial_depth) and axial_depth > 0):
        raise InputError(f"axial depth must be > 0, got {axial_depth * MM_PER_M!r} mm")
    if not rows:
        raise InputError("calibration needs at least one speed with two or more cuts")
    na = teeth * axial_depth
    out = []
    for rpm in sorted({r.rpm for r in rows}):
        sel = [r for r in rows if r.rpm == rpm]
        c = np.array([feed_per_tooth(r.feed, rpm, teeth) for r in sel])
        if np.unique(c).size < 2:
            raise InputError(
                f"calibration at {rpm:g} rpm: need cuts at two or more different feeds, got "
                f"{len(sel)} cut(s) at {np.unique(c).size} feed(s)"
            )
        fits = [_fit(c, np.array([getattr(r, q) for r in sel])) for q in ("fx", "fy", "fz")]
        (fxc, fxe, _), (fyc, fye, _), (fzc, fze, _) = fits
        coeffs = CuttingCoefficients(
            ktc=4 * fyc / na,
            krc=-4 * fxc / na,
            kac=math.pi * fzc / na,
            kte=math.pi * fye / na,
            kre=-math.pi * fxe / na,
            kae=2 * fze / na,
        )
        out.append(
            SpeedCalibration(
                rpm=float(rpm),
                coeffs=coeffs,
                r2=np.array([f[2] for f in fits]),
                feed_per_tooth=c,
                slopes=np.array([f[0] for f in fits]),
                intercepts=np.array([f[1] for f in fits]),
            )
        )
    return out


def calibrate_plunge(rows: list[PlungeForceRow], teeth: int, diameter: float
                     ) -> list[PlungeCalibration]:
    """Fit the four plunge coefficients per spindle speed (module docstring), sorted by
    speed; each speed needs plunges at >= 2 distinct feeds per tooth."""
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"teeth must be a whole number >= 1, got {teeth!r}")
    if not (math.isfinite(diameter) and diameter > 0):
        raise InputError(f"tool diameter must be > 0, got {diameter * MM_PER_M!r} mm")
    if not rows:
        raise InputError("plunge calibration needs at least one speed with two or more cuts")
    radius = diameter / 2.0
    out = []
    for rpm in sorted({r.rpm for r in rows}):
        sel = [r for r in rows if r.rpm == rpm]
        c = np.array([feed_per_tooth(r.feed, rpm, teeth) for r in sel])
        if np.unique(c).size < 2:
            raise InputError(
                f"plunge calibration at {rpm:g} rpm: need plunges at two or more different "
                f"feeds, got {len(sel)} plunge(s) at {np.unique(c).size} feed(s)")
        thrust = _fit(c, np.array([r.thrust for r in sel]))
        torque = _fit(c, np.array([r.torque for r in sel]))
        coeffs = PlungeCoefficients(
            thrust_cutting=thrust[0] / (teeth * radius),
            thrust_edge=thrust[1] / (teeth * radius),
            torque_cutting=2.0 * torque[0] / (teeth * radius**2),
            torque_edge=2.0 * torque[1] / (teeth * radius**2),
        )
        out.append(PlungeCalibration(
            rpm=float(rpm), coeffs=coeffs, r2=np.array([thrust[2], torque[2]]),
            feed_per_tooth=c, slopes=np.array([thrust[0], torque[0]]),
            intercepts=np.array([thrust[1], torque[1]])))
    return out


def calibration_table(
    cals: list[SpeedCalibration], material: str = "", tool: str = "", source: str = "",
    plunge: list[PlungeCalibration] | None = None,
) -> CoefficientTable:
    """Collect per-speed calibrations into a :class:`CoefficientTable`.

    Its ``feed_per_tooth_range`` is the smallest and largest feed per tooth of all the cuts
    (every speed), the range in which the fitted lines of Eq. 3.24 were observed. ``plunge``
    (optional) must be calibrated at exactly the speeds of ``cals`` (InputError naming the
    others).
    """
    if not cals:
        raise InputError("calibration table: no calibrated speed")
    c = np.concatenate([cal.feed_per_tooth for cal in cals])
    speeds = {cal.rpm: cal.coeffs for cal in cals}
    if plunge:
        by_rpm = {p.rpm: p.coeffs for p in plunge}
        if set(by_rpm) != set(speeds):
            extra = sorted(set(by_rpm) - set(speeds))
            missing = sorted(set(speeds) - set(by_rpm))
            why = []
            if missing:
                why.append(f"no plunge cuts at {', '.join(f'{r:g}' for r in missing)} rpm")
            if extra:
                why.append(f"plunge cuts at {', '.join(f'{r:g}' for r in extra)} rpm, where "
                           "there are no slot cuts")
            raise InputError(f"plunge calibration: {'; '.join(why)}; the plunge cuts need the "
                             "spindle speeds of the slot cuts (a plunge block at every speed)")
        speeds = {rpm: dataclasses.replace(k, plunge=by_rpm[rpm]) for rpm, k in speeds.items()}
    return CoefficientTable.from_speeds(
        speeds,
        material=material,
        tool=tool,
        source=source,
        feed_per_tooth_range=(float(c.min()), float(c.max())),
    )
