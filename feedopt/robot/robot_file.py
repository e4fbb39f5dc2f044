"""``robot.yaml``, the schema: every field, its unit (in its name) and what it refuses.

A robot directory holds a URDF and this file. Like the scenario it is strict: an unknown key
is refused with the nearest valid name (``tcp_xyz:`` -> ``tcp_xyz_mm``), a number must be
written as a number, and the ``tool:`` block is required (without it the tool axis would
silently be the flange's z, which on a ROS-Industrial KUKA flange points across the
spindle). What depends on the URDF (list lengths = the robot's joints, frames that exist)
is checked by :func:`feedopt.robot.model.load_robot` with the same kind of message.
``feedopt validate --robot DIR`` checks a directory; ``feedopt validate --robot-schema``
prints :func:`robot_reference`.

Units: stiffness in MN m/rad (revolute joints) or MN/m (prismatic joints), speeds and
accelerations in deg/s, deg/s^2 (revolute) or mm/s, mm/s^2 (prismatic), TCP offsets in mm and
deg. Joint stiffness outside :data:`STIFFNESS_PLAUSIBLE_MNM` is refused with the unit
mistake it looks like (N m/rad typed into the MN m/rad list gives zero deflection and a
full-feed run; a compliance typed as a stiffness gives metres of deflection).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from feedopt import schema
from feedopt.errors import InputError

#: Controller families (``controller.type``); ``generic`` gets no native program, only the
#: RSI-style setpoint CSV.
CONTROLLERS = ("kuka", "ur", "abb", "fanuc", "generic")
#: Joint stiffness a machining robot's joint can have [MN m/rad or MN/m]: from a small
#: cobot's ~0.01 to ~10 for the largest arms (thesis Table 3.4: 0.14-3.93), with a decade of
#: margin either side. Beyond it the number is a unit mistake.
STIFFNESS_PLAUSIBLE_MNM = (1e-3, 1e2)

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Vector3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]


class ToolSection(schema.Strict):
    """The tool on the flange: where its TCP is and which way its axis points."""

    tcp_xyz_mm: Vector3 | None = Field(
        None, description="TCP position in the flange frame [mm] (required with flange_frame)")
    tcp_rpy_deg: Vector3 | None = Field(
        None, description="TCP orientation in the flange frame, URDF roll-pitch-yaw [deg]; the "
        "TCP's +z points from the tool tip into the spindle (required with flange_frame)")
    source: str = Field("not stated", description="where the tool numbers come from")


class CouplingSection(schema.Strict):
    """A controller axis that also counts another URDF joint (FANUC's J2/J3 interaction: the
    controller's J3 is the forearm's angle from the horizontal, the URDF's q3 its angle from
    the upper arm)."""

    axis: Annotated[int, Field(ge=1, le=12)] = Field(description="the controller axis (1-based)")
    joint: Annotated[int, Field(ge=1, le=12)] = Field(description="the URDF joint it adds")
    factor: FiniteFloat = Field(1.0, description="controller units per URDF joint unit")


class AxisConventionSection(schema.Strict):
    """How the controller numbers its axes: controller axis = sign * URDF joint + offset (+ the
    coupled joints)."""

    sign: list[Literal[1, -1]] = Field(description="per joint, +1 or -1")
    offset_deg: list[FiniteFloat] = Field(
        description="per joint [deg] (mm for a prismatic joint): the controller's value at the "
        "URDF's zero")
    coupled: list[CouplingSection] = Field(
        [], description="controller axes that add factor * another URDF joint, e.g. FANUC's "
        "J2/J3 interaction [{axis: 3, joint: 2, factor: 1}] (check the sign on your robot)")


class ControllerSection(schema.Strict):
    """The controller the exports are written for."""

    type: Literal["kuka", "ur", "abb", "fanuc", "generic"] = Field(
        "generic", description="kuka (KRL, RSI), ur (URScript), abb (RAPID), fanuc (LS) or "
        "generic (setpoint CSV only)")
    axes: AxisConventionSection | None = Field(
        None, description="the controller's axis convention; required for a kuka, abb or "
        "fanuc export (a KRL, RSI, RAPID or LS program is never written with URDF angles; "
        "an ABB or FANUC arm with a parallel linkage reports A3/J3 from the horizontal: "
        "coupled [{axis: 3, joint: 2, factor: 1}]), identity when not given for ur and "
        "generic")


class SourcedValues(schema.Strict):
    """Per-joint values with where they come from."""

    values: list[PositiveFloat] = Field(description="one value per joint, > 0")
    source: str = Field("not stated", description="where the numbers come from")


class RobotFile(schema.Strict):
    """``robot.yaml``: the numbers a URDF does not carry."""

    name: str | None = Field(None, description="robot name (default: the directory's name)")
    urdf: str = Field(description="file name of the URDF, relative to the robot directory")
    controller: ControllerSection = Field(
        ControllerSection(), description="controller family and axis convention; "
        "'controller: kuka' is short for {type: kuka}")
    warnings: list[str] = Field([], description="caveats on these numbers (placeholders, "
                                "unverified sources) every run with this robot repeats")
    kinematics_source: str | None = Field(None, description="where the URDF numbers come from")
    joint_limits_source: str | None = Field(None, description="where the joint ranges come from")
    flange_frame: str | None = Field(None, description="URDF frame the tool is mounted on "
                                     "(give this or tcp_frame)")
    tcp_frame: str | None = Field(None, description="a URDF frame that already is the TCP "
                                  "(+z from the tip into the spindle)")
    tool: ToolSection = Field(description="the tool on the flange (required)")
    extra_axis: str | None = Field(
        None, description="7-axis robots: the joint robot.redundancy: optimise holds where the "
        "arm is stiffest for the cut (a KUKA LBR: its third joint, the controller's E1; "
        "default: the one prismatic joint of an arm on a track)")
    joint_stiffness_mnm_per_rad: dict[str, list[FiniteFloat] | str] = Field(
        description="named stiffness sets, e.g. cp: [...], dpp: [...], and source: '...' "
        "[MN m/rad per revolute joint, MN/m per prismatic joint]")
    joint_velocity_deg_s: SourcedValues = Field(
        description="speed limits [deg/s; mm/s for a prismatic joint]")
    joint_acceleration_deg_s2: SourcedValues = Field(
        description="acceleration limits [deg/s^2; mm/s^2 for a prismatic joint]")

    @field_validator("controller", mode="before")
    @classmethod
    def _controller_shorthand(cls, value: object) -> object:
        return {"type": value} if isinstance(value, str) else value

    @field_validator("joint_velocity_deg_s", "joint_acceleration_deg_s2", mode="before")
    @classmethod
    def _bare_list(cls, value: object) -> object:
        return {"values": value} if isinstance(value, list) else value

    @field_validator("joint_stiffness_mnm_per_rad")
    @classmethod
    def _stiffness_sets(cls, value: dict) -> dict:
        if not isinstance(value.get("source", ""), str):
            raise ValueError("source must be a sentence (a string)")
        sets = {k: v for k, v in value.items() if k != "source"}
        if not sets:
            raise ValueError("no stiffness set: give at least one, e.g. dpp: [one value per "
                             "joint] in MN m/rad")
        for key, values in sets.items():
            if not isinstance(values, list):
                raise ValueError(f"{key} must be a list of numbers, one per joint")
        return value

    @model_validator(mode="after")
    def _one_tcp(self) -> RobotFile:
        if (self.flange_frame is None) == (self.tcp_frame is None):
            raise ValueError("give exactly one of flange_frame (the tool block then places the "
                             "TCP on it) and tcp_frame (a URDF frame that is the TCP)")
        if self.flange_frame is not None and (self.tool.tcp_xyz_mm is None
                                              or self.tool.tcp_rpy_deg is None):
            raise ValueError("tool.tcp_xyz_mm and tool.tcp_rpy_deg are required with "
                             "flange_frame (the TCP on the flange, mm and deg)")
        if self.tcp_frame is not None and (self.tool.tcp_xyz_mm is not None
                                           or self.tool.tcp_rpy_deg is not None):
            raise ValueError("tool.tcp_xyz_mm / tcp_rpy_deg place a TCP on flange_frame; "
                             "with tcp_frame the URDF frame is the TCP: drop them (keep "
                             "tool.source)")
        return self

    def stiffness_sets(self) -> dict[str, list[float]]:
        """The named stiffness sets (without ``source``)."""
        return {k: v for k, v in self.joint_stiffness_mnm_per_rad.items() if k != "source"}


def stiffness_unit_mistake(value_mnm: float) -> str | None:
    """What a joint stiffness [MN m/rad] outside :data:`STIFFNESS_PLAUSIBLE_MNM` looks like,
    or None inside it."""
    lo, hi = STIFFNESS_PLAUSIBLE_MNM
    if value_mnm > hi * 1e3:
        return (f"outside the plausible {lo:g}-{hi:g} MN m/rad; it looks like N m/rad (divide "
                f"by 1e6: {value_mnm / 1e6:g})")
    if value_mnm > hi:
        return (f"outside the plausible {lo:g}-{hi:g} MN m/rad; it looks like kN m/rad "
                f"(divide by 1000: {value_mnm / 1e3:g})")
    if value_mnm < lo:
        return (f"outside the plausible {lo:g}-{hi:g} MN m/rad (a machining robot's joints "
                "are 0.01-10 MN m/rad); it looks like a compliance (rad/(N m)) or a value in "
                "GN m/rad")
    return None


def parse_robot_file(raw: object, source: Path) -> RobotFile:
    """Validate the mapping read from ``robot.yaml`` (InputError naming every problem)."""
    if not isinstance(raw, dict):
        raise InputError(f"{source}: expected a mapping of fields at the top level, got "
                         f"{type(raw).__name__}")
    try:
        return RobotFile.model_validate(raw)
    except ValidationError as exc:
        raise InputError(schema.format_validation_error(exc, str(source), RobotFile,
                                                        "robot file")) from None


def robot_reference() -> str:
    """A Markdown reference of every robot.yaml field, generated from the schema."""
    out = ["# robot.yaml reference", "",
           "Generated from `feedopt/robot/robot_file.py` (`feedopt validate --robot-schema`).",
           "A robot directory holds a URDF and this file; see docs/robot.md.", ""]
    out += schema.reference_lines(RobotFile)
    return "\n".join(out) + "\n"
