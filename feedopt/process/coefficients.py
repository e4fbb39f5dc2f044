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
        plunge:                      # optional: straight plunges (feedopt.process.plunge)
          thrust_cutting_n_mm2: 1500
          thrust_edge_n_mm: 20
          torque_cutting_n_mm2: 900
          torque_edge_n_mm: 10
    feed_per_tooth_range_mm: [0.01905, 0.12705]   # optional

``feed_per_tooth_range_mm`` (optional, written by ``feedopt calibrate --out``) is the smallest
and largest feed per tooth of the calibration cuts over all speeds; the linear model
F = F_c c + F_e (Eq. 3.24) is only known to hold there, so a feed per tooth outside it earns a
warning (:func:`feed_per_tooth_warning`), not an error. Files without it stay valid.

``plunge`` (optional, per speed) holds the coefficients of the end cutting edges in a
straight plunge along the tool axis (:mod:`feedopt.process.plunge`: thrust
F_z = N (K_tc c + K_te) R, torque T = N (K_cc c + K_ce) R^2 / 2), in N/mm^2 and N/mm as their
names say; all four keys are required in a block, nothing else is allowed, the cutting ones
must be > 0 and the edge ones >= 0. Either every speed has a ``plunge`` block or none does
(they are interpolated between speeds like the others); without them the plunges of a
program are not modelled (the run says which).

Signs (thesis 3.6.1): the tangential and radial cutting coefficients are > 0 (the chip pushes
the tool back against the cutting speed and away from the surface); the tangential and radial
edge coefficients are >= 0 (0 means "no edge force", a legitimate simplification). A negative
value gives smaller forces, hence faster plans that only look "verified" against the same
wrong model, so :func:`load_coefficients` refuses it. The axial coefficients Kac and Kae may
have either sign: their sign only states the direction of the axial force (+z times
``Kac h + Kae``, Eq. 3.25), which depends on the helix hand and the sign convention.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from feedopt.errors import InputError
from feedopt.process._io import check_keys, number, read_yaml_mapping, text
from feedopt.process.plunge import PLUNGE_FILE_KEYS, PlungeCoefficients, plunge_sign_problems
from feedopt.units import MM

#: Optional file-level YAML key of the calibrated feed-per-tooth range ``[min, max]`` [mm].
RANGE_KEY = "feed_per_tooth_range_mm"

#: Relative slack of the range check (the file stores 6 significant digits).
RANGE_SLACK = 1e-5

