"""Joint acceleration limits of the node model that hold between the samples (Bernstein rows).

The ``convex`` law's SOCP (Verscheure et al. 2009) has its variables at solver gridpoints:
a_k = sddot and b_k = sdot^2, with sddot linear in s on each grid interval. Imposing the joint
accelerations |q'(s) sddot + q''(s) sdot^2| <= limit at the gridpoints alone leaves them
free in between, where a corner shorter than a sample makes q'' spike. Here every grid
interval is cut at the path samples into cells; on a cell q' (cubic), q'' (quadratic), sddot
(linear) and sdot^2 (quadratic) are polynomials, so the joint acceleration is a quartic whose
Bernstein coefficients are linear in (a_k, a_k+1, b_k). A polynomial lies within the range of
its Bernstein coefficients (Farin, *Curves and Surfaces for CAGD*, ch. 5), so bounding them
bounds the joint acceleration on the whole cell: :func:`node_model_rows`.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

from feedopt.schedule.joints import IntervalPeaks, bernstein_ascending, rate_pieces
from feedopt.schedule.polynomial import derivative_coefficients, horner
from feedopt.schedule.problem import ScheduleProblem


def _shifted(c: np.ndarray, order: int, x0: np.ndarray) -> np.ndarray:
    """Ascending coefficients in ``tau`` of the ``order``-th derivative of the PPoly pieces
    ``c`` (k+1, m, dof) at ``x0 + tau`` (Taylor expansion at ``x0`` (m,), exact)."""
    degree = c.shape[0] - 1 - order
    x = np.asarray(x0, dtype=float)[:, None]
    return np.stack([horner(derivative_coefficients(c, order + r), x) / factorial(r)
                     for r in range(degree + 1)])


def _times(p: np.ndarray, q: list) -> np.ndarray:
    """Ascending coefficients of ``p`` (k+1, m, dof) times the polynomial ``q`` (a list of
    (m,) ascending coefficients), padded to degree 4."""
    out = np.zeros((5,) + p.shape[1:])
    for i in range(p.shape[0]):
        for j, qj in enumerate(q):
            out[i + j] += p[i] * np.asarray(qj)[:, None]
    return out


@dataclass(frozen=True)
class JointRows:
    """Linear constraints ``-1 <= ca a[ia] + ca1 a[ia1] + cb b[ib] <= 1`` (one per row) on
    the node values of a solver grid (a = sddot, b = sdot^2 at the gridpoints), each a
    Bernstein coefficient of one joint's acceleration on one cell over its limit
    (:func:`node_model_rows`)."""

    ia: np.ndarray
    ca: np.ndarray
    ia1: np.ndarray
    ca1: np.ndarray
    ib: np.ndarray
    cb: np.ndarray

    def __len__(self) -> int:
        return int(self.ia.size)


@dataclass(frozen=True)
class NodeGrid:
    """A solver grid and what :func:`node_model_rows` needs of it, in the solver's units
    (``scale`` per metre: ``MM_PER_M`` for millimetres).

    s : (N+1,) gridpoints; b_int : (N,) bound on sdot^2 per grid interval; a_cap : bound on
    |sddot|; qdd_max : (dof,) joint acceleration limits [rad/s^2]; rest_start / rest_end :
    the first / last grid interval starts / ends at rest (constant jerk there, not the node
    model)."""

    s: np.ndarray
    b_int: np.ndarray
    a_cap: float
    qdd_max: np.ndarray
    rest_start: bool
    rest_end: bool
    scale: float = 1.0


def _cells(s: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, ...]:
    """Cells between the union of samples and gridpoints: start, width, sample interval and
    grid interval of each."""
    edges = np.unique(np.concatenate([s, grid]))
    edges = edges[(edges >= grid[0]) & (edges <= grid[-1])]
    mid = 0.5 * (edges[:-1] + edges[1:])
    i = np.clip(np.searchsorted(s, mid, side="right") - 1, 0, s.size - 2)
    k = np.clip(np.searchsorted(grid, mid, side="right") - 1, 0, grid.size - 2)
    return edges[:-1], np.diff(edges), i, k


def node_model_rows(problem: ScheduleProblem, grid: NodeGrid,
                    peaks: IntervalPeaks) -> JointRows:
    """Joint acceleration constraints of the node model that hold between the samples too.

    The node model (Verscheure et al. 2009, as in :mod:`feedopt.schedule.convex`): on grid
    interval k, sddot is linear in s from a_k to a_k+1 and sdot^2 = b_k + 2 a_k u +
    (a_k+1 - a_k) u^2 / D (u = s - s_k, D its length). On every cell (a grid interval cut at
    the samples) q'(s) sddot + q''(s) sdot^2 is a quartic in s whose Bernstein coefficients
    are linear in (a_k, a_k+1, b_k): bounding them bounds the joint acceleration on the whole
    cell (convex hull property), not only at the gridpoints. On a grid interval that starts
    (ends) at rest the motion is a constant-jerk start (stop): |sddot| <= |a| and sdot^2 <= b
    at its other end, so |q' sddot + q'' sdot^2| <= max|q'| |a| + max|q''| b there.

    Only cells where a joint can reach its limit (max|q'| a_cap + max|q''| b_int >= limit,
    with ``peaks`` of the sample interval) get rows.
    """
    sc = grid.scale
    start, width, i, k = _cells(problem.s * sc, grid.s)
    p1 = peaks.dq_ds[i] / sc
    p2 = peaks.d2q_ds2[i] / sc**2
    reach = p1 * grid.a_cap + p2 * grid.b_int[k, None]
    risky = reach >= grid.qdd_max
    cell = np.flatnonzero(np.any(risky, axis=1))
    last = grid.s.size - 2
    rest = ((k[cell] == 0) & grid.rest_start) | ((k[cell] == last) & grid.rest_end)
    parts = [_rest_rows(cell[rest], k, p1, p2, risky, grid),
             _cell_rows(problem, cell[~rest], (start, width, i, k), risky, grid)]
    return JointRows(*(np.concatenate([p[f] for p in parts]) for f in range(6)))


def _rest_rows(cell: np.ndarray, k: np.ndarray, p1: np.ndarray, p2: np.ndarray,
               risky: np.ndarray, grid: NodeGrid) -> tuple[np.ndarray, ...]:
    """Rows ``+-max|q'| a + max|q''| b <= limit`` at the moving end of a rest piece."""
    c, j = np.nonzero(risky[cell])
    kk = k[cell][c]
    node = np.where(kk == 0, 1, kk)  # the end that moves
    lim = grid.qdd_max[j]
    a1, b1 = p1[cell[c], j] / lim, p2[cell[c], j] / lim
    zero = np.zeros_like(a1)
    return (np.concatenate([node, node]), np.concatenate([a1, -a1]),
            np.concatenate([node, node]), np.concatenate([zero, zero]),
            np.concatenate([node, node]), np.concatenate([b1, b1]))


