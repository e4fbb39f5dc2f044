"""Paths parameterised by arc length: lines and corner blends (thesis 3.3, appendix B.1).

A :class:`Path` is a sequence of :class:`Segment` (lines and blends) laid end to end in arc
length s [m]. :meth:`Path.evaluate` returns, for any array of s, the position, the unit
tangent dp/ds, the curvature vector d2p/ds2 and its derivative d3p/ds3, vectorised: samples are
grouped by segment kind and each kind is evaluated on its whole array at once.

Parametric blends (Bezier, varying radius) are evaluated by arc length through a numerical
s(t) table and its inverse t(s) (:mod:`feedopt.geometry.arclength`, thesis Eq. 3.23); the
derivatives w.r.t. s follow from those w.r.t. t by the chain rule (:func:`arc_length_derivatives`).

:func:`build_lipb_path` builds the linear-interpolation-with-polynomial-blends path from
waypoints with one blend per interior corner (circle, bezier4, bezier5, varying_radius or none).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from feedopt.errors import InputError
from feedopt.geometry import arclength, blends
from feedopt.geometry.blends import BLEND_KINDS
from feedopt.units import MM

SEGMENT_KINDS = ("line", "circle", "bezier4", "bezier5", "varying_radius")
REPEAT_TOL = 1e-9  # consecutive waypoints closer than this [m] are "repeated"
COLLINEAR_TOL = 1e-7  # corners turning less than this [rad] get no blend
# corners turning more than pi - REVERSAL_TOL [rad] are refused: no circle fits them and the
# Bezier blends of Eq. 3.3-3.8 degenerate towards cusps (alpha -> 0)
REVERSAL_TOL = 1e-3
# bezier4 blends of corners turning more than pi - this [rad] are refused: alpha of Eq. 3.3
# tends to 0 while p_2 stays on the corner, so the speed nearly vanishes at both ends and
# mid-blend (curvature peak ~280/delta at this limit) and its arc length loses accuracy
BEZIER4_TURN_MARGIN = 0.1
_CHUNK = 1 << 16


@dataclass(frozen=True)
class PathPoints:
    """Evaluation of a path at arc lengths ``s`` (all arrays share the leading axis n).

    s : (n,) arc length [m]; position (n, 3) [m]; tangent (n, 3) unit dp/ds;
    curvature (n, 3) curvature vector d2p/ds2 [1/m]; dcurvature (n, 3) d3p/ds3 [1/m^2];
    segment (n,) index into ``Path.segments``.
    """

    s: np.ndarray
    position: np.ndarray
    tangent: np.ndarray
    curvature: np.ndarray
    dcurvature: np.ndarray
    segment: np.ndarray


@dataclass(frozen=True, eq=False)
class Segment:
    """One piece of a path.

    kind : "line" | "circle" | "bezier4" | "bezier5" | "varying_radius"
    s_start, length : where it starts on the path and its arc length [m]
    corner_index : waypoint index (in the caller's array) of the corner a blend rounds; -1
        for lines
    params : geometry, by kind (arrays in m):
        line: ``origin`` (3,), ``direction`` (3,) unit
        circle: ``centre``, ``e1``, ``e2`` (3,), ``radius``, ``angle`` (scalars);
            p(phi) = centre + radius (cos phi e1 + sin phi e2), phi = (s - s_start)/radius
        bezier4/5: ``control`` (d+1, 3) control points, ``alpha`` (Eq. 3.3/3.7)
        varying_radius: ``centre``, ``e1``, ``e2``, ``radius`` (r0), ``angle`` (theta_f);
            p(theta) = centre + r(theta) (cos theta e1 + sin theta e2), r of Eq. 3.17
        parametric kinds also carry their arc-length table: ``s_nodes``, ``sigma_nodes``.
    """

    kind: str
    s_start: float
    length: float
    corner_index: int = -1
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def s_end(self) -> float:
        return self.s_start + self.length


def arc_length_derivatives(d1: np.ndarray, d2: np.ndarray, d3: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """dp/ds, d2p/ds2, d3p/ds3 from the derivatives p', p'', p''' w.r.t. any parameter t.

    With sigma = |p'|, sigma' = p'.p''/sigma, sigma'' = (|p''|^2 + p'.p''' - sigma'^2)/sigma:
    t_s = 1/sigma, t_ss = -sigma'/sigma^3, t_sss = 3 sigma'^2/sigma^5 - sigma''/sigma^4.
    """
    sig = np.linalg.norm(d1, axis=-1)
    sp = np.einsum("ij,ij->i", d1, d2) / sig
    spp = (np.einsum("ij,ij->i", d2, d2) + np.einsum("ij,ij->i", d1, d3) - sp * sp) / sig
    u1 = 1.0 / sig
    u2 = -sp * u1**3
    u3 = 3.0 * sp * sp * u1**5 - spp * u1**4
    tan = d1 * u1[:, None]
    curv = d2 * (u1 * u1)[:, None] + d1 * u2[:, None]
    dcurv = d3 * (u1**3)[:, None] + 3.0 * d2 * (u1 * u2)[:, None] + d1 * u3[:, None]
    return tan, curv, dcurv


class _Lines:
    def __init__(self, segs: list[Segment]):
        self.origin = np.array([g.params["origin"] for g in segs]).reshape(-1, 3)
        self.direction = np.array([g.params["direction"] for g in segs]).reshape(-1, 3)

    def eval(self, j, sl):
        d = self.direction[j]
        z = np.zeros_like(d)
        return self.origin[j] + sl[:, None] * d, d, z, z.copy()


class _Circles:
    def __init__(self, segs: list[Segment]):
        for key in ("centre", "e1", "e2"):
            setattr(self, key, np.array([g.params[key] for g in segs]).reshape(-1, 3))
        self.radius = np.array([g.params["radius"] for g in segs], dtype=float)

    def eval(self, j, sl):
        r = self.radius[j]
        phi = sl / r
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        e1, e2 = self.e1[j], self.e2[j]
        er = c * e1 + s * e2
        et = -s * e1 + c * e2
        return (self.centre[j] + r[:, None] * er, et, -er / r[:, None],
                -et / (r * r)[:, None])


class _Parametric:
    """Common part of Bezier and varying-radius blends: evaluation through t(s)."""

    def __init__(self, segs: list[Segment]):
        self.table = arclength.ArcLengthTable(
            t_end=self._t_end(),
            s_nodes=np.array([g.params["s_nodes"] for g in segs]),
            sigma_nodes=np.array([g.params["sigma_nodes"] for g in segs]),
        )

    def eval(self, j, sl):
        t = arclength.invert(self.speed, self.table, j, sl)
        p, d1, d2, d3 = self.derivs(j, t)
        return (p, *arc_length_derivatives(d1, d2, d3))


class _Bezier(_Parametric):
    def __init__(self, segs: list[Segment] | None = None, control: np.ndarray | None = None):
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

    def _t_end(self):
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


class _VaryingRadius(_Parametric):
    def __init__(self, segs: list[Segment] | None = None, *, centre=None, e1=None, e2=None,
                 radius=None, angle=None):
        if segs is not None:
            centre = np.array([g.params["centre"] for g in segs]).reshape(-1, 3)
            e1 = np.array([g.params["e1"] for g in segs]).reshape(-1, 3)
            e2 = np.array([g.params["e2"] for g in segs]).reshape(-1, 3)
            radius = np.array([g.params["radius"] for g in segs], dtype=float)
            angle = np.array([g.params["angle"] for g in segs], dtype=float)
        self.centre, self.e1, self.e2 = centre, e1, e2
        self.r0, self.tf = np.asarray(radius, float), np.asarray(angle, float)
        if segs is not None:
            super().__init__(segs)

    def _t_end(self):
        return self.tf

    def speed(self, j, t):
        r, dr, _, _ = blends.varying_radius(t, self.r0[j], self.tf[j])
        return np.sqrt(r * r + dr * dr)

    def derivs(self, j, th):
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


_EVALUATORS = {"line": _Lines, "circle": _Circles, "bezier4": _Bezier, "bezier5": _Bezier,
               "varying_radius": _VaryingRadius}


class Path:
    """A sequence of segments parameterised by arc length s in [0, length] [m].

    Segments must be contiguous: ``segments[i].s_start == sum of earlier lengths``.
    """

    def __init__(self, segments: tuple[Segment, ...] | list[Segment]):
        segs = tuple(segments)
        if not segs:
            raise InputError("a path needs at least one segment")
        self.segments: tuple[Segment, ...] = segs
        self._start = np.array([g.s_start for g in segs], dtype=float)
        self._len = np.array([g.length for g in segs], dtype=float)
        self.length: float = float(self._start[-1] + self._len[-1])
        kinds = [g.kind for g in segs]
        self._kind = tuple(kinds)
        self._code = np.array([SEGMENT_KINDS.index(k) for k in kinds], dtype=np.intp)
        self._local = np.zeros(len(segs), dtype=np.intp)
        self._eval: dict[int, Any] = {}
        for code, kind in enumerate(SEGMENT_KINDS):
            idx = np.flatnonzero(self._code == code)
            if idx.size:
                self._local[idx] = np.arange(idx.size)
                self._eval[code] = _EVALUATORS[kind]([segs[i] for i in idx])

    @property
    def segment_start(self) -> np.ndarray:
        """(k,) arc length at which each segment starts [m]."""
        return self._start.copy()

    @property
    def segment_kind(self) -> tuple[str, ...]:
        """Kind of each segment ("line" or the blend kind)."""
        return self._kind

    def evaluate(self, s: ArrayLike) -> PathPoints:
        """Position, unit tangent, curvature vector and its derivative at arc lengths ``s``.

        A junction belongs to the segment that starts there (except s = length). Values
        outside [0, length] beyond 1e-9 of the length raise ``ValueError``.
        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        tol = 1e-9 * max(self.length, 1e-12)
        if s.size and (np.nanmin(s) < -tol or np.nanmax(s) > self.length + tol
                       or not np.all(np.isfinite(s))):
            raise ValueError(f"arc lengths must lie in [0, {self.length}] m")
        s = np.clip(s, 0.0, self.length)
        seg = np.clip(np.searchsorted(self._start, s, side="right") - 1, 0, len(self._start) - 1)
        pos, tan, curv, dcurv = self._eval_segments(seg, s - self._start[seg])
        return PathPoints(s=s, position=pos, tangent=tan, curvature=curv, dcurvature=dcurv,
                          segment=seg)

    def sample(self, spacing: float) -> PathPoints:
        """Uniform samples in s: n = ceil(length / spacing) + 1, both ends included."""
        if not (np.isfinite(spacing) and spacing > 0):
            raise InputError(
                f"sample spacing must be a positive, finite number of mm, got {spacing / MM:g} mm")
        n = int(np.ceil(self.length / spacing - 1e-9)) + 1
        return self.evaluate(np.linspace(0.0, self.length, max(n, 2)))

    def _eval_segments(self, seg: np.ndarray, sl: np.ndarray):
        """Evaluate segments ``seg`` at local arc lengths ``sl`` (clipped to the segment)."""
        seg = np.asarray(seg, dtype=np.intp)
        sl = np.clip(np.asarray(sl, dtype=float), 0.0, self._len[seg])
        n = seg.size
        out = [np.empty((n, 3)) for _ in range(4)]
        code = self._code[seg]
        for c, ev in self._eval.items():
            idx = np.flatnonzero(code == c)
            for lo in range(0, idx.size, _CHUNK):
                part = idx[lo:lo + _CHUNK]
                res = ev.eval(self._local[seg[part]], sl[part])
                for o, r in zip(out, res, strict=True):
                    o[part] = r
        return tuple(out)


# --- LIPB construction ----------------------------------------------------------------------


def _validate_waypoints(waypoints: ArrayLike, drop_repeated: bool
                        ) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Check waypoints; returns (points (n,3) m, original indices, dropped indices)."""
    try:
        w = np.asarray(waypoints, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"waypoints must be an (n, 3) array of numbers: {exc}") from None
    if w.ndim != 2 or w.shape[1] not in (2, 3):
        raise InputError(f"waypoints must be an (n, 3) array (x, y, z), got shape {w.shape}")
    if w.shape[1] == 2:
        w = np.column_stack([w, np.zeros(len(w))])
    bad = np.flatnonzero(~np.all(np.isfinite(w), axis=1))
    if bad.size:
        raise InputError(
            f"waypoint {bad[0]} is not finite: {_mm(w[bad[0]])}; "
            f"{bad.size} waypoint(s) contain NaN or inf")
    if len(w) < 2:
        raise InputError(f"a path needs at least two distinct waypoints, got {len(w)}")
    step = np.linalg.norm(np.diff(w, axis=0), axis=1)
    rep = np.flatnonzero(step <= REPEAT_TOL) + 1
    index = np.arange(len(w))
    if rep.size:
        if not drop_repeated:
            shown = ", ".join(str(i) for i in rep[:10]) + (" ..." if rep.size > 10 else "")
            raise InputError(
                f"{rep.size} waypoint(s) repeat the previous one (indices {shown}); remove them "
                "or pass drop_repeated=True (CLI: --drop-repeated)")
        keep = np.ones(len(w), dtype=bool)
        keep[rep] = False
        w, index = w[keep], index[keep]
    if len(w) < 2:
        raise InputError("a path needs at least two distinct waypoints, all of them coincide")
    return w, index, rep.tolist()


def build_lipb_path(waypoints: np.ndarray, blend: str, size: float, *,
                    drop_repeated: bool = False) -> Path:
    """Lines through ``waypoints`` with one blend per interior corner (LIPB, thesis 3.3).

    Parameters
    ----------
    waypoints : (n, 3) array [m] ((n, 2) is taken as z = 0)
    blend : "circle" | "bezier4" | "bezier5" | "varying_radius" | "none"
    size : radius r for circle / varying_radius, tolerance delta (distance from the corner
        along each line to where the blend starts, Eq. 3.1) for bezier4 / bezier5 [m];
        ignored for "none".
    drop_repeated : drop consecutive repeated waypoints instead of refusing them.

    Corners turning less than ``COLLINEAR_TOL`` get no blend (their two lines meet with a
    G1 jump below that angle); a corner turning back on itself (within ``REVERSAL_TOL`` = 1e-3
    rad of pi) is refused, and bezier4 refuses corners turning more than pi - 0.1 rad (its
    Eq. 3.3 blend degenerates to a near-cusp there). A blend may use at most half of each
    adjoining line, so neighbouring blends never overlap; otherwise ``InputError`` names the
    corner and the largest size that fits there.

    Blends (each in its corner's own plane, see :mod:`feedopt.geometry.blends`):
    circle (appendix B.1): G1, curvature jumps 0 -> 1/r at both ends.
    bezier4 / bezier5 (Eq. 3.1-3.8): G2.
    varying_radius (Eq. 3.13-3.17, 3.23): polar curve r(theta) about the circle blend's
    centre, theta measured from the ray centre -> first tangent point P_t1 towards P_t2, over
    theta_f = turning angle (the circle's swept angle; the thesis's theta_1 of B.1 is this
    ray's angle). Then r(0) = r0 and r'(0) = 0 put the start on P_t1 with dp/dtheta = r0 d_in
    (tangent to the line), and r''(0) = r0 makes the curvature (r^2 + 2r'^2 - r r'')/
    (r^2 + r'^2)^1.5 zero, so the thesis formula meets the lines with G0, G1 and G2 as written
    (symmetrically at theta_f). Its curvature peaks at mid-corner at 1/r_mid + r0/(2 r_mid^2)
    ~ 1.5/r0, i.e. the tightest radius of curvature is about r0/1.5, not r0.
    """
    if blend not in BLEND_KINDS:
        raise InputError(f"unknown blend {blend!r}; choose one of {', '.join(BLEND_KINDS)}")
    if blend != "none" and not (np.isfinite(size) and size > 0):
        what = "radius" if blend in ("circle", "varying_radius") else "tolerance"
        raise InputError(
            f"blend {blend} needs a positive, finite {what} in mm, got {size / MM:g} mm "
            "(e.g. 12.7 mm)")
    w, index, _ = _validate_waypoints(waypoints, drop_repeated)
    n = len(w)
    seg_vec = np.diff(w, axis=0)
    seg_len = np.linalg.norm(seg_vec, axis=1)
    seg_dir = seg_vec / seg_len[:, None]

    c = blends.corner_geometry(w) if n > 2 else None
    ls = np.zeros(n)  # tangent distance at every waypoint (0 at the ends and skipped corners)
    has_blend = np.zeros(n, dtype=bool)
    if c is not None:
        rev = np.flatnonzero(c.turn > np.pi - REVERSAL_TOL)
        if rev.size:
            i = rev[0] + 1
            raise InputError(
                f"corner at waypoint {index[i]} ({_mm(w[i])}) reverses the direction of travel "
                f"(turns {np.degrees(c.turn[rev[0]]):.4f} deg, within "
                f"{np.degrees(REVERSAL_TOL):.3g} deg of 180); no blend can round it: "
                "insert a waypoint beside it to make two "
                f"gentler corners, or split the path there ({rev.size} such corner(s))")
        if blend == "bezier4":
            sharp = np.flatnonzero(c.turn > np.pi - BEZIER4_TURN_MARGIN)
            if sharp.size:
                i = sharp[0] + 1
                raise InputError(
                    f"bezier4 blend degenerates at the corner at waypoint {index[i]} "
                    f"({_mm(w[i])}), which turns {np.degrees(c.turn[sharp[0]]):.3f} deg (more "
                    f"than {np.degrees(np.pi - BEZIER4_TURN_MARGIN):.2f} deg): Eq. 3.3 gives an "
                    "almost zero alpha there (a near-cusp); use bezier5, circle or "
                    f"varying_radius, or add a waypoint ({sharp.size} such corner(s))")
        if blend != "none":
            active = c.turn >= COLLINEAR_TOL
            has_blend[1:-1] = active
            need = np.where(active, blends.tangent_distance(blend, c.turn, size), 0.0)
            room = 0.5 * np.minimum(c.len_in, c.len_out)
            bad = np.flatnonzero(need > room * (1.0 + 1e-12))
            if bad.size:
                fits = blends.largest_fitting_size(blend, c.turn, room)
                b = bad[0]
                what = "radius" if blend in ("circle", "varying_radius") else "tolerance"
                raise InputError(
                    f"{blend} blend does not fit at the corner at waypoint {index[b + 1]} "
                    f"({_mm(w[b + 1])}): {what} {size * 1e3:.6g} mm needs {need[b] * 1e3:.6g}"
                    f" mm of each adjoining line but a blend may use at most half of them "
                    f"({c.len_in[b] * 1e3:.6g} mm and {c.len_out[b] * 1e3:.6g} mm long); the "
                    f"largest {what} that fits there is {fits[b] * 1e3:.6g} mm "
                    f"({bad.size} corner(s) too tight; the largest {what} that fits all corners"
                    f" is {np.min(fits[active]) * 1e3:.6g} mm)")
            ls[1:-1] = need

    # lines between consecutive waypoints, shortened by the blends at both ends
    l_start = w[:-1] + ls[:-1, None] * seg_dir
    l_len = seg_len - ls[:-1] - ls[1:]
    keep_line = l_len > 1e-12 * seg_len

    blend_data: dict[str, np.ndarray] = {}
    blend_len = np.zeros(n)
    corner_ids = np.flatnonzero(has_blend)  # waypoint indices with a blend
    if corner_ids.size:
        sub = blends.Corners(*(np.asarray(getattr(c, f))[corner_ids - 1] for f in
                               ("point", "d_in", "d_out", "turn", "normal", "len_in",
                                "len_out")))
        blend_data, lens = _make_blends(blend, sub, size)
        blend_len[corner_ids] = lens

    # order: line 0, blend 1, line 1, blend 2, ..., line n-2
    kinds: list[str] = []
    lengths: list[float] = []
    refs: list[int] = []  # line index or corner position
    for i in range(n - 1):
        if i > 0 and has_blend[i]:
            kinds.append(blend)
            lengths.append(blend_len[i])
            refs.append(i)
        if keep_line[i]:
            kinds.append("line")
            lengths.append(l_len[i])
            refs.append(i)
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    pos_of_corner = {int(ci): k for k, ci in enumerate(corner_ids)}
    segs = []
    for kind, s0, ln, ref in zip(kinds, starts.tolist(), lengths, refs, strict=True):
        if kind == "line":
            params = {"origin": l_start[ref], "direction": seg_dir[ref]}
            segs.append(Segment("line", s0, float(ln), -1, params))
        else:
            k = pos_of_corner[ref]
            params = {key: val[k] for key, val in blend_data.items()}
            segs.append(Segment(kind, s0, float(ln), int(index[ref]), params))
    return Path(tuple(segs))


def _make_blends(kind: str, c: blends.Corners, size: float
                 ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Per-blend parameter arrays (leading axis = corner) and blend lengths."""
    if kind == "circle":
        cb = blends.circle_blend(c, size)
        data = {"centre": cb.centre, "e1": cb.e1, "e2": cb.e2, "radius": cb.radius,
                "angle": cb.angle}
        return data, cb.radius * cb.angle
    if kind in ("bezier4", "bezier5"):
        control, alpha = blends.bezier_control_points(c, size, 4 if kind == "bezier4" else 5)
        ev = _Bezier(control=control)
        table = arclength.build_table(ev.speed, ev._t_end())
        data = {"control": control, "alpha": alpha}
    else:  # varying_radius, built on the circle blend's geometry
        cb = blends.circle_blend(c, size)
        ev = _VaryingRadius(centre=cb.centre, e1=cb.e1, e2=cb.e2, radius=cb.radius,
                            angle=cb.angle)
        table = arclength.build_table(ev.speed, ev._t_end())
        data = {"centre": cb.centre, "e1": cb.e1, "e2": cb.e2, "radius": cb.radius,
                "angle": cb.angle}
    data["s_nodes"] = table.s_nodes
    data["sigma_nodes"] = table.sigma_nodes
    return data, table.length


def _mm(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v * 1e3:.6g}" for v in p) + ") mm"
