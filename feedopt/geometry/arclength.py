"""Numerical arc length s(t) of parametric blends and its inverse t(s) (thesis Eq. 3.23).

For a batch of curves with speed sigma(t) = |dp/dt| > 0 on [0, t_end], a table of s at
``N + 1`` equally spaced parameter nodes is built by Gauss-Legendre quadrature on every
sub-interval. The inverse t(s) starts from a cubic Hermite interpolant of the table (slopes
dt/ds = 1/sigma at the nodes) and is refined by Newton steps on s(t) - s = 0, where s(t) is the
table value at the node below plus a Gauss-Legendre integral up to t, safeguarded by
bisection inside the node interval until |s(t) - s| <= 1e-12 of the length. Everything is vectorised
over curves and samples; the speed function receives the curve index array and the parameter
array (broadcastable) and returns sigma. :func:`arc_length_derivatives` turns derivatives
w.r.t. the parameter into derivatives w.r.t. s (chain rule).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

SpeedFn = Callable[[np.ndarray, np.ndarray], np.ndarray]

TABLE_INTERVALS = 32
_GL_TABLE = np.polynomial.legendre.leggauss(8)
_GL_NEWTON = np.polynomial.legendre.leggauss(6)
NEWTON_STEPS = 1  # Newton steps always taken; then safeguarded steps until |ds| <= 1e-12 L
MAX_STEPS = 80


@dataclass(frozen=True)
class ArcLengthTable:
    """s(t) at equally spaced parameter nodes of ``m`` curves.

    t_end : (m,) parameter range [0, t_end]
    s_nodes : (m, N+1) arc length at t_k = t_end k / N [m] (s_nodes[:, -1] is the length)
    sigma_nodes : (m, N+1) speed |dp/dt| at the nodes
    """

    t_end: np.ndarray
    s_nodes: np.ndarray
    sigma_nodes: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return self.s_nodes[:, -1]


def build_table(speed: SpeedFn, t_end: np.ndarray, intervals: int = TABLE_INTERVALS
                ) -> ArcLengthTable:
    """Tabulate s(t) = integral_0^t sigma (Eq. 3.23) for every curve (vectorised)."""
    t_end = np.asarray(t_end, dtype=float)
    m = len(t_end)
    h = t_end / intervals  # (m,)
    x, w = _GL_TABLE
    k = np.arange(intervals)
    # quadrature points (m, N, g)
    t = (k[None, :, None] + 0.5 * (x[None, None, :] + 1.0)) * h[:, None, None]
    j = np.arange(m)[:, None, None]
    sig = speed(j, t)
    inc = 0.5 * h[:, None] * np.einsum("mng,g->mn", sig, w)
    s_nodes = np.zeros((m, intervals + 1))
    np.cumsum(inc, axis=1, out=s_nodes[:, 1:])
    tn = np.arange(intervals + 1)[None, :] * h[:, None]
    sigma_nodes = speed(np.arange(m)[:, None], tn)
    return ArcLengthTable(t_end=t_end, s_nodes=s_nodes, sigma_nodes=sigma_nodes)


def invert(speed: SpeedFn, table: ArcLengthTable, j: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Parameter t of curve ``j[i]`` at arc length ``s[i]`` (0 <= s <= length), vectorised:
    node interval, cubic Hermite first guess, safeguarded Newton steps on s(t) - s = 0."""
    j = np.asarray(j, dtype=np.intp)
    s = np.asarray(s, dtype=float)
    length = table.length[j]
    s = np.clip(s, 0.0, length)
    k = _node_interval(table, j, s, length)
    h = table.t_end[j] / (table.s_nodes.shape[1] - 1)
    t0 = k * h
    t = _hermite_guess(table, j, s, k, t0, h)
    tol = 1e-12 * length + 1e-300
    t = _refine(speed, j, s, table.s_nodes[j, k], t0, h, t, tol)
    return np.clip(t, 0.0, table.t_end[j])


