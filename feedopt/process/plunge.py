"""Straight plunges: the end cutting edges of a centre-cutting flat end mill fed along its axis.

Model (mechanistic, as drilling and plunge milling: Altintas, *Manufacturing Automation*,
2nd ed., 2012, ch. 2, drilling mechanics; Altintas & Ko, "Chatter stability of plunge
milling", CIRP Annals 55(1), 2006): a tool with N end edges, each running radially from the
centre r = 0 to the rim r = R = D / 2, fed along its axis by c per tooth
(c = path feed / (N rpm / 60), the feed being along the tool axis). Every edge element dr
cuts a chip c thick (along the axis) and dr wide; the thrust (along the axis) and the
tangential (cutting) force on it are linear in c::

    dF_thrust = (K_tc c + K_te) dr          dF_tan = (K_cc c + K_ce) dr
    dT = r dF_tan                            (spindle torque of the element)

Per tooth, over its engaged length b (b = R for a full plunge; r from 0 to R)::

    F_thrust = int_0^R (K_tc c + K_te) dr     = (K_tc c + K_te) R
    F_tan    = int_0^R (K_cc c + K_ce) dr     = (K_cc c + K_ce) R
    T        = int_0^R r (K_cc c + K_ce) dr   = (K_cc c + K_ce) R^2 / 2  (= F_tan r_mean)

and for the N teeth, ``F_z = N (K_tc c + K_te) R`` and ``T = N (K_cc c + K_ce) R^2 / 2``.

Frame and signs (``shared/design.md``, :mod:`feedopt.process.forces`): forces act ON THE
TOOL in the force-model frame, z = tool axis pointing into the spindle. A plunge feeds the
tool along -z into the material, so the material pushes it back up: the thrust on the tool
is ``+z`` with positive coefficients (unlike the side-milling Kac, Kae, whose sign is a
convention). The torque is the spindle's cutting torque, > 0 like D/2 Ft of Algorithm 1.
Tooth k (k = 0 .. N-1) lies along the rotation angle ``psi_k = phi + k 2 pi / N`` of
:mod:`feedopt.process.forces` (its end edge is at the tip, where the helix lags nothing);
its tangential force on the tool points like the side-milling dFt there,
``F_tan (-cos psi_k, sin psi_k, 0)``. Summed over N >= 2 evenly spaced teeth these lateral
forces cancel exactly (``sum_k cos psi_k = sum_k sin psi_k = 0``): the plunge force is then
constant over the rotation. A single tooth (N = 1) leaves the rotating lateral force
``F_tan (-cos phi, sin phi)``, which is modelled here as well.

The end edges engage fully (``plunge = 1``) or not at all (``plunge = 0``): the footprint of
a plunge partly off the material, or into a pre-drilled hole, is not computed (its lateral
imbalance would need the engaged edge length per tooth and angle); it is taken as full,
which over-estimates the thrust and the torque.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass, fields

import numpy as np

from feedopt.errors import InputError
from feedopt.process.tool import Tool
from feedopt.units import MM

__all__ = [
    "PLUNGE_FILE_KEYS",
    "PLUNGE_SIGN_RULES",
    "PlungeCoefficients",
    "check_plunge_depth",
    "plunge_forces",
    "plunge_mean",
    "plunge_parts",
    "plunge_sign_problems",
]


@dataclass(frozen=True)
class PlungeCoefficients:
    """Plunge (end-edge) coefficients, SI: thrust and tangential (torque) cutting coefficients
    K_tc, K_cc [N/m^2] and edge coefficients K_te, K_ce [N/m] (module docstring)."""

    thrust_cutting: float
    thrust_edge: float
    torque_cutting: float
    torque_edge: float

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v):
                raise InputError(f"plunge coefficient {f.name} must be finite, got {v!r}")

    def as_array(self) -> np.ndarray:
        """The four values in field order."""
        return np.array(astuple(self), dtype=float)


#: Material-file key of each field and its scale to SI (N/mm^2 -> N/m^2, N/mm -> N/m).
PLUNGE_FILE_KEYS = {
    "thrust_cutting": ("thrust_cutting_n_mm2", 1e6),
    "thrust_edge": ("thrust_edge_n_mm", 1e3),
    "torque_cutting": ("torque_cutting_n_mm2", 1e6),
    "torque_edge": ("torque_edge_n_mm", 1e3),
}

#: Sign rule per field: (must be > 0 rather than >= 0, why).
PLUNGE_SIGN_RULES = {
    "thrust_cutting": (True, "the chip pushes the tool back along its axis"),
    "thrust_edge": (False, "0 means no thrust edge force"),
    "torque_cutting": (True, "the chip resists the rotation"),
    "torque_edge": (False, "0 means no tangential edge force"),
}


def plunge_sign_problems(coeffs: PlungeCoefficients) -> list[str]:
    """Fields that break :data:`PLUNGE_SIGN_RULES`, one phrase each in file units."""
    out = []
    for name, (strict, why) in PLUNGE_SIGN_RULES.items():
        key, scale = PLUNGE_FILE_KEYS[name]
        v = float(getattr(coeffs, name)) / scale
        if (v <= 0) if strict else (v < 0):
            unit = "N/mm^2" if key.endswith("mm2") else "N/mm"
            out.append(f"plunge.{key} = {v:.6g} {unit} (must be {'> 0' if strict else '>= 0'}: "
                       f"{why})")
    return out


def plunge_forces(tool: Tool, coeffs: PlungeCoefficients, feed_per_tooth: float,
                  angle: float = 0.0) -> tuple[np.ndarray, float]:
    """Force on the tool [N] (3,) (x, y, z of the force-model frame) and spindle torque [N m]
    of a full plunge at feed per tooth ``feed_per_tooth`` [m] with tooth 1 at ``angle`` [rad]:
    ``F_z = N (K_tc c + K_te) R``, ``T = N (K_cc c + K_ce) R^2 / 2`` (module docstring)."""
    cutting, edge, t_cut, t_edge = plunge_parts(tool, coeffs, np.ones(1), np.array([angle]))
    c = float(feed_per_tooth)
    force = c * cutting[0, 0] + edge[0, 0]
    return force, float(c * t_cut[0, 0] + t_edge[0, 0])


def _lateral_sums(teeth: int, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sum_k cos(psi_k) and sum_k sin(psi_k) over the teeth; exactly 0 for N >= 2."""
    if teeth >= 2:
        return np.zeros(angles.shape), np.zeros(angles.shape)
    return np.cos(angles), np.sin(angles)


