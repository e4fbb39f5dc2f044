"""Cutter geometry (thesis Table A.1) and its YAML reader."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from feedopt.errors import InputError
from feedopt.process._io import check_keys, number, read_yaml_mapping, text
from feedopt.units import MM


@dataclass(frozen=True)
class Tool:
    """An end mill, SI units.

    Attributes
    ----------
    name : str
    diameter : float
        Mill diameter D [m].
    teeth : int
        Number of flutes N.
    helix : float
        Helix angle beta [rad] (0 = straight teeth).
    flute_length : float
        Length of cut [m]; the largest usable axial depth.
    """

    name: str
    diameter: float
    teeth: int
    helix: float
    flute_length: float

    def __post_init__(self) -> None:
        validate_tool(self)

    @property
    def pitch(self) -> float:
        """Tooth pitch angle 2 pi / N [rad]."""
        return 2.0 * math.pi / self.teeth


#: Most cutting edges a tool may have (a large face mill has a few dozen inserts).
MAX_TEETH = 100


def validate_tool(tool: Tool, where: str = "tool") -> None:
    """Raise InputError if a tool field is out of its physical range."""
    if (not (isinstance(tool.teeth, int) and not isinstance(tool.teeth, bool))
            or not 1 <= tool.teeth <= MAX_TEETH):
        raise InputError(f"{where}.teeth must be a whole number from 1 to {MAX_TEETH}, got "
                         f"{tool.teeth!r}")
    if not (math.isfinite(tool.diameter) and tool.diameter > 0):
        raise InputError(f"{where}.diameter must be > 0 mm, got {tool.diameter / MM:g} mm")
    if not (math.isfinite(tool.helix) and 0.0 <= tool.helix < math.pi / 2):
        raise InputError(
            f"{where}.helix must be in [0, 90) deg, got {math.degrees(tool.helix)!r} deg"
        )
    if not (math.isfinite(tool.flute_length) and tool.flute_length > 0):
        raise InputError(
            f"{where}.flute_length must be > 0 mm, got {tool.flute_length / MM:g} mm"
        )


#: Keys of a tool file: the ones the model uses, then free text and informative lengths.
TOOL_KEYS = ("name", "diameter_mm", "teeth", "helix_deg", "flute_length_mm", "source",
             "material", "overall_length_mm", "shank_diameter_mm")
_FLAT_ONLY = ("feedopt models square (flat) end mills only: a corner radius, ball nose or "
              "other shape is not supported")
_TOOL_HINTS = {"corner": _FLAT_ONLY, "ball": _FLAT_ONLY, "shape": _FLAT_ONLY,
               "type": _FLAT_ONLY, "radius": _FLAT_ONLY}


def load_tool(path: str | Path) -> Tool:
    """Read a cutter YAML file (strict: unknown keys are refused).

    Fields: ``name``, ``diameter_mm``, ``teeth``, ``helix_deg``, ``flute_length_mm``; optional
    and not used by the model: ``source`` and ``material`` (text), ``overall_length_mm`` and
    ``shank_diameter_mm`` (> 0; the overall length at least the flute length).
    """
    data = read_yaml_mapping(path, "tool")
    where = f"tool file {str(path)!r}"
    check_keys(data, TOOL_KEYS, where, _TOOL_HINTS)
    teeth = data.get("teeth")
    if teeth is None:
        raise InputError(f"{where}: missing field 'teeth'")
    if isinstance(teeth, bool) or not isinstance(teeth, int) or not 1 <= teeth <= MAX_TEETH:
        raise InputError(f"{where}.teeth: expected a whole number from 1 to {MAX_TEETH} (the "
                         f"cutting edges or inserts of the tool), got {teeth!r}")
    diameter_mm = number(data, "diameter_mm", where)
    helix_deg = number(data, "helix_deg", where)
    flute_mm = number(data, "flute_length_mm", where)
    if diameter_mm <= 0:
        raise InputError(f"{where}.diameter_mm: must be > 0 mm, got {diameter_mm:g}")
    if not 0 <= helix_deg < 90:
        raise InputError(f"{where}.helix_deg: must be in [0, 90) deg, got {helix_deg:g}")
    if flute_mm <= 0:
        raise InputError(f"{where}.flute_length_mm: must be > 0 mm, got {flute_mm:g}")
    _check_informative(data, where, flute_mm)
    return Tool(
        name=text(data, "name", where, Path(path).stem),
        diameter=diameter_mm * MM,
        teeth=teeth,
        helix=math.radians(helix_deg),
        flute_length=flute_mm * MM,
    )


def _check_informative(data: dict, where: str, flute_mm: float) -> None:
    """The optional fields the model does not use still hold what they say."""
    text(data, "source", where)
    text(data, "material", where)
    for key in ("overall_length_mm", "shank_diameter_mm"):
        if data.get(key) is None:
            continue
        value = number(data, key, where)
        if value <= 0:
            raise InputError(f"{where}.{key}: must be > 0 mm, got {value:g}")
        if key == "overall_length_mm" and value < flute_mm:
            raise InputError(f"{where}.overall_length_mm: {value:g} mm is shorter than the "
                             f"flute length {flute_mm:g} mm")