def _node_interval(table: ArcLengthTable, j: np.ndarray, s: np.ndarray, length: np.ndarray
                   ) -> np.ndarray:
    """Index k of the table interval [s_k, s_k+1] of curve j that holds s."""
    n_int = table.s_nodes.shape[1] - 1
    # search a globally monotone key j + s/length (in [j, j+1])
    with np.errstate(invalid="ignore", divide="ignore"):
        frac_nodes = table.s_nodes / table.length[:, None]
        frac = np.where(length > 0, s / length, 0.0)
    keys = (np.arange(len(table.t_end))[:, None] * 2.0 + frac_nodes).ravel()
    flat = np.searchsorted(keys, j * 2.0 + frac, side="right") - 1
    k = np.clip(flat - j * (n_int + 1), 0, n_int - 1)
    # the key loses ~1e-12 relative precision for large j: settle ties on the true s
    k = np.where((s < table.s_nodes[j, k]) & (k > 0), k - 1, k)
    return np.where((s > table.s_nodes[j, k + 1]) & (k < n_int - 1), k + 1, k)


def _hermite_guess(table: ArcLengthTable, j: np.ndarray, s: np.ndarray, k: np.ndarray,
                   t0: np.ndarray, h: np.ndarray) -> np.ndarray:
    """t(s) by the cubic Hermite interpolant of the table on the node interval (slopes
    dt/ds = 1/sigma at the nodes)."""
    s0 = table.s_nodes[j, k]
    s1 = table.s_nodes[j, k + 1]
    ds = s1 - s0
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = np.where(ds > 0, (s - s0) / ds, 0.0)
    m0 = ds / table.sigma_nodes[j, k]  # dt/dtau at the ends
    m1 = ds / table.sigma_nodes[j, k + 1]
    tau2, tau3 = tau * tau, tau * tau * tau
    return (
        t0 * (2 * tau3 - 3 * tau2 + 1)
        + m0 * (tau3 - 2 * tau2 + tau)
        + (t0 + h) * (-2 * tau3 + 3 * tau2)
        + m1 * (tau3 - tau2)
    )


def _refine(speed: SpeedFn, j: np.ndarray, s: np.ndarray, s0: np.ndarray, t0: np.ndarray,
            h: np.ndarray, t: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """Newton steps on s(t) - s = 0 from ``t`` (``NEWTON_STEPS`` always, then until
    |s(t) - s| <= tol), s(t) = s0 + Gauss-Legendre integral of sigma over [t0, t], bisecting
    inside the node interval [t0, t0 + h] whenever a step would leave the bracket."""
    x, w = _GL_NEWTON
    lo, hi = t0.copy(), t0 + h  # t(s) lies in the node interval: safeguard bracket
    todo = np.arange(s.size)
    for it in range(MAX_STEPS):
        ta, t0a, ja = t[todo], t0[todo], j[todo]
        half = 0.5 * (ta - t0a)
        # quadrature nodes on [t0, t] and t itself in one speed call
        tq = np.empty((ta.size, x.size + 1))
        tq[:, :-1] = t0a[:, None] + half[:, None] * (x[None, :] + 1.0)
        tq[:, -1] = ta
        sig = speed(ja[:, None], tq)
        res = s0[todo] + half * (sig[:, :-1] @ w) - s[todo]
        sig_t = sig[:, -1]
        if it >= NEWTON_STEPS:  # check convergence only after the usual steps
            bad = np.abs(res) > tol[todo]
            todo, ta, res, sig_t = todo[bad], ta[bad], res[bad], sig_t[bad]
            if not todo.size:
                break
        lo[todo] = np.where(res < 0, ta, lo[todo])
        hi[todo] = np.where(res > 0, ta, hi[todo])
        step = ta - res / sig_t
        inside = (step >= lo[todo]) & (step <= hi[todo])
        t[todo] = np.where(inside, step, 0.5 * (lo[todo] + hi[todo]))
    return t


def arc_length(speed: SpeedFn, j: np.ndarray, t: np.ndarray, table: ArcLengthTable
               ) -> np.ndarray:
    """s(t) for curves ``j`` at parameters ``t`` (table node below + Gauss-Legendre)."""
    j = np.asarray(j, dtype=np.intp)
    t = np.asarray(t, dtype=float)
    n_int = table.s_nodes.shape[1] - 1
    h = table.t_end[j] / n_int
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.clip(np.floor(np.where(h > 0, t / h, 0.0)).astype(np.intp), 0, n_int - 1)
    t0 = k * h
    x, w = _GL_TABLE
    half = 0.5 * (t - t0)
    tq = t0[:, None] + half[:, None] * (x[None, :] + 1.0)
    return table.s_nodes[j, k] + half * (speed(j[:, None], tq) @ w)


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
