"""Programmed circular and helical arcs (G2/G3) as path segments, evaluated in closed form.

A helix about the axis ``normal`` through ``centre``:
p(phi) = centre + r (cos phi e1 + sin phi e2) + rise phi normal, 0 <= phi <= angle,
with e1 the unit vector from the centre to the start, e2 = +-(normal x e1) the direction of
travel at the start (G3: +, G2: -) and ``rise`` the advance along the normal per radian. Its
arc length is s = phi lam with lam = sqrt(r^2 + rise^2), so the tangent, curvature vector and
its derivative by arc length are closed-form (a flat arc is rise = 0).

:func:`arc_params` turns a :class:`~feedopt.gcode.moves.Move` into these parameters: the centre
is moved onto the perpendicular bisector of start and end (nearest to the programmed centre),
so the arc passes exactly through both programmed end points even when the program's start
and end radii differ within the reader's tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from feedopt.geometry.registry import SegmentKind, register_segment_kind
from feedopt.units import MM

if TYPE_CHECKING:  # pragma: no cover
    from feedopt.gcode.moves import Move
    from feedopt.geometry.path import Segment

ARC = "arc"


def arc_params(move: Move) -> tuple[dict[str, np.ndarray | float], float]:
    """Helix parameters [m] of an arc move and its arc length [m].

    Returns ``({"centre", "e1", "e2", "normal", "radius", "rise", "angle"}, length)``; the
    start is ``centre + radius e1``.
    """
    assert move.plane is not None and move.centre is not None
    u, v, n = move.plane.value
    s = np.asarray(move.start, dtype=float) * MM
    e = np.asarray(move.end, dtype=float) * MM
    c = np.asarray(move.centre, dtype=float) * MM
    normal = np.asarray(move.plane.normal, dtype=float)
    s2, e2_, c2 = s[[u, v]], e[[u, v]], c[[u, v]]
    chord = e2_ - s2
    chord_len = float(np.hypot(*chord))
    if chord_len > 1e-12:  # not a full circle: centre onto the bisector of start and end
        w = np.array([-chord[1], chord[0]]) / chord_len
        mid = 0.5 * (s2 + e2_)
        c2 = mid + float(np.dot(c2 - mid, w)) * w
    radial = s2 - c2
    r = float(np.hypot(*radial))
    a0 = math.atan2(radial[1], radial[0])
    a1 = math.atan2(e2_[1] - c2[1], e2_[0] - c2[0])
    if chord_len > 1e-12:
        angle = (move.direction * (a1 - a0)) % (2.0 * math.pi)
    else:
        angle = move.sweep_rad
    centre = s.copy()
    centre[u], centre[v] = c2
    e1 = np.zeros(3)
    e1[u], e1[v] = radial / r
    e2 = move.direction * np.cross(normal, e1)
    rise = float((e[n] - s[n]) / angle)
    length = angle * math.hypot(r, rise)
    return ({"centre": centre, "e1": e1, "e2": e2, "normal": normal, "radius": r,
             "rise": rise, "angle": angle}, length)


def trim_arc(params: dict, start: float, length: float) -> dict:
    """The part of an arc from arc length ``start`` over ``length`` [m], as arc params."""
    lam = math.hypot(params["radius"], params["rise"])
    phi0 = start / lam
    c, s = math.cos(phi0), math.sin(phi0)
    e1, e2 = params["e1"], params["e2"]
    return {**params, "centre": params["centre"] + params["rise"] * phi0 * params["normal"],
            "e1": c * e1 + s * e2, "e2": -s * e1 + c * e2, "angle": length / lam}


class ArcEvaluator:
    """Closed-form helices: with phi = s / lam, dp/ds = (r e_t + rise n) / lam,
    d2p/ds2 = -r e_r / lam^2, d3p/ds3 = -r e_t / lam^3 (e_r, e_t radial and tangential)."""

    def __init__(self, segs: Sequence[Segment]):
        rows = [g.params for g in segs]
        self.centre, self.e1, self.e2, self.normal = (
            np.array([p[k] for p in rows], dtype=float).reshape(-1, 3)
            for k in ("centre", "e1", "e2", "normal"))
        self.radius = np.array([p["radius"] for p in rows], dtype=float)
        self.rise = np.array([p["rise"] for p in rows], dtype=float)
        self.lam = np.hypot(self.radius, self.rise)

    def eval(self, j, sl):
        lam, r, h = self.lam[j], self.radius[j], self.rise[j]
        phi = sl / lam
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        e1, e2, n = self.e1[j], self.e2[j], self.normal[j]
        er = c * e1 + s * e2
        et = -s * e1 + c * e2
        r_, h_, lam_ = r[:, None], h[:, None], lam[:, None]
        pos = self.centre[j] + r_ * er + (h * phi)[:, None] * n
        tan = (r_ * et + h_ * n) / lam_
        curv = -r_ * er / lam_**2
        dcurv = -r_ * et / lam_**3
        return pos, tan, curv, dcurv


ARC_KIND = register_segment_kind(SegmentKind(
    name=ARC, evaluator=ArcEvaluator, colour="tab:brown",
    description="programmed circular or helical arc (G2/G3), closed form"))
