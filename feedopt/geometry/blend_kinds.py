"""The built-in corner blends and their registry entries (thesis 3.3, appendix B.1).

Each kind is a builder (corners -> segment parameters, vectorised over corners, using the
corner geometry of :mod:`feedopt.geometry.blends`) and an evaluator (all segments of the kind
in a path -> position, tangent, curvature vector and its derivative by arc length):

- ``circle``: arcs tangent to both lines (appendix B.1), evaluated in closed form; G1.
- ``bezier4`` / ``bezier5``: Bezier curves of Eq. 3.1-3.4 / 3.5-3.8; G2.
- ``varying_radius``: the polar curve r(theta) of Eq. 3.13-3.17 about the circle's centre; G2.

The parametric kinds (Bezier, varying radius) are evaluated by arc length through the
numerical s(t) table of :mod:`feedopt.geometry.arclength` (Eq. 3.23):
:class:`ParametricEvaluator` is the common part, for new parametric kinds too.
Importing this module registers the four kinds (``feedopt.geometry`` does it). Their
builders take one size or one size per corner (an (m,) array, :data:`ARRAY_SIZES`), so a
program's corners, each sized to its own tolerance, are built in one call.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from feedopt.geometry import arclength, blends
from feedopt.geometry.registry import RADIUS, TOLERANCE, BlendKind, BuiltBlends, register_blend

if TYPE_CHECKING:  # pragma: no cover
    from feedopt.geometry.segment import Segment

# bezier4 blends of corners turning more than pi - this [rad] are refused: alpha of Eq. 3.3
# tends to 0 while p_2 stays on the corner, so the speed nearly vanishes at both ends and
# mid-blend (curvature peak ~280/delta at this limit) and its arc length loses accuracy
BEZIER4_TURN_MARGIN = 0.1
#: the kinds whose ``build`` and ``tangent_distance`` accept one size per corner
ARRAY_SIZES = frozenset({"circle", "bezier4", "bezier5", "varying_radius"})


def _rows(segs: Sequence[Segment], key: str) -> np.ndarray:
    """(m, 3) array of the 3-vector parameter ``key`` of every segment."""
    return np.array([g.params[key] for g in segs]).reshape(-1, 3)


def _scalars(segs: Sequence[Segment], key: str) -> np.ndarray:
    return np.array([g.params[key] for g in segs], dtype=float)


class CircleEvaluator:
    """Circular arcs p(phi) = centre + r (cos phi e1 + sin phi e2), phi = s / r
    (appendix B.1): unit tangent, curvature -e_r / r and its derivative in closed form."""

    def __init__(self, segs: Sequence[Segment]):
        self.centre, self.e1, self.e2 = (_rows(segs, k) for k in ("centre", "e1", "e2"))
        self.radius = _scalars(segs, "radius")

    def eval(self, j, sl):
        r = self.radius[j]
        phi = sl / r
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        e1, e2 = self.e1[j], self.e2[j]
        er = c * e1 + s * e2
        et = -s * e1 + c * e2
        return (self.centre[j] + r[:, None] * er, et, -er / r[:, None],
                -et / (r * r)[:, None])


class ParametricEvaluator:
    """Common part of parametric blends p(t), t in [0, t_end]: evaluation by arc length.

    Subclasses set their coefficients, then call ``super().__init__(segs)`` (which reads the
    arc-length table ``s_nodes``, ``sigma_nodes`` from the segments' params), and define
    ``t_end()`` (m,), ``speed(j, t)`` = |dp/dt| (``j`` broadcastable against ``t``) and
    ``derivs(j, t)`` = p, p', p'', p''' (n, 3) each. :meth:`eval` inverts s(t) (Eq. 3.23) and
    applies the chain rule (:func:`~feedopt.geometry.arclength.arc_length_derivatives`).
    """

    def __init__(self, segs: Sequence[Segment]):
        self.table = arclength.ArcLengthTable(
            t_end=self.t_end(),
            s_nodes=np.array([g.params["s_nodes"] for g in segs]),
            sigma_nodes=np.array([g.params["sigma_nodes"] for g in segs]),
        )

    def t_end(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def speed(self, j, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def derivs(self, j, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def tabulate(self) -> arclength.ArcLengthTable:
        """The s(t) table of these curves (Eq. 3.23), for the builders."""
        return arclength.build_table(self.speed, self.t_end())

    def eval(self, j, sl):
        t = arclength.invert(self.speed, self.table, j, sl)
        p, d1, d2, d3 = self.derivs(j, t)
        return (p, *arclength.arc_length_derivatives(d1, d2, d3))


class BezierEvaluator(ParametricEvaluator):
    """Bezier curves of any degree d in the power basis b(u) = sum_i a_i u^i (Eq. 3.4 / 3.8),
    u in [0, 1], from the segments' ``control`` (d+1, 3) or from ``control`` (m, d+1, 3)."""

    def __init__(self, segs: Sequence[Segment] | None = None,
                 control: np.ndarray | None = None):
        if control is None:
            control = np.array([g.params["control"] for g in segs])
        self.a = blends.bezier_power_coefficients(control)  # (m, d+1, 3)
        deg = self.a.shape[1] - 1
        self.da = self.a[:, 1:] * np.arange(1, deg + 1)[None, :, None]  # p' coefficients
        # |p'(u)|^2 as a scalar polynomial of degree 2(d-1)
        q = np.zeros((self.a.shape[0], 2 * deg - 1))
        for i in range(deg):
            for k in range(deg):
                q[:, i + k] += np.einsum("mj,mj->m", self.da[:, i], self.da[:, k])
        self.q = q
        if segs is not None:
            super().__init__(segs)

    def t_end(self):
        return np.ones(self.a.shape[0])

    def speed(self, j, t):
        """|p'(u)| = sqrt of the scalar polynomial q; ``j`` broadcastable against ``u``."""
        j, t = np.asarray(j), np.asarray(t)
        if j.ndim == t.ndim and j.ndim > 0 and j.shape[-1] == 1:
            # one curve per row (the usual call): gather its coefficients once
            coef = np.moveaxis(self.q[j[..., 0]], -1, 0)[..., None]
        else:
            coef = np.moveaxis(self.q[j], -1, 0)
        acc = coef[-1] * t  # Horner, in place
        for i in range(coef.shape[0] - 2, 0, -1):
            acc += coef[i]
            acc *= t
        acc += coef[0]
        np.maximum(acc, 0.0, out=acc)
        return np.sqrt(acc, out=acc)

    def derivs(self, j, u):
        """Position and 3 u-derivatives: basis rows (n, d+1) times the gathered coefficients."""
        a = self.a[j]  # (n, d+1, 3)
        d = a.shape[1] - 1
        pw = u[:, None] ** np.arange(d + 1)  # u^0 .. u^d
        i = np.arange(d + 1)
        out = []
        for k in range(4):
            fac = np.ones(d + 1)
            for m in range(k):
                fac *= np.maximum(i - m, 0)  # i (i-1) ... (i-k+1)
            basis = np.zeros_like(pw)
            basis[:, k:] = pw[:, : d + 1 - k] * fac[k:]
            out.append(np.einsum("ni,nij->nj", basis, a))
        return tuple(out)


class VaryingRadiusEvaluator(ParametricEvaluator):
    """p(theta) = centre + r(theta) (cos theta e1 + sin theta e2), theta in [0, theta_f],
    r of Eq. 3.17 (:func:`~feedopt.geometry.blends.varying_radius`), from the segments' params
    or from the arrays (m, 3) ``centre``, ``e1``, ``e2`` and (m,) ``radius`` (r0), ``angle``
    (theta_f)."""

    def __init__(self, segs: Sequence[Segment] | None = None, *, centre=None, e1=None,
                 e2=None, radius=None, angle=None):
        if segs is not None:
            centre, e1, e2 = (_rows(segs, k) for k in ("centre", "e1", "e2"))
            radius, angle = _scalars(segs, "radius"), _scalars(segs, "angle")
        self.centre, self.e1, self.e2 = centre, e1, e2
        self.r0, self.tf = np.asarray(radius, float), np.asarray(angle, float)
        if segs is not None:
            super().__init__(segs)

    def t_end(self):
        return self.tf

    def speed(self, j, t):
        r, dr, _, _ = blends.varying_radius(t, self.r0[j], self.tf[j])
        return np.sqrt(r * r + dr * dr)

    def derivs(self, j, th):
        """Derivatives of the polar curve of Eq. 3.13-3.17 (e_r, e_t radial and tangential
        unit vectors): p' = r' e_r + r e_t, p'' = (r'' - r) e_r + 2 r' e_t,
        p''' = (r''' - 3 r') e_r + (3 r'' - r) e_t."""
        r, r1, r2, r3 = blends.varying_radius(th, self.r0[j], self.tf[j])
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        e1, e2 = self.e1[j], self.e2[j]
        er = c * e1 + s * e2
        et = -s * e1 + c * e2
        r, r1, r2, r3 = (x[:, None] for x in (r, r1, r2, r3))
        p = self.centre[j] + r * er
        d1 = r1 * er + r * et
        d2 = (r2 - r) * er + 2.0 * r1 * et
        d3 = (r3 - 3.0 * r1) * er + (3.0 * r2 - r) * et
        return p, d1, d2, d3


def tabulated(params: dict[str, np.ndarray], ev: ParametricEvaluator) -> BuiltBlends:
    """``params`` plus the s(t) table of ``ev``'s curves (Eq. 3.23), lengths from the table."""
    table = ev.tabulate()
    return BuiltBlends({**params, "s_nodes": table.s_nodes, "sigma_nodes": table.sigma_nodes},
                       table.length)


def _circle_params(cb: blends.CircleBlend) -> dict[str, np.ndarray]:
    return {"centre": cb.centre, "e1": cb.e1, "e2": cb.e2, "radius": cb.radius,
            "angle": cb.angle}


def build_circle(c: blends.Corners, r: float | np.ndarray) -> BuiltBlends:
    """Arcs of radius ``r`` (appendix B.1, :func:`~feedopt.geometry.blends.circle_blend`);
    length r gamma."""
    cb = blends.circle_blend(c, r)
    return BuiltBlends(_circle_params(cb), cb.radius * cb.angle)


def _build_bezier(c: blends.Corners, delta: float | np.ndarray, order: int) -> BuiltBlends:
    control, alpha = blends.bezier_control_points(c, delta, order)
    return tabulated({"control": control, "alpha": alpha}, BezierEvaluator(control=control))


def build_bezier4(c: blends.Corners, delta: float | np.ndarray) -> BuiltBlends:
    """4th-order Bezier blends of tolerance ``delta`` (Eq. 3.1-3.4)."""
    return _build_bezier(c, delta, 4)


def build_bezier5(c: blends.Corners, delta: float | np.ndarray) -> BuiltBlends:
    """5th-order Bezier blends of tolerance ``delta`` (Eq. 3.5-3.8)."""
    return _build_bezier(c, delta, 5)


def build_varying_radius(c: blends.Corners, r0: float | np.ndarray) -> BuiltBlends:
    """Varying-radius blends (Eq. 3.13-3.17) on the circle blend's geometry: r(0) =
    r(theta_f) = r0 about the circle's centre, theta_f = the turning angle."""
    cb = blends.circle_blend(c, r0)
    ev = VaryingRadiusEvaluator(centre=cb.centre, e1=cb.e1, e2=cb.e2, radius=cb.radius,
                                angle=cb.angle)
    return tabulated(_circle_params(cb), ev)


CIRCLE = register_blend(BlendKind(
    name="circle", size=RADIUS, tangent_distance=blends.radius_tangent_distance,
    largest_size=blends.radius_fitting, build=build_circle, evaluator=CircleEvaluator,
    colour="tab:red", description="circular arc (appendix B.1): G1, curvature jumps 0 -> 1/r"))
BEZIER4 = register_blend(BlendKind(
    name="bezier4", size=TOLERANCE, tangent_distance=blends.tolerance_tangent_distance,
    largest_size=blends.tolerance_fitting, build=build_bezier4, evaluator=BezierEvaluator,
    colour="tab:orange", max_turn=np.pi - BEZIER4_TURN_MARGIN,
    max_turn_reason="Eq. 3.3 gives an almost zero alpha there (a near-cusp)",
    description="4th-order Bezier (Eq. 3.1-3.4): G2"))
BEZIER5 = register_blend(BlendKind(
    name="bezier5", size=TOLERANCE, tangent_distance=blends.tolerance_tangent_distance,
    largest_size=blends.tolerance_fitting, build=build_bezier5, evaluator=BezierEvaluator,
    colour="tab:green", description="5th-order Bezier (Eq. 3.5-3.8): G2"))
VARYING_RADIUS = register_blend(BlendKind(
    name="varying_radius", size=RADIUS, tangent_distance=blends.radius_tangent_distance,
    largest_size=blends.radius_fitting, build=build_varying_radius,
    evaluator=VaryingRadiusEvaluator, colour="tab:blue",
    description="the thesis's varying-radius curve (Eq. 3.13-3.17): G2"))
