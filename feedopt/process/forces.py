"""Static mechanistic milling force model (thesis Algorithm 1, Altintas [39]) with axial force.

Frame and signs (``shared/design.md``): forces act ON THE TOOL in the force-model frame,
x = feed, y = normal, z = tool axis. For a tooth slice of height da at immersion phi with chip
h = c sin(phi)::

    dFt = da (Ktc h + Kte)     dFr = da (Krc h + Kre)     dFa = da (Kac h + Kae)
    dFx = -dFt cos(phi) - dFr sin(phi)
    dFy = +dFt sin(phi) - dFr cos(phi)
    dFz = +dFa

This is the convention of thesis Eq. 3.25: with the Table 3.3 coefficients (negative Kac, Kae)
a full-immersion slot gives negative mean Fx, positive Fy and negative Fz, as measured in
Table 3.2. Every force is affine in the feed per tooth c, so it is returned split:
``F(phi) = c * cutting(phi) + edge(phi)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.engagement import Engagement, validate_engagement
from feedopt.process.tool import Tool

__all__ = [
    "CuttingCoefficients",
    "Engagement",
    "ForceSplit",
    "Tool",
    "feed_from_feed_per_tooth",
    "feed_per_tooth",
    "milling_forces",
    "rotation_angles",
    "spindle_power",
]

_TWO_PI = 2.0 * math.pi
# Per-row key offset for the flattened sorted-angle table (> 2 pi so rows never interleave).
_ROW_GAP = 4.0 * math.pi
# Samples per chunk inside milling_forces (temporaries ~12 MB each at 360 angles).
_CHUNK = 512
# Above this many distinct axial depths, sum slice by slice instead of one table per depth.
_MAX_TABLES = 64


@dataclass(frozen=True)
class ForceSplit:
    """Forces over the cutter rotation at each path sample, split as c * cutting + edge.

    Attributes
    ----------
    angles : (m,) rotation angle of tooth 1 [rad]
    cutting : (n, m, 3) force on the tool per unit feed per tooth [N/m], (x feed, y normal, z)
    edge : (n, m, 3) edge force on the tool [N]
    cutting_torque : (n, m) spindle torque D/2 Ft per unit feed per tooth [N m / m]
    edge_torque : (n, m) spindle torque of the edge forces [N m]
    """

    angles: np.ndarray
    cutting: np.ndarray
    edge: np.ndarray
    cutting_torque: np.ndarray
    edge_torque: np.ndarray

    def forces(self, c: float | np.ndarray) -> np.ndarray:
        """Total force ``c * cutting + edge`` [N], shape (n, m, 3); ``c`` scalar or (n,) [m]."""
        cc = np.asarray(c, dtype=float)
        return _per_sample(cc, 2) * self.cutting + self.edge

    def torque(self, c: float | np.ndarray) -> np.ndarray:
        """Spindle torque Tc = D/2 Ft [N m], shape (n, m) (thesis Algorithm 1)."""
        cc = np.asarray(c, dtype=float)
        return _per_sample(cc, 1) * self.cutting_torque + self.edge_torque

    def power(self, c: float | np.ndarray, rpm: float | np.ndarray) -> np.ndarray:
        """Spindle power Pc = Tc omega [W], shape (n, m)."""
        return spindle_power(self.torque(c), _per_sample(np.asarray(rpm, dtype=float), 1))


def _per_sample(x: np.ndarray, trailing: int) -> np.ndarray:
    return x if x.ndim == 0 else x.reshape(x.shape + (1,) * trailing)


def feed_per_tooth(feed: float | np.ndarray, rpm: float, teeth: int) -> np.ndarray | float:
    """Feed per tooth c = v / (N n / 60) [m] from feed rate v [m/s] and spindle speed [rpm]."""
    _check_speed(rpm, teeth)
    return (
        np.asarray(feed, dtype=float) * 60.0 / (rpm * teeth)
        if np.ndim(feed)
        else (float(feed) * 60.0 / (rpm * teeth))
    )


def feed_from_feed_per_tooth(c: float | np.ndarray, rpm: float, teeth: int) -> np.ndarray | float:
    """Feed rate v = c N n / 60 [m/s] (inverse of :func:`feed_per_tooth`)."""
    _check_speed(rpm, teeth)
    return (
        np.asarray(c, dtype=float) * rpm * teeth / 60.0
        if np.ndim(c)
        else (float(c) * rpm * teeth / 60.0)
    )


def spindle_power(torque: np.ndarray | float, rpm: np.ndarray | float) -> np.ndarray:
    """Pc = Tc * omega with omega = 2 pi rpm / 60 [W]."""
    return np.asarray(torque, dtype=float) * (np.asarray(rpm, dtype=float) * _TWO_PI / 60.0)


def rotation_angles(count: int, teeth: int | None = None, midpoint: bool = False) -> np.ndarray:
    """``count`` equally spaced angles over one revolution (or one tooth pitch if ``teeth``).

    ``midpoint=True`` places them at the centres of the ``count`` intervals; their mean of a
    force is then a midpoint-rule average, second-order accurate for straight teeth whose
    entry/exit fall on interval edges.
    """
    if isinstance(count, bool) or int(count) != count or count < 1:
        raise InputError(f"angle count must be a whole number >= 1, got {count!r}")
    span = _TWO_PI / teeth if teeth else _TWO_PI
    return (np.arange(int(count)) + (0.5 if midpoint else 0.0)) * (span / count)


def _check_speed(rpm: float, teeth: int) -> None:
    if not (np.isfinite(rpm) and rpm > 0):
        raise InputError(f"spindle speed must be > 0 rpm, got {rpm!r}")
    if teeth < 1:
        raise InputError(f"teeth must be >= 1, got {teeth!r}")


def milling_forces(
    tool: Tool,
    coeffs: CuttingCoefficients,
    engagement: Engagement,
    angles: np.ndarray,
    axial_slices: int = 20,
) -> ForceSplit:
    """Simulate the milling forces of thesis Algorithm 1 at every path sample.

    The axial depth is cut into ``axial_slices`` slices of height da = a / L evaluated at
    their mid-heights z_j; slice j of tooth k lags by the helix:
    phi_kj = phi + (k - 1) 2 pi / N - (2 tan(beta) / D) z_j (Algorithm 1). A slice cuts while
    ``entry <= phi_kj mod 2 pi < exit`` (half-open so that in a slot exactly one straight
    tooth is in the cut at a time).

    Vectorised without loops over samples or angles: for each distinct axial depth the
    N * L slice angles of every rotation angle are sorted once and their force contributions
    prefix-summed, so a sample's force is a difference of two prefix sums located by binary
    search of its entry/exit angles. Identical engagements are computed once. The result is
    exactly the per-slice sum of Algorithm 1.

    Parameters
    ----------
    tool, coeffs : cutter and cutting coefficients (SI).
    engagement : entry/exit angles and axial depth per sample, shape (n,).
    angles : (m,) rotation angles of tooth 1 [rad]; forces repeat every pitch 2 pi / N.
    axial_slices : number L of axial slices (>= 1).

    Returns
    -------
    ForceSplit with arrays of shape (n, m, 3) and (n, m).
    """
    if isinstance(axial_slices, bool) or int(axial_slices) != axial_slices or axial_slices < 1:
        raise InputError(f"axial_slices must be a whole number >= 1, got {axial_slices!r}")
    validate_engagement(engagement, tool.flute_length)
    phi = np.asarray(angles, dtype=float).reshape(-1)
    if phi.size == 0 or not np.all(np.isfinite(phi)):
        raise InputError("angles must be a non-empty array of finite values [rad]")

    n, m = engagement.n, phi.size
    cutting = np.empty((n, m, 3))
    edge = np.empty((n, m, 3))
    cutting_torque = np.empty((n, m))
    edge_torque = np.empty((n, m))
    out = (cutting, edge, cutting_torque, edge_torque)
    if n == 0:
        return ForceSplit(phi, *out)

    key = np.stack([engagement.entry, engagement.exit, engagement.axial_depth], axis=1)
    uniq, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    # process distinct engagements in sample order so that destinations are mostly slices
    order = np.argsort(first, kind="stable")
    uniq, first = uniq[order], first[order]
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    inverse = rank[inverse.reshape(-1)]
    depths, depth_of = np.unique(uniq[:, 2], return_inverse=True)
    depth_of = depth_of.reshape(-1)
    offsets = np.arange(m) * _ROW_GAP

    if depths.size > _MAX_TABLES:  # many distinct axial depths: sum slice by slice
        for start in range(0, uniq.shape[0], _CHUNK):
            u = np.arange(start, min(start + _CHUNK, uniq.shape[0]))
            _write(out, first[u], *_slice_sums(tool, coeffs, phi, uniq[u], int(axial_slices)))
    else:
        for d_index, a in enumerate(depths):
            keys, prefix = _sorted_slice_table(tool, coeffs, phi, float(a), int(axial_slices))
            rows = np.nonzero(depth_of == d_index)[0]
            for start in range(0, rows.size, _CHUNK):
                u = rows[start : start + _CHUNK]
                hi = _prefix_at(keys, prefix, offsets, uniq[u, 1])
                lo = _prefix_at(keys, prefix, offsets, uniq[u, 0])
                _write(
                    out,
                    first[u],
                    (hi[..., 0:3], lo[..., 0:3]),
                    (hi[..., 4:7], lo[..., 4:7]),
                    (hi[..., 3], lo[..., 3]),
                    (hi[..., 7], lo[..., 7]),
                )

    if uniq.shape[0] < n:  # copy the results of repeated engagements
        dup = np.ones(n, dtype=bool)
        dup[first] = False
        src = first[inverse[dup]]
        for arr in out:
            arr[dup] = arr[src]
    return ForceSplit(phi, *out)


def _write(out: tuple[np.ndarray, ...], dest: np.ndarray, *parts: tuple) -> None:
    """out[k][dest] = parts[k][0] - parts[k][1]; in place when ``dest`` is consecutive."""
    if dest[-1] - dest[0] == dest.size - 1:
        sl = slice(int(dest[0]), int(dest[-1]) + 1)
        for arr, (hi, lo) in zip(out, parts, strict=True):
            np.subtract(hi, lo, out=arr[sl])
    else:
        for arr, (hi, lo) in zip(out, parts, strict=True):
            arr[dest] = hi - lo


def _slice_sums(
    tool: Tool, coeffs: CuttingCoefficients, phi: np.ndarray, rows: np.ndarray, slices: int
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Algorithm 1 summed slice by slice (loop over teeth x slices only) for engagement rows
    ``(entry, exit, a)`` of differing axial depth; returns (value, 0) pairs for :func:`_write`.

    Accumulates the masked sums of 1, sin, cos, sin cos and sin^2 of the slice angles, of which
    every force component is a linear combination.
    """
    st, ex, a = rows[:, 0:1], rows[:, 1:2], rows[:, 2:3]
    lag = 2.0 * math.tan(tool.helix) / tool.diameter * a / slices  # per slice step, (k, 1)
    b = np.zeros((5, rows.shape[0], phi.size))
    for tooth in range(tool.teeth):
        psi = phi + tooth * tool.pitch
        for j in range(slices):
            theta = np.mod(psi - (j + 0.5) * lag, _TWO_PI)
            mask = ((theta >= st) & (theta < ex)).astype(float)
            s, c = np.sin(theta), np.cos(theta)
            ms = mask * s
            b[0] += mask
            b[1] += ms
            b[2] += mask * c
            b[3] += ms * c
            b[4] += ms * s
    b *= (a / slices)[None]  # slice height da, per row
    k, r = coeffs, tool.diameter / 2.0
    cut = np.stack([-k.ktc * b[3] - k.krc * b[4], k.ktc * b[4] - k.krc * b[3], k.kac * b[1]], -1)
    edge = np.stack([-k.kte * b[2] - k.kre * b[1], k.kte * b[1] - k.kre * b[2], k.kae * b[0]], -1)
    return (cut, 0.0), (edge, 0.0), (r * k.ktc * b[1], 0.0), (r * k.kte * b[0], 0.0)


