"""Corner blends of linear interpolation with polynomial blends (LIPB), thesis 3.3 and B.1.

All functions are vectorised over the corners of a polyline (leading axis ``m``), the sizes
(radius, tolerance) may be one number or one per corner, and they work in 3D: every corner
lives in its own plane, spanned by the incoming direction ``d_in`` and the inward normal
``normal`` (the component of ``d_out`` perpendicular to ``d_in``, i.e. the side the path
turns to). Angles: ``turn`` is the turning angle gamma between the travel
directions; the corner (interior) angle of appendix B.1 is ``alpha = pi - gamma``.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np

from feedopt.geometry.corners import Corners as Corners
from feedopt.geometry.registry import get_blend


def corner_geometry(waypoints: np.ndarray) -> Corners:
    """Directions, turning angles and inward normals at every interior waypoint.

    ``waypoints`` is (n, 3) with no repeated consecutive points.
    """
    w = np.asarray(waypoints, dtype=float)
    v = np.diff(w, axis=0)
    lengths = np.linalg.norm(v, axis=1)
    d = v / lengths[:, None]
    d_in, d_out = d[:-1], d[1:]
    cos = np.einsum("ij,ij->i", d_in, d_out)
    perp = d_out - cos[:, None] * d_in
    sin = np.linalg.norm(perp, axis=1)
    turn = np.arctan2(sin, cos)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = np.where(sin[:, None] > 0, perp / sin[:, None], 0.0)
    return Corners(
        point=w[1:-1],
        d_in=d_in,
        d_out=d_out,
        turn=turn,
        normal=normal,
        len_in=lengths[:-1],
        len_out=lengths[1:],
    )


def tangent_distance(kind: str, turn: np.ndarray, size: float) -> np.ndarray:
    """Distance from the corner to where a blend of ``kind`` meets each line [m].

    Dispatches to the kind's ``tangent_distance`` in the registry
    (:func:`radius_tangent_distance`, :func:`tolerance_tangent_distance` for the built-in
    kinds); ``"none"``: 0.
    """
    blend = get_blend(kind)
    if blend is None:
        return np.zeros_like(np.asarray(turn, dtype=float))
    return blend.tangent_distance(turn, size)


def largest_fitting_size(kind: str, turn: np.ndarray, room: np.ndarray) -> np.ndarray:
    """Largest size of a ``kind`` blend whose tangent distance is at most ``room`` [m]
    (inverse of :func:`tangent_distance`; ``"none"``: any size, inf)."""
    blend = get_blend(kind)
    if blend is None:
        return np.full_like(np.asarray(room, dtype=float), np.inf)
    return blend.largest_size(turn, room)


def radius_tangent_distance(turn: np.ndarray, r: float | np.ndarray) -> np.ndarray:
    """``l_s = r / |tan(alpha/2)| = r tan(gamma/2)`` of a blend of radius ``r`` (one, or one
    per corner) tangent to both lines (appendix B.1; circle and varying_radius)."""
    turn = np.asarray(turn, dtype=float)
    return np.asarray(r, dtype=float) * np.tan(0.5 * turn)


def radius_fitting(turn: np.ndarray, room: np.ndarray) -> np.ndarray:
    """Largest radius whose tangent distance r tan(gamma/2) is at most ``room`` [m]."""
    with np.errstate(divide="ignore"):
        return room / np.tan(0.5 * np.asarray(turn, dtype=float))


def tolerance_tangent_distance(turn: np.ndarray, delta: float | np.ndarray) -> np.ndarray:
    """The tolerance delta itself (one, or one per corner): the blend starts where the sphere
    of radius delta about q_k meets the lines (Eq. 3.1 and 3.5; bezier4, bezier5)."""
    turn = np.asarray(turn, dtype=float)
    return np.broadcast_to(np.asarray(delta, dtype=float), turn.shape).copy()


def tolerance_fitting(turn: np.ndarray, room: np.ndarray) -> np.ndarray:
    """Largest tolerance that fits: ``room`` itself."""
    return np.asarray(room, dtype=float)


@dataclass(frozen=True)
class CircleBlend:
    """Circular arcs tangent to both lines (appendix B.1, generalised to 3D).

    p(phi) = centre + r (cos(phi) e1 + sin(phi) e2), 0 <= phi <= angle, with
    e1 = -normal (centre -> first tangent point) and e2 = d_in, so dp/dphi(0) = r d_in.
    """

    centre: np.ndarray  # (m, 3)
    e1: np.ndarray  # (m, 3)
    e2: np.ndarray  # (m, 3)
    radius: np.ndarray  # (m,)
    angle: np.ndarray  # (m,) swept angle = turning angle gamma
    start: np.ndarray  # (m, 3) tangent point P_t1 on the incoming line
    end: np.ndarray  # (m, 3) tangent point P_t2 on the outgoing line


def _per_corner(size: float | np.ndarray, m: int) -> np.ndarray:
    """A size given once or per corner as an (m,) array."""
    return np.broadcast_to(np.asarray(size, dtype=float), (m,)).copy()


def circle_blend(c: Corners, r: float | np.ndarray) -> CircleBlend:
    """Circle of radius ``r`` (one, or one per corner) tangent to both lines of every corner
    (appendix B.1).

    Tangent points ``P_t = q_k -/+ l_s d`` with ``l_s = r tan(gamma/2)``; the centre is
    ``P_t1 + r n`` with ``n`` the inward normal from the corner's own plane (the thesis took
    the perpendicular of a concave-down 2D corner; this works for any orientation).
    """
    r = _per_corner(r, len(c.turn))
    ls = radius_tangent_distance(c.turn, r)
    start = c.point - ls[:, None] * c.d_in
    end = c.point + ls[:, None] * c.d_out
    centre = start + r[:, None] * c.normal
    return CircleBlend(
        centre=centre,
        e1=-c.normal,
        e2=c.d_in.copy(),
        radius=r,
        angle=c.turn.copy(),
        start=start,
        end=end,
    )


# --- Bezier blends (Eq. 3.1-3.8) ------------------------------------------------------------


def bezier_alpha(p0: np.ndarray, p_end: np.ndarray, t0: np.ndarray, t_end: np.ndarray,
                 order: int) -> np.ndarray:
    """Largest root alpha_k of the quadratic of Eq. 3.3 (order 4) or Eq. 3.7 (order 5)."""
    tsum = t0 + t_end
    chord = p_end - p0
    ts2 = np.einsum("ij,ij->i", tsum, tsum)
    ct = np.einsum("ij,ij->i", chord, tsum)
    cc = np.einsum("ij,ij->i", chord, chord)
    if order == 4:
        a, b, c = 4.0 - 0.25 * ts2, 3.0 * ct, -9.0 * cc
    elif order == 5:
        a, b, c = 256.0 - 49.0 * ts2, 420.0 * ct, -900.0 * cc
    else:  # pragma: no cover - internal misuse
        raise ValueError(f"Bezier order must be 4 or 5, got {order}")
    # a > 0 and c <= 0, so the roots are real; the largest is (-b + sqrt(b^2 - 4ac)) / 2a,
    # written in the cancellation-free form 2c / (-b - sqrt(...)) when b > 0.
    disc = np.sqrt(b * b - 4.0 * a * c)
    with np.errstate(divide="ignore", invalid="ignore"):
        stable = np.where(b > 0, (2.0 * c) / (-b - disc), (-b + disc) / (2.0 * a))
    return stable


def bezier_control_points(c: Corners, delta: float | np.ndarray, order: int
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Control points (m, order+1, 3) and alpha (m,) of the Bezier blends of tolerance
    ``delta`` (one, or one per corner).

    q' = q_k - delta d_in, q'' = q_k + delta d_out (sphere of radius delta about q_k meets
    the lines), unit tangents t_0 = (q_k - q')/delta, t_end = (q'' - q_k)/delta
    (Eq. 3.1, 3.5); control points by Eq. 3.4 (order 4) or Eq. 3.8 (order 5).
    """
    q = c.point
    delta = _per_corner(delta, len(c.turn))[:, None]
    qa = q - delta * c.d_in
    qb = q + delta * c.d_out
    t0 = (q - qa) / delta
    t1 = (qb - q) / delta
    alpha = bezier_alpha(qa, qb, t0, t1, order)
    al = alpha[:, None]
    if order == 4:
        pts = [qa, qa + 0.25 * al * t0, q, qb - 0.25 * al * t1, qb]  # Eq. 3.4
    else:
        p1 = qa + al / 5.0 * t0
        p4 = qb - al / 5.0 * t1
        pts = [qa, p1, 2.0 * p1 - qa, 2.0 * p4 - qb, p4, qb]  # Eq. 3.8
    return np.stack(pts, axis=1), alpha


