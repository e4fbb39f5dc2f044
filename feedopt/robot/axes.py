"""A controller's axis convention: how the values on its pendant relate to the URDF's joints.

controller axis = sign * URDF joint + offset, per joint (``robot.yaml`` ``controller.axes``).
A ROS-Industrial KUKA URDF has the upper arm vertical at q2 = 0 where KUKA's A2 is -90 deg
(offset_deg [0, -90, 90, 0, 0, 0]); the bundled robots' URDFs already follow their
controllers (identity). Every export that writes axis values converts with
:meth:`AxisConvention.to_controller`; scenario start configurations and ``--q-deg`` are
controller values converted with :meth:`AxisConvention.from_controller`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.robot_file import AxisConventionSection
from feedopt.units import MM

#: Why a KUKA program is not written for a robot whose robot.yaml states no axis convention.
UNSTATED_AXES = (
    "robot.yaml states no controller.axes, so the URDF's joint angles cannot be turned into "
    "KUKA axis values (a ROS-Industrial KUKA URDF has A2 = q2 - 90 deg, A3 = q3 + 90 deg); "
    "feedopt never writes URDF angles as axis values. Add to robot.yaml: controller: {type: "
    "kuka, axes: {sign: [1, 1, 1, 1, 1, 1], offset_deg: [0, -90, 90, 0, 0, 0]}} with your "
    "URDF's numbers (check: the pose at KUKA's HOME axis values)")


@dataclass(frozen=True)
class AxisConvention:
    """Per joint (dof,): ``sign`` (+-1), ``offset`` [rad or m] and ``unit`` (SI per
    controller unit: rad per deg, m per mm). ``stated``: robot.yaml gave it (else identity,
    the URDF's own angles)."""

    sign: np.ndarray
    offset: np.ndarray
    unit: np.ndarray
    stated: bool

    @classmethod
    def identity(cls, unit: np.ndarray) -> AxisConvention:
        """The URDF's own joints, in deg (mm for prismatic joints)."""
        n = np.asarray(unit).size
        return cls(np.ones(n), np.zeros(n), np.asarray(unit, dtype=float), False)

    def to_controller(self, q: np.ndarray) -> np.ndarray:
        """Controller axis values [deg, mm] of URDF joints ``q`` (..., dof) [rad, m]."""
        return (self.sign * np.asarray(q, dtype=float) + self.offset) / self.unit

    def to_controller_si(self, q: np.ndarray) -> np.ndarray:
        """Controller axis values [rad, m] of URDF joints ``q`` (URScript's unit)."""
        return self.sign * np.asarray(q, dtype=float) + self.offset

    def from_controller(self, values: np.ndarray) -> np.ndarray:
        """URDF joints [rad, m] of controller axis values (..., dof) [deg, mm]."""
        return self.sign * (np.asarray(values, dtype=float) * self.unit - self.offset)

    def describe(self) -> str:
        """One line for export headers: which convention the axis values are in."""
        if self.stated and not np.any(self.offset) and np.all(self.sign > 0):
            return ("axis values = URDF joint angles (robot.yaml controller.axes: the "
                    "controller's convention is the URDF's)")
        if not self.stated:
            return "axis values are the URDF's joint angles (robot.yaml states no controller.axes)"
        parts = [f"{'' if s > 0 else '-'}q{j + 1}{o:+g}" if o else
                 f"{'' if s > 0 else '-'}q{j + 1}"
                 for j, (s, o) in enumerate(zip(self.sign, self.offset / self.unit,
                                                strict=True))]
        return ("axis values in the controller's convention (robot.yaml controller.axes): "
                + ", ".join(f"A{j + 1} = {p}" for j, p in enumerate(parts)))


def axis_convention(section: AxisConventionSection | None, joints: tuple[str, ...],
                    unit: np.ndarray, where: Path) -> AxisConvention:
    """The convention of ``controller.axes`` (identity without it), one entry per joint."""
    if section is None:
        return AxisConvention.identity(unit)
    n = len(joints)
    for key in ("sign", "offset_deg"):
        got = len(getattr(section, key))
        if got != n:
            raise InputError(f"{where}: controller.axes.{key}: expected {n} values, one per "
                             f"joint ({', '.join(joints)}), got {got}")
    offset = np.asarray(section.offset_deg, dtype=float) * np.asarray(unit)
    if np.any(np.abs(offset[unit != MM]) > 2 * np.pi):
        raise InputError(f"{where}: controller.axes.offset_deg: every offset of a revolute "
                         f"joint must be within +-360 deg, got {section.offset_deg}")
    return AxisConvention(np.asarray(section.sign, dtype=float), offset,
                          np.asarray(unit, dtype=float), True)
