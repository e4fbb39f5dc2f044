"""Sums over the axial slices in the cut, O(1) per tooth and rotation angle (thesis Algorithm 1).

The milling force of Algorithm 1 at rotation angle phi of tooth 1 is a sum over teeth t and
axial slices j of height da whose angle ``theta = mod(phi + t p - lag_j, 2 pi)`` (pitch
p = 2 pi / N, helix lag ``lag_j = rate ((j + 1/2) da)``, rate = 2 tan(beta) / D) satisfies
``entry <= theta < exit``. It needs five sums over the slices in the cut::

    b = sum [1, sin theta, cos theta, sin theta cos theta, sin^2 theta]

The lags are increasing in j, so at fixed (t, phi) the slices in the cut form one contiguous
run of j per turn r of the unwrapped angle ``phi + t p - lag_j`` (r = 0, 1, ... revolutions),
and with omega_j = t p - lag_j the sums follow from prefix sums over j of
``[cos omega, sin omega, cos 2 omega, sin 2 omega]`` by the angle-addition identities
(sin theta cos theta = sin 2 theta / 2, sin^2 theta = (1 - cos 2 theta) / 2).

The ends of each run are located arithmetically, ``j ~ (phi + t p - 2 pi r - bound) / (rate da)
- 1/2``, and wherever that estimate is within rounding of a slice the end is settled by the
exact floating-point in-cut test of the direct summation (the same operations, so a slice at a
critical angle of :func:`feedopt.process.forces.critical_angles` is classified identically).
Cost: O(L) per sample for its prefix table, then O(1) per tooth and angle (was O(L)).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Flutes", "in_cut_sum_blocks", "in_cut_sums", "rows_matmul", "settle_critical",
           "slice_lags"]

_TWO_PI = 2.0 * math.pi
_INV_TWO_PI = 1.0 / _TWO_PI
# Elements (teeth x samples x angles) per block: ~0.25 MB work arrays, reused block to block.
_BLOCK = 1 << 15
# Rows per product of rows_matmul.
_MATMUL_ROWS = 8192


@dataclass(frozen=True)
class Flutes:
    """The cutter as the slice sums see it.

    Attributes
    ----------
    teeth : number N of teeth
    pitch : tooth pitch 2 pi / N [rad], the tool's own float
    rate : helix lag per unit height 2 tan(beta) / D [rad/m]
    slices : number L of axial slices
    """

    teeth: int
    pitch: float
    rate: float
    slices: int


def slice_lags(rate: float, height: np.ndarray | float, j: np.ndarray | float) -> np.ndarray:
    """Helix lag ``rate * ((j + 1/2) * height)`` of slice(s) ``j`` [rad] (broadcasting).

    The one floating-point definition of the lags: the in-cut test at a boundary depends on
    these exact operations.
    """
    return rate * ((j + 0.5) * height)


def settle_critical(target: np.ndarray, lag: np.ndarray, interval: tuple[np.ndarray, np.ndarray],
                    pitch: float, teeth: int) -> np.ndarray:
    """Rotation angles of tooth 1 in one pitch at which a slice of lag ``lag`` is at
    ``target`` (an entry, or an exit less a backoff), all arrays of one shape, such that the
    in-cut test ``lo <= mod(phi + t pitch - lag, 2 pi) < hi`` of the force sums holds there
    (``interval`` = (lo, hi); lo >= hi: not cutting, left as is): the exact arithmetic of the
    sums for the tooth that reaches the target, nudged forward by a few ulps where rounding
    would put the slice just outside."""
    lo, hi = interval
    phi = np.mod(target + lag, pitch)
    cutting = lo < hi
    for _ in range(8):
        phi = np.where(phi >= pitch, phi - pitch, phi)
        tooth = np.mod(np.rint((target + lag - phi) / pitch), teeth)
        theta = np.mod(phi + tooth * pitch - lag, _TWO_PI)
        bad = cutting & ~((theta >= lo) & (theta < hi))
        if not bad.any():
            break
        # signed shortfall to the target, wrapped to (-pi, pi], plus a few ulps
        short = np.mod(target - theta + math.pi, _TWO_PI) - math.pi
        step = np.maximum(short, 0.0) + 4.0 * np.spacing(_TWO_PI + lag)
        phi = np.where(bad, phi + step, phi)
    return phi


def in_cut_sums(phi: np.ndarray, entry: np.ndarray, exit_: np.ndarray, height: np.ndarray,
                flutes: Flutes) -> np.ndarray:
    """Slice sums ``[1, sin, cos, sin cos, sin^2]`` of the slices in the cut, shape (5, c, k).

    Parameters
    ----------
    phi : (c, k) rotation angles of tooth 1 per sample [rad].
    entry, exit_ : (c,) immersion interval per sample [rad], 0 <= entry <= exit_ <= pi.
    height : (c,) slice height da = a / L per sample [m] (not multiplied in).
    flutes : teeth, pitch, helix rate and slice count.
    """
    out = np.empty((5,) + phi.shape)
    for rows, b in in_cut_sum_blocks(phi, entry, exit_, height, flutes):
        out[:, rows] = b
    return out


def in_cut_sum_blocks(phi: np.ndarray, entry: np.ndarray, exit_: np.ndarray,
                      height: np.ndarray, flutes: Flutes, max_rows: int | None = None
                      ) -> Iterator[tuple[slice, np.ndarray]]:
    """:func:`in_cut_sums` block by block: yields ``(rows, sums of those rows (5, r, k))``.

    Blocks hold ~32 k elements (teeth x rows x angles; measured fastest: the work arrays stay
    in cache) and at most ``max_rows`` rows. The work arrays, the yielded sums among them,
    are reused by the next block so that a long call touches fresh memory once: use the sums
    before advancing.
    """
    c, k = phi.shape
    rows = max(1, _BLOCK // max(1, k * flutes.teeth))
    rows = min(rows, max_rows) if max_rows else rows
    ws = _Workspace()
    for start in range(0, c, rows):
        sl = slice(start, min(start + rows, c))
        args = (phi[sl], entry[sl], exit_[sl], height[sl], flutes, ws)
        if flutes.rate == 0.0 or flutes.slices == 1:  # one lag per sample: slices cut together
            yield sl, _same_lag_sums(*args)
        else:
            yield sl, _block_sums(*args)


@dataclass
class _Workspace:
    """Named flat buffers handed out as views of the requested shape (grown when too small):
    fresh pages cost a fault each, so blocks reuse them."""

    buffers: dict[str, np.ndarray] = field(default_factory=dict)

    def get(self, name: str, shape: tuple[int, ...], dtype: type = float) -> np.ndarray:
        size = math.prod(shape)
        buf = self.buffers.get(name)
        if buf is None or buf.size < size:
            buf = self.buffers[name] = np.empty(size, dtype=dtype)
        return buf[:size].reshape(shape)


def _same_lag_sums(phi: np.ndarray, entry: np.ndarray, exit_: np.ndarray, height: np.ndarray,
                   flutes: Flutes, ws: _Workspace) -> np.ndarray:
    """:func:`in_cut_sums` when every slice of a sample has the same lag (straight teeth or
    one slice): one in-cut test per tooth, weight L."""
    lag = slice_lags(flutes.rate, height, 0.0)[:, None]
    st, ex = entry[:, None], exit_[:, None]
    b = ws.get("b", (5,) + phi.shape)
    b.fill(0.0)
    for tooth in range(flutes.teeth):
        theta = np.mod(phi + tooth * flutes.pitch - lag, _TWO_PI)
        w = ((theta >= st) & (theta < ex)) * float(flutes.slices)
        s, co = _sin_cos(theta)
        ws_ = w * s
        b[0] += w
        b[1] += ws_
        b[2] += w * co
        b[3] += ws_ * co
        b[4] += ws_ * s
    return b


@dataclass(frozen=True)
class _Rows:
    """Per-sample constants of a block, shape (c,)."""

    entry: np.ndarray
    exit: np.ndarray
    height: np.ndarray
    tol: np.ndarray  # an end estimate u is settled exactly if |u - rint(u)| <= tol [slices]
    width: np.ndarray  # (exit - entry) / (rate da): run length in slices
    stride: int  # c N: prefix-table rows from one slice to the next


@dataclass(frozen=True)
class _Elements:
    """The (tooth, sample, angle) elements of one pass over a turn (broadcasting arrays)."""

    psi: np.ndarray  # phi + t p [rad]
    turn: np.ndarray  # turn r of the unwrapped slice angle summed in this pass
    row: np.ndarray  # sample of each element (index into _Rows)
    start: np.ndarray  # prefix-table row of g = 0 for the element's tooth and sample


def _block_sums(phi: np.ndarray, entry: np.ndarray, exit_: np.ndarray, height: np.ndarray,
                flutes: Flutes, ws: _Workspace) -> np.ndarray:
    """:func:`in_cut_sums` of one block of samples (helical teeth, L >= 2).

    Pass 0 sums, per (tooth, angle), the run on the highest turn that can reach the cut:
    ``top = floor((psi - lag_0 - entry + margin) / 2 pi)``. Lower turns add runs only where
    the lags span more than 2 pi - (exit - entry) (or come within the margin of it).
    """
    n_t, n_s = flutes.teeth, flutes.slices
    c, k = phi.shape
    shape = (n_t, c, k)
    lag = slice_lags(flutes.rate, height[:, None], np.arange(n_s))  # (c, L), increasing
    table = _prefix_table(lag, flutes, ws)
    psi = np.add(phi, (np.arange(n_t) * flutes.pitch)[:, None, None], out=ws.get("psi", shape))
    psi_max = float(np.abs(phi).max()) + _TWO_PI
    margin = 1e-9 * (1.0 + psi_max)  # on turns: >> rounding of psi - lag_j and of its wrap
    step = flutes.rate * height  # lag spacing rate da [rad]; below 1e-100: no estimate
    inv_step = np.divide(1.0, step, out=np.zeros_like(step), where=step > 1e-100)
    tol_rad = 1e-12 * (1.0 + psi_max + float(lag[:, -1].max()))  # ~1000x the rounding
    rows = _Rows(entry, exit_, height, np.where(inv_step > 0, tol_rad * inv_step, np.inf),
                 (exit_ - entry) * inv_step, c * n_t)
    frac = np.subtract(psi, (lag[:, 0] + entry - margin)[:, None], out=ws.get("frac", shape))
    frac *= _INV_TWO_PI
    top = np.floor(frac, out=ws.get("top", shape))
    frac -= top
    # run end on turn top: u = (psi - 2 pi top - entry) / step + 1/2, slices j < u at or past
    u = np.multiply(frac, (_TWO_PI * inv_step)[:, None], out=ws.get("u", shape))
    u += ((lag[:, 0] - margin) * inv_step + 0.5)[:, None]
    start = (np.arange(c) * n_t + np.arange(n_t)[:, None])[:, :, None]  # (N, c, 1)
    count, sums = _run_sums(_Elements(psi, top, np.arange(c)[None, :, None], start), u, rows,
                            table, flutes, ws)
    reach = (lag[:, -1] - lag[:, 0] + exit_ - entry + 2.0 * margin) * _INV_TWO_PI
    turn = 1
    while turn < reach.max():  # turn top - r reaches the cut only where frac < reach - r
        idx = np.flatnonzero(frac < (reach - turn)[:, None])
        tooth_sample = idx // k
        els = _Elements(psi.reshape(-1)[idx], top.reshape(-1)[idx] - turn, tooth_sample % c,
                        start.reshape(-1)[tooth_sample])
        u_turn = u.reshape(-1)[idx] + turn * _TWO_PI * inv_step[els.row]
        more_count, more = _run_sums(els, u_turn, rows, table, flutes, _Workspace())
        count.reshape(-1)[idx] += more_count
        sums.reshape(-1, 4)[idx] += more
        turn += 1
    return _combine(phi, np.sum(count, axis=0), np.sum(sums, axis=0), ws)


def _prefix_table(lag: np.ndarray, flutes: Flutes, ws: _Workspace) -> np.ndarray:
    """Prefix sums over j of ``[cos w, sin w, cos 2w, sin 2w]`` with w = t p - lag_j per tooth
    t and sample s, shape ((L + 1) c N, 4): row ``(g c + s) N + t`` holds the sums over j < g.

    The prefix sums of ``[cos, sin, cos 2, sin 2]`` of the lags, rotated to each tooth by
    one (4, 4 N) product (angle-difference identities)."""
    c, n_s = lag.shape
    n_t = flutes.teeth
    part = ws.get("table_part", (n_s, c, 4))
    sl, cl = _sin_cos(lag.T)  # (L, c)
    part[..., 0], part[..., 1] = cl, sl
    np.multiply(2.0 * sl, cl, out=part[..., 3])
    np.multiply(cl - sl, cl + sl, out=part[..., 2])
    prefix = ws.get("table_prefix", (n_s + 1, c, 4))
    prefix[0] = 0.0
    for j in range(n_s):  # L vector adds: faster than cumsum along a short axis
        np.add(prefix[j], part[j], out=prefix[j + 1])
    rotation = np.zeros((4, n_t, 4))
    for t in range(n_t):
        a = t * flutes.pitch
        ca, sa, c2a, s2a = math.cos(a), math.sin(a), math.cos(2.0 * a), math.sin(2.0 * a)
        rotation[:2, t, :2] = [[ca, sa], [sa, -ca]]  # cos(a - l), sin(a - l) from cos l, sin l
        rotation[2:, t, 2:] = [[c2a, s2a], [s2a, -c2a]]
    table = ws.get("table", ((n_s + 1) * c, n_t * 4))
    rows_matmul(prefix.reshape(-1, 4), rotation.reshape(4, -1), table)
    return table.reshape(-1, 4)


def rows_matmul(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out = a @ b`` for a tall ``a`` (rows, p) and a small ``b`` (p, q), on blocks of
    8192 rows: larger products leave the cache and go multi-threaded in OpenBLAS, several
    times slower for these shapes on a loaded 2-core machine (and under feedopt's threads)."""
    for start in range(0, a.shape[0], _MATMUL_ROWS):
        sl = slice(start, start + _MATMUL_ROWS)
        np.matmul(a[sl], b, out=out[sl])
    return out


