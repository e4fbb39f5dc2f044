"""Cutting-force coefficients (thesis Table 3.3) and their speed-dependent lookup.

File format (``shared/design.md``, written by ``feedopt calibrate --out``)::

    material: 6061-T6511
    tool: 2-flute 19.05 mm HSS TiN
    source: ...            # optional, free text
    speeds:
      - rpm: 2000
        ktc_n_m2: 8.57e8
        krc_n_m2: 3.19e8
        kac_n_m2: -1.05e8
        kte_n_m: 7.42e3
        kre_n_m: 8.45e3
        kae_n_m: -2.13e3
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass, fields
from pathlib import Path

import numpy as np
import yaml

from feedopt.errors import InputError
from feedopt.process._io import number, read_yaml_mapping

#: YAML key of each CuttingCoefficients field, in field order.
FILE_KEYS = {
    "ktc": "ktc_n_m2",
    "krc": "krc_n_m2",
    "kac": "kac_n_m2",
    "kte": "kte_n_m",
    "kre": "kre_n_m",
    "kae": "kae_n_m",
}


@dataclass(frozen=True)
class CuttingCoefficients:
    """Mechanistic cutting (``*c``, N/m^2) and edge (``*e``, N/m) coefficients.

    Tangential, radial and axial, in the sign convention of thesis Eq. 3.25 / Table 3.3:
    the axial force on the tool is ``+z`` of the force-model frame times ``Kac h + Kae``, so the
    negative Table 3.3 values give the downward (``-z``) force measured in slotting.
    """

    ktc: float
    krc: float
    kac: float
    kte: float
    kre: float
    kae: float

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v):
                raise InputError(f"cutting coefficient {f.name} must be finite, got {v!r}")

    def as_array(self) -> np.ndarray:
        """The six values in field order ``(ktc, krc, kac, kte, kre, kae)``."""
        return np.array(astuple(self), dtype=float)


@dataclass(frozen=True)
class CoefficientTable:
    """Coefficients calibrated at several spindle speeds (strictly increasing ``rpm``).

    ``values[i]`` holds ``(ktc, krc, kac, kte, kre, kae)`` at ``rpm[i]``.
    """

    rpm: np.ndarray
    values: np.ndarray
    material: str = ""
    tool: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        rpm = np.asarray(self.rpm, dtype=float).reshape(-1)
        values = np.asarray(self.values, dtype=float).reshape(-1, 6)
        if rpm.size == 0:
            raise InputError("coefficient table: 'speeds' is empty; give at least one speed")
        if rpm.size != values.shape[0]:
            raise InputError("coefficient table: one row of six coefficients per speed needed")
        if np.any(rpm <= 0) or np.any(np.diff(rpm) <= 0):
            raise InputError(
                f"coefficient table: speeds must be > 0 rpm and distinct, got {rpm.tolist()}"
            )
        object.__setattr__(self, "rpm", rpm)
        object.__setattr__(self, "values", values)

    @classmethod
    def from_speeds(
        cls,
        speeds: dict[float, CuttingCoefficients],
        material: str = "",
        tool: str = "",
        source: str = "",
    ) -> CoefficientTable:
        """Build a table from ``{rpm: CuttingCoefficients}`` (any order)."""
        rpms = sorted(speeds)
        return cls(
            rpm=np.array(rpms, dtype=float),
            values=np.array([speeds[r].as_array() for r in rpms]),
            material=material,
            tool=tool,
            source=source,
        )

    def at(self, rpm: float, extrapolate: bool = False) -> CuttingCoefficients:
        """Coefficients at spindle speed ``rpm``, linearly interpolated between speeds.

        Outside the calibrated range this raises InputError unless ``extrapolate`` is true,
        in which case the coefficients of the nearest calibrated speed are held (constant
        extrapolation: a linear trend of fitted coefficients is not trustworthy).
        """
        rpm = float(rpm)
        if not (math.isfinite(rpm) and rpm > 0):
            raise InputError(f"spindle speed must be > 0 rpm, got {rpm!r}")
        lo, hi = float(self.rpm[0]), float(self.rpm[-1])
        tol = 1e-9 * hi
        if not extrapolate and (rpm < lo - tol or rpm > hi + tol):
            span = f"{lo:g} rpm" if lo == hi else f"{lo:g}..{hi:g} rpm"
            raise InputError(
                f"spindle speed {rpm:g} rpm is outside the calibrated speeds ({span})"
                f"{' of ' + repr(self.material) if self.material else ''}; calibrate at that "
                "speed or allow extrapolation (holds the nearest calibrated speed)"
            )
        vals = [float(np.interp(rpm, self.rpm, self.values[:, k])) for k in range(6)]
        return CuttingCoefficients(*vals)


def load_coefficients(path: str | Path) -> CoefficientTable:
    """Read a coefficients YAML file (format in the module docstring) into SI units."""
    data = read_yaml_mapping(path, "coefficients")
    where = f"coefficients file {str(path)!r}"
    speeds = data.get("speeds")
    if not isinstance(speeds, list) or not speeds:
        raise InputError(f"{where}: missing field 'speeds' (a list with one entry per rpm)")
    table: dict[float, CuttingCoefficients] = {}
    for i, entry in enumerate(speeds):
        at = f"{where}: speeds[{i}]"
        if not isinstance(entry, dict):
            raise InputError(f"{at}: expected a mapping with rpm and six coefficients")
        rpm = number(entry, "rpm", at)
        if rpm <= 0:
            raise InputError(f"{at}.rpm: must be > 0, got {rpm!r}")
        if rpm in table:
            raise InputError(f"{at}.rpm: speed {rpm:g} rpm listed twice")
        values = {k: number(entry, key, at) for k, key in FILE_KEYS.items()}
        table[rpm] = CuttingCoefficients(**values)
    return CoefficientTable.from_speeds(
        table,
        material=str(data.get("material", "")),
        tool=str(data.get("tool", "")),
        source=str(data.get("source", "")),
    )


def save_coefficients(table: CoefficientTable, path: str | Path) -> None:
    """Write ``table`` in the coefficients-file format (inverse of :func:`load_coefficients`)."""
    speeds = []
    for rpm, row in zip(table.rpm, table.values, strict=True):
        entry: dict[str, float] = {"rpm": _plain(rpm)}
        for k, v in zip(FILE_KEYS.values(), row, strict=True):
            entry[k] = float(f"{v:.6g}")
        speeds.append(entry)
    doc: dict[str, object] = {}
    if table.material:
        doc["material"] = table.material
    if table.tool:
        doc["tool"] = table.tool
    if table.source:
        doc["source"] = table.source
    doc["speeds"] = speeds
    Path(path).write_text(yaml.safe_dump(doc, sort_keys=False, width=1000))


def _plain(x: float) -> float | int:
    return int(x) if float(x).is_integer() else float(x)
