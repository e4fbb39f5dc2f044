"""The numerics kernel of the timing laws: quintic Hermite pieces and piecewise polynomials.

Every law's ``s(t)`` and toppra's joint path ``q(s)`` are piecewise polynomials stored the
way :class:`scipy.interpolate.PPoly` stores them: coefficients ``c`` of shape ``(k+1, m,
...)``, highest power first, each piece in its local variable ``x - x_i``. scipy evaluates and
differentiates whole PPoly objects; this module holds what it does not offer, in one place:

* :func:`quintic_hermite` / :func:`quintic_hermite_spline`: the quintic meeting value, first
  and second derivative at both ends of a piece (thesis Eq. 3.21-3.22);
* :func:`horner`: evaluation of per-piece coefficients at per-piece points (numpy's
  ``polyval`` takes one polynomial, not one per column), and :func:`derivative_coefficients`;
* :func:`bisect_increasing`: the vectorised inverse of increasing pieces (``s -> t``);
* :func:`sample_pieces`: the same points in every piece (for extrema and dense checks).

The Horner loop starts from zeros and adds one row at a time, the rounding every caller had
before the kernel existed (inverting a flat s(t) near a rest end amplifies an ulp of change).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np


def quintic_hermite(
    T: np.ndarray | float,
    dp: np.ndarray | float,
    v0: np.ndarray | float,
    v1: np.ndarray | float,
    a0: np.ndarray | float,
    a1: np.ndarray | float,
    p0: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Coefficients of the quintic on ``[0, T]`` meeting the six end conditions of Eq. 3.22.

    ``p(0) = p0``, ``p(T) = p0 + dp``, ``p'(0) = v0``, ``p'(T) = v1``, ``p''(0) = a0``,
    ``p''(T) = a1`` (thesis Eq. 3.21-3.22 with p = s and T = t_f; the same conditions give
    toppra's joint path q(s) through the samples).

    Parameters
    ----------
    T : array_like
        Piece widths (duration, or arc length for q(s)); positive. When it has fewer
        dimensions than the end values it is broadcast along their leading axes (one width
        per piece for ``(m, dof)`` joint values).
    dp : array_like
        Rise ``p(T) - p(0)`` of each piece (passed directly, not as ``p1 - p0``, so that a
        piece of known length keeps it to the last bit).
    v0, v1, a0, a1 : array_like
        First and second derivatives at both ends.
    p0 : array_like
        Value at the start (the constant coefficient).

    Returns
    -------
    (6, ...) array
        Coefficients, highest power first (PPoly order), in the local variable.

    Notes
    -----
    The powers of ``T`` are products of ``T2 = T * T`` (not ``T**3`` ...: numpy's ``power``
    rounds differently); the thesis and constant laws' numbers depend on that rounding.
    """
    ends = [np.atleast_1d(np.asarray(x, dtype=float)) for x in (dp, v0, v1, a0, a1, p0)]
    T = np.atleast_1d(np.asarray(T, dtype=float))
    ndim = max(x.ndim for x in ends)
    if T.ndim < ndim:
        T = T.reshape(T.shape + (1,) * (ndim - T.ndim))
    T, dp, v0, v1, a0, a1, p0 = np.broadcast_arrays(T, *ends)
    T2 = T * T
    c3 = (20 * dp - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T2) / (2 * T2 * T)
    c4 = (-30 * dp + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T2) / (2 * T2 * T2)
    c5 = (12 * dp - 6 * (v1 + v0) * T - (a0 - a1) * T2) / (2 * T2 * T2 * T)
    return np.stack([c5, c4, c3, 0.5 * a0, v0, p0])


def quintic_hermite_spline(
    h: np.ndarray, p: np.ndarray, v: np.ndarray, a: np.ndarray
) -> np.ndarray:
    """Coefficients of the C2 quintic spline through knots with given p, p' and p''.

    Parameters
    ----------
    h : (m,) array
        Widths of the ``m`` pieces (the knots are ``x_0 + cumsum(h)``).
    p, v, a : (m+1, ...) arrays
        Value, first and second derivative at the knots (a trailing axis: several curves,
        e.g. the joints of q(s)).

    Returns
    -------
    (6, m, ...) array
        PPoly coefficients of the pieces (:func:`quintic_hermite` on each knot pair).
    """
    p, v, a = (np.asarray(x, dtype=float) for x in (p, v, a))
    return quintic_hermite(h, p[1:] - p[:-1], v[:-1], v[1:], a[:-1], a[1:], p[:-1])


