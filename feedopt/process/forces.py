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

Samples that plunge (``Engagement.plunge``) add the force and torque of the end cutting edges
(:mod:`feedopt.process.plunge`: thrust ``+z`` on the tool, N (K_tc c + K_te) R, and torque
N (K_cc c + K_ce) R^2 / 2; constant over the rotation for N >= 2 teeth) to the same split.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.engagement import Engagement, validate_engagement
from feedopt.process.force_sums import (
    Flutes,
    in_cut_sum_blocks,
    rows_matmul,
    settle_critical,
    slice_lags,
)
from feedopt.process.general_forces import (
    general_critical_angles,
    general_sums,
    slice_engagement,
)
from feedopt.process.plunge import plunge_parts
from feedopt.process.tool import Tool

__all__ = [
    "CuttingCoefficients",
    "Engagement",
    "ForceSplit",
    "Tool",
    "critical_angles",
    "feed_from_feed_per_tooth",
    "feed_per_tooth",
    "milling_forces",
    "milling_forces_at",
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
# Elements (samples x angles) per chunk of the slice sums (milling_forces_at and
# milling_forces with many distinct depths); force_sums cuts them into smaller blocks.
_AT_CHUNK = 1 << 16
# Elements per block of _add_rows (256 kB: the gathered block stays in cache).
_ADD_BLOCK_ELEMENTS = 1 << 15
# Exit critical angles are placed this far before the exit angle (slice still in the cut).
_EXIT_BACKOFF = 1e-9


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
    _check_slices(axial_slices)
    validate_engagement(engagement, tool.flute_length)
    phi = np.asarray(angles, dtype=float).reshape(-1)
    if phi.size == 0 or not np.all(np.isfinite(phi)):
        raise InputError("angles must be a non-empty array of finite values [rad]")
    if engagement.plunge is not None:  # side edges, then the end edges added
        side = milling_forces(tool, coeffs, engagement.side_only(), phi, axial_slices)
        return _with_plunge(side, tool, coeffs, engagement.plunge)
    if _on_profile(tool, engagement):  # Engin & Altintas on the profile's slices
        return _general_split(tool, coeffs, engagement, phi, int(axial_slices))
    if engagement.feed_axial is not None:  # a leaning feed: the side edges' chip scaled
        return _leaned(milling_forces(tool, coeffs, engagement.with_feed_axial(None), phi,
                                      axial_slices), engagement.feed_axial)
    if engagement.pieces is not None:  # sum of the pieces (EngagementPieces)
        pieces = engagement.pieces
        return _add_pieces(
            _hull_part(engagement,
                       lambda e, _i: milling_forces(tool, coeffs, e, phi, axial_slices), phi),
            milling_forces(tool, coeffs, pieces.as_engagement(), phi, axial_slices),
            pieces.sample)
    return _one_interval_forces(tool, coeffs, engagement, phi, int(axial_slices))


def _on_profile(tool: Tool, engagement: Engagement) -> bool:
    """Whether the forces are summed on the profile's slices
    (:mod:`feedopt.process.general_forces`): a cutter that is not a flat end mill (ball,
    bull, tapered, face), or an engagement given per slice (a tilted tool in a stock)."""
    return not tool.is_flat or engagement.by_slice is not None


def _one_interval_forces(tool: Tool, coeffs: CuttingCoefficients, engagement: Engagement,
                         phi: np.ndarray, axial_slices: int) -> ForceSplit:
    """:func:`milling_forces` of an engagement on one interval per sample (no pieces, no
    plunge): per distinct engagement, prefix sums of a sorted slice table per axial depth."""
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
        step = max(1, _AT_CHUNK // m)
        for start in range(0, uniq.shape[0], step):
            u = np.arange(start, min(start + step, uniq.shape[0]))
            _write(out, first[u], *_slice_sums(tool, coeffs, phi, uniq[u], int(axial_slices)))
    else:
        for d_index, a in enumerate(depths):
            table = _sorted_slice_table(tool, coeffs, phi, float(a), int(axial_slices))
            rows = np.nonzero(depth_of == d_index)[0]
            for start in range(0, rows.size, _CHUNK):
                u = rows[start : start + _CHUNK]
                hi = _prefix_at(*table, offsets, uniq[u, 1])
                lo = _prefix_at(*table, offsets, uniq[u, 0])
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


def critical_angles(tool: Tool, engagement: Engagement, axial_slices: int = 20) -> np.ndarray:
    """Rotation angles of tooth 1 at which the force jumps, per sample, shape (n, K).

    A slice j (mid-height z_j, helix lag 2 tan(beta) / D * z_j exactly as in
    :func:`milling_forces`) of any tooth enters the cut at ``theta == entry`` and leaves it at
    ``theta == exit``; there the forces are discontinuous (e.g. the thick chip at entry in down
    milling), so a uniform grid of rotation angles misses their supremum. Returned per sample:

    * columns ``0 .. L-1``: the angle at which slice j reaches the entry angle; the slice is in
      the cut there (half-open test), so the force equals its limit from the right;
    * columns ``L .. 2L-1``: the angle at which slice j is at ``exit - 1e-9`` rad, the last
      angle before it leaves (limit from the left, to ~1e-9 rad).

    All teeth give the same angle modulo the tooth pitch, so the angles are reduced to
    ``[0, 2 pi / N)``, one pitch, over which the forces are periodic; K = 2 L (K = 2 for
    straight teeth, whose slices all have the same lag). Entry angles are corrected by a few
    ulps where rounding would otherwise place the slice just outside the cut. Samples with
    ``entry >= exit`` (no cut) get meaningless but finite angles.
    """
    slices = _check_slices(axial_slices)
    validate_engagement(engagement, tool.flute_length)
    if _on_profile(tool, engagement):  # per slice and interval of the profile
        return general_critical_angles(tool, slice_engagement(tool, engagement, slices))
    if engagement.pieces is not None:
        return _pieced_critical_angles(tool, engagement, slices)
    if tool.helix == 0.0:
        slices_used = 1  # every slice has lag 0
    else:
        slices_used = slices
    n = engagement.n
    a = engagement.axial_depth[:, None]
    lag = np.broadcast_to(_slice_lags(tool, a, slices)[:, :slices_used], (n, slices_used))
    entry = np.broadcast_to(engagement.entry[:, None], lag.shape)
    exit_ = np.broadcast_to(engagement.exit[:, None], lag.shape)
    target = np.concatenate([entry, exit_ - _EXIT_BACKOFF], axis=1)
    lag2 = np.concatenate([lag, lag], axis=1)
    # Make the in-cut test of milling_forces / milling_forces_at hold at the returned angle.
    interval = (np.concatenate([entry, entry], axis=1), np.concatenate([exit_, exit_], axis=1))
    return settle_critical(target, lag2, interval, tool.pitch, tool.teeth)


def milling_forces_at(
    tool: Tool,
    coeffs: CuttingCoefficients,
    engagement: Engagement,
    angles: np.ndarray,
    axial_slices: int = 20,
) -> ForceSplit:
    """Algorithm 1 forces at a different set of rotation angles per sample.

    Same model, slices and half-open in-cut test as :func:`milling_forces` (and equal to it to
    rounding when every row of ``angles`` is the same), but ``angles`` has shape (n, k): row i
    holds the k rotation angles of tooth 1 [rad] at which sample i is evaluated, e.g. a grid
    joined with :func:`critical_angles`. A (k,) array is used for every sample.

    The sums over the teeth x slices in the cut take O(1) per tooth and angle (prefix sums over
    each run of slices in the cut, :mod:`feedopt.process.force_sums`), vectorised over
    samples and angles in blocks of ~32 k elements so the work arrays stay in cache.

    Returns
    -------
    ForceSplit whose ``angles`` is the (n, k) array and whose other arrays have shapes
    (n, k, 3) and (n, k).
    """
    slices = _check_slices(axial_slices)
    validate_engagement(engagement, tool.flute_length)
    n = engagement.n
    phi = np.asarray(angles, dtype=float)
    if phi.ndim == 1:
        phi = np.broadcast_to(phi, (n, phi.size))
    if phi.ndim != 2 or phi.shape[0] != n:
        raise InputError(
            f"angles must have shape (n, k) = ({n}, k) (one row per sample), got {phi.shape}"
        )
    if phi.shape[1] == 0 or not np.all(np.isfinite(phi)):
        raise InputError("angles must be a non-empty array of finite values [rad]")
    if engagement.plunge is not None:  # side edges, then the end edges added
        side = milling_forces_at(tool, coeffs, engagement.side_only(), phi, axial_slices)
        return _with_plunge(side, tool, coeffs, engagement.plunge)
    if _on_profile(tool, engagement):  # Engin & Altintas on the profile's slices
        out = general_sums(tool, coeffs, phi, slice_engagement(tool, engagement, slices))
        return ForceSplit(np.array(phi), out[..., 0:3], out[..., 4:7], out[..., 3], out[..., 7])
    if engagement.feed_axial is not None:  # a leaning feed: the side edges' chip scaled
        return _leaned(milling_forces_at(tool, coeffs, engagement.with_feed_axial(None), phi,
                                         axial_slices), engagement.feed_axial)
    if engagement.pieces is not None:  # sum of the pieces (EngagementPieces)
        pieces = engagement.pieces
        return _add_pieces(
            _hull_part(engagement, lambda e, i: milling_forces_at(tool, coeffs, e, phi[i],
                                                                   axial_slices), np.array(phi)),
            milling_forces_at(tool, coeffs, pieces.as_engagement(), phi[pieces.sample],
                              axial_slices),
            pieces.sample)
    out = _sums_at(tool, coeffs, phi, engagement.entry, engagement.exit,
                   engagement.axial_depth / slices, slices)
    return ForceSplit(np.array(phi), out[..., 0:3], out[..., 4:7], out[..., 3], out[..., 7])


def _sums_at(
    tool: Tool,
    coeffs: CuttingCoefficients,
    phi: np.ndarray,
    entry: np.ndarray,
    exit_: np.ndarray,
    da: np.ndarray,
    slices: int,
) -> np.ndarray:
    """Projected slice sums of :func:`milling_forces_at`: (c, k) angles -> (c, k, 8).

    The sums over the teeth x slices in the cut come from
    :func:`feedopt.process.force_sums.in_cut_sum_blocks` in O(1) per tooth and angle (prefix
    sums over each contiguous run of slices in the cut), block by block straight into the
    result. At a run's end the in-cut test uses the floating-point operations of
    :func:`milling_forces` (``mod(phi + tooth pitch - lag_j, 2 pi)``, lags of
    :func:`_slice_lags`), so a slice at a boundary (:func:`critical_angles`) is classified
    identically.
    """
    out = np.empty(phi.shape + (8,))
    blocks = in_cut_sum_blocks(phi, entry, exit_, da, _flutes(tool, slices),
                               max(1, _AT_CHUNK // max(1, phi.shape[1])))
    for sl, b in blocks:  # b: the block's work array, projected straight into out
        b *= da[sl, None]
        _project(b, coeffs, tool.diameter / 2.0, out[sl])
    return out


def flat_side_scale(feed_axial: np.ndarray) -> np.ndarray:
    """Per sample the factor on a flat end mill's cutting (chip) terms when its feed leans
    by ``fz = f . k`` along the axis: the side edges (kappa = 90 deg) cut the chip
    ``c fx sin(theta)``, ``fx = sqrt(1 - fz^2)`` (:mod:`feedopt.process.general_forces`,
    "Feed along the axis", at kappa = 90 deg), exact where ``fz >= 0`` (the end edges move
    away from the material). Where ``fz < 0`` the end edges cut the descent's chip too (not
    modelled): there the whole feed is taken across the axis (factor 1, an upper bound of
    the side edges' chip)."""
    fz = np.asarray(feed_axial, dtype=float)
    return np.where(fz < 0.0, 1.0, np.sqrt(np.maximum(0.0, 1.0 - fz * fz)))


def _leaned(split: ForceSplit, feed_axial: np.ndarray) -> ForceSplit:
    """``split`` of a flat end mill with its cutting terms scaled by
    :func:`flat_side_scale` per sample (edge forces do not depend on the chip)."""
    f = flat_side_scale(feed_axial)
    return ForceSplit(split.angles, split.cutting * f[:, None, None], split.edge,
                      split.cutting_torque * f[:, None], split.edge_torque)


def _with_plunge(split: ForceSplit, tool: Tool, coeffs: CuttingCoefficients,
                 plunge: np.ndarray) -> ForceSplit:
    """``split`` (side edges) plus the end-edge force and torque of the plunging samples
    (:func:`feedopt.process.plunge.plunge_parts`); InputError without plunge coefficients."""
    if not tool.is_flat:
        i = int(np.argmax(plunge > 0))
        raise InputError(f"sample {i} plunges along the tool axis with a {tool.shape.value} "
                         "cutter: the end-cutting model is a flat end mill's")
    if coeffs.plunge is None:
        i = int(np.argmax(plunge > 0))
        raise InputError(f"sample {i} plunges along the tool axis, but the cutting "
                         "coefficients have no plunge block (material file: plunge: "
                         "thrust_cutting_n_mm2, ...; feedopt calibrate --plunge-forces)")
    rows = np.flatnonzero(plunge > 0)
    angles = split.angles if split.angles.ndim == 1 else split.angles[rows]
    parts = plunge_parts(tool, coeffs.plunge, np.ones(rows.size), angles)
    arrays = []
    for name, part in zip(("cutting", "edge", "cutting_torque", "edge_torque"), parts,
                          strict=True):
        arr = getattr(split, name)  # fresh arrays of the side-edge pass: added in place
        arr = arr if arr.flags.writeable else arr.copy()
        arr[rows] += part
        arrays.append(arr)
    return ForceSplit(split.angles, *arrays)


def _hull_part(engagement: Engagement, evaluate, angles: np.ndarray) -> ForceSplit:
    """``evaluate`` (a force function of an engagement without pieces) on the samples of
    ``engagement`` that are on one interval; zero force on the pieced samples. A chunk of
    pieced samples only costs nothing here."""
    plain = ~engagement.pieced
    idx = np.flatnonzero(plain)
    part = evaluate(engagement.hull_only().take(idx), idx)
    if idx.size == engagement.n:
        return ForceSplit(angles, part.cutting, part.edge, part.cutting_torque,
                          part.edge_torque)
    arrays = []
    for name in ("cutting", "edge", "cutting_torque", "edge_torque"):
        a = getattr(part, name)
        full = np.zeros((engagement.n,) + a.shape[1:])
        full[idx] = a
        arrays.append(full)
    return ForceSplit(angles, *arrays)


def _add_pieces(base: ForceSplit, pieces: ForceSplit, sample: np.ndarray) -> ForceSplit:
    """``base`` (the samples on one interval, pieced samples at zero force) plus the forces
    of the pieces added to their samples (``sample`` non-decreasing). ``base`` is the fresh
    result of :func:`_hull_part` and is added to in place (a copy of four (n, m, 3) arrays
    per chunk was a third of this function's time on a raster)."""
    starts = np.flatnonzero(np.r_[True, sample[1:] != sample[:-1]])
    counts = np.diff(np.r_[starts, sample.size])
    owners = sample[starts]  # increasing
    out = []
    for name in ("cutting", "edge", "cutting_torque", "edge_torque"):
        arr = getattr(base, name)
        arr = arr if arr.flags.writeable else np.array(arr)
        part = getattr(pieces, name)
        # rank by rank (a sample has a few pieces): ((0 + p0) + p1) + ... on the zero base of
        # a pieced sample, 2-3x faster than np.add.reduceat over (pieces, angles, 3) rows
        for rank in range(int(counts.max(initial=0))):
            has = counts > rank
            _add_rows(arr, owners[has], part, starts[has] + rank)
        out.append(arr)
    return ForceSplit(base.angles, *out)


def _add_rows(arr: np.ndarray, rows: np.ndarray, part: np.ndarray, src: np.ndarray) -> None:
    """``arr[rows] += part[src]`` for increasing ``rows``. Consecutive rows (a chunk of pieced
    samples) are added as slices, in blocks whose gathered temporary stays in cache: numpy's
    fancy-index store and the page faults of a fresh (rows, m, 3) temporary were 90 % of
    :func:`_add_pieces`. (``np.take(..., out=)`` is 20x slower than the gather from the
    strided force views.)"""
    if not rows.size or rows[-1] - rows[0] != rows.size - 1:
        arr[rows] += part[src]
        return
    block = max(1, _ADD_BLOCK_ELEMENTS // max(1, math.prod(part.shape[1:])))
    for start in range(0, rows.size, block):
        stop = min(start + block, rows.size)
        dest = arr[rows[0] + start:rows[0] + stop]
        np.add(dest, part[src[start:stop]], out=dest)


def _pieced_critical_angles(tool: Tool, engagement: Engagement, slices: int) -> np.ndarray:
    """:func:`critical_angles` of an engagement with pieces: per sample the critical angles
    of each of its pieces side by side, padded by repeating (shape (n, w K) for at most w
    pieces per sample)."""
    pieces = engagement.pieces
    base = critical_angles(tool, engagement.hull_only(), slices)  # (n, K)
    of_pieces = critical_angles(tool, pieces.as_engagement(), slices)  # (p, K)
    n, k = base.shape
    starts = np.flatnonzero(np.r_[True, pieces.sample[1:] != pieces.sample[:-1]])
    counts = np.diff(np.r_[starts, pieces.count])
    owners = pieces.sample[starts]
    width = int(counts.max())
    out = np.repeat(base[:, None, :], width, axis=1)  # (n, w, K)
    out[owners] = of_pieces[starts][:, None, :]  # pad with the sample's first piece
    rank = np.arange(pieces.count) - np.repeat(starts, counts)
    out[pieces.sample, rank] = of_pieces
    return out.reshape(n, width * k)


def _check_slices(axial_slices: int) -> int:
    if isinstance(axial_slices, bool) or int(axial_slices) != axial_slices or axial_slices < 1:
        raise InputError(f"axial_slices must be a whole number >= 1, got {axial_slices!r}")
    return int(axial_slices)


def _write(out: tuple[np.ndarray, ...], dest: np.ndarray, *parts: tuple) -> None:
    """out[k][dest] = parts[k][0] - parts[k][1]; in place when ``dest`` is consecutive, and
    a plain copy when ``parts[k][1]`` is the scalar 0 (:func:`_slice_sums`)."""
    where = (slice(int(dest[0]), int(dest[-1]) + 1) if dest[-1] - dest[0] == dest.size - 1
             else dest)
    for arr, (hi, lo) in zip(out, parts, strict=True):
        if isinstance(lo, float) and lo == 0.0:
            arr[where] = hi
        elif isinstance(where, slice):
            np.subtract(hi, lo, out=arr[where])
        else:
            arr[where] = hi - lo


def _slice_sums(
    tool: Tool, coeffs: CuttingCoefficients, phi: np.ndarray, rows: np.ndarray, slices: int
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Algorithm 1 summed slice by slice (loop over teeth x slices only) for engagement rows
    ``(entry, exit, a)`` of differing axial depth; returns (value, 0) pairs for :func:`_write`.

    The same direct summation as :func:`milling_forces_at` (:func:`_sums_at`) with the angles
    shared by all rows.
    """
    shared = np.broadcast_to(phi, (rows.shape[0], phi.size))
    p = _sums_at(tool, coeffs, shared, rows[:, 0], rows[:, 1], rows[:, 2] / slices, slices)
    return (p[..., 0:3], 0.0), (p[..., 4:7], 0.0), (p[..., 3], 0.0), (p[..., 7], 0.0)


def _slice_lags(tool: Tool, a: np.ndarray | float, slices: int) -> np.ndarray:
    """Helix lag 2 tan(beta) / D * z_j of the slice mid-heights z_j = (j + 1/2) a / L [rad].

    ``a`` scalar gives shape (L,), ``a`` of shape (k, 1) gives (k, L). The single definition
    used by every force routine, so that they classify a slice at a boundary identically.
    """
    return slice_lags(_helix_rate(tool), np.asarray(a, dtype=float) / slices, np.arange(slices))


def _general_split(tool: Tool, coeffs: CuttingCoefficients, engagement: Engagement,
                   phi: np.ndarray, slices: int) -> ForceSplit:
    """:func:`milling_forces` of a general cutter (:mod:`feedopt.process.general_forces`):
    distinct engagements (without pieces) computed once, at the shared angles ``phi``."""
    n = engagement.n
    if engagement.pieces is None and engagement.by_slice is None and n:
        lean = np.zeros(n) if engagement.feed_axial is None else engagement.feed_axial
        key = np.stack([engagement.entry, engagement.exit, engagement.axial_depth, lean],
                       axis=1)
        uniq, inverse = np.unique(key, axis=0, return_inverse=True)
        rows = Engagement(uniq[:, 0], uniq[:, 1], uniq[:, 2], feed_axial=uniq[:, 3])
        inverse = inverse.reshape(-1)
    else:
        rows, inverse = engagement, np.arange(n)
    shared = np.broadcast_to(phi, (rows.n, phi.size))
    out = general_sums(tool, coeffs, shared, slice_engagement(tool, rows, slices))[inverse]
    return ForceSplit(phi, out[..., 0:3], out[..., 4:7], out[..., 3], out[..., 7])


def _helix_rate(tool: Tool) -> float:
    """Helix lag per unit height 2 tan(beta) / D [rad/m]."""
    return 2.0 * math.tan(tool.helix) / tool.diameter


def _flutes(tool: Tool, slices: int) -> Flutes:
    """The tool as :mod:`feedopt.process.force_sums` sees it (L = ``slices``)."""
    return Flutes(tool.teeth, tool.pitch, _helix_rate(tool), slices)


def _project(b: np.ndarray, coeffs: CuttingCoefficients, radius: float,
             out: np.ndarray | None = None) -> np.ndarray:
    """Map the five slice sums ``b = [sum 1, sin, cos, sin cos, sin^2]`` (leading axis, already
    times the slice height da) to ``[cut x, y, z, torque, edge x, y, z, torque]`` (last axis;
    into ``out`` if given): a (.., 5) x (5, 8) product (:func:`_projection_matrix`) on row
    blocks (:func:`feedopt.process.force_sums.rows_matmul`)."""
    direct = out is not None and out.flags.c_contiguous
    result = out if direct else np.empty(b.shape[1:] + (8,))
    rows_matmul(b.reshape(5, -1).T, _projection_matrix(coeffs, radius), result.reshape(-1, 8))
    if out is None or direct:
        return result
    out[...] = result
    return out


def _projection_matrix(coeffs: CuttingCoefficients, radius: float) -> np.ndarray:
    """(5, 8) matrix of :func:`_project`. The sign conventions of the module docstring:
    dFx = -dFt cos - dFr sin, dFy = dFt sin - dFr cos, dFz = dFa, torque = D/2 dFt, with
    dF(t,r,a) = da (K(t,r,a)c sin phi per unit c + K(t,r,a)e); rows [1, sin, cos, sin cos,
    sin^2]."""
    k = coeffs
    m = np.zeros((5, 8))
    m[3, 0], m[4, 0] = -k.ktc, -k.krc  # cutting x
    m[4, 1], m[3, 1] = k.ktc, -k.krc  # cutting y
    m[1, 2] = k.kac  # cutting z
    m[1, 3] = radius * k.ktc  # cutting torque
    m[2, 4], m[1, 4] = -k.kte, -k.kre  # edge x
    m[1, 5], m[2, 5] = k.kte, -k.kre  # edge y
    m[0, 6] = k.kae  # edge z
    m[0, 7] = radius * k.kte  # edge torque
    return m


def _prefix_at(
    keys: np.ndarray,
    prefix: np.ndarray,
    theta: np.ndarray,
    offsets: np.ndarray,
    bound: np.ndarray,
) -> np.ndarray:
    """Prefix sums of the slices with angle < ``bound`` at every rotation angle.

    Returns shape (k, m, 8), or (1, m, 8) when all ``k`` bounds are equal (broadcasts).
    Equal bounds give equal sums, so entry == exit yields exactly zero force.

    The binary search runs on the row-offset keys, whose rounding can blur a tie between a
    slice angle and ``bound`` (by ~1e-16 times the offset); the index is then moved to where
    the exact test ``theta < bound`` on the unshifted angles ``theta`` puts it.
    """
    values, inv = np.unique(bound, return_inverse=True)
    idx = np.searchsorted(keys, values[:, None] + offsets, side="left")
    width = keys.size // offsets.size
    start = np.arange(offsets.size) * width
    b = values[:, None]
    for _ in range(width):  # at most a few slices lie within rounding of a bound
        down = (idx > start) & (theta[np.maximum(idx - 1, 0)] >= b)
        up = (idx < start + width) & (theta[np.minimum(idx, theta.size - 1)] < b)
        if not (down.any() or up.any()):
            break
        idx += up.astype(idx.dtype) - down
    table = prefix[idx]
    return table if values.size == 1 else table[inv.reshape(-1)]


def _sorted_slice_table(
    tool: Tool, coeffs: CuttingCoefficients, phi: np.ndarray, a: float, slices: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sorted slice angles (flattened, row r offset by r * 4 pi), prefix sums of the 8
    per-slice contributions ``[cut x, y, z, torque, edge x, y, z, torque]`` and the sorted
    angles without offsets (flattened)."""
    m, teeth = phi.size, tool.teeth
    lag = _slice_lags(tool, a, slices)
    theta = phi[:, None, None] + (np.arange(teeth) * tool.pitch)[None, :, None] - lag[None, None, :]
    theta = np.mod(theta.reshape(m, teeth * slices), _TWO_PI)
    theta.sort(axis=1)
    s, c = np.sin(theta), np.cos(theta)
    # per-slice "sums" of 1, sin, cos, sin cos, sin^2 times the slice height
    b = np.stack([np.ones_like(s), s, c, s * c, s * s]) * (a / slices)
    contrib = _project(b, coeffs, tool.diameter / 2.0)
    keys = (theta + (np.arange(m) * _ROW_GAP)[:, None]).reshape(-1)
    prefix = np.zeros((keys.size + 1, 8))
    np.cumsum(contrib.reshape(-1, 8), axis=0, out=prefix[1:])
    return keys, prefix, theta.reshape(-1)