def _run_sums(els: _Elements, u_entry: np.ndarray, rows: _Rows, table: np.ndarray,
              flutes: Flutes, ws: _Workspace) -> tuple[np.ndarray, np.ndarray]:
    """Number of slices in the cut on ``els.turn`` (the run ``g_exit <= j < g_entry``;
    ``u_entry`` estimates g_entry) and their sums ``[cos w, sin w, cos 2w, sin 2w]`` (shape
    + (4,)), from the prefix table."""
    shape = u_entry.shape
    i_entry = _run_end(els, u_entry, rows.entry, rows, flutes,
                       ws.get("i_entry", shape, np.intp), ws)
    u_exit = np.subtract(u_entry, rows.width[els.row], out=ws.get("u_exit", shape))
    i_exit = _run_end(els, u_exit, rows.exit, rows, flutes, ws.get("i_exit", shape, np.intp),
                      ws)
    count = np.subtract(i_entry, i_exit, out=ws.get("count", shape))
    count /= rows.stride  # exact whole numbers
    sums = np.take(table, i_entry, axis=0, out=ws.get("sums", shape + (4,)), mode="clip")
    sums -= np.take(table, i_exit, axis=0, out=ws.get("take", shape + (4,)), mode="clip")
    return count, sums


def _run_end(els: _Elements, u: np.ndarray, bound: np.ndarray, rows: _Rows, flutes: Flutes,
             out: np.ndarray, ws: _Workspace) -> np.ndarray:
    """Prefix-table row of the end g of the run: the number of slices j whose wrapped angle is
    at or past ``bound`` on ``els.turn`` (or on a later turn). The key ``(turn, mod(psi -
    lag_j, 2 pi))`` is non-increasing in j, so they are the j < g. ``u`` estimates g from the
    lag spacing: g = floor(u) clipped to [0, L], settled by the exact test where u is within
    rounding of a whole number. (Truncation of u clipped to [0, L + 1/2] is that floor.)"""
    shape = u.shape
    clipped = np.clip(u, 0.0, flutes.slices + 0.5, out=ws.get("clipped", shape))
    np.copyto(out, clipped, casting="unsafe")
    out *= rows.stride
    out += els.start
    dist = np.rint(u, out=ws.get("dist", shape))
    np.subtract(u, dist, out=dist)
    np.abs(dist, out=dist)
    near = np.flatnonzero(dist <= rows.tol[els.row])
    if near.size:
        row, start = _locate(els, shape, near)
        flat = els.psi.reshape(-1)[near], els.turn.reshape(-1)[near]
        settled = _settle(u.reshape(-1)[near], *flat, bound[row], rows.height[row],
                          rows.tol[row], flutes)
        out.reshape(-1)[near] = start + settled * rows.stride
    return out