def _cell_rows(problem: ScheduleProblem, cell: np.ndarray, cells: tuple,
               risky: np.ndarray, grid: NodeGrid) -> tuple[np.ndarray, ...]:
    """The five Bernstein rows per risky joint of each cell (see :func:`node_model_rows`)."""
    start, width, i, k = (x[cell] for x in cells)
    sc = grid.scale
    pieces = rate_pieces(problem, i, scale=sc)
    x0 = start - problem.s[i] * sc  # cell start within its sample interval
    q1, q2 = _shifted(pieces, 0, x0), _shifted(pieces, 1, x0)
    d = np.diff(grid.s)[k]
    u0 = start - grid.s[k]  # cell start within its grid interval
    f_b = _times(q2, [np.ones_like(d)])
    f_a = _times(q1, [1 - u0 / d, -1 / d]) + _times(q2, [2 * u0 - u0**2 / d, 2 - 2 * u0 / d,
                                                         -1 / d])
    f_a1 = _times(q1, [u0 / d, 1 / d]) + _times(q2, [u0**2 / d, 2 * u0 / d, 1 / d])
    c, j = np.nonzero(risky[cell])
    # the last coefficient is the value at the cell's end: the first of the next cell when
    # that one is in the same grid interval with rows for the joint (a duplicate row)
    nxt = np.minimum(cell[c] + 1, risky.shape[0] - 1)
    shared = (cell[c] + 1 < risky.shape[0]) & risky[nxt, j] & (cells[3][nxt] == k[c])
    use = np.ones((5, c.size), dtype=bool)
    use[4] = ~shared
    out = []
    for f in (f_a, f_a1, f_b):
        bern = bernstein_ascending(f, width) / grid.qdd_max  # (5, cells, dof)
        out.append(bern[:, c, j][use])
    kk = np.broadcast_to(k[c], use.shape)[use]
    return kk, out[0], kk + 1, out[1], kk, out[2]


