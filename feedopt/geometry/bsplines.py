"""Many clamped B-splines of one degree in flat arrays, evaluated all at once.

:class:`SplineBatch` holds ``m`` B-spline curves (full knot vectors and coefficients
concatenated, with offsets) so that evaluating any of them at any parameters, building the
least-squares design matrix of all of them, or inverting their arc length is one vectorised
call instead of a Python loop per curve (a CAM raster has a thousand smoothed chains).

Basis functions and their derivatives: Piegl and Tiller, *The NURBS Book* (2nd ed., 1997),
algorithm A2.3 (``DersBasisFuns``), written over arrays of points: for the knot span
t_i <= u < t_{i+1} of each point the k+1 non-zero basis functions N_{i-k..i} and their first
``nd`` derivatives. A curve point is sum_j N_{i-k+j}(u) c_{i-k+j}.

Arc length (thesis Eq. 3.23) of each curve is tabulated at nodes in its parameter
(:class:`ArcTable`, Gauss-Legendre on every node interval) and inverted by a cubic Hermite
guess and safeguarded Newton steps until |s(u) - s| <= 1e-12 of the curve's length, as
:func:`feedopt.geometry.arclength.invert` does for the blends.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

_GL_TABLE = np.polynomial.legendre.leggauss(8)
_GL_NEWTON = np.polynomial.legendre.leggauss(6)
_MAX_NEWTON = 60
_CHUNK = 1 << 16


def shifted_keys(keys: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (one per owner) that make the flat, per-owner increasing ``keys`` (owner o's
    at ``keys[start[o]:start[o+1]]``) increasing as a whole, and the shifted keys: each owner's
    range is moved to start where the previous one ends."""
    first, last = keys[start[:-1]], keys[start[1:] - 1]
    offset = np.concatenate([[0.0], np.cumsum(last - first)])[:-1] - first
    return offset, keys + np.repeat(offset, np.diff(start))


def segment_of(keys: np.ndarray, start: np.ndarray, owner: np.ndarray, x: np.ndarray,
               shifted: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Flat index ``g`` with keys[g] <= x < keys[g+1] inside owner ``owner`` (see
    :func:`shifted_keys`), clipped to the owner's range [start[o], start[o+1] - 2]."""
    offset, flat = shifted if shifted is not None else shifted_keys(keys, start)
    g = np.searchsorted(flat, x + offset[owner], side="right") - 1
    lo, hi = start[owner], start[owner + 1] - 2
    g = np.clip(g, lo, hi)
    # the shifted keys lose a few ulps of the offsets: settle ties on the true values
    g = np.where((x < keys[g]) & (g > lo), g - 1, g)
    return np.where((x >= keys[np.minimum(g + 1, keys.size - 1)]) & (g < hi), g + 1, g)


def basis_derivatives(t_loc: np.ndarray, u: np.ndarray, k: int, nd: int) -> np.ndarray:
    """(n, nd+1, k+1) derivatives 0..nd of the k+1 basis functions non-zero at ``u`` (n,);
    ``t_loc`` (n, 2k) are the knots t_{i-k+1} .. t_{i+k} around each point's span i
    (The NURBS Book, A2.3)."""
    n = u.size
    left = [None] + [u - t_loc[:, k - j] for j in range(1, k + 1)]
    right = [None] + [t_loc[:, k + j - 1] - u for j in range(1, k + 1)]
    ndu = [[None] * (k + 1) for _ in range(k + 1)]
    ndu[0][0] = np.ones(n)
    for j in range(1, k + 1):
        saved = np.zeros(n)
        for r in range(j):
            ndu[j][r] = right[r + 1] + left[j - r]
            temp = ndu[r][j - 1] / ndu[j][r]
            ndu[r][j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j][j] = saved
    ders = np.empty((n, nd + 1, k + 1))
    for j in range(k + 1):
        ders[:, 0, j] = ndu[j][k]
    for r in range(k + 1):
        a = [[None] * (k + 1), [None] * (k + 1)]
        s1, s2 = 0, 1
        a[0][0] = np.ones(n)
        for kk in range(1, nd + 1):
            d = np.zeros(n)
            rk, pk = r - kk, k - kk
            if r >= kk:
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk]
                d = a[s2][0] * ndu[rk][pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = kk - 1 if r - 1 <= pk else k - r
            for j in range(j1, j2 + 1):
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j]
                d = d + a[s2][j] * ndu[rk + j][pk]
            if r <= pk:
                a[s2][kk] = -a[s1][kk - 1] / ndu[pk + 1][r]
                d = d + a[s2][kk] * ndu[r][pk]
            ders[:, kk, r] = d
            s1, s2 = s2, s1
    fac = float(k)
    for kk in range(1, nd + 1):
        ders[:, kk] *= fac
        fac *= k - kk
    return ders