def plunge_parts(tool: Tool, coeffs: PlungeCoefficients, plunge: np.ndarray,
                 angles: np.ndarray) -> tuple[np.ndarray, ...]:
    """The plunge's share of a force split at ``n`` samples and their rotation angles.

    ``plunge`` (n,) is 0 or 1 per sample; ``angles`` (m,) for every sample or (n, m).
    Returns ``(cutting (n, m, 3) [N/m], edge (n, m, 3) [N], cutting_torque (n, m) [N m/m],
    edge_torque (n, m) [N m])``, so that force = c * cutting + edge (as
    :class:`feedopt.process.forces.ForceSplit`).
    """
    p = np.asarray(plunge, dtype=float).reshape(-1)
    phi = np.asarray(angles, dtype=float)
    phi = np.broadcast_to(phi, (p.size, phi.shape[-1])) if phi.ndim == 1 else phi
    n_r = tool.teeth * tool.diameter / 2.0  # N R
    torque_arm = tool.diameter / 4.0  # R / 2: T = F_tan R / 2 per unit N R
    cos_sum, sin_sum = _lateral_sums(tool.teeth, phi)
    cos_sum, sin_sum = cos_sum * p[:, None], sin_sum * p[:, None]
    out = []
    for thrust, tangential in ((coeffs.thrust_cutting, coeffs.torque_cutting),
                               (coeffs.thrust_edge, coeffs.torque_edge)):
        per_tooth_tan = tangential * tool.diameter / 2.0  # F_tan of one tooth per unit (c or 1)
        force = np.empty(phi.shape + (3,))
        force[..., 0] = -per_tooth_tan * cos_sum
        force[..., 1] = per_tooth_tan * sin_sum
        force[..., 2] = (thrust * n_r) * p[:, None]
        out.append(force)
    torque = [np.broadcast_to((k * n_r * torque_arm) * p[:, None], phi.shape).copy()
              for k in (coeffs.torque_cutting, coeffs.torque_edge)]
    return out[0], out[1], torque[0], torque[1]


def plunge_mean(tool: Tool, coeffs: PlungeCoefficients, plunge: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Mean plunge force over a revolution, per unit feed per tooth and at zero feed, (n, 3)
    each: ``(0, 0, N K_tc R p)`` and ``(0, 0, N K_te R p)`` (the rotating lateral force of a
    single tooth averages to zero)."""
    p = np.asarray(plunge, dtype=float).reshape(-1)
    n_r = tool.teeth * tool.diameter / 2.0
    cut, edge = np.zeros((p.size, 3)), np.zeros((p.size, 3))
    cut[:, 2] = coeffs.thrust_cutting * n_r * p
    edge[:, 2] = coeffs.thrust_edge * n_r * p
    return cut, edge


def check_plunge_depth(deep: np.ndarray, move: np.ndarray, moves, tool: Tool, source: str,
                       below: np.ndarray | None = None) -> None:
    """InputError at the first sample of ``deep`` (a plunge reaching more than the flute
    length below the material top), naming the program line and the flute length;
    ``below`` (n,) the depth below the top [m] when it is known."""
    if not deep.any():
        return
    i = int(np.argmax(deep))
    how = ("more than the flute length" if below is None
           else f"{below[i] / MM:.4g} mm, more than the flute length")
    raise InputError(
        f"{source} {moves.label(int(move[i]))}: the plunge reaches {how} "
        f"{tool.flute_length / MM:g} mm of tool '{tool.name}' below the material top: the "
        "shank would rub; plunge in steps no deeper than the flutes (with the chips cleared) "
        "or use a longer tool")
