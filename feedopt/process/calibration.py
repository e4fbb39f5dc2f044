"""Cutting-coefficient calibration from average slotting forces (thesis Eq. 3.24-3.25).

At each spindle speed the average forces of full-immersion slots are regressed linearly on
the feed per tooth c, F_q = F_qc c + F_qe (Eq. 3.24), and the six coefficients follow from the
slot averages (Eq. 3.25)::

    Ktc = 4 Fyc / (N a)    Kte = pi Fye / (N a)
    Krc = -4 Fxc / (N a)   Kre = -pi Fxe / (N a)
    Kac = pi Fzc / (N a)   Kae = 2 Fze / (N a)
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import CoefficientTable, CuttingCoefficients
from feedopt.process.forces import feed_per_tooth
from feedopt.textio import read_user_text
from feedopt.units import MM, MM_PER_M

CSV_COLUMNS = ("spindle_rpm", "feed_mm_s", "fx_n", "fy_n", "fz_n")


@dataclass(frozen=True)
class SlotForceRow:
    """One calibration cut: average force on the tool in a full-immersion slot (SI)."""

    rpm: float
    feed: float  # [m/s]
    fx: float  # [N]
    fy: float
    fz: float


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
    p = Path(path)
    if not p.is_file():
        raise InputError(f"forces CSV {str(p)!r} does not exist")
    lines = [
        ln for ln in read_user_text(p, "forces CSV", encoding="utf-8-sig").splitlines()
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        raise InputError(f"forces CSV {str(p)!r} has no header row")
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"forces CSV {str(p)!r}: missing column(s) {', '.join(missing)}; expected header "
            f"{','.join(CSV_COLUMNS)}"
        )
    rows = []
    for i, raw in enumerate(reader, start=1):
        if None in raw:  # DictReader files surplus fields under the key None
            raise InputError(
                f"forces CSV {str(p)!r}, data row {i}: {len(header) + len(raw[None])} fields, "
                f"but the header has {len(header)}"
            )
        rec = {(k or "").strip(): (v or "").strip() for k, v in raw.items()}
        vals = {}
        for col in CSV_COLUMNS:
            try:
                vals[col] = float(rec[col])
            except ValueError:
                raise InputError(
                    f"forces CSV {str(p)!r}, data row {i}: {col} = {rec[col]!r} is not a number"
                ) from None
            if not math.isfinite(vals[col]):
                raise InputError(f"forces CSV {str(p)!r}, data row {i}: {col} must be finite")
        if vals["spindle_rpm"] <= 0 or vals["feed_mm_s"] <= 0:
            raise InputError(
                f"forces CSV {str(p)!r}, data row {i}: spindle_rpm and feed_mm_s must be > 0, "
                f"got {vals['spindle_rpm']:g} rpm, {vals['feed_mm_s']:g} mm/s"
            )
        rows.append(
            SlotForceRow(
                vals["spindle_rpm"],
                vals["feed_mm_s"] * MM,
                vals["fx_n"],
                vals["fy_n"],
                vals["fz_n"],
            )
        )
    if not rows:
        raise InputError(f"forces CSV {str(p)!r} has no data rows")
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


def calibration_table(
    cals: list[SpeedCalibration], material: str = "", tool: str = "", source: str = ""
) -> CoefficientTable:
    """Collect per-speed calibrations into a :class:`CoefficientTable`.

    Its ``feed_per_tooth_range`` is the smallest and largest feed per tooth of all the cuts
    (every speed), the range in which the fitted lines of Eq. 3.24 were observed.
    """
    if not cals:
        raise InputError("calibration table: no calibrated speed")
    c = np.concatenate([cal.feed_per_tooth for cal in cals])
    return CoefficientTable.from_speeds(
        {cal.rpm: cal.coeffs for cal in cals},
        material=material,
        tool=tool,
        source=source,
        feed_per_tooth_range=(float(c.min()), float(c.max())),
    )
