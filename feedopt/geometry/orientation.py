"""The tool's orientation along a five-axis path: a G2 curve on the unit sphere in arc length.

A five-axis program gives a tool vector u_k (unit, from the tip into the spindle) at the
ends of its moves; the controller turns the tool along the great circle between consecutive
vectors in proportion to the distance travelled (TCPM / G43.5 / APT ``GOTO/x,y,z,i,j,k``).
On the smoothed path the k-th programmed vector sits at the arc length s_k where the path
passes its point (``MoveTable.s_start``), so the programmed orientation is, on
[s_k, s_k+1], the great circle

    A_k(s) = cos(w_k (s - s_k)) u_k + sin(w_k (s - s_k)) v_k,
    w_k = angle(u_k, u_k+1) / (s_k+1 - s_k)

(v_k the unit part of u_k+1 orthogonal to u_k), positioned and timed by the same arc length
as the position: synchronised by construction. It turns with a jump of its angular rate at
every s_k (G1 on the sphere). Each interior knot gets a local blend, in the spirit of Huang,
Du & Zhu 2018 (local smoothing of five-axis tool paths in workpiece coordinates, position and
orientation smoothed against their own tolerances by the same path parameter) and of the
thesis's corner blends (section 3.3): on [s_k - h_k, s_k + h_k]

    w(s) = (1 - b(t)) A_k-1(s) + b(t) A_k(s),   u(s) = w(s) / |w(s)|,
    t = (s - s_k + h_k) / (2 h_k)

with the quintic smoothstep b = 10 t^3 - 15 t^4 + 6 t^5 (b' = b'' = 0 at both ends), both
great circles continued past s_k. At the window's ends u, du/ds and d2u/ds2 equal the great
circle's (|w| = 1 and its first two derivatives vanish there), so u(s) is G2 (C2 in s)
everywhere; outside the windows it is exactly the programmed orientation. The half-width h_k
is the largest of: half of each neighbouring interval (windows never overlap) and the one
whose largest angle between u(s) and the programmed A(s) (measured at the same s, on 65
points of the window) is within the angle tolerance (shrunk by the ratio until it is). Stops
(where the tool stops anyway: exact stops, dwells, reversals) and the path's ends get no
window.

Derivatives of the normalisation (rho = |w|): rho' = u.w', rho'' = (w'.w' + w.w'' - rho'^2)
/ rho; u' = (w' - rho' u) / rho, u'' = (w'' - rho'' u - 2 rho' u') / rho.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError

#: largest angle [rad] between consecutive programmed vectors: a half turn or more has no
#: single great circle (the controller's interpolation is ambiguous there)
MAX_STEP = math.radians(179.0)
#: largest turn of the tool vector between two samples [rad]: where the programmed vector
#: turns faster than this per ``path.spacing_mm`` the path is sampled more finely (the IK
#: follows the tool from sample to sample; a robot's wrist turns more than the tool)
MAX_TURN_PER_SAMPLE = math.radians(0.5)
#: points per window on which the deviation from the programmed orientation is measured
_DEVIATION_POINTS = 65
_ROUNDS = 40


@dataclass(frozen=True)
class OrientationKnots:
    """Programmed tool vectors on the path.

    s : (k,) strictly increasing arc lengths [m]; u : (k, 3) unit vectors there;
    stop : (k,) bool, True where the path stops (no blend); label : (k,) where each came
    from, for messages (``"line 12"``)."""

    s: np.ndarray
    u: np.ndarray
    stop: np.ndarray
    label: tuple[str, ...]


@dataclass(frozen=True)
class OrientationPoints:
    """u(s) and its derivatives: (n, 3) each [1, 1/m, 1/m^2]."""

    axis: np.ndarray
    d1: np.ndarray
    d2: np.ndarray


def _circles(knots: OrientationKnots) -> tuple[np.ndarray, np.ndarray]:
    """(v, w): per interval the unit vector v_k orthogonal to u_k towards u_k+1 (k-1, 3)
    and the angular rate w_k [rad/m]; InputError for a step of half a turn or more."""
    u0, u1 = knots.u[:-1], knots.u[1:]
    dot = np.clip(np.einsum("ij,ij->i", u0, u1), -1.0, 1.0)
    perp = u1 - dot[:, None] * u0
    norm = np.linalg.norm(perp, axis=1)
    angle = np.arctan2(norm, dot)
    if np.any(angle > MAX_STEP):
        k = int(np.argmax(angle))
        raise InputError(
            f"{knots.label[k + 1]}: the tool vector turns {math.degrees(angle[k]):.1f} deg "
            f"in one move (from {knots.label[k]}); more than {math.degrees(MAX_STEP):.0f} deg "
            "has no single great circle to turn along: split the move")
    safe = norm > 1e-300
    v = np.where(safe[:, None], perp / np.where(safe, norm, 1.0)[:, None], 0.0)
    return v, angle / np.diff(knots.s)


def _great_circle(u: np.ndarray, v: np.ndarray, w: np.ndarray, ds: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A, A', A'' of the great circles (u, v, w) at ``ds`` past their start."""
    c, s = np.cos(w * ds)[:, None], np.sin(w * ds)[:, None]
    a = c * u + s * v
    d1 = w[:, None] * (c * v - s * u)
    return a, d1, -(w**2)[:, None] * a