def constant_accel_bernstein(problem: ScheduleProblem, grid: np.ndarray,
                             intervals: np.ndarray, scale: float = 1.0
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint acceleration of a law with constant sddot = u_k on each grid interval
    (toppra's output, sdot^2 = x_k + 2 u_k (s - s_k)) on the sample ``intervals``:
    q'(s) u_k + q''(s) (x_k + 2 u_k (s - s_k)) = u_k A(s) + x_k B(s), A and B cubics whose
    Bernstein coefficients (4, m, dof) are returned with the grid interval k (m,) of each
    sample interval. ``grid`` holds the gridpoints' sample indices; s in ``1 / scale`` m."""
    k = np.searchsorted(grid, intervals, side="right") - 1
    pieces = rate_pieces(problem, intervals, scale=scale)
    q1, q2 = pieces[::-1], derivative_coefficients(pieces)[::-1]  # ascending
    u0 = (problem.s[intervals] - problem.s[grid[k]]) * scale
    f_a = _times(q1, [np.ones_like(u0)]) + _times(q2, [2 * u0, 2 * np.ones_like(u0)])
    f_b = _times(q2, [np.ones_like(u0)])
    h = (problem.s[intervals + 1] - problem.s[intervals]) * scale
    return bernstein_ascending(f_a[:4], h), bernstein_ascending(f_b[:4], h), k


def constant_accel_ratio(problem: ScheduleProblem, grid: np.ndarray, x: np.ndarray,
                         u: np.ndarray, chunk: int = 1 << 14) -> float:
    """Largest |joint acceleration| / limit of the constant-sddot law (``x`` = sdot^2 at the
    gridpoints, ``u`` = sddot per grid interval, SI) over every sample interval: an upper
    bound, exact at the samples. Its value at the start of every interval is a lower bound
    of the maximum; the Bernstein coefficients of :func:`constant_accel_bernstein` are taken
    only on intervals whose cheap bound (``problem.joint_screen`` with |u| and the larger
    sdot^2 of the interval's ends) exceeds it."""
    limit = np.asarray(problem.joint_acceleration_max, dtype=float)
    i = np.arange(problem.n - 1)
    k = np.searchsorted(grid, i, side="right") - 1
    x0 = x[k] + 2 * u[k] * (problem.s[i] - problem.s[grid[k]])
    x1 = x0 + 2 * u[k] * np.diff(problem.s)
    start = problem.dq_ds[:-1] * u[k, None] + problem.d2q_ds2[:-1] * x0[:, None]
    worst = float(np.max(np.abs(start) / limit, initial=0.0))
    screen = problem.joint_screen
    bound = screen.accel_dq * np.abs(u[k]) + screen.accel_d2q * np.maximum(x0, x1)
    todo = np.flatnonzero(bound > worst)
    for first in range(0, todo.size, chunk):
        j = todo[first:first + chunk]
        a, b, kj = constant_accel_bernstein(problem, grid, j)
        f = a * u[kj, None] + b * x[kj, None]
        worst = max(worst, float(np.max(np.abs(f) / limit)))
    return worst


def constant_accel_rows(problem: ScheduleProblem, grid: np.ndarray, scale: float = 1.0
                        ) -> tuple[np.ndarray, np.ndarray]:
    """toppra's canonical rows ``|a_k u + b_k x| <= 1`` per gridpoint (N+1, R): the
    Bernstein coefficients of :func:`constant_accel_bernstein` over every sample interval of
    grid interval k, per joint, over its limit (the last gridpoint, and grid intervals with
    fewer sample intervals than the longest, get zero rows)."""
    i = np.arange(grid[0], grid[-1])  # the sample intervals of the grid (a window of it)
    a, b, k = constant_accel_bernstein(problem, grid, i, scale)
    limit = np.asarray(problem.joint_acceleration_max, dtype=float)
    dof = limit.size
    cell = i - grid[k]  # position of the sample interval in its grid interval
    width = 4 * dof
    rows_a = np.zeros((grid.size, width * (int(cell.max()) + 1)))
    rows_b = np.zeros_like(rows_a)
    col = cell[:, None] * width + np.arange(width)[None, :]  # (m, 4 dof)
    for rows, f in ((rows_a, a), (rows_b, b)):
        rows[k[:, None], col] = (f / limit).transpose(1, 0, 2).reshape(i.size, width)
    return rows_a, rows_b
