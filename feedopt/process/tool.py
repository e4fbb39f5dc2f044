"""Cutter geometry (thesis Table A.1; general shapes, :mod:`feedopt.process.cutter`), its
bending (:mod:`feedopt.process.tool_bending`) and its YAML reader."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from feedopt.errors import InputError
from feedopt.process._io import check_keys, number, read_yaml_mapping, text
from feedopt.process.cutter import CutterShape, Profile
from feedopt.process.tool_bending import YOUNGS_MODULUS_PA, ToolBeam, tip_compliance_m_per_n
from feedopt.units import MM

#: Tool-tip stiffness in a tool file is in N/um; this many N/m per N/um.
N_PER_M_PER_N_PER_UM = 1e6


@dataclass(frozen=True)
class Tool:
    """An end mill, SI units.

    Attributes
    ----------
    name : str
    diameter : float
        Mill diameter D [m] (a tapered mill's tip, a face mill's cutting diameter Dc at the
        insert tips; :mod:`feedopt.process.cutter`).
    teeth : int
        Number of flutes (inserts) N.
    helix : float
        Helix angle beta [rad] (0 = straight teeth).
    flute_length : float
        Length of cut [m]; the largest usable axial depth.
    shape : CutterShape
        flat (default), ball, bull, tapered or face.
    corner_radius : float
        Corner (ball, bull) or insert nose radius rc [m]; D/2 for a ball-nose.
    taper : float
        Half angle of a tapered mill's side [rad]; for a face mill 90 deg minus the insert's
        entering (lead) angle kappa_r. 0 otherwise.
    stickout : float or None
        Length [m] from the holder face to the tip; None: the tool is taken as rigid unless
        ``tip_stiffness`` is given.
    shank_diameter : float or None
        Shank diameter [m] (default D).
    youngs_modulus : float or None
        E of the tool material [Pa] (needed with ``stickout``).
    tip_stiffness : float or None
        Measured lateral stiffness at the tool tip, holder included [N/m]; replaces the
        cantilever model.
    """

    name: str
    diameter: float
    teeth: int
    helix: float
    flute_length: float
    shape: CutterShape = CutterShape.FLAT
    corner_radius: float = 0.0
    taper: float = 0.0
    stickout: float | None = None
    shank_diameter: float | None = None
    youngs_modulus: float | None = None
    tip_stiffness: float | None = None

    def __post_init__(self) -> None:
        validate_tool(self)

    @property
    def pitch(self) -> float:
        """Tooth pitch angle 2 pi / N [rad]."""
        return 2.0 * math.pi / self.teeth

    @property
    def profile(self) -> Profile:
        """The envelope of the cutting edges (:mod:`feedopt.process.cutter`)."""
        rc = self.corner_radius
        return Profile(r0=self.diameter / 2.0 - rc, corner=rc, kappa1=math.pi / 2 - self.taper)

    @property
    def is_flat(self) -> bool:
        """A cylindrical flat end mill (thesis Algorithm 1's cutter)."""
        return self.profile.is_cylinder

    @property
    def helix_rate(self) -> float:
        """Helix lag per unit height 2 tan(beta) / D [rad/m]."""
        return 2.0 * math.tan(self.helix) / self.diameter

    @property
    def bends(self) -> bool:
        """True when the tool's own compliance is modelled (a stickout or a tip stiffness)."""
        return self.stickout is not None or self.tip_stiffness is not None

    def tip_compliance(self) -> tuple[float, float]:
        """(lateral, axial) compliance at the tool tip [m/N]: the measured tip stiffness, or
        the stepped cantilever of :mod:`feedopt.process.tool_bending`; (0, 0) when rigid."""
        if self.tip_stiffness is not None:
            axial = 0.0 if self.stickout is None else tip_compliance_m_per_n(self.beam())[1]
            return 1.0 / self.tip_stiffness, axial
        if self.stickout is None:
            return 0.0, 0.0
        return tip_compliance_m_per_n(self.beam())

    def beam(self) -> ToolBeam:
        """The tool as a stepped cantilever (needs ``stickout`` and ``youngs_modulus``)."""
        return ToolBeam(diameter_m=self.diameter, flute_length_m=self.flute_length,
                        stickout_m=self.stickout,
                        shank_diameter_m=self.shank_diameter or self.diameter,
                        youngs_modulus_pa=self.youngs_modulus)


def wider_above_tip(tool: Tool) -> str | None:
    """A note when the cutter is wider above its tip than D/2 (a tapered or face mill's
    straight edge), None otherwise: engagements are given at D/2, and material met there is
    taken to stand vertically, so a wall beside the cutter (a radial depth below a slot's) is
    cut by the wider edge above it, and the stock sweep covers the tip diameter only."""
    profile = tool.profile
    if profile.kappa1 >= math.pi / 2:
        return None
    r_top = float(profile.at_length(profile.length_to_height(tool.flute_length))[0])
    return (f"the {tool.shape.value} cutter is {2 * r_top / MM:.4g} mm across at the top of "
            f"its flutes, wider than its {tool.diameter / MM:g} mm tip: engagements are at the "
            "tip diameter, and the material beside it is taken to stand vertically there "
            "(docs/tools.md)")


#: Most cutting edges a tool may have (a large face mill has a few dozen inserts).
MAX_TEETH = 100
#: Largest taper half angle [deg] (a 160 deg V-bit); a face mill's smallest lead angle is
#: 90 deg minus it (a flatter edge would make the cutter wider than any tool at its flutes).
MAX_TAPER_DEG = 80.0
#: Plausible ranges of the bending fields of a tool file (key: (low, high, unit)): outside
#: them a value is a typo or a unit slip (a stickout in um, a stiffness in N/m), refused.
BENDING_RANGES = {"stickout_mm": (0.1, 1000.0, "mm"), "shank_diameter_mm": (0.05, 200.0, "mm"),
                  "youngs_modulus_gpa": (10.0, 1200.0, "GPa"),
                  "tip_stiffness_n_per_um": (1e-3, 1e4, "N/um")}


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
    _validate_shape(tool, where)
    if tool.stickout is not None and tool.youngs_modulus is None:
        raise InputError(f"{where}: a stickout needs the tool material's Young's modulus "
                         f"(material: one of {', '.join(YOUNGS_MODULUS_PA)})")
    if tool.stickout is not None:
        tool.beam()  # its own checks
    if tool.tip_stiffness is not None and not (math.isfinite(tool.tip_stiffness)
                                               and tool.tip_stiffness > 0):
        raise InputError(f"{where}.tip_stiffness must be > 0 N/um")


def _validate_shape(tool: Tool, where: str) -> None:
    """The corner radius and taper fit the shape (:class:`CutterShape`)."""
    shape, rc, r = tool.shape, tool.corner_radius, tool.diameter / 2.0
    taper = math.degrees(tool.taper)
    if not (math.isfinite(rc) and 0.0 <= rc <= r * (1 + 1e-12)):
        raise InputError(f"{where}.corner_radius must be in [0, D/2 = {r / MM:.15g}] mm, got "
                         f"{rc / MM:.15g} mm")
    rules = {
        CutterShape.FLAT: (rc == 0.0 and taper == 0.0, "a flat end mill has no corner radius "
                           "and no taper (shape: bull or tapered)"),
        CutterShape.BALL: (rc == r and taper == 0.0, "a ball-nose has corner radius D/2 and "
                           "no taper (shape: tapered with corner_radius_mm for a tapered ball)"),
        CutterShape.BULL: (0.0 < rc < r and taper == 0.0, "a bull-nose has 0 < corner radius "
                           "< D/2 and no taper (corner radius D/2: shape: ball)"),
        CutterShape.TAPERED: (0.0 < taper <= MAX_TAPER_DEG + 1e-9, "a tapered mill needs "
                              f"taper_deg in (0, {MAX_TAPER_DEG:g}]"),
        CutterShape.FACE: (0.0 <= taper <= MAX_TAPER_DEG + 1e-9 and rc < r, "a face mill needs "
                           f"lead_angle_deg in [{90 - MAX_TAPER_DEG:g}, 90] and a nose radius "
                           "below D/2"),
    }
    ok, rule = rules[shape]
    if not ok:
        raise InputError(f"{where}: shape {shape.value} with corner radius {rc / MM:.15g} mm "
                         f"and taper {taper:g} deg: {rule}")


#: Keys of a tool file: the ones the model uses, then free text and informative lengths.
TOOL_KEYS = ("name", "diameter_mm", "teeth", "helix_deg", "flute_length_mm", "source",
             "material", "overall_length_mm", "shank_diameter_mm", "shape", "corner_radius_mm",
             "taper_deg", "lead_angle_deg", "stickout_mm", "youngs_modulus_gpa",
             "tip_stiffness_n_per_um")
_TOOL_HINTS = {word: f"use {key}" for word, key in (
    ("corner", "corner_radius_mm"), ("nose", "corner_radius_mm (an insert's nose radius)"),
    ("radius", "corner_radius_mm"), ("type", "shape (flat, ball, bull, tapered, face)"),
    ("ball", "shape: ball"), ("stick", "stickout_mm"), ("overhang", "stickout_mm"),
    ("projection", "stickout_mm"), ("entering", "lead_angle_deg"), ("lead", "lead_angle_deg"),
    ("young", "youngs_modulus_gpa"), ("modulus", "youngs_modulus_gpa"),
    ("stiffness", "tip_stiffness_n_per_um"), ("taper", "taper_deg (shape: tapered)"),
    ("angle", "lead_angle_deg (face) or taper_deg (tapered)"))}


def load_tool(path: str | Path) -> Tool:
    """Read a cutter YAML file (strict: unknown keys are refused).

    Fields: ``name``, ``diameter_mm``, ``teeth``, ``helix_deg``, ``flute_length_mm``; the
    shape (:mod:`feedopt.process.cutter`): ``shape`` (flat, ball, bull, tapered, face; default
    flat), ``corner_radius_mm`` (bull; a tapered mill's tip, a face mill's insert nose; a
    ball's is D/2), ``taper_deg`` (tapered: half angle), ``lead_angle_deg`` (face: the
    entering angle, 90 for square shoulder inserts); the bending
    (:mod:`feedopt.process.tool_bending`): ``stickout_mm`` (holder face to tip; without it
    the tool is rigid), ``material`` (carbide, hss or steel give E; other text needs
    ``youngs_modulus_gpa``), ``shank_diameter_mm``, ``tip_stiffness_n_per_um`` (measured,
    holder included; replaces the cantilever); informative: ``source``,
    ``overall_length_mm``.
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
    shape, corner_mm, taper_deg = _shape_fields(data, where, diameter_mm)
    bending = _bending_fields(data, where, flute_mm)
    try:
        return Tool(
            name=text(data, "name", where, Path(path).stem),
            diameter=diameter_mm * MM, teeth=teeth, helix=math.radians(helix_deg),
            flute_length=flute_mm * MM, shape=shape, corner_radius=corner_mm * MM,
            taper=math.radians(taper_deg), **bending,
        )
    except InputError as err:  # validate_tool names the field "tool.x" / "tool:"
        message = str(err)
        for prefix in ("tool: ", "tool."):
            message = message.removeprefix(prefix)
        raise InputError(f"{where}: {message}") from None


def _shape_fields(data: dict, where: str, diameter_mm: float) -> tuple[CutterShape, float, float]:
    """(shape, corner radius [mm], taper [deg]) of a tool file."""
    name = data.get("shape", "flat")
    try:
        shape = CutterShape(name.strip().lower() if isinstance(name, str) else name)
    except ValueError:
        got = "null" if name is None else repr(name)
        raise InputError(f"{where}.shape: expected one of "
                         f"{', '.join(s.value for s in CutterShape)}, got {got}") from None
    corner = number(data, "corner_radius_mm", where) if "corner_radius_mm" in data else None
    if shape is CutterShape.BALL and corner is None:
        corner = diameter_mm / 2.0
    taper = number(data, "taper_deg", where) if "taper_deg" in data else 0.0
    if "taper_deg" in data and shape is not CutterShape.TAPERED:
        raise InputError(f"{where}.taper_deg: only a tapered mill (shape: tapered) has a taper")
    if "lead_angle_deg" in data:
        if shape is not CutterShape.FACE:
            raise InputError(f"{where}.lead_angle_deg: only a face mill (shape: face) has a "
                             "lead angle")
        lead = number(data, "lead_angle_deg", where)
        if not 90.0 - MAX_TAPER_DEG <= lead <= 90:
            raise InputError(f"{where}.lead_angle_deg: must be in [{90 - MAX_TAPER_DEG:g}, 90] "
                             f"deg (the inserts' entering angle), got {lead:g}")
        taper = 90.0 - lead
    elif shape is CutterShape.FACE:
        raise InputError(f"{where}: a face mill needs lead_angle_deg (its inserts' entering "
                         "angle: 90 for square shoulder, 45 for chamfered inserts)")
    return shape, 0.0 if corner is None else corner, taper


def _bending_fields(data: dict, where: str, flute_mm: float) -> dict:
    """stickout, shank diameter, E and measured tip stiffness of a tool file (SI), each
    within :data:`BENDING_RANGES`."""
    out: dict = {}
    for key, field, scale in (("stickout_mm", "stickout", MM),
                              ("shank_diameter_mm", "shank_diameter", MM),
                              ("youngs_modulus_gpa", "youngs_modulus", 1e9),
                              ("tip_stiffness_n_per_um", "tip_stiffness", N_PER_M_PER_N_PER_UM)):
        if data.get(key) is not None:
            value = number(data, key, where)
            low, high, unit = BENDING_RANGES[key]
            if not low <= value <= high:
                raise InputError(f"{where}.{key}: {value:g} {unit} is outside the plausible "
                                 f"{low:g}..{high:g} {unit} (a unit slip?)")
            out[field] = value * scale
    if "youngs_modulus" in out and "stickout" not in out:
        raise InputError(f"{where}.youngs_modulus_gpa: only used with stickout_mm (the tool's "
                         "bending); give the stickout or drop it")
    if "stickout" in out:
        if out["stickout"] < flute_mm * MM:
            raise InputError(
                f"{where}.stickout_mm: {out['stickout'] / MM:g} mm is shorter than the flute "
                f"length {flute_mm:g} mm: the holder would clamp the flutes; give the length "
                "of flutes that sticks out as flute_length_mm")
        if out["stickout"] > float(data.get("overall_length_mm") or math.inf) * MM:
            raise InputError(f"{where}.stickout_mm: longer than overall_length_mm")
        if "youngs_modulus" not in out:
            out["youngs_modulus"] = _modulus_of(data, where)
    return out


def _modulus_of(data: dict, where: str) -> float:
    """E [Pa] of the tool file's ``material`` (:data:`YOUNGS_MODULUS_PA`, any case)."""
    material = str(data.get("material") or "").strip().lower()
    if material not in YOUNGS_MODULUS_PA:
        got = f"got {data['material']!r}" if data.get("material") else "none given"
        raise InputError(
            f"{where}: stickout_mm needs the tool's Young's modulus: material one of "
            f"{', '.join(YOUNGS_MODULUS_PA)} ({got}) or youngs_modulus_gpa")
    return YOUNGS_MODULUS_PA[material]


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
