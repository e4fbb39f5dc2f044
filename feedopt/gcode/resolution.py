"""Units and the rounding of written numbers, shared by the G-code and APT CL readers."""

from __future__ import annotations

import math

MM_PER_INCH = 25.4
#: Largest difference of two radii that rounding to one unit can make, in units: each end
#: point and the centre are off by up to half a unit in both plane axes (sqrt(2) / 2 each).
ROUNDING_RADIUS_UNITS = 2.0 * math.sqrt(2.0)


def unit_scale(inch: bool) -> float:
    """Millimetres per program unit."""
    return MM_PER_INCH if inch else 1.0


def resolution_mm(decimals: int | None, inch: bool) -> float | None:
    """One unit of the last decimal of the coordinates read so far [mm] (None: none read)."""
    if decimals is None:
        return None
    return 10.0 ** -decimals * unit_scale(inch)


def radius_tolerance_mm(option_mm: float, resolution: float | None) -> float:
    """The arc radius tolerance in force: the option, or the rounding the resolution allows
    (:data:`ROUNDING_RADIUS_UNITS` units), whichever is larger."""
    return max(option_mm, 0.0 if resolution is None else ROUNDING_RADIUS_UNITS * resolution)
