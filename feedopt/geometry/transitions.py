"""G2 transitions: quintic curves that join two path pieces with equal position, tangent
and curvature vector at both ends.

Where two pieces of a programmed path meet with a curvature jump (line-arc, arc-arc, the ends
of a circular corner blend) or a kink next to an arc, the last ``a`` of the first piece and
the first ``b`` of the second are replaced by the quintic Hermite curve q(u), u in [0, 1],
with q(0) = p0, q'(0) = l T0, q''(0) = l^2 K0 and q(1) = p1, q'(1) = l T1, q''(1) = l^2 K1
(T unit tangents, K curvature vectors d2p/ds2, l = |p1 - p0|): its curvature vector
(q'' - (q''.T)T) / |q'|^2 equals K at both ends, so the joins are G2. This is the quintic G2
interpolant of Erkorkmaz and Altintas (2001, "High speed CNC system design. Part I: jerk
limited trajectory generation and quintic spline interpolation", Int. J. Mach. Tools Manuf.
41) between two given curve points; with straight neighbours (K = 0) it is the thesis's
5th-order Bezier blend (Eq. 3.5-3.8 put P2 = 2 P1 - P0, i.e. zero end curvature). It is held
in Bezier form (P1 = P0 + q'(0)/5, P2 = P0 + 2 q'(0)/5 + q''(0)/20, symmetrically at the end)
and evaluated by arc length like the Bezier blends (Eq. 3.23).
"""

from __future__ import annotations

import numpy as np

from feedopt.geometry.blend_kinds import BezierEvaluator, tabulated
from feedopt.geometry.registry import BuiltBlends, SegmentKind, register_segment_kind

TRANSITION = "transition"


def hermite_control(p0: np.ndarray, t0: np.ndarray, k0: np.ndarray, p1: np.ndarray,
                    t1: np.ndarray, k1: np.ndarray) -> np.ndarray:
    """Bezier control points (m, 6, 3) of the quintic G2 Hermite curves between the end
    states (p, T, K) of ``m`` pairs of pieces (all (m, 3), SI)."""
    scale = np.linalg.norm(p1 - p0, axis=1)[:, None]
    d0, d1 = scale * t0, scale * t1
    a0, a1 = scale**2 * k0, scale**2 * k1
    return np.stack([p0, p0 + d0 / 5.0, p0 + 0.4 * d0 + a0 / 20.0,
                     p1 - 0.4 * d1 + a1 / 20.0, p1 - d1 / 5.0, p1], axis=1)


def build_transitions(p0: np.ndarray, t0: np.ndarray, k0: np.ndarray, p1: np.ndarray,
                      t1: np.ndarray, k1: np.ndarray) -> BuiltBlends:
    """Segment parameters (``control`` and the arc-length table) and lengths [m] of the
    transitions between the given end states (vectorised over the leading axis)."""
    control = hermite_control(p0, t0, k0, p1, t1, k1)
    return tabulated({"control": control}, BezierEvaluator(control=control))


TRANSITION_KIND = register_segment_kind(SegmentKind(
    name=TRANSITION, evaluator=BezierEvaluator, colour="tab:pink",
    description="quintic G2 transition between pieces with a curvature jump"))