def _locate(els: _Elements, shape: tuple[int, ...], near: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Sample and table start of the elements at flat indices ``near``: of a flat subset (1-d
    arrays), or of the full (N, c, k) grid (``row`` (1, c, 1), ``start`` (N, c, 1))."""
    if els.row.ndim == 1:
        return els.row[near], els.start[near]
    tooth_sample = near // shape[2]
    return tooth_sample % shape[1], els.start.reshape(-1)[tooth_sample]


def _settle(u: np.ndarray, psi: np.ndarray, turn: np.ndarray, bound: np.ndarray,
            height: np.ndarray, tol: np.ndarray, flutes: Flutes) -> np.ndarray:
    """Exact run ends g near their estimates ``u``: with u off by < 1/4 slice, g is j or j + 1
    for the slice j = rint(u) - 1 next to u, j + 1 iff j is at or past the bound. Where the
    rounding reaches 1/4 slice (``tol``, tiny slices) walk to the end one slice at a time."""
    n_s = flutes.slices
    j = np.clip(np.rint(u) - 1.0, 0.0, n_s - 1.0).astype(np.intp)
    g = j + _at_or_past(psi, j, turn, bound, height, flutes)
    wide = np.flatnonzero(tol >= 0.25)
    if wide.size:
        g[wide] = _walk(g[wide], psi[wide], turn[wide], bound[wide], height[wide], flutes)
    return g


def _walk(g: np.ndarray, psi: np.ndarray, turn: np.ndarray, bound: np.ndarray,
          height: np.ndarray, flutes: Flutes) -> np.ndarray:
    """Move each end ``g`` one slice at a time until ``_at_or_past`` holds for j < g only."""
    n_s = flutes.slices
    for _ in range(n_s + 1):
        down = (g > 0) & ~_at_or_past(psi, np.maximum(g - 1, 0), turn, bound, height, flutes)
        up = (g < n_s) & _at_or_past(psi, np.minimum(g, n_s - 1), turn, bound, height, flutes)
        if not (down.any() or up.any()):
            break
        g = g + up - down
    return g


def _at_or_past(psi: np.ndarray, j: np.ndarray, turn: np.ndarray, bound: np.ndarray,
                height: np.ndarray, flutes: Flutes) -> np.ndarray:
    """Exact test: slice j's angle ``mod(psi - lag_j, 2 pi)`` (the floats of the direct
    summation; one conditional shift, which equals np.mod on [-2 pi, 4 pi)) is on a later turn
    than ``turn``, or on it and ``>= bound``."""
    raw = psi - slice_lags(flutes.rate, height, j)
    theta = np.where(raw >= _TWO_PI, raw - _TWO_PI, np.where(raw < 0.0, raw + _TWO_PI, raw))
    far = np.flatnonzero((raw < -_TWO_PI) | (raw >= 2.0 * _TWO_PI))
    if far.size:
        theta[far] = np.mod(raw[far], _TWO_PI)
    wraps = np.rint((raw - theta) * _INV_TWO_PI)
    return (wraps > turn) | ((wraps == turn) & (theta >= bound))


def _combine(phi: np.ndarray, count: np.ndarray, sums: np.ndarray, ws: _Workspace) -> np.ndarray:
    """(5, c, k) slice sums ``[1, sin, cos, sin cos, sin^2]`` of theta = phi + w from the
    number of slices in the cut ``count`` (c, k) and their sums ``[cos w, sin w, cos 2w,
    sin 2w]`` (c, k, 4): angle-addition identities."""
    sp, cp = _sin_cos(phi)
    s2p, c2p = 2.0 * sp * cp, (cp - sp) * (cp + sp)
    cw, sw, c2w, s2w = (sums[..., i] for i in range(4))
    b = ws.get("b", (5,) + phi.shape)
    tmp = ws.get("combine", phi.shape)
    b[0] = count
    np.multiply(sp, cw, out=b[1])
    b[1] += np.multiply(cp, sw, out=tmp)
    np.multiply(cp, cw, out=b[2])
    b[2] -= np.multiply(sp, sw, out=tmp)
    np.multiply(s2p, c2w, out=b[3])
    b[3] += np.multiply(c2p, s2w, out=tmp)
    b[3] *= 0.5
    np.multiply(c2p, c2w, out=b[4])
    b[4] -= np.multiply(s2p, s2w, out=tmp)
    np.subtract(count, b[4], out=b[4])
    b[4] *= 0.5
    return b


def _sin_cos(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin x and cos x from t = tan(x / 2), to a few ulps absolute (numpy's float64 tan is
    vectorised, its sin and cos are ~10x slower)."""
    t = np.tan(0.5 * x)
    t2 = t * t
    inv = 1.0 + t2
    np.divide(1.0, inv, out=inv)
    t *= 2.0
    t *= inv
    np.subtract(1.0, t2, out=t2)
    t2 *= inv
    return t, t2