def _smoothstep(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """b, db/dt, d2b/dt2 of the quintic smoothstep 10 t^3 - 15 t^4 + 6 t^5."""
    return (t**3 * (10.0 - 15.0 * t + 6.0 * t * t), 30.0 * t * t * (1.0 - t) ** 2,
            60.0 * t * (1.0 - t) * (1.0 - 2.0 * t))


def _normalised(w: np.ndarray, w1: np.ndarray, w2: np.ndarray) -> OrientationPoints:
    """u = w / |w| and its first two derivatives (module docstring)."""
    rho = np.linalg.norm(w, axis=1)
    u = w / rho[:, None]
    r1 = np.einsum("ij,ij->i", u, w1)
    d1 = (w1 - r1[:, None] * u) / rho[:, None]
    r2 = (np.einsum("ij,ij->i", w1, w1) + np.einsum("ij,ij->i", w, w2) - r1**2) / rho
    d2 = (w2 - r2[:, None] * u - 2.0 * r1[:, None] * d1) / rho[:, None]
    return OrientationPoints(u, d1, d2)


class ToolOrientation:
    """u(s) on the whole path (module docstring): the knots' great circles, blended over the
    half-widths ``half_window`` (k,) [m] around the interior knots (0: no blend)."""

    def __init__(self, knots: OrientationKnots, half_window: np.ndarray):
        self.knots = knots
        self.half_window = np.asarray(half_window, dtype=float)
        self._v, self._w = _circles(knots)

    @property
    def length(self) -> float:
        """Arc length covered [m] (the last knot's)."""
        return float(self.knots.s[-1])

    def programmed(self, s: np.ndarray) -> OrientationPoints:
        """The programmed orientation (great circles, no blends) at ``s`` (n,) [m]."""
        k = self._interval(s)
        a, d1, d2 = _great_circle(self.knots.u[k], self._v[k], self._w[k], s - self.knots.s[k])
        return OrientationPoints(a, d1, d2)

    def _interval(self, s: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(self.knots.s, s, side="right") - 1, 0,
                       self.knots.s.size - 2)

    def evaluate(self, s) -> OrientationPoints:
        """u, du/ds, d2u/ds2 at arc lengths ``s`` (n,) [m]."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        out = self.programmed(s)
        knot = np.clip(np.searchsorted(self.knots.s, s), 0, self.knots.s.size - 1)
        near = np.where(knot > 0, knot - 1, knot)  # the knots on either side of s
        pick = np.where(np.abs(s - self.knots.s[near]) < np.abs(s - self.knots.s[knot]),
                        near, knot)
        h = self.half_window[pick]
        inside = (h > 0) & (np.abs(s - self.knots.s[pick]) < h)
        if not inside.any():
            return out
        rows = np.flatnonzero(inside)
        blended = self._blend(pick[rows], s[rows])
        for field in ("axis", "d1", "d2"):
            getattr(out, field)[rows] = getattr(blended, field)
        return out

    def _blend(self, k: np.ndarray, s: np.ndarray) -> OrientationPoints:
        """The blend around interior knots ``k`` at ``s`` (inside their windows)."""
        ks, h = self.knots.s, self.half_window[k]
        a = _great_circle(self.knots.u[k - 1], self._v[k - 1], self._w[k - 1], s - ks[k - 1])
        b = _great_circle(self.knots.u[k], self._v[k], self._w[k], s - ks[k])
        beta, b1, b2 = _smoothstep((s - ks[k] + h) / (2.0 * h))
        b1, b2 = (b1 / (2.0 * h))[:, None], (b2 / (2.0 * h) ** 2)[:, None]
        beta = beta[:, None]
        gap, gap1 = b[0] - a[0], b[1] - a[1]
        w = (1.0 - beta) * a[0] + beta * b[0]
        w1 = (1.0 - beta) * a[1] + beta * b[1] + b1 * gap
        w2 = (1.0 - beta) * a[2] + beta * b[2] + 2.0 * b1 * gap1 + b2 * gap
        return _normalised(w, w1, w2)

    def sample_spacing(self, bounds: np.ndarray, spacing: float
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Stretch bounds [m] (``bounds`` plus the knots and the windows' ends) and a spacing
        per stretch [m]: at most ``spacing``, and fine enough that the tool vector turns at
        most :data:`MAX_TURN_PER_SAMPLE` per step: a great circle's rate, in a window twice
        the faster of its two circles (a blend turns faster than either by at most the
        difference of their rates)."""
        ks, h = self.knots.s, self.half_window
        w = np.abs(self._w)
        turning = np.r_[w > 0, False] | np.r_[False, w > 0]  # a knot beside a turn
        if not turning.any():  # a constant tool vector: sampled as a three-axis path
            return np.unique(bounds), np.full(np.unique(bounds).size - 1, spacing)
        ks, h = ks[turning], h[turning]
        b = np.unique(np.concatenate([bounds, ks, ks - h, ks + h]))
        b = b[(b >= bounds[0]) & (b <= bounds[-1])]
        # knots and window ends within 5 % of the spacing of a neighbour (two
        # neighbouring windows meet about half way) are dropped: no slivers of a step; the
        # stops and ends stay exact
        gaps = np.diff(b)
        close = np.r_[np.inf, gaps] <= 0.05 * spacing
        close |= np.r_[gaps, np.inf] <= 0.05 * spacing
        b = b[~close | np.isin(b, bounds)]
        mid = 0.5 * (b[:-1] + b[1:])
        rate = np.abs(self._w)[self._interval(mid)]
        ks, h = self.knots.s, self.half_window
        j = np.clip(np.searchsorted(ks, mid), 1, ks.size - 1)
        j = np.where(np.abs(mid - ks[j - 1]) < np.abs(mid - ks[j]), j - 1, j)
        inside = (h[j] > 0) & (np.abs(mid - ks[j]) < h[j])
        both = 2.0 * np.maximum(w[np.clip(j - 1, 0, w.size - 1)], w[np.clip(j, 0, w.size - 1)])
        rate = np.where(inside, both, rate)
        with np.errstate(divide="ignore"):
            return b, np.minimum(spacing, MAX_TURN_PER_SAMPLE / rate)

    def peaks(self, s: np.ndarray, sub: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Per sample ``s`` (n,) [m] the largest |du/ds| [1/m] and |d2u/ds2| [1/m^2] over its
        two neighbouring intervals: evaluated on ``sub + 1`` points of each interval (both
        ends) and on 65 points of every window (a window shorter than a sample, or longer
        than one, peaks inside: within 1 % of a brute force, tests/geometry)."""
        s = np.asarray(s, dtype=float)
        t = np.arange(sub + 1) / sub
        grid = (s[:-1, None] + np.diff(s)[:, None] * t).ravel()
        k = np.flatnonzero(self.half_window > 0)
        tw = np.linspace(-1.0, 1.0, _DEVIATION_POINTS)
        inner = (self.knots.s[k, None] + self.half_window[k, None] * tw).ravel()
        inner = inner[(inner >= s[0]) & (inner <= s[-1])]
        on_grid, at_inner = self.evaluate(grid), self.evaluate(inner)
        # a window point on a sample belongs to both intervals beside it
        left = np.clip(np.searchsorted(s, inner, side="left") - 1, 0, s.size - 2)
        right = np.clip(np.searchsorted(s, inner, side="right") - 1, 0, s.size - 2)
        out = []
        for d_grid, d_inner in ((on_grid.d1, at_inner.d1), (on_grid.d2, at_inner.d2)):
            per = np.linalg.norm(d_grid, axis=1).reshape(s.size - 1, sub + 1).max(axis=1)
            norm = np.linalg.norm(d_inner, axis=1)
            np.maximum.at(per, left, norm)
            np.maximum.at(per, right, norm)
            # + 1 %: the largest of sampled values (within 1 % of a brute force) as a bound
            out.append(1.01 * np.maximum(np.r_[per[:1], per], np.r_[per, per[-1:]]))
        return out[0], out[1]

    def window_points(self) -> np.ndarray:
        """Arc lengths [m] of 65 points in every window (where the rates peak), sorted."""
        k = np.flatnonzero(self.half_window > 0)
        tw = np.linspace(-1.0, 1.0, _DEVIATION_POINTS)
        return np.sort((self.knots.s[k, None] + self.half_window[k, None] * tw).ravel())

    def deviation(self, knots: np.ndarray | None = None) -> np.ndarray:
        """Largest angle [rad] between u(s) and the programmed orientation over each knot's
        window (k,) (0 without a window), measured on the window's points."""
        k = np.flatnonzero(self.half_window > 0) if knots is None else np.asarray(knots)
        out = np.zeros(self.knots.s.size)
        if k.size == 0:
            return out
        t = np.linspace(-1.0, 1.0, _DEVIATION_POINTS)
        s = (self.knots.s[k, None] + self.half_window[k, None] * t).ravel()
        kk = np.repeat(k, t.size)
        got = self._blend(kk, s).axis
        ref = self.programmed(s).axis
        ang = np.arctan2(np.linalg.norm(np.cross(got, ref), axis=1),
                         np.einsum("ij,ij->i", got, ref))
        out[k] = ang.reshape(k.size, t.size).max(axis=1)
        return out


def _largest_windows(knots: OrientationKnots) -> np.ndarray:
    """Half of each interior knot's shorter neighbouring interval [m]; 0 at stops and ends."""
    gaps = np.diff(knots.s)
    h = np.zeros(knots.s.size)
    h[1:-1] = 0.5 * np.minimum(gaps[:-1], gaps[1:])
    return np.where(knots.stop, 0.0, h)


def blend_orientation(knots: OrientationKnots, tolerance: float) -> ToolOrientation:
    """The G2 orientation of ``knots`` within ``tolerance`` [rad] of the programmed one
    (module docstring): every window as wide as it may be, those deviating too far shrunk
    by the ratio (times 0.95) until none does, all knots at once."""
    if not (tolerance > 0):
        raise ValueError("the orientation tolerance must be positive")
    h = _largest_windows(knots)
    orientation = ToolOrientation(knots, h)
    turning = np.flatnonzero(h > 0)
    for _ in range(_ROUNDS):
        dev = orientation.deviation(turning)[turning]
        over = dev > tolerance
        if not over.any():
            return orientation
        k = turning[over]
        h[k] *= np.clip(0.95 * tolerance / dev[over], 0.05, 0.95)
        orientation = ToolOrientation(knots, h)
        turning = k
    raise RuntimeError("orientation windows did not settle within the tolerance")
