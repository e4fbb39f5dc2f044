"""Closed-form average milling forces per revolution (Altintas [39]; thesis Eq. 3.24-3.25).

Averaging the slice forces of :mod:`feedopt.process.forces` over one revolution gives, for
N teeth, axial depth a, feed per tooth c and any entry/exit angles (the helix does not change
the average)::

    Fx = N a / (2 pi) [ c/4 (Ktc cos 2phi - Krc (2phi - sin 2phi)) - Kte sin phi + Kre cos phi ]
    Fy = N a / (2 pi) [ c/4 (Ktc (2phi - sin 2phi) + Krc cos 2phi) - Kte cos phi - Kre sin phi ]
    Fz = N a / (2 pi) [ -Kac c cos phi + Kae phi ]

each evaluated between phi_st and phi_ex. For a slot (0..pi) they reduce to
Fx = -N a Krc c / 4 - N a Kre / pi, Fy = N a Ktc c / 4 + N a Kte / pi,
Fz = N a Kac c / pi + N a Kae / 2, which inverted are thesis Eq. 3.25.
"""

from __future__ import annotations

import math

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.engagement import Engagement
from feedopt.process.forces import flat_side_scale
from feedopt.process.general_forces import (
    AVERAGE_SLICES,
    general_average,
    slice_average,
    slice_engagement,
)
from feedopt.process.tool import Tool

#: slice-intervals per block of the leaning general cutter's revolution means
AVERAGE_BLOCK = 1 << 16


def _antiderivative(phi: np.ndarray, k: CuttingCoefficients, c: np.ndarray) -> np.ndarray:
    s, co = np.sin(phi), np.cos(phi)
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    fx = c / 4 * (k.ktc * c2 - k.krc * (2 * phi - s2)) - k.kte * s + k.kre * co
    fy = c / 4 * (k.ktc * (2 * phi - s2) + k.krc * c2) - k.kte * co - k.kre * s
    fz = -k.kac * c * co + k.kae * phi
    return np.stack(np.broadcast_arrays(fx, fy, fz), axis=-1)


def average_forces(
    tool: Tool,
    coeffs: CuttingCoefficients,
    entry: float | np.ndarray,
    exit: float | np.ndarray,
    axial_depth: float | np.ndarray,
    feed_per_tooth: float | np.ndarray,
) -> np.ndarray:
    """Mean force on the tool over one revolution [N], shape ``broadcast(...) + (3,)``.

    Closed form of Altintas [39] (module docstring), x feed, y normal, z axial; inputs
    broadcast against each other. ``exit <= entry`` gives zero force.
    """
    if not tool.is_flat:  # ball, bull, tapered, face: per slice of the profile
        return general_average(tool, coeffs, (entry, exit, axial_depth), feed_per_tooth)
    st = np.asarray(entry, dtype=float)
    ex = np.asarray(exit, dtype=float)
    a = np.asarray(axial_depth, dtype=float)
    c = np.asarray(feed_per_tooth, dtype=float)
    ex = np.maximum(ex, st)
    diff = _antiderivative(ex, coeffs, c) - _antiderivative(st, coeffs, c)
    scale = tool.teeth * a / (2.0 * math.pi)
    return np.asarray(scale)[..., None] * diff


def side_average(tool: Tool, coeffs: CuttingCoefficients, engagement: Engagement
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Mean cutting force per unit feed per tooth [N/m] and edge force [N] of the side edges
    over one revolution, each (n, 3), tool frame (the plunge column ignored): the closed
    forms of :func:`average_forces` summed over a sample's pieces. A feed leaning along the
    tool axis (``engagement.feed_axial``): a flat end mill's cutting part scaled by
    :func:`~feedopt.process.forces.flat_side_scale`, a general cutter's exact mean of its
    tilted slices (:func:`~feedopt.process.general_forces.slice_average`), as is an
    engagement given by slice (any cutter)."""
    lean = engagement.feed_axial
    if engagement.by_slice is not None or (lean is not None and not tool.is_flat):
        out = np.empty((engagement.n, 8))
        rows = max(1, AVERAGE_BLOCK // AVERAGE_SLICES)  # bounded memory: (rows, L, W, 5)
        for start in range(0, engagement.n, rows):
            sl = slice(start, min(start + rows, engagement.n))
            out[sl] = slice_average(tool, coeffs, slice_engagement(tool, engagement.take(sl),
                                                                   AVERAGE_SLICES))
        return out[:, 0:3], out[:, 4:7]
    hull = engagement.hull_only()
    edge = average_forces(tool, coeffs, hull.entry, hull.exit, hull.axial_depth, 0.0)
    cut = average_forces(tool, coeffs, hull.entry, hull.exit, hull.axial_depth, 1.0) - edge
    if engagement.pieces is not None:
        p = engagement.pieces
        pe = average_forces(tool, coeffs, p.entry, p.exit, p.axial_depth, 0.0)
        pc = average_forces(tool, coeffs, p.entry, p.exit, p.axial_depth, 1.0) - pe
        np.add.at(edge, p.sample, pe)
        np.add.at(cut, p.sample, pc)
    if lean is not None:
        cut = cut * flat_side_scale(lean)[:, None]
    return cut, edge


def average_torque(
    tool: Tool,
    coeffs: CuttingCoefficients,
    entry: float | np.ndarray,
    exit: float | np.ndarray,
    axial_depth: float | np.ndarray,
    feed_per_tooth: float | np.ndarray,
) -> np.ndarray:
    """Mean spindle torque D/2 Ft over one revolution [N m]:
    N a D / (4 pi) [ -Ktc c cos phi + Kte phi ] from phi_st to phi_ex (a flat end mill;
    InputError for another shape: its torque is r(z) dFt, from the force model)."""
    if not tool.is_flat:
        raise InputError(f"average_torque: the closed form is a flat end mill's, not a "
                         f"{tool.shape.value}'s: use feedopt.process.forces")
    st = np.asarray(entry, dtype=float)
    ex = np.maximum(np.asarray(exit, dtype=float), st)
    c = np.asarray(feed_per_tooth, dtype=float)
    a = np.asarray(axial_depth, dtype=float)

    def prim(p: np.ndarray) -> np.ndarray:
        return -coeffs.ktc * c * np.cos(p) + coeffs.kte * p

    return tool.teeth * a * tool.diameter / (4.0 * math.pi) * (prim(ex) - prim(st))