@dataclass(frozen=True, eq=False)
class SplineBatch:
    """``m`` clamped B-spline curves of degree ``k`` in flat arrays.

    knots : (sum of n_c + k + 1,) the full knot vectors, curve c's at
        ``knots[knot_start[c]:knot_start[c+1]]``
    coef : (sum of n_c, 3) the coefficients, curve c's at ``coef[coef_start[c]:...]``
    """

    k: int
    knots: np.ndarray
    knot_start: np.ndarray
    coef: np.ndarray
    coef_start: np.ndarray

    @classmethod
    def from_lists(cls, k: int, knots: list[np.ndarray], coef: list[np.ndarray]
                   ) -> SplineBatch:
        ks = np.concatenate([[0], np.cumsum([t.size for t in knots])])
        cs = np.concatenate([[0], np.cumsum([len(c) for c in coef])])
        return cls(k, np.concatenate(knots), ks, np.concatenate(coef).reshape(-1, 3), cs)

    def __len__(self) -> int:
        return self.knot_start.size - 1

    @property
    def u_end(self) -> np.ndarray:
        """(m,) end of each curve's parameter range."""
        return self.knots[self.knot_start[1:] - 1]

    @functools.cached_property
    def _shifted(self) -> tuple[np.ndarray, np.ndarray]:
        return shifted_keys(self.knots, self.knot_start)

    @functools.cached_property
    def derivative(self) -> SplineBatch:
        """The curves' first derivatives p'(u): degree k-1 on the knots without their first
        and last, coefficients k (c_{i+1} - c_i) / (t_{i+k+1} - t_{i+1})."""
        k, ks, cs = self.k, self.knot_start, self.coef_start
        m = len(self)
        valid = np.ones(self.coef.shape[0], dtype=bool)
        valid[cs[1:] - 1] = False
        i = np.flatnonzero(valid)
        own = np.repeat(np.arange(m), np.diff(cs) - 1)
        base = ks[own] + i - cs[own]
        d = k * (self.coef[i + 1] - self.coef[i]) / (self.knots[base + k + 1]
                                                     - self.knots[base + 1])[:, None]
        keep = np.ones(self.knots.size, dtype=bool)
        keep[ks[:-1]] = False
        keep[ks[1:] - 1] = False
        return SplineBatch(k - 1, self.knots[keep], ks - 2 * np.arange(m + 1), d,
                           cs - np.arange(m + 1))

    def span(self, c: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Local span index i (k <= i < n_c) of curve ``c`` holding ``u`` (the last span at
        the end of the range)."""
        g = segment_of(self.knots, self.knot_start, c, u, self._shifted) - self.knot_start[c]
        return np.clip(g, self.k, np.diff(self.knot_start)[c] - self.k - 2)

    def basis(self, c: np.ndarray, u: np.ndarray, nd: int) -> tuple[np.ndarray, np.ndarray]:
        """Basis derivatives (n, nd+1, k+1) at ``u`` of curves ``c`` and the flat index of the
        first of the k+1 coefficients they multiply (n,)."""
        c = np.asarray(c, dtype=np.intp)
        u = np.asarray(u, dtype=float)
        i = self.span(c, u)
        base = self.knot_start[c] + i
        t_loc = self.knots[base[:, None] + np.arange(-self.k + 1, self.k + 1)]
        return basis_derivatives(t_loc, u, self.k, nd), self.coef_start[c] + i - self.k

    def evaluate(self, c: np.ndarray, u: np.ndarray, nd: int = 0) -> np.ndarray:
        """(nd+1, n, 3): curve ``c`` and its first ``nd`` u-derivatives at ``u``."""
        c = np.asarray(c, dtype=np.intp).ravel()
        u = np.asarray(u, dtype=float).ravel()
        out = np.empty((nd + 1, u.size, 3))
        for lo in range(0, u.size, _CHUNK):
            part = slice(lo, lo + _CHUNK)
            b, first = self.basis(c[part], u[part], nd)
            cf = self.coef[first[:, None] + np.arange(self.k + 1)]  # (n, k+1, 3)
            out[:, part] = np.matmul(b, cf).transpose(1, 0, 2)
        return out

    def design_matrix(self, c: np.ndarray, u: np.ndarray) -> sp.csr_array:
        """(n, sum n_c) sparse matrix of the basis values: row r holds curve c[r]'s basis
        at u[r] in the columns of its coefficients."""
        b, first = self.basis(c, u, 0)
        n = u.size
        cols = first[:, None] + np.arange(self.k + 1)
        return sp.csr_array((b[:, 0].ravel(), cols.ravel(), np.arange(0, n * (self.k + 1) + 1,
                                                                   self.k + 1)),
                            shape=(n, self.coef.shape[0]))


def speed(batch: SplineBatch, c: np.ndarray, u: np.ndarray) -> np.ndarray:
    """|dp/du| of curves ``c`` at ``u`` (any matching shapes)."""
    shape = np.shape(u)
    c = np.broadcast_to(c, shape)
    d = batch.derivative.evaluate(c, u)[0]
    return np.sqrt(np.einsum("ij,ij->i", d, d)).reshape(shape)


@dataclass(frozen=True)
class ArcTable:
    """s(u) of every curve of a batch at parameter nodes (flat, curve c's at
    ``[start[c]:start[c+1]]``): parameters ``t`` [m], arc length ``s`` [m] from the curve's
    start, speed ``sigma`` = |dp/du|."""

    t: np.ndarray
    s: np.ndarray
    sigma: np.ndarray
    start: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return self.s[self.start[1:] - 1]

    def curve(self, c: int) -> dict[str, np.ndarray]:
        sl = slice(self.start[c], self.start[c + 1])
        return {"t_nodes": self.t[sl], "s_nodes": self.s[sl], "sigma_nodes": self.sigma[sl]}


def arc_table(batch: SplineBatch, split: int) -> ArcTable:
    """s(u) at ``split`` nodes per knot span of every curve (Gauss-Legendre, 8 points per
    node interval); the interior knots must be distinct."""
    k, ks = batch.k, batch.knot_start
    m = len(batch)
    # distinct knots of every curve (the full vector without k repeats at either end)
    n_dist = np.diff(ks) - 2 * k
    pick = np.repeat(ks[:-1] + k, n_dist) + _ramp(n_dist)
    dist = batch.knots[pick]
    own_d = np.repeat(np.arange(m), n_dist)
    is_last = np.zeros(dist.size, dtype=bool)
    is_last[np.cumsum(n_dist) - 1] = True
    lo = np.flatnonzero(~is_last)  # span starts
    frac = np.arange(split) / split
    nodes = dist[lo, None] + (dist[lo + 1] - dist[lo])[:, None] * frac
    own = np.concatenate([np.repeat(own_d[lo], split), own_d[is_last]])
    t_nodes = np.concatenate([nodes.ravel(), dist[is_last]])
    order = np.argsort(own, kind="stable")  # last knots after their curve's spans
    t_nodes, own = t_nodes[order], own[order]
    start = np.concatenate([[0], np.cumsum(np.bincount(own, minlength=m))])
    x, w = _GL_TABLE
    inner = np.ones(t_nodes.size, dtype=bool)
    inner[start[1:] - 1] = False
    h = np.where(inner, np.diff(t_nodes, append=t_nodes[-1]), 0.0)
    tq = t_nodes[:, None] + 0.5 * h[:, None] * (x[None, :] + 1.0)
    inc = 0.5 * h * (speed(batch, own[:, None], tq) @ w)
    cum = np.concatenate([[0.0], np.cumsum(inc)])
    s = cum[:-1] - np.repeat(cum[start[:-1]], np.diff(start))
    return ArcTable(t_nodes, s, speed(batch, own, t_nodes), start)


def _ramp(counts: np.ndarray) -> np.ndarray:
    """0, 1, ..., counts[0]-1, 0, 1, ..., counts[1]-1, ..."""
    return np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)


def arc_length(batch: SplineBatch, table: ArcTable, c: np.ndarray, u: np.ndarray
               ) -> np.ndarray:
    """s(u) of curves ``c``: table node below plus Gauss-Legendre (8 points)."""
    c = np.asarray(c, dtype=np.intp)
    u = np.asarray(u, dtype=float)
    u = np.clip(u, table.t[table.start[c]], table.t[table.start[c + 1] - 1])
    g = segment_of(table.t, table.start, c, u)
    x, w = _GL_TABLE
    half = 0.5 * (u - table.t[g])
    tq = table.t[g][:, None] + half[:, None] * (x + 1.0)
    return table.s[g] + half * (speed(batch, c[:, None], tq) @ w)


@dataclass(frozen=True)
class Inverter:
    """u(s) of every curve of a batch: its table, per curve the tolerance 1e-12 L and the
    bound of the Newton residual that needs no check (see :meth:`invert`)."""

    batch: SplineBatch
    table: ArcTable
    tol: np.ndarray
    quad_bound: np.ndarray
    shifted: tuple[np.ndarray, np.ndarray]

    @classmethod
    def of(cls, batch: SplineBatch, table: ArcTable) -> Inverter:
        # Newton from residual r leaves ~ |sigma'| r^2 / (2 sigma^2) <= bound r^2 (|sigma'| <=
        # |p''|; factor 4 for the p'' between the nodes): below tol no check is needed
        own = np.repeat(np.arange(len(batch)), np.diff(table.start))
        last = np.zeros(table.t.size, dtype=bool)
        last[table.start[1:] - 1] = True
        mid = 0.5 * (table.t + np.roll(table.t, -1))
        pts = np.concatenate([table.t, mid[~last]])
        who = np.concatenate([own, own[~last]])
        p2 = np.linalg.norm(batch.evaluate(who, pts, 2)[2], axis=-1)
        p2_max = np.zeros(len(batch))
        np.maximum.at(p2_max, who, p2)
        sig_min = np.minimum.reduceat(table.sigma, table.start[:-1])
        tol = 1e-12 * table.length + 1e-300
        return cls(batch, table, tol, 4.0 * 0.5 * p2_max / sig_min**2,
                   shifted_keys(table.s, table.start))

    def invert(self, c: np.ndarray, s: np.ndarray) -> np.ndarray:
        """u(s) of curves ``c``: cubic Hermite guess on the table interval, then safeguarded
        Newton steps on s(u) - s = 0 until |s(u) - s| <= 1e-12 of the length."""
        tb = self.table
        c = np.asarray(c, dtype=np.intp)
        s = np.clip(np.asarray(s, dtype=float), 0.0, tb.length[c])
        g = segment_of(tb.s, tb.start, c, s, self.shifted)
        t0, t1, s0, s1 = tb.t[g], tb.t[g + 1], tb.s[g], tb.s[g + 1]
        ds = s1 - s0
        with np.errstate(invalid="ignore", divide="ignore"):
            tau = np.where(ds > 0, (s - s0) / ds, 0.0)
        m0, m1 = ds / tb.sigma[g], ds / tb.sigma[g + 1]
        tau2, tau3 = tau * tau, tau * tau * tau
        t = np.clip(t0 * (2 * tau3 - 3 * tau2 + 1) + m0 * (tau3 - 2 * tau2 + tau)
                    + t1 * (-2 * tau3 + 3 * tau2) + m1 * (tau3 - tau2), t0, t1)
        return self._newton(c, s, t, t0, t1, s0)

    def _newton(self, c, s, t, t0, t1, s0) -> np.ndarray:
        lo, hi = t0.copy(), t1.copy()
        x, w = _GL_NEWTON
        todo = np.arange(s.size)
        stepped = np.zeros(s.size, dtype=bool)
        for _ in range(_MAX_NEWTON):
            ta, t0a, ca = t[todo], t0[todo], c[todo]
            half = 0.5 * (ta - t0a)
            tq = np.empty((ta.size, x.size + 1))
            tq[:, :-1] = t0a[:, None] + half[:, None] * (x + 1.0)
            tq[:, -1] = ta
            sig = speed(self.batch, ca[:, None], tq)
            res = s0[todo] + half * (sig[:, :-1] @ w) - s[todo]
            tol = self.tol[ca]
            # converged, or one Newton step from a residual small enough to need no check
            done = np.abs(res) <= tol
            quick = ~done & ~stepped[todo] & (self.quad_bound[ca] * res * res <= 0.01 * tol)
            step = ta - res / sig[:, -1]
            q = todo[quick]
            t[q] = np.clip(step[quick], lo[q], hi[q])
            keep = ~done & ~quick
            todo, ta, res, step = todo[keep], ta[keep], res[keep], step[keep]
            if not todo.size:
                break
            stepped[todo] = True
            lo[todo] = np.where(res < 0, ta, lo[todo])
            hi[todo] = np.where(res > 0, ta, hi[todo])
            inside = (step >= lo[todo]) & (step <= hi[todo])
            t[todo] = np.where(inside, step, 0.5 * (lo[todo] + hi[todo]))
        return t
