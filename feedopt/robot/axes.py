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
    coupling: np.ndarray | None = None  # (dof, dof), zero diagonal: axis i += C[i, j] q_j
    # (C in controller units per URDF joint unit: deg per deg, deg per mm, ...)

    @classmethod
    def identity(cls, unit: np.ndarray) -> AxisConvention:
        """The URDF's own joints, in deg (mm for prismatic joints)."""
        n = np.asarray(unit).size
        return cls(np.ones(n), np.zeros(n), np.asarray(unit, dtype=float), False)

    @property
    def matrix(self) -> np.ndarray:
        """M of controller axis = M (q / unit) + offset / unit, in controller units (deg, mm):
        diag(sign) plus the coupling."""
        m = np.diag(self.sign)
        return m if self.coupling is None else m + self.coupling

    @property
    def prismatic(self) -> np.ndarray:
        """(dof,) True for a prismatic joint (its values in mm)."""
        return self.unit == MM

    def unit_names(self) -> tuple[str, ...]:
        """Per joint the controller unit: "mm" (prismatic) or "deg"."""
        return tuple("mm" if p else "deg" for p in self.prismatic)

    def to_controller(self, q: np.ndarray) -> np.ndarray:
        """Controller axis values [deg, mm] of URDF joints ``q`` (..., dof) [rad, m]."""
        q = np.asarray(q, dtype=float)
        if self.coupling is None:
            return (self.sign * q + self.offset) / self.unit
        return (q / self.unit) @ self.matrix.T + self.offset / self.unit

    def to_controller_si(self, q: np.ndarray) -> np.ndarray:
        """Controller axis values [rad, m] of URDF joints ``q`` (URScript's unit)."""
        if self.coupling is None:
            return self.sign * np.asarray(q, dtype=float) + self.offset
        return self.to_controller(q) * self.unit

    def from_controller(self, values: np.ndarray) -> np.ndarray:
        """URDF joints [rad, m] of controller axis values (..., dof) [deg, mm]."""
        values = np.asarray(values, dtype=float)
        if self.coupling is None:
            return self.sign * (values * self.unit - self.offset)
        rhs = values - self.offset / self.unit
        return np.linalg.solve(self.matrix, rhs.T).T * self.unit

    def coupled_axes(self) -> np.ndarray:
        """(dof,) True where the controller's axis adds another joint."""
        if self.coupling is None:
            return np.zeros(self.sign.size, dtype=bool)
        return np.any(self.coupling != 0, axis=1)

    def describe(self) -> str:
        """One line for export headers: which convention the axis values are in."""
        if (self.stated and not np.any(self.offset) and np.all(self.sign > 0)
                and self.coupling is None):
            return ("axis values = URDF joint angles (robot.yaml controller.axes: the "
                    "controller's convention is the URDF's)")
        if not self.stated:
            return "axis values are the URDF's joint angles (robot.yaml states no controller.axes)"
        parts = [f"{'' if s > 0 else '-'}q{j + 1}{self._coupled(j)}{o:+g}" if o else
                 f"{'' if s > 0 else '-'}q{j + 1}{self._coupled(j)}"
                 for j, (s, o) in enumerate(zip(self.sign, self.offset / self.unit,
                                                strict=True))]
        return ("axis values in the controller's convention (robot.yaml controller.axes): "
                + ", ".join(f"A{j + 1} = {p}" for j, p in enumerate(parts)))


    def _coupled(self, axis: int) -> str:
        """`` + 1*q2`` terms of controller axis ``axis`` (0-based)."""
        if self.coupling is None:
            return ""
        return "".join(f" {'+' if c > 0 else '-'} {abs(c):g}*q{j + 1}"
                       for j, c in enumerate(self.coupling[axis]) if c)


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
    sign = np.asarray(section.sign, dtype=float)
    return AxisConvention(sign, offset, np.asarray(unit, dtype=float), True,
                          _coupling(section, joints, sign, where))


def _coupling(section: AxisConventionSection, joints: tuple[str, ...], sign: np.ndarray,
              where: Path) -> np.ndarray | None:
    """The coupling matrix of ``controller.axes.coupled`` (None without any), checked: axes and
    joints of this robot, no axis coupled to itself, the map invertible."""
    if not section.coupled:
        return None
    n = len(joints)
    c = np.zeros((n, n))
    for k, entry in enumerate(section.coupled):
        if entry.axis > n or entry.joint > n or entry.axis == entry.joint:
            raise InputError(f"{where}: controller.axes.coupled.{k}: axis {entry.axis} and joint "
                             f"{entry.joint} must be two different ones of this robot's {n} "
                             f"({', '.join(joints)})")
        c[entry.axis - 1, entry.joint - 1] += entry.factor
    if abs(np.linalg.det(np.diag(sign) + c)) < 1e-9:
        raise InputError(f"{where}: controller.axes.coupled: the controller's axes would not "
                         "determine the joints (the map is singular); check the factors")
    return c
