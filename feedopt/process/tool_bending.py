"""Tool and holder compliance in series with the robot's: the end mill as a stepped cantilever.

An end mill clamped in its holder is modelled as an Euler-Bernoulli cantilever, fixed at the
holder face (x = 0) and free at the tool tip (x = L, L = stickout). From the holder face:

* the shank, a solid cylinder of diameter d_s over L_s = L - L_f, then
* the fluted part at the tip, L_f = min(flute length, stickout), modelled as a solid cylinder
  of the equivalent diameter d_e = 0.8 D (:data:`EQUIVALENT_DIAMETER_RATIO`).

If the flute length exceeds the stickout, only flute sticks out (L_s = 0). The holder itself is
taken as rigid. All quantities are SI: m, N, Pa, m/N.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError

#: Equivalent (solid-cylinder) diameter of the fluted part over the cutting diameter, d_e / D.
#: Kops, L. & Vo, D. T. (1990), "Determination of the equivalent diameter of an end mill based
#: on its compliance", CIRP Annals 39(1), 59-62: d_e ~ 0.8 D for common two- to four-flute
#: end mills.
EQUIVALENT_DIAMETER_RATIO = 0.8

#: Young's modulus E [Pa] of tool materials. Handbook values, not fitted to any measurement:
#: "carbide" is cemented WC-Co with ~10 % Co (supplier/handbook range 550-650 GPa, as in the
#: Sandvik Coromant hard-material data and the ISO 513 grade families); "hss" is M2/M42
#: high-speed steel and "steel" a tool/holder steel (both ~210 GPa, steel handbook value).
YOUNGS_MODULUS_PA: dict[str, float] = {
    "carbide": 600e9,
    "hss": 210e9,
    "steel": 210e9,
}


def _area_m2(diameter_m: float) -> float:
    """Cross-section A = pi d^2 / 4 [m^2] of a solid cylinder."""
    return math.pi * diameter_m**2 / 4.0


def _second_moment_m4(diameter_m: float) -> float:
    """Second moment of area I = pi d^4 / 64 [m^4] of a solid cylinder."""
    return math.pi * diameter_m**4 / 64.0


@dataclass(frozen=True)
class ToolBeam:
    """An end mill in its holder, as a stepped cantilever (SI units).

    Attributes
    ----------
    diameter_m : cutting diameter D [m]; the flutes act as a cylinder of 0.8 D.
    flute_length_m : length of cut [m] (may exceed the stickout).
    stickout_m : length from the holder face to the tool tip L [m].
    shank_diameter_m : shank diameter d_s [m].
    youngs_modulus_pa : Young's modulus E [Pa] (e.g. ``YOUNGS_MODULUS_PA["carbide"]``).
    """

    diameter_m: float
    flute_length_m: float
    stickout_m: float
    shank_diameter_m: float
    youngs_modulus_pa: float

    def __post_init__(self) -> None:
        for name, hint in (("diameter_m", "the cutting diameter, e.g. 0.01 for 10 mm"),
                           ("flute_length_m", "the length of cut, e.g. 0.02 for 20 mm"),
                           ("stickout_m", "holder face to tip, e.g. 0.03 for 30 mm"),
                           ("shank_diameter_m", "e.g. 0.01 for a 10 mm shank"),
                           ("youngs_modulus_pa", "e.g. 600e9 for carbide, 210e9 for HSS")):
            value = getattr(self, name)
            ok = (isinstance(value, numbers.Real) and not isinstance(value, bool)
                  and math.isfinite(value) and value > 0)
            if not ok:
                raise InputError(f"ToolBeam.{name} must be a finite number > 0 ({hint}), "
                                 f"got {value!r}")

    @property
    def flute_out_m(self) -> float:
        """Fluted length outside the holder L_f = min(flute length, stickout) [m]."""
        return min(self.flute_length_m, self.stickout_m)

    @property
    def shank_out_m(self) -> float:
        """Shank length outside the holder L_s = L - L_f [m] (0 if the flutes reach it)."""
        return self.stickout_m - self.flute_out_m

    @property
    def equivalent_diameter_m(self) -> float:
        """Equivalent diameter of the fluted part d_e = 0.8 D [m] (Kops & Vo 1990)."""
        return EQUIVALENT_DIAMETER_RATIO * self.diameter_m


def tip_compliance_m_per_n(beam: ToolBeam) -> tuple[float, float]:
    """(lateral, axial) compliance [m/N] of the tool tip to a load at the tip.

    Lateral, by the moment-area theorem: a tip load P gives M(x) = P (L - x), and the tip
    deflection is the first moment of the M/(EI) diagram about the tip,
    delta = int_0^L M(x) (L - x) / (E I(x)) dx = (P/E) int_0^L u^2 / I du (u = L - x).
    The flutes occupy u in [0, L_f] and the shank u in [L_f, L], so

        delta / P = [L_f^3 / I_f + (L^3 - L_f^3) / I_s] / (3 E),   I = pi d^4 / 64,

    which for a uniform beam is the textbook L^3 / (3 E I). Axial (bars in series):

        delta / P = L_f / (E A_f) + L_s / (E A_s),   A = pi d^2 / 4.

    Shear deformation is neglected (Euler-Bernoulli), the holder is rigid.
    """
    e = beam.youngs_modulus_pa
    length, lf, ls = beam.stickout_m, beam.flute_out_m, beam.shank_out_m
    i_f = _second_moment_m4(beam.equivalent_diameter_m)
    i_s = _second_moment_m4(beam.shank_diameter_m)
    lateral = (lf**3 / i_f + (length**3 - lf**3) / i_s) / (3.0 * e)
    axial = (lf / _area_m2(beam.equivalent_diameter_m)
             + ls / _area_m2(beam.shank_diameter_m)) / e
    return lateral, axial


def compliance_matrices(lateral: float | np.ndarray, axial: float | np.ndarray,
                        tool_axes: np.ndarray) -> np.ndarray:
    """Tool compliance matrices C = c_lat (I - a a^T) + c_ax a a^T [m/N], shape (n, 3, 3).

    ``lateral`` and ``axial`` [m/N] are scalars or shape (n,); ``tool_axes`` (n, 3) are the
    tool axes in the frame of the result, normalised here (any length > 0). C a = c_ax a and
    C u = c_lat u for u perpendicular to a.
    """
    axes = np.asarray(tool_axes, dtype=float)
    if axes.ndim != 2 or axes.shape[1] != 3:
        raise ValueError(f"tool_axes must have shape (n, 3), got {axes.shape}")
    n = axes.shape[0]
    lat = np.broadcast_to(np.asarray(lateral, dtype=float), (n,))
    ax = np.broadcast_to(np.asarray(axial, dtype=float), (n,))
    for name, values in (("lateral", lat), ("axial", ax)):
        bad = np.flatnonzero(~(np.isfinite(values) & (values >= 0)))
        if bad.size:
            raise InputError(f"tool {name} compliance must be finite and >= 0 m/N, got "
                             f"{values[bad[0]]!r} at sample {bad[0]}")
    norms = np.linalg.norm(axes, axis=1)
    bad = np.flatnonzero(~(np.isfinite(norms) & (norms > 0)))
    if bad.size:
        raise InputError(f"tool axis at sample {bad[0]} must be a finite non-zero vector, got "
                         f"{axes[bad[0]].tolist()}")
    a = axes / norms[:, None]
    outer = a[:, :, None] * a[:, None, :]
    return lat[:, None, None] * (np.eye(3) - outer) + ax[:, None, None] * outer


def tool_share(robot_compliance: np.ndarray, tool_compliance: np.ndarray,
               forces: np.ndarray) -> np.ndarray:
    """Per-sample tool share of the tip deflection, |C_tool F| / |(C_robot + C_tool) F|.

    Compliances [m/N] shape (n, 3, 3) in one frame, forces [N] shape (n, 3). The springs are in
    series (same force, deflections add). NaN where the total deflection is zero.
    """
    robot = np.asarray(robot_compliance, dtype=float)
    tool = np.asarray(tool_compliance, dtype=float)
    f = np.asarray(forces, dtype=float)
    if robot.shape != tool.shape or robot.shape[1:] != (3, 3) or f.shape != robot.shape[:2]:
        raise ValueError(f"need compliances (n, 3, 3) and forces (n, 3), got {robot.shape}, "
                         f"{tool.shape} and {f.shape}")
    tool_deflection = np.linalg.norm(np.einsum("nij,nj->ni", tool, f), axis=1)
    total = np.linalg.norm(np.einsum("nij,nj->ni", robot + tool, f), axis=1)
    share = np.full(total.shape, np.nan)
    np.divide(tool_deflection, total, out=share, where=total > 0)
    return share
