"""Scenario files: one YAML document says everything about a planning job.

Validated with pydantic; user units (mm, mm/s, deg, rpm) are in the field names and are
converted to SI only by the runner. Relative file paths are resolved against the scenario
file's directory. :func:`load_scenario` turns every validation problem into one
:class:`~feedopt.errors.InputError` that names the field path, what was expected and, for
an unknown field, the closest valid name. ``feedopt validate --schema`` prints the
reference of every field (generated from this module).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from feedopt import schema
from feedopt.errors import InputError
from feedopt.geometry.registry import blend_names
from feedopt.schedule.laws import LAWS as LAW_REGISTRY
from feedopt.schedule.laws import law_names
from feedopt.textio import read_user_text
from feedopt.yamlio import parse_yaml, read_yaml

# Allowed laws and blends come from their registries (feedopt.schedule.laws,
# feedopt.geometry.registry): a new law or blend kind needs no edit here.
LAWS = law_names()  # the built-in laws, for defaults and CLI help
#: the baseline each kind of path is compared with: constant (one nominal feed) or the
#: program's own feeds; a scenario without schedule.laws runs every law but the other one
BASELINE_OF_PROGRAMS, BASELINE_OF_PATHS = "programmed", "constant"
#: path generators that read a CAM program (moves with feeds, rapids, stops): G-code, APT CL,
#: HEIDENHAIN Klartext
PROGRAM_GENERATORS = ("gcode", "apt", "heidenhain")


def default_laws(generator: str) -> list[str]:
    """Every registered law except the baseline that does not apply to ``generator``."""
    other = BASELINE_OF_PATHS if generator in PROGRAM_GENERATORS else BASELINE_OF_PROGRAMS
    return [law for law in LAW_REGISTRY if law != other]
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Vector3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]


_Strict = schema.Strict


class RedundancySection(_Strict):
    """Options of ``robot.redundancy: optimise`` (feedopt.robot.redundancy)."""

    objective: Literal["time", "deflection"] = Field("time", description="minimise T* "
                                                     "(time) or the largest deflection at "
                                                     "the nominal feed")
    knots: Annotated[int, Field(ge=2, le=60)] | None = Field(
        None, description="knots of the psi(s) spline (default: one per 50 mm, 6-12)")
    search_spacing_mm: Annotated[float, Field(gt=0, le=50, allow_inf_nan=False)] = Field(
        1.0, description="sample spacing of the search (verified at the run's spacing)")
    max_evaluations: Annotated[int, Field(ge=1, le=100_000)] = Field(
        400, description="objective evaluations (IK + bound) the search may take")
    path_acceleration: bool = Field(True, description="keep joint accelerations within their "
                                    "limits also when a law ramps at the full tangential "
                                    "acceleration (false: only the velocity term)")


class RobotSection(_Strict):
    """The robot: a directory with robot.yaml + URDF, stiffness set and start pose."""

    directory: str = Field(description="robot directory (robot.yaml + URDF), relative paths "
                           "resolve against the scenario file")
    stiffness: Literal["dpp", "cp"] = Field("dpp", description="joint stiffness set of thesis "
                                            "Table 3.4 (DPP is what the thesis uses, Eq. 3.20)")
    start_configuration_deg: Annotated[list[FiniteFloat], Field(min_length=1, max_length=12)] = (
        Field(description="joint values that seed IK at the first sample, one per joint: the "
              "controller's axis values in deg (mm for a prismatic joint), as on its pendant "
              "(robot.yaml controller.axes converts them; the URDF's joint angles when it "
              "states no axes)")
    )
    fix_tool_rotation: bool = Field(False, description="fix the rotation about the tool axis "
                                    "(6-DoF task); default: free, the milling 5-DoF task")
    redundancy: Literal["nearest", "optimise"] = Field(
        "nearest", description="the free rotation about the tool axis: the nearest IK "
        "solution, or a smooth profile psi(s) optimised to make the robot stiff where the "
        "force is (lower T*, feedopt.robot.redundancy); on a 7-axis robot (an arm on a track, "
        "a 7-joint arm) optimise holds its extra axis (robot.yaml extra_axis) at the value "
        "that lowers T* (feedopt.robot.extra_axis)")
    redundancy_options: RedundancySection = RedundancySection()

    @model_validator(mode="after")
    def _redundancy_needs_the_free_rotation(self) -> RobotSection:
        if self.redundancy == "optimise" and self.fix_tool_rotation:
            raise ValueError("redundancy: optimise needs the rotation about the tool axis free; "
                             "fix_tool_rotation: true fixes it (remove one of them)")
        return self


class WorkpieceSection(_Strict):
    """Placement of the workpiece frame W in the robot base frame B."""

    position_mm: Vector3 = Field(description="origin of W in B (mm)")
    rpy_deg: Vector3 = Field([0.0, 0.0, 0.0], description="roll, pitch, yaw of W in B (deg, "
                             "extrinsic X-Y-Z)")
    tool_axis: Vector3 = Field([0.0, 0.0, 1.0], description="tool axis in W, pointing from the "
                               "tool tip into the spindle (default: normal of the top face)")


class PathSection(_Strict):
    """Tool path in the workpiece frame: a generator or a waypoint file, and its blends."""

    generator: Literal["triangle_wave", "square_wave", "line", "csv", "gcode", "apt",
                       "heidenhain"] = Field(
        description="triangle_wave | square_wave (length/height/waves), line (start/end), "
        "csv (file with columns x_mm,y_mm,z_mm, optionally i,j,k tool vectors), gcode (a CAM "
        "program: file; its F words are the nominal feed per move, its S word the spindle "
        "speed), apt (an APT CL file, five-axis GOTO/x,y,z,i,j,k: read like a program), "
        "heidenhain (a Klartext .h program, five-axis LN ... TX TY TZ: read like a program)")
    length_mm: PositiveFloat = Field(304.8, description="wave length along x (mm)")
    height_mm: PositiveFloat = Field(76.2, description="wave height along y (mm)")
    waves: Annotated[int, Field(ge=1)] = Field(3, description="number of waves")
    start_mm: Vector3 = Field([0.0, 0.0, 0.0], description="line start (mm)")
    end_mm: Vector3 = Field([203.2, -9.525, 0.0], description="line end (mm); the chapter-4 "
                            "cut drifts to the right (-y) into the material (down milling)")
    file: str | None = Field(None, description="waypoint CSV (generator csv) or G-code program "
                             "(generator gcode; its G54 origin is the workpiece frame's)")
    z_mm: FiniteFloat = Field(0.0, description="height of generated waves in W (mm)")
    blend: str = Field("varying_radius", description="corner blend kind (thesis 3.3): one of "
                       "the registered kinds (feedopt path --help lists them) or none")
    blend_size_mm: PositiveFloat = Field(12.7, description="blend radius (circle, "
                                         "varying_radius) or tolerance (bezier4/5) (mm)")
    spacing_mm: Annotated[float, Field(ge=0.001, allow_inf_nan=False)] = Field(
        0.1, description="sample spacing along the path (mm, >= 0.001)")
    drop_repeated_waypoints: bool = Field(False, description="drop repeated consecutive "
                                          "waypoints (and say so) instead of refusing them")
    tolerance_mm: PositiveFloat = Field(0.01, description="gcode: largest deviation of the "
                                        "smoothed path from the program next to cutting moves "
                                        "(corner blends, G2 transitions, smoothed chains) (mm)")
    air_tolerance_mm: PositiveFloat = Field(0.5, description="gcode: the same between air "
                                            "moves (rapids, plunges, retracts) (mm)")
    arc_tolerance_mm: PositiveFloat = Field(0.002, description="gcode: largest difference of "
                                            "an arc's start and end radius (mm); the reader "
                                            "allows 2*sqrt(2) units of the program's last "
                                            "written decimal if that is more (and says so)")
    dwell_p_units: Literal["s", "ms"] = Field("s", description="gcode: unit of G4's P word: s "
                                              "(seconds: RS-274/NGC, LinuxCNC, Haas P1.5) or "
                                              "ms (Fanuc posts: P1000 = 1 s); G4 X is always "
                                              "seconds")
    stock_top_mm: FiniteFloat = Field(0.0, description="gcode without a stock: section: Z of "
                                      "the stock's top face in the program frame (CAM "
                                      "convention: G54 Z0 on top); cut moves above it are in "
                                      "air, plunges below it take the cutting tolerance, an "
                                      "air link (tool change, G28, G53) below it is refused")
    chain_max_move_mm: PositiveFloat = Field(2.0, description="gcode: G1 cut moves up to this "
                                             "long may be smoothed together as a free-form "
                                             "chain (mm)")
    chain_max_turn_deg: Annotated[float, Field(gt=0, le=90, allow_inf_nan=False)] = Field(
        15.0, description="gcode: ... when consecutive moves turn by at most this (deg)")
    orientation_tolerance_deg: Annotated[float, Field(gt=0, le=10, allow_inf_nan=False)] = (
        Field(0.2, description="five-axis paths (gcode with tool vectors, apt, csv with "
              "columns i,j,k): largest angle between the smoothed tool vector and the "
              "programmed one where consecutive great circles are blended (deg)"))
    tool_number: Annotated[int, Field(ge=0)] | None = Field(
        None, description="gcode: the program's tool number (T) the scenario's tool file "
        "describes (default: the program's only tool)")

    @field_validator("blend")
    @classmethod
    def _known_blend(cls, value: str) -> str:
        if value not in blend_names():
            raise ValueError(f"unknown blend {value!r}; choose one of {', '.join(blend_names())}")
        return value

    @model_validator(mode="after")
    def _needs_file(self) -> PathSection:
        if self.generator == "csv" and not self.file:
            raise ValueError("generator 'csv' needs 'file' (a waypoint CSV: x_mm,y_mm,z_mm)")
        if self.generator == "gcode" and not self.file:
            raise ValueError("generator 'gcode' needs 'file' (a G-code program)")
        if self.generator == "apt" and not self.file:
            raise ValueError("generator 'apt' needs 'file' (an APT CL file)")
        if self.generator == "heidenhain" and not self.file:
            raise ValueError("generator 'heidenhain' needs 'file' (a Klartext .h program)")
        return self


class DepthProfile(_Strict):
    """Radial depth as a table over arc length (linear interpolation), given in mm of arc
    length (``s_mm``) or as fractions of the path length (``s_fraction``, 0..1)."""

    s_mm: Annotated[list[FiniteFloat], Field(min_length=2)] | None = Field(
        None, description="arc lengths of the table (mm)")
    s_fraction: Annotated[list[FiniteFloat], Field(min_length=2)] | None = Field(
        None, description="arc lengths of the table as fractions of the path length")
    depth_mm: Annotated[list[FiniteFloat], Field(min_length=2)] = Field(
        description="radial depth at each table point (mm)")

    @model_validator(mode="after")
    def _same_length(self) -> DepthProfile:
        if (self.s_mm is None) == (self.s_fraction is None):
            raise ValueError("give exactly one of s_mm and s_fraction")
        s = self.s_mm if self.s_mm is not None else self.s_fraction
        if len(s) != len(self.depth_mm):
            raise ValueError("the arc-length and depth_mm lists must have the same length")
        if any(b <= a for a, b in zip(s, s[1:], strict=False)):
            raise ValueError("arc lengths must be strictly increasing")
        if self.s_fraction is not None and (s[0] < 0 or s[-1] > 1):
            raise ValueError("s_fraction values must lie in [0, 1]")
        return self


class CutSection(_Strict):
    """Cutting conditions."""

    type: Literal["slot", "peripheral"] | None = Field(None, description="slot (full "
                                                       "immersion) or peripheral (radial "
                                                       "depth); required without a stock")
    axial_depth_mm: PositiveFloat | None = Field(None, description="axial depth of cut a (mm); "
                                                 "required without a stock")
    radial_depth_mm: PositiveFloat | None = Field(None, description="constant radial depth "
                                                  "a_e for peripheral cuts (mm)")
    radial_depth_profile: DepthProfile | None = Field(None, description="radial depth vs arc "
                                                      "length for peripheral cuts")
    milling: Literal["down", "up"] = Field("down", description="down (climb): the material "
        "is on the right of the feed direction seen from the spindle (cutter turning clockwise "
        "seen from above, Altintas' frame); up: on the left")
    spindle_rpm: PositiveFloat | None = Field(None, description="spindle speed (rev/min); "
                                              "required unless a G-code program sets it (S)")
    extrapolate_coefficients: bool = Field(False, description="allow cutting coefficients "
                                           "outside the calibrated speed range")

    @model_validator(mode="after")
    def _radial(self) -> CutSection:
        if self.type == "peripheral" and (self.radial_depth_mm is None) == (
            self.radial_depth_profile is None
        ):
            raise ValueError("a peripheral cut needs exactly one of radial_depth_mm and "
                             "radial_depth_profile")
        if self.type == "slot" and (self.radial_depth_mm or self.radial_depth_profile):
            raise ValueError("a slot is full immersion: remove radial_depth_mm/_profile")
        return self


class StockSection(_Strict):
    """The workpiece as material (a Z-map, feedopt.process.stock): the engagement of every
    sample comes from the material the cutter meets, replacing cut.type / depths."""

    box_mm: Annotated[list[FiniteFloat], Field(min_length=6, max_length=6)] | None = Field(
        None, description="box of stock in W: [x0, y0, z0, x1, y1, z1] (mm)")
    mesh: str | None = Field(None, description="closed triangle mesh of the stock (STL, binary "
                             "or ASCII, in W, in stock.units); a Z-map's tops per cell by "
                             "vertical rays, or on a five-axis path a tri-dexel (rays along x, "
                             "y and z)")
    from_program: bool = Field(False, description="gcode: a box made from the program: from "
                               "path.stock_top_mm down to the deepest cut, around the cutting "
                               "moves (and plunges below the top) widened by the tool radius; "
                               "stated in the console")
    units: Literal["mm", "m"] | None = Field(None, description="units of the stock.mesh STL "
                                             "coordinates (STL stores none): mm (default, the "
                                             "CAD convention) or m; only with mesh (box_mm is "
                                             "in mm)")
    air_cut: bool = Field(False, description="the path is meant not to cut the stock (an air "
                          "cut): without it, a path that cuts no material at any sample is "
                          "refused (stock and path in different places, or mesh units wrong); "
                          "with it, that is a warning")
    cell_mm: Annotated[float, Field(ge=0.02, le=5.0, allow_inf_nan=False)] = Field(
        0.25, description="Z-map cell size (mm): entry/exit angles within about "
        "cell / sqrt(2) / (R sin phi) rad (1.1 deg at 0.25 mm, R 9.525 mm); a stock may have "
        "at most 40 million cells (4 bytes each: 1.58 x 1.58 m at 0.25 mm). On a five-axis "
        "path the tri-dexel's ray spacing (at most 60 million rays; keep it well below the "
        "depth of cut: the material is read within 0.6 of it)")
    depth_step_mm: Annotated[float, Field(ge=0.005, le=5.0, allow_inf_nan=False)] = Field(
        0.1, description="Z-map only (a tri-dexel finds the engagement per profile slice): "
        "axial depth resolution across the cutter (mm): where the material "
        "top under the cutter varies (ramps, helices, steps), the engaged angles are split "
        "into pieces whose depths differ by this much, each at its largest depth (the force "
        "is overestimated by at most this much depth, never underestimated)")

    @model_validator(mode="after")
    def _one_shape(self) -> StockSection:
        if (self.box_mm is not None) + (self.mesh is not None) + self.from_program != 1:
            raise ValueError("give exactly one of box_mm, mesh and from_program: true")
        if self.units is not None and self.mesh is None:
            raise ValueError("units applies to stock.mesh only (box_mm is always in mm): "
                             "remove units")
        if self.box_mm is not None:
            x0, y0, z0, x1, y1, z1 = self.box_mm
            if not (x1 > x0 and y1 > y0 and z1 > z0):
                raise ValueError(f"box_mm must be [x0, y0, z0, x1, y1, z1] with x1 > x0, y1 > "
                                 f"y0, z1 > z0, got {self.box_mm}")
        return self


class FeedSection(_Strict):
    nominal_mm_s: PositiveFloat | None = Field(None, description="nominal feed; the constant "
                                               "law runs at it (required, except with a G-code "
                                               "program, whose F words are the nominal feed)")
    max_mm_s: PositiveFloat | None = Field(None, description="largest feed any law may use "
                                           "(default: the nominal feed, so the deflection "
                                           "limit only lowers it, as in the thesis)")
    rapid_mm_s: PositiveFloat | None = Field(None, description="gcode: largest TCP speed of "
                                             "rapids (G0) (default: only the robot's joint "
                                             "velocity limits)")
    plunge_max_mm_s: PositiveFloat | None = Field(None, description="gcode: largest feed of "
                                                  "straight plunges into material when the "
                                                  "material file has no plunge coefficients "
                                                  "(then they are not deflection-limited; "
                                                  "default: the program's F)")
    start_mm_s: Annotated[float, Field(ge=0)] = Field(0.0, description="feed at the start")
    end_mm_s: Annotated[float, Field(ge=0)] = Field(0.0, description="feed at the end")


class DeflectionSection(_Strict):
    limit_mm: PositiveFloat = Field(description="deflection limit (mm); in mode 'surface' "
                                    "the largest |d| accepted besides the part tolerances")
    mode: Literal["norm", "normal", "direction", "residual", "surface"] = Field(
        "norm", description=(
            "limit the norm of the TCP deflection (thesis), its component along the in-plane "
            "surface normal, along a given direction, (residual) what is left of it when the "
            "commanded path is offset by the mean deflection of a revolution: max |d(phi) - "
            "mean d| (compensation, feedopt.schedule.compensation), or (surface) the errors "
            "of the machined walls and floor, wall_limit_mm / floor_limit_mm "
            "(feedopt.schedule.surface)"))
    wall_limit_mm: PositiveFloat | None = Field(None, description="mode surface: largest "
                                                "|wall error| (mm), the deflection normal to "
                                                "the wall when an edge generates it")
    floor_limit_mm: PositiveFloat | None = Field(None, description="mode surface: largest "
                                                 "|floor error| (mm), along the tool axis")
    direction: Vector3 | None = Field(None, description="base-frame direction for mode "
                                      "'direction'")
    compensation_cap_mm: PositiveFloat | None = Field(None, description="mode residual: "
                                                      "largest compensating offset |mean d| "
                                                      "(mm); default none")

    @model_validator(mode="after")
    def _direction(self) -> DeflectionSection:
        if self.mode == "direction" and self.direction is None:
            raise ValueError("mode 'direction' needs 'direction' [x, y, z]")
        if self.compensation_cap_mm is not None and self.mode != "residual":
            raise ValueError("compensation_cap_mm applies to mode 'residual' (compensation) "
                             f"only; this scenario's mode is '{self.mode}'")
        surface = (self.wall_limit_mm, self.floor_limit_mm)
        if self.mode == "surface" and surface == (None, None):
            raise ValueError("mode 'surface' needs wall_limit_mm, floor_limit_mm or both (the "
                             "part tolerances the feed is planned for)")
        if self.mode != "surface" and surface != (None, None):
            raise ValueError("wall_limit_mm and floor_limit_mm apply to mode 'surface' only; "
                             f"this scenario's mode is '{self.mode}' (set mode: surface)")
        if self.direction is not None and sum(x * x for x in self.direction) < 1e-24:
            raise ValueError("direction must be a non-zero vector")
        return self


class LimitsSection(_Strict):
    tangential_acceleration_mm_s2: PositiveFloat = Field(500.0, description="|sddot| limit")
    tangential_jerk_mm_s3: PositiveFloat = Field(5000.0, description="|sdddot| limit")
    joint_velocity_scale: Annotated[float, Field(gt=0, le=1)] = Field(
        1.0, description="fraction of the robot's joint velocity limits to use")
    joint_acceleration_scale: Annotated[float, Field(gt=0, le=1)] = Field(
        1.0, description="fraction of the robot's joint acceleration limits to use")
    spindle_torque_nm: PositiveFloat = Field(400.0, description="spindle torque limit (thesis: "
                                             "Suhner Max 40B)")
    spindle_power_w: PositiveFloat = Field(7500.0, description="spindle power limit")
    orientation_rate_deg_s: PositiveFloat | None = Field(
        None, description="five-axis paths: largest rate at which the tool axis turns "
        "(deg/s; default: none, the joint limits bind)")
    orientation_acceleration_deg_s2: PositiveFloat | None = Field(
        None, description="five-axis paths: largest angular acceleration of the tool axis "
        "(deg/s^2; default: none)")


class ScheduleSection(_Strict):
    laws: list[str] = Field(default_laws("line"), min_length=1, description="timing laws to "
                            "run: " + ", ".join(LAWS) + " (default: all but the baseline that "
                            "does not apply: programmed for generated paths and CSVs, constant "
                            "for G-code programs)")
    law_options: dict[str, dict] = Field(
        {}, description="per-law options, e.g. {convex: {...}}; the fields of each law are "
        "listed under schedule.law_options.<law> below")
    key_point_spacing_mm: Annotated[float, Field(ge=0)] = Field(
        0.0, description="chapter-4 key points every l along lines (0: chapter-3 law)")
    angle_step_deg: Annotated[float, Field(ge=0.01, le=10)] = Field(
        1.0, description="cutter angle step of the force model (slice entry/exit angles are "
        "always added)")
    axial_slices: Annotated[int, Field(ge=1, le=500)] = Field(20, description="axial slices")

    @field_validator("laws")
    @classmethod
    def _known_laws(cls, value: list[str]) -> list[str]:
        unknown = [law for law in value if law not in LAW_REGISTRY]
        if unknown:
            raise ValueError(f"unknown law(s) {', '.join(map(repr, unknown))}; choose from "
                             f"{', '.join(LAW_REGISTRY)}")
        return value

    @model_validator(mode="after")
    def _valid_options(self) -> ScheduleSection:
        for law in self.law_options:
            if law not in LAW_REGISTRY:
                raise ValueError(f"law_options.{law}: unknown law; choose from "
                                 f"{', '.join(LAW_REGISTRY)}")
            self.options_for(law)
        return self

    def options_for(self, law: str) -> BaseModel:
        """The validated options of ``law`` (its defaults where the scenario sets none)."""
        model = LAW_REGISTRY[law].options_model()
        try:
            return model.model_validate(self.law_options.get(law, {}))
        except ValidationError as exc:
            problems = "; ".join(
                f"law_options.{law}.{'.'.join(str(p) for p in e['loc'])}: {e['msg']}"
                + (f" (valid: {', '.join(model.model_fields)})"
                   if e["type"] == "extra_forbidden" else "")
                for e in exc.errors())
            raise ValueError(problems) from None


#: RSI sensor cycles a KRC4 runs (ms): IPO_FAST (4 ms) and IPO mode (12 ms).
RSI_CYCLES_MS = (4.0, 12.0)


class ExportSection(_Strict):
    rsi_cycle_ms: PositiveFloat = Field(4.0, description="RSI cycle (ms): the controller's "
                                        "sensor cycle, 4 (IPO_FAST) or 12 (IPO)")

    @model_validator(mode="after")
    def _cycle(self) -> ExportSection:
        if self.rsi_cycle_ms not in RSI_CYCLES_MS:
            raise ValueError(f"rsi_cycle_ms = {self.rsi_cycle_ms:g} ms is not an RSI cycle: a "
                             "KRC4 exchanges RSI packets every 4 ms (IPO_FAST) or 12 ms (IPO)")
        return self


class FitNote(_Strict):
    """A scenario value chosen so that a result matches a reference (a fit, not a
    prediction): shown with the run's results, with what the reference's own data suggest."""

    field: str = Field(description="the fitted scenario field, dotted, with [k] for a list "
                       "element (e.g. cut.axial_depth_mm, stock.box_mm[5])",
                       pattern=r"^[a-z_]+(\.[a-z_]+)*(\[[0-9]+\])?$")
    value: FiniteFloat = Field(description="the fitted value (a run where the field has "
                               "another value says so)")
    why: str = Field(description="what it was chosen to reproduce")
    suggested: FiniteFloat | None = Field(None, description="the value the reference's own "
                                          "data suggest")
    suggested_source: str = Field("", description="where that value comes from")
    result_at_suggested: str = Field("", description="the result at the suggested value")

    def text(self, actual: float) -> str:
        """One line for the console, summary.json and the report; ``actual`` is the field's
        value in the run (a sweep or an edit may have changed it)."""
        if abs(actual - self.value) > 1e-9 * max(1.0, abs(self.value)):
            return (f"{self.field} = {actual:g} here, not its fitted {self.value:g} ({self.why}): "
                    "these results are predictions at a changed value")
        out = f"{self.field} = {self.value:g} is a FIT: {self.why}"
        if self.suggested is not None:
            out += (f". The reference's own data suggest {self.suggested:g}"
                    + (f" ({self.suggested_source})" if self.suggested_source else ""))
            if self.result_at_suggested:
                out += f"; there: {self.result_at_suggested}"
        return out


def _field_value(model: BaseModel, path: str) -> object:
    """The value of a dotted field path (optionally ending in [k]) of ``model``."""
    name, _, index = path.partition("[")
    value: object = model
    for part in name.split("."):
        if not isinstance(value, BaseModel) or part not in type(value).model_fields:
            raise ValueError(f"no scenario field {name!r}")
        value = getattr(value, part)
    if index:
        k = int(index.rstrip("]"))
        if not isinstance(value, list) or k >= len(value):
            raise ValueError(f"{name} has no element [{k}]")
        value = value[k]
    return value


class Scenario(_Strict):
    """A complete planning job (see scenarios/*.yaml)."""

    name: str = Field(description="scenario name (output folder out/<name>/): letters, digits, "
                      "'.', '_', '-'", pattern=r"^[A-Za-z0-9_][A-Za-z0-9._-]{0,99}$")
    description: str = Field("", description="free text")
    robot: RobotSection
    workpiece: WorkpieceSection
    path: PathSection
    tool: str = Field(description="tool YAML file (diameter, teeth, helix, flute length)")
    material: str = Field(description="cutting-coefficient YAML (feedopt calibrate --out)")
    cut: CutSection
    stock: StockSection | None = Field(None, description="the workpiece as material: the "
                                       "engagement comes from it (replaces cut.type and the "
                                       "depths)")
    feed: FeedSection
    deflection: DeflectionSection
    limits: LimitsSection = LimitsSection()
    schedule: ScheduleSection = ScheduleSection()
    export: ExportSection = ExportSection()
    fits: list[FitNote] = Field(default_factory=list, description="values chosen to reproduce "
                                "a reference result (fits, not predictions): printed and "
                                "reported with the results")

    @model_validator(mode="after")
    def _fits_match(self) -> Scenario:
        for k, fit in enumerate(self.fits):
            try:
                value = _field_value(self, fit.field)
            except ValueError as exc:
                raise ValueError(f"fits[{k}].field: {exc}") from None
            if value is None:  # not given: the section's own rules name it
                continue
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ValueError(f"fits[{k}].field: {fit.field} is not a number")
        return self

    def fit_notes(self) -> list[str]:
        """The fit notes of this scenario, each against the field's value here."""
        values = [_field_value(self, fit.field) for fit in self.fits]
        return [fit.text(float(v)) for fit, v in zip(self.fits, values, strict=True)
                if v is not None]

    @model_validator(mode="before")
    @classmethod
    def _default_laws(cls, raw):
        """schedule.laws, when not given, from the kind of path."""
        if isinstance(raw, dict) and isinstance(raw.get("path"), dict):
            sched = raw.get("schedule", {})
            if isinstance(sched, dict) and "laws" not in sched:
                gen = raw["path"].get("generator")
                raw = {**raw, "schedule": {**sched, "laws": default_laws(str(gen))}}
        return raw

    @model_validator(mode="after")
    def _program_sets_feed(self) -> Scenario:
        program = self.path.generator in PROGRAM_GENERATORS
        if program and self.feed.nominal_mm_s is not None:
            raise ValueError("feed.nominal_mm_s: with path.generator gcode the program's F "
                             "words are the nominal feed of every move; remove "
                             "feed.nominal_mm_s (feed.max_mm_s may still cap it)")
        if not program and self.feed.nominal_mm_s is None:
            raise ValueError("feed.nominal_mm_s: required (the nominal feed, mm/s)")
        if not program and self.cut.spindle_rpm is None:
            raise ValueError("cut.spindle_rpm: required (the spindle speed, rev/min)")
        if self.feed.rapid_mm_s is not None and not program:
            raise ValueError("feed.rapid_mm_s: only a G-code program has rapids; remove it")
        if self.feed.plunge_max_mm_s is not None and not program:
            raise ValueError("feed.plunge_max_mm_s: only a G-code program has plunges; remove it")
        if self.stock is not None and self.stock.from_program and not program:
            raise ValueError("stock.from_program: only a G-code program gives a stock; use "
                             "stock.box_mm or stock.mesh")
        if self.stock is None and (self.cut.type is None or self.cut.axial_depth_mm is None):
            raise ValueError("cut.type and cut.axial_depth_mm: required without a stock (or "
                             "give stock: {box_mm: [...]} for the engagement from the material)")
        if self.stock is not None and any(abs(a - b) > 1e-12 for a, b in zip(
                self.workpiece.tool_axis, (0.0, 0.0, 1.0), strict=True)):
            raise ValueError("stock: the Z-map stock model is for 3-axis milling with the tool "
                             "axis along +z of the workpiece frame; workpiece.tool_axis must "
                             "be [0, 0, 1] (a tilted tool takes its axis from the path's tool "
                             "vectors, and then a tri-dexel stock: remove tool_axis)")
        return self


def scenario_warnings(scenario: Scenario) -> list[str]:
    """What a valid scenario asks for that is probably not what the user meant, and what the
    run will do about it (printed, and kept in summary.json and the report)."""
    out = []
    cut = scenario.cut
    if scenario.stock is not None and (cut.type is not None or cut.axial_depth_mm is not None
                                       or cut.radial_depth_mm is not None
                                       or cut.radial_depth_profile is not None):
        out.append("stock and cut.type/depths are both given: the engagement comes from the "
                   "stock; cut.type, axial and radial depths and cut.milling are not used")
    feed = scenario.feed
    if (feed.max_mm_s is not None and feed.nominal_mm_s is not None
            and feed.max_mm_s < feed.nominal_mm_s):
        out.append(f"feed.max_mm_s = {feed.max_mm_s:g} mm/s is below feed.nominal_mm_s = "
                   f"{feed.nominal_mm_s:g} mm/s: every optimised law is capped at "
                   f"{feed.max_mm_s:g} mm/s, while the constant baseline still runs at the "
                   "nominal feed")
    laws = scenario.schedule.laws
    repeated = sorted({law for law in laws if laws.count(law) > 1})
    if repeated:
        out.append(f"schedule.laws lists {', '.join(repeated)} more than once: each law is "
                   "planned once")
    return out


def format_validation_error(exc: ValidationError, source: str) -> str:
    """One readable message for all pydantic errors of a scenario (:mod:`feedopt.schema`)."""
    return schema.format_validation_error(exc, source, Scenario, "scenario")


def load_scenario(path: str | Path) -> tuple[Scenario, Path]:
    """Read and validate a scenario file; returns it and its directory.

    Raises
    ------
    InputError
        Missing file, malformed YAML (with line), or any schema violation.
    """
    path = Path(path)
    if not os.path.lexists(path):
        raise InputError(f"scenario file not found: {path}")
    # a dangling link, a link loop, a folder, a FIFO (never opened), a device and a file
    # over the scenario cap each get their own message from the reader
    raw = parse_yaml(read_user_text(path, "scenario file"), str(path))
    if not isinstance(raw, dict):
        raise InputError(f"{path}: a scenario must be a YAML mapping of sections, got "
                         f"{type(raw).__name__}")
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as exc:
        raise InputError(format_validation_error(exc, str(path))) from None
    return scenario, path.resolve().parent


#: Most files of a robot directory :func:`scenario_input_files` lists one by one; a larger
#: directory is listed as itself (every existing file under it is then protected).
MAX_ROBOT_DIR_FILES = 10_000


def scenario_input_files(scenario: Scenario, base_dir: Path) -> list[Path]:
    """Every file the scenario reads (not the scenario file itself), for the output checks.

    The tool and material files, ``path.file`` (waypoint CSV or G-code program),
    ``stock.mesh``, every file under the robot directory (robot.yaml, URDF, meshes) and a
    URDF that robot.yaml names outside it. Paths are absolute, missing files included (the
    stage that reads them reports those); symbolic links are kept, so that a check can both
    resolve them and compare the files. A robot directory of more than
    :data:`MAX_ROBOT_DIR_FILES` files is listed as the directory itself.
    """
    def at(relative: str) -> Path:
        p = Path(relative)
        return Path(os.path.abspath(p if p.is_absolute() else base_dir / p))

    files = [at(scenario.tool), at(scenario.material)]
    if scenario.path.generator in ("csv", *PROGRAM_GENERATORS) and scenario.path.file:
        files.append(at(scenario.path.file))
    if scenario.stock is not None and scenario.stock.mesh is not None:
        files.append(at(scenario.stock.mesh))
    robot_dir = at(scenario.robot.directory)
    robot_files: list[Path] = []
    for folder, _dirs, names in os.walk(robot_dir):  # errors (missing, unreadable): skipped
        robot_files += [Path(folder) / n for n in names]
        if len(robot_files) > MAX_ROBOT_DIR_FILES:
            robot_files = [robot_dir]
            break
    files += robot_files
    try:
        doc = read_yaml(robot_dir / "robot.yaml", "robot file")
    except InputError:  # loading the robot says what is wrong with it
        doc = None
    if isinstance(doc, dict) and isinstance(doc.get("urdf"), str):
        files.append(Path(os.path.abspath(robot_dir / doc["urdf"])))
    return list(dict.fromkeys(files))


def resolve(base: Path, relative: str, what: str) -> Path:
    """Resolve a file named in a scenario against its directory; InputError if missing."""
    p = Path(relative)
    p = p if p.is_absolute() else base / p
    if not os.path.lexists(p):  # a dangling link or a loop: its reader says what it is
        raise InputError(f"{what} not found: {relative} (looked for {p})")
    return p


def schema_reference() -> str:
    """A markdown reference of every scenario field, generated from the schema."""
    out = ["# Scenario reference", "",
           "Generated from `feedopt/scenario.py` (`feedopt validate --schema`).", ""]

    out += schema.reference_lines(Scenario, "", leaves=(DepthProfile,))
    out += ["", "## Timing laws and their options (schedule.law_options.<law>)", ""]
    for name, spec in LAW_REGISTRY.items():
        out.append(f"- **{name}**: {spec.description}")
        out += schema.reference_lines(spec.options_model(), f"schedule.law_options.{name}.")
    return "\n".join(out) + "\n"