#: Top-level keys of a coefficients file (unknown keys are refused).
FILE_TOP_KEYS = ("material", "tool", "source", RANGE_KEY, "speeds")

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

    Physical signs (checked by :func:`sign_problems`, enforced by :func:`load_coefficients`
    and ``feedopt calibrate``, not here, so that unit or test coefficient sets can be built):
    ``ktc > 0``, ``krc > 0``, ``kte >= 0``, ``kre >= 0``; ``kac`` and ``kae`` may have either
    sign, which is only the direction convention of the axial force (Eq. 3.25).

    ``plunge``: the end-edge coefficients of a straight plunge
    (:class:`~feedopt.process.plunge.PlungeCoefficients`), None when the material file has
    none.
    """

    ktc: float
    krc: float
    kac: float
    kte: float
    kre: float
    kae: float
    plunge: PlungeCoefficients | None = None

    def __post_init__(self) -> None:
        for name in FILE_KEYS:
            v = getattr(self, name)
            if not math.isfinite(v):
                raise InputError(f"cutting coefficient {name} must be finite, got {v!r}")

    def as_array(self) -> np.ndarray:
        """The six side-milling values ``(ktc, krc, kac, kte, kre, kae)`` (not the plunge)."""
        return np.array([getattr(self, name) for name in FILE_KEYS], dtype=float)


#: Sign rule per coefficient: (must be > 0, what the rule means); Kac and Kae are free.
SIGN_RULES = {
    "ktc": (True, "the tangential cutting force opposes the cutting speed"),
    "krc": (True, "the radial cutting force pushes the tool away from the cut surface"),
    "kte": (False, "0 means no tangential edge force"),
    "kre": (False, "0 means no radial edge force"),
}

AXIAL_SIGN_NOTE = (
    "Kac and Kae may have either sign (their sign is the direction convention of the axial "
    "force, thesis Eq. 3.25)"
)


def sign_problems(coeffs: CuttingCoefficients) -> list[str]:
    """Coefficients that break the sign rules of thesis 3.6.1, one phrase each (SI values).

    ``Ktc`` and ``Krc`` must be > 0, ``Kte`` and ``Kre`` >= 0; ``Kac`` and ``Kae`` are not
    checked (either sign is a valid convention). Empty list when every sign is physical.
    """
    out = []
    for name, (strict, why) in SIGN_RULES.items():
        v = float(getattr(coeffs, name))
        if (v <= 0) if strict else (v < 0):
            rule = "> 0" if strict else ">= 0"
            unit = "N/m^2" if name.endswith("c") else "N/m"
            out.append(f"{FILE_KEYS[name]} = {v:.6g} {unit} (must be {rule}: {why})")
    return out


@dataclass(frozen=True)
class CoefficientTable:
    """Coefficients calibrated at several spindle speeds (strictly increasing ``rpm``).

    ``values[i]`` holds ``(ktc, krc, kac, kte, kre, kae)`` at ``rpm[i]``.
    ``feed_per_tooth_range`` is ``(min, max)`` feed per tooth of the calibration cuts [m], or
    None when unknown (files without ``feed_per_tooth_range_mm``).
    ``plunge`` is None (no plunge coefficients) or (k, 4): the
    :class:`~feedopt.process.plunge.PlungeCoefficients` at every speed (SI, field order).
    """

    rpm: np.ndarray
    values: np.ndarray
    material: str = ""
    tool: str = ""
    source: str = ""
    feed_per_tooth_range: tuple[float, float] | None = None
    plunge: np.ndarray | None = None

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
        if self.plunge is not None:
            plunge = np.asarray(self.plunge, dtype=float)
            if plunge.shape != (rpm.size, 4) or not np.all(np.isfinite(plunge)):
                raise InputError("coefficient table: plunge coefficients need four finite "
                                 "values at every speed")
            object.__setattr__(self, "plunge", plunge)
        if self.feed_per_tooth_range is not None:
            lo, hi = (float(v) for v in self.feed_per_tooth_range)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise InputError(
                    f"coefficient table: feed per tooth range must be 0 < min <= max, got "
                    f"[{lo / MM:g}, {hi / MM:g}] mm"
                )
            object.__setattr__(self, "feed_per_tooth_range", (lo, hi))

    @classmethod
    def from_speeds(
        cls,
        speeds: dict[float, CuttingCoefficients],
        material: str = "",
        tool: str = "",
        source: str = "",
        feed_per_tooth_range: tuple[float, float] | None = None,
    ) -> CoefficientTable:
        """Build a table from ``{rpm: CuttingCoefficients}`` (any order); their plunge
        coefficients must be given at every speed or at none (InputError naming a speed
        without)."""
        rpms = sorted(speeds)
        has = [speeds[r].plunge is not None for r in rpms]
        if any(has) and not all(has):
            missing = ", ".join(f"{r:g}" for r, h in zip(rpms, has, strict=True) if not h)
            raise InputError(f"plunge coefficients are given at some speeds but not at "
                             f"{missing} rpm: give a plunge block at every speed or at none")
        return cls(
            rpm=np.array(rpms, dtype=float),
            values=np.array([speeds[r].as_array() for r in rpms]),
            material=material,
            tool=tool,
            source=source,
            feed_per_tooth_range=feed_per_tooth_range,
            plunge=(np.array([speeds[r].plunge.as_array() for r in rpms]) if all(has)
                    else None),
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
        plunge = None
        if self.plunge is not None:
            plunge = PlungeCoefficients(*(float(np.interp(rpm, self.rpm, self.plunge[:, k]))
                                          for k in range(4)))
        return CuttingCoefficients(*vals, plunge=plunge)


def feed_per_tooth_warning(table: CoefficientTable, feed_per_tooth_m: float) -> str | None:
    """Warning text when a feed per tooth [m] lies outside the table's calibrated range.

    None when it is inside (within a relative ``RANGE_SLACK``) or when the table does not
    record its range. The text is in mm and names the material when the table has one; the
    caller adds its own prefix (``feedopt <command>: warning: ``).
    """
    rng = table.feed_per_tooth_range
    c = float(feed_per_tooth_m)
    if rng is None or not math.isfinite(c):
        return None
    lo, hi = rng
    if lo * (1 - RANGE_SLACK) <= c <= hi * (1 + RANGE_SLACK):
        return None
    side = "below" if c < lo else "above"
    of = f" of {table.material!r}" if table.material else ""
    return (
        f"feed per tooth {c / MM:.5g} mm is {side} the range the cutting coefficients{of} were "
        f"calibrated for ({lo / MM:.5g}..{hi / MM:.5g} mm per tooth); the linear force model "
        "(thesis Eq. 3.24) is extrapolated there and the forces may be wrong"
    )


def _range_of(data: dict, where: str) -> tuple[float, float] | None:
    if RANGE_KEY not in data or data[RANGE_KEY] is None:
        return None
    raw = data[RANGE_KEY]
    at = f"{where}.{RANGE_KEY}"
    if not isinstance(raw, list) or len(raw) != 2:
        raise InputError(f"{at}: expected [min, max] in mm per tooth, got {raw!r}")
    lo, hi = (number({"v": v}, "v", at) for v in raw)
    if not 0 < lo <= hi:
        raise InputError(
            f"{at}: expected 0 < min <= max (mm per tooth), got [{lo:g}, {hi:g}]; e.g. "
            "[0.019, 0.127] for feeds of 0.019 to 0.127 mm per tooth"
        )
    return lo * MM, hi * MM


def _plunge_block(entry: dict, at: str) -> PlungeCoefficients | None:
    """The ``plunge`` block of a speed entry (strict, N/mm^2 and N/mm -> SI), None without."""
    if "plunge" not in entry:
        return None
    block = entry["plunge"]
    where = f"{at}.plunge"
    if not isinstance(block, dict):
        raise InputError(f"{where}: expected a mapping with "
                         f"{', '.join(k for k, _ in PLUNGE_FILE_KEYS.values())}, got {block!r}")
    check_keys(block, tuple(k for k, _ in PLUNGE_FILE_KEYS.values()), where)
    coeffs = PlungeCoefficients(**{name: number(block, key, where) * scale
                                   for name, (key, scale) in PLUNGE_FILE_KEYS.items()})
    problems = plunge_sign_problems(coeffs)
    if problems:
        raise InputError(f"{at}: {'; '.join(problems)}. The thrust and torque of a plunge "
                         "grow with the feed and push the tool back (forces on the tool); "
                         "check the signs or recalibrate (feedopt calibrate --plunge-forces)")
    return coeffs


def load_coefficients(path: str | Path) -> CoefficientTable:
    """Read a coefficients YAML file (format in the module docstring) into SI units; strict:
    unknown keys, at the top or in a speed entry, are refused (InputError naming the key).

    Refuses coefficients with unphysical signs (:func:`sign_problems`): InputError naming the
    file, the speed entry and the field.
    """
    data = read_yaml_mapping(path, "coefficients")
    where = f"coefficients file {str(path)!r}"
    check_keys(data, FILE_TOP_KEYS, where)
    speeds = data.get("speeds")
    if not isinstance(speeds, list) or not speeds:
        raise InputError(f"{where}: missing field 'speeds' (a list with one entry per rpm)")
    table: dict[float, CuttingCoefficients] = {}
    for i, entry in enumerate(speeds):
        at = f"{where}: speeds[{i}]"
        if not isinstance(entry, dict):
            raise InputError(f"{at}: expected a mapping with rpm and six coefficients")
        check_keys(entry, ("rpm", *FILE_KEYS.values(), "plunge"), at)
        rpm = number(entry, "rpm", at)
        if rpm <= 0:
            raise InputError(f"{at}.rpm: must be > 0, got {rpm!r}")
        if rpm in table:
            raise InputError(f"{at}.rpm: speed {rpm:g} rpm listed twice")
        values = {k: number(entry, key, at) for k, key in FILE_KEYS.items()}
        coeffs = CuttingCoefficients(**values, plunge=_plunge_block(entry, at))
        problems = sign_problems(coeffs)
        if problems:
            raise InputError(
                f"{at} (rpm {rpm:g}): {'; '.join(problems)}. A wrong sign gives smaller "
                "forces and faster plans that only look verified; check the sign convention "
                "(forces on the tool, thesis Eq. 3.25) or recalibrate. "
                f"{AXIAL_SIGN_NOTE}."
            )
        table[rpm] = coeffs
    labels = {key: text(data, key, where) for key in ("material", "tool", "source")}
    feed_range = _range_of(data, where)
    try:
        return CoefficientTable.from_speeds(table, **labels, feed_per_tooth_range=feed_range)
    except InputError as exc:  # plunge blocks at some speeds only
        raise InputError(f"{where}: {exc}") from None


def save_coefficients(table: CoefficientTable, path: str | Path) -> None:
    """Write ``table`` in the coefficients-file format (inverse of :func:`load_coefficients`)."""
    speeds = []
    for rpm, row in zip(table.rpm, table.values, strict=True):
        entry: dict[str, float] = {"rpm": _plain(rpm)}
        for k, v in zip(FILE_KEYS.values(), row, strict=True):
            entry[k] = float(f"{v:.6g}")
        speeds.append(entry)
    if table.plunge is not None:
        for entry, row in zip(speeds, table.plunge, strict=True):
            entry["plunge"] = {key: float(f"{v / scale:.6g}") for (key, scale), v
                               in zip(PLUNGE_FILE_KEYS.values(), row, strict=True)}
    doc: dict[str, object] = {}
    if table.material:
        doc["material"] = table.material
    if table.tool:
        doc["tool"] = table.tool
    if table.source:
        doc["source"] = table.source
    header = ""
    if table.feed_per_tooth_range is not None:
        lo, hi = table.feed_per_tooth_range
        # 6 significant digits: the check's RANGE_SLACK keeps the cuts' own feeds inside
        doc[RANGE_KEY] = [float(f"{lo / MM:.6g}"), float(f"{hi / MM:.6g}")]
        header = (
            f"# {RANGE_KEY}: smallest and largest feed per tooth of the calibration cuts [mm];\n"
            "# outside it the linear force model is extrapolated (feedopt warns).\n"
        )
    doc["speeds"] = speeds
    Path(path).write_text(header + yaml.safe_dump(doc, sort_keys=False, width=1000))


def _plain(x: float) -> float | int:
    return int(x) if float(x).is_integer() else float(x)