def bezier_power_coefficients(control: np.ndarray) -> np.ndarray:
    """Power-basis coefficients a_i (Eq. 3.4 / 3.8 right-hand sides) of Bezier curves.

    ``control`` is (m, d+1, 3); returns (m, d+1, 3) with b(u) = sum_i a_i u^i.
    """
    d = control.shape[1] - 1
    mat = np.zeros((d + 1, d + 1))
    for i in range(d + 1):
        for j in range(i + 1):
            mat[i, j] = comb(d, i) * comb(i, j) * (-1) ** (i - j)
    return np.einsum("ij,mjk->mik", mat, control)


# --- Varying-radius blend (Eq. 3.13-3.17) ---------------------------------------------------


def varying_radius(theta: np.ndarray, r0: np.ndarray, theta_f: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """r(theta) of Eq. 3.17 and its first three theta-derivatives.

    r = A theta^2 (theta - theta_f)^2 + r0 with A = r0 / (2 theta_f^2) (Eq. 3.16 at
    a_r = 0), so r(0) = r(theta_f) = r0, r'(0) = r'(theta_f) = 0 and r''(0) = r''(theta_f) = r0,
    i.e. zero radial acceleration r'' - r at both ends (Eq. 3.12).
    """
    th = np.asarray(theta, dtype=float)
    tf = np.asarray(theta_f, dtype=float)
    a = np.asarray(r0, dtype=float) / (2.0 * tf * tf)
    x = th * (th - tf)  # theta (theta - theta_f)
    r = a * x * x + r0
    dr = a * 2.0 * x * (2.0 * th - tf)
    d2r = a * (12.0 * th * th - 12.0 * th * tf + 2.0 * tf * tf)
    d3r = a * (24.0 * th - 12.0 * tf)
    return r, dr, d2r, d3r