def derivative_coefficients(c: np.ndarray, order: int = 1) -> np.ndarray:
    """Coefficients of the ``order``-th derivative of polynomials stored along axis 0.

    ``c`` is ``(k+1, ...)``, highest power first; the result is ``(k+1-order, ...)`` (one
    zero row when ``order > k``), as :meth:`scipy.interpolate.PPoly.derivative` computes it.
    """
    c = np.asarray(c, dtype=float)
    k = c.shape[0] - 1
    if order > k:
        return np.zeros((1,) + c.shape[1:])
    if order <= 0:
        return c
    powers = np.arange(k, order - 1, -1, dtype=float)  # power of each kept row
    factor = np.ones_like(powers)
    for j in range(order):
        factor *= powers - j
    return c[: k + 1 - order] * factor.reshape((-1,) + (1,) * (c.ndim - 1))


def horner(c: np.ndarray, x: np.ndarray | float) -> np.ndarray:
    """Evaluate polynomials with coefficients ``c`` (axis 0, highest power first) at ``x``.

    ``c[:, ...]`` and ``x`` broadcast against each other: ``c`` of shape ``(k+1, m)`` with
    ``x`` of shape ``(m,)`` evaluates piece ``i`` at ``x[i]``; with ``x`` of shape ``(p, 1)``
    every piece at all ``p`` points (result ``(p, m)``).
    """
    x = np.asarray(x)
    val = np.zeros(np.broadcast_shapes(x.shape, np.shape(c)[1:]))
    for row in c:
        val = val * x + row
    return val


def bisect_increasing(
    c: np.ndarray,
    target: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    steps: int,
    origin: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bracket where increasing polynomials reach ``target`` by ``steps`` bisections.

    Parameters
    ----------
    c : (k+1, n) array
        One polynomial per target (highest power first), in the variable ``x - origin``.
    target : (n,) array
        Values to reach.
    lo, hi : (n,) arrays
        Initial bracket (``p(lo) <= target <= p(hi)``).
    steps : int
        Number of halvings (the bracket shrinks by 2^-steps).
    origin : (n,) array, optional
        Start of each polynomial's local variable (PPoly breakpoints); default 0.

    Returns
    -------
    lo, hi : (n,) arrays
        Final bracket: ``p(lo) < target <= p(hi)`` wherever the polynomial is increasing,
        so ``hi`` is the earliest point reaching the target, to 2^-steps of the bracket.
    """
    lo = np.array(lo, dtype=float)
    hi = np.array(hi, dtype=float)
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        val = horner(c, mid if origin is None else mid - origin)
        below = val < target
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return lo, hi


#: Polynomial pieces per chunk of :func:`sample_piece_chunks`: 32768 x 9 points, 2.4 MB an
#: array, where a law with a piece per path sample has 9e6 points at 1e6 samples.
PIECES_PER_CHUNK = 1 << 15


def sample_piece_chunks(breaks: np.ndarray, points: int,
                        pieces: int | None = None) -> Iterator[np.ndarray]:
    """:func:`sample_pieces` (with ``endpoint``) of ``pieces`` pieces at a time (default
    :data:`PIECES_PER_CHUNK`): the chunks joined are that array, value for value, but never
    held at once."""
    breaks = np.asarray(breaks, dtype=float)
    pieces = pieces or PIECES_PER_CHUNK
    for start in range(0, breaks.size - 1, pieces):
        yield sample_pieces(breaks[start:min(start + pieces, breaks.size - 1) + 1], points)


def sample_pieces(breaks: np.ndarray, points: int, endpoint: bool = True) -> np.ndarray:
    """The same ``points`` relative positions in every piece between ``breaks``, flattened.

    With ``endpoint`` each piece gets ``linspace(0, 1, points)`` (both ends, so interior
    breakpoints appear twice: once as the end of a piece, once as the start of the next);
    without it ``linspace(0, 1, points, endpoint=False)`` and the last breakpoint once at the
    end.
    """
    breaks = np.asarray(breaks, dtype=float)
    u = np.linspace(0.0, 1.0, points, endpoint=endpoint)
    t = (breaks[:-1, None] + np.diff(breaks)[:, None] * u[None, :]).ravel()
    return t if endpoint else np.append(t, breaks[-1])