def _prefix_at(
    keys: np.ndarray, prefix: np.ndarray, offsets: np.ndarray, bound: np.ndarray
) -> np.ndarray:
    """Prefix sums of the slices with angle < ``bound`` at every rotation angle.

    Returns shape (k, m, 8), or (1, m, 8) when all ``k`` bounds are equal (broadcasts).
    Equal bounds give equal sums, so entry == exit yields exactly zero force.
    """
    values, inv = np.unique(bound, return_inverse=True)
    idx = np.searchsorted(keys, values[:, None] + offsets, side="left")
    table = prefix[idx]
    return table if values.size == 1 else table[inv.reshape(-1)]


def _sorted_slice_table(
    tool: Tool, coeffs: CuttingCoefficients, phi: np.ndarray, a: float, slices: int
) -> tuple[np.ndarray, np.ndarray]:
    """Sorted slice angles (flattened, row r offset by r * 4 pi) and prefix sums of the 8
    per-slice contributions ``[cut x, y, z, torque, edge x, y, z, torque]``."""
    m, teeth = phi.size, tool.teeth
    da = a / slices
    z = (np.arange(slices) + 0.5) * da
    lag = 2.0 * math.tan(tool.helix) / tool.diameter * z
    theta = phi[:, None, None] + (np.arange(teeth) * tool.pitch)[None, :, None] - lag[None, None, :]
    theta = np.mod(theta.reshape(m, teeth * slices), _TWO_PI)
    theta.sort(axis=1)
    s, c = np.sin(theta), np.cos(theta)
    k = coeffs
    contrib = np.empty((m, teeth * slices, 8))
    # cutting part per unit c: dFt = da Ktc sin, dFr = da Krc sin, dFa = da Kac sin
    contrib[..., 0] = -k.ktc * s * c - k.krc * s * s
    contrib[..., 1] = k.ktc * s * s - k.krc * s * c
    contrib[..., 2] = k.kac * s
    contrib[..., 3] = k.ktc * s * (tool.diameter / 2.0)
    # edge part: dFt = da Kte, dFr = da Kre, dFa = da Kae
    contrib[..., 4] = -k.kte * c - k.kre * s
    contrib[..., 5] = k.kte * s - k.kre * c
    contrib[..., 6] = k.kae
    contrib[..., 7] = k.kte * (tool.diameter / 2.0)
    contrib *= da
    keys = (theta + (np.arange(m) * _ROW_GAP)[:, None]).reshape(-1)
    prefix = np.zeros((keys.size + 1, 8))
    np.cumsum(contrib.reshape(-1, 8), axis=0, out=prefix[1:])
    return keys, prefix
