"""Milling forces of a general end mill (ball-nose, bull-nose, tapered, face mill): Engin &
Altintas 2001 on the profile of :mod:`feedopt.process.cutter`.

Each slice j of the profile (radius r_j, axial immersion kappa_j, chip width db = ds) of tooth
t sits at ``theta = mod(phi + t p - psi_j, 2 pi)`` with the helix lag of a constant lead,
``psi_j = 2 tan(beta) z_j / D`` (E&A Eq. 6 for a helical ball end: the lead of the cylinder
carried onto the nose; on a flat end mill the lag of Algorithm 1). In the cut it takes the
chip ``h = c sin(theta) sin(kappa_j)`` (E&A Eq. 11) and the edge forces (E&A Eq. 12)::

    dFt = db (Ktc h + Kte)    dFr = db (Krc h + Kre)    dFa = db (Kac h + Kae)

with the coefficients of the flat-end-mill calibration (per unit chip width: on a cylinder
db = da, so the calibration carries over). They act on the tool along the tangential
direction ``(-cos theta, sin theta, 0)``, the edge normal ``n = (sin kappa sin theta,
sin kappa cos theta, -cos kappa)`` (radial force pushing into the tool, -dFr n) and the
profile tangent ``(cos kappa sin theta, cos kappa cos theta, sin kappa)`` (axial force; on a
cylinder +z, the sign convention of :mod:`feedopt.process.forces`, which is E&A's with the
axial direction reversed)::

    dFx = -dFt cos(theta) - dFr sin(kappa) sin(theta) + dFa cos(kappa) sin(theta)
    dFy = +dFt sin(theta) - dFr sin(kappa) cos(theta) + dFa cos(kappa) cos(theta)
    dFz = +dFr cos(kappa) + dFa sin(kappa)

and the spindle torque is ``r_j dFt``. At kappa = 90 deg these are the cylinder's equations.

Feed along the axis
-------------------
A tilted tool (a lead angle, a ramp) feeds partly along its axis: the feed direction in the
tool frame is ``(fx, 0, fz)`` and the chip is the advance per tooth projected on the edge
normal (E&A Eq. 11 generalised: Ozturk & Budak 2007; Lazoglu 2003)::

    h = c (fx sin(kappa) sin(theta) - fz cos(kappa))

with the same edge forces and directions (``SliceEngagement.feed_x`` / ``feed_z``); the
engaged intervals must then hold only where h > 0 (the front of the tool,
:mod:`feedopt.process.tilted_engagement`).

Engagement by height
--------------------
An :class:`~feedopt.process.engagement.Engagement` gives the material in front of the cutter
as angles at the nominal radius R = D / 2, i.e. the lateral positions ``y = R cos(phi)`` of the
material's sides (an entry at 0 or an exit at 180 deg: the material reaches past the rim), and
its depth a above the tip. A slice at height z < a of radius r meets that material over
``[arccos(min(y_hi, r) / r), arccos(max(y_lo, -r) / r))``: a ball-nose in a slot of depth
a < R engages the full half of every slice below a, a bull-nose at a step of radial depth ae
engages only the slices with r > R - ae, from 0 to arccos((R - ae) / r) (up milling). The
material is thus taken to stand at the same lateral position at every height (a vertical side:
the Z-map's cells, a previous pass's wall). Pieces (several intervals with their own depths)
are summed as for the flat end mill.
"""

from __future__ import annotations

import math

import numpy as np

from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.cutter import SliceEngagement, Slices, profile_slices
from feedopt.process.engagement import Engagement
from feedopt.process.force_sums import settle_critical
from feedopt.process.tool import Tool

__all__ = ["SliceEngagement", "general_average", "general_critical_angles", "general_sums",
           "merge_intervals", "slice_engagement", "slice_intervals"]

_TWO_PI = 2.0 * math.pi
# Elements (samples x angles x slices) per block of the direct sums.
_BLOCK = 1 << 16
# Exit critical angles are placed this far before the exit (as in forces.critical_angles).
_EXIT_BACKOFF = 1e-9


def slice_intervals(radius: float, slices: Slices, entry: np.ndarray, exit_: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per sample and slice the engaged interval ``[entry_j, exit_j)`` [rad], shape (n, L),
    of material given at the nominal ``radius`` by ``entry``/``exit_`` (n,) (module
    docstring); ``entry_j == exit_j`` where the slice does not cut."""
    entry = np.asarray(entry, dtype=float)[:, None]
    exit_ = np.asarray(exit_, dtype=float)[:, None]
    y_hi = np.where(entry <= 0.0, np.inf, radius * np.cos(entry))
    y_lo = np.where(exit_ >= math.pi, -np.inf, radius * np.cos(exit_))
    r = slices.radius
    lo = np.arccos(np.clip(y_hi / r, -1.0, 1.0))
    hi = np.arccos(np.clip(y_lo / r, -1.0, 1.0))
    cutting = (entry < exit_) & (lo < hi)
    return np.where(cutting, lo, 0.0), np.where(cutting, hi, 0.0)


def _lags(rate: float, slices: Slices) -> np.ndarray:
    """Helix lag psi_j = rate z_j [rad] (n, L), rate = 2 tan(beta) / D."""
    return rate * slices.height


def slice_engagement(tool: Tool, engagement: Engagement, slices: int) -> SliceEngagement:
    """The engagement of a general cutter by slice (module docstring): the profile sliced
    over each sample's (largest) axial depth; a slice at height z takes the pieces deeper than
    z (a sample without pieces: its one interval), projected to its radius and merged where
    they touch or overlap. An engagement given by slice (``engagement.by_slice``) is its
    own table, at its own slices."""
    if engagement.by_slice is not None:
        return engagement.by_slice
    radius = tool.diameter / 2.0
    if engagement.pieces is None:
        sliced = profile_slices(tool.profile, engagement.axial_depth, slices)
        lo, hi = slice_intervals(radius, sliced, engagement.entry, engagement.exit)
        return _leaning(SliceEngagement(sliced, lo[..., None], hi[..., None]),
                        engagement.feed_axial)
    entry, exit_, depth = _padded_pieces(engagement)  # (n, W)
    # sliced over the deepest piece (the summary depth is that already, from the stock)
    sliced = profile_slices(tool.profile, np.maximum(engagement.axial_depth, depth.max(axis=1)),
                            slices)
    los, his = [], []
    for w in range(entry.shape[1]):
        lo, hi = slice_intervals(radius, sliced, entry[:, w], exit_[:, w])
        deep = sliced.height < depth[:, w, None]
        los.append(np.where(deep, lo, 0.0))
        his.append(np.where(deep, hi, 0.0))
    return _leaning(SliceEngagement(sliced, *merge_intervals(np.stack(los, axis=2),
                                                     np.stack(his, axis=2))),
                    engagement.feed_axial)


def _leaning(se: SliceEngagement, feed_axial: np.ndarray | None) -> SliceEngagement:
    """``se`` (intervals within [0, pi] from a lateral band of material) for a feed leaning
    by ``fz`` (n,) along the tool axis (None: ``se``): the feed ``(fx, fz)``,
    ``fx = sqrt(1 - fz^2)``, and the intervals cut to where the chip
    ``c (fx sin(kappa) sin(theta) - fz cos(kappa))`` is positive (module docstring), i.e.
    ``sin(theta) > t = fz cos(kappa) / (fx sin(kappa))``:

    - t > 0 (a rising feed, a lead): the front ``[arcsin t, pi - arcsin t]``, nothing for
      t >= 1 (the edge near the tip leaves the material);
    - t < 0 (a descending feed): all of the front and, behind the tool, ``theta`` in
      ``(pi, pi + b)`` and ``(2 pi - b, 2 pi)``, b = arcsin(-t) (all of the back for
      t <= -1), where the same lateral band has material: at ``theta = 2 pi - phi`` the edge
      is at the lateral position of ``phi``, so the band's back intervals mirror the front's
      (the material below the tool's last positions, which the descending bottom cuts)."""
    if feed_axial is None:
        return se
    fz = np.asarray(feed_axial, dtype=float)
    fx = np.sqrt(np.maximum(0.0, 1.0 - fz * fz))
    s = se.sliced
    num, den = fz[:, None] * s.cos_kappa, fx[:, None] * s.sin_kappa
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den > 0.0, num / den, np.where(num > 0.0, np.inf, -np.inf))
    a = np.arcsin(np.clip(t, 0.0, 1.0))[..., None]
    b = np.arcsin(np.clip(-t, 0.0, 1.0))[..., None]
    lo, hi = np.maximum(se.lo, a), np.minimum(se.hi, np.pi - a)
    keep = (lo < hi) & (t < 1.0)[..., None]
    parts_lo, parts_hi = [np.where(keep, lo, 0.0)], [np.where(keep, hi, 0.0)]
    if not np.any(b > 0.0):  # no descent: the front only
        return SliceEngagement(s, parts_lo[0], parts_hi[0], fx, fz)
    near_end = (np.maximum(se.lo, 0.0), np.minimum(se.hi, b))  # phi in (0, b)
    near_pi = (np.maximum(se.lo, np.pi - b), se.hi)  # phi in (pi - b, pi)
    for p_lo, p_hi in (near_end, near_pi):
        on = (p_lo < p_hi) & (b > 0.0)
        parts_lo.append(np.where(on, 2.0 * np.pi - p_hi, 0.0))
        parts_hi.append(np.where(on, 2.0 * np.pi - p_lo, 0.0))
    lo_all, hi_all = merge_intervals(np.concatenate(parts_lo, axis=2),
                                     np.concatenate(parts_hi, axis=2))
    return SliceEngagement(s, lo_all, hi_all, fx, fz)


def _padded_pieces(engagement: Engagement) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(entry, exit, depth) per sample and interval (n, W): a plain sample's one interval,
    a pieced sample's pieces in order; padded with empty intervals of zero depth."""
    n, pieces = engagement.n, engagement.pieces
    pieced = engagement.pieced
    counts = np.where(pieced, 0, 1) + np.bincount(pieces.sample, minlength=n)
    width = int(counts.max(initial=1))
    out = [np.zeros((n, width)) for _ in range(3)]
    plain = np.flatnonzero(~pieced)
    for arr, value in zip(out, (engagement.entry, engagement.exit, engagement.axial_depth),
                          strict=True):
        arr[plain, 0] = value[plain]
    starts = np.flatnonzero(np.r_[True, pieces.sample[1:] != pieces.sample[:-1]])
    rank = np.arange(pieces.count) - np.repeat(starts, np.diff(np.r_[starts, pieces.count]))
    for arr, value in zip(out, (pieces.entry, pieces.exit, pieces.axial_depth), strict=True):
        arr[pieces.sample, rank] = value
    return out[0], out[1], out[2]


def merge_intervals(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Intervals (..., W) merged where they touch or overlap, in increasing order; empty
    intervals (lo >= hi) dropped; padded at the end with empty ones (0, 0)."""
    shape = lo.shape
    lo, hi = lo.reshape(-1, shape[-1]), hi.reshape(-1, shape[-1])
    empty = lo >= hi
    lo = np.where(empty, np.inf, lo)
    hi = np.where(empty, -np.inf, hi)
    order = np.argsort(lo, axis=1, kind="stable")
    lo, hi = np.take_along_axis(lo, order, 1), np.take_along_axis(hi, order, 1)
    valid = np.isfinite(lo)
    reach = np.maximum.accumulate(hi, axis=1)
    new = valid.copy()
    new[:, 1:] &= lo[:, 1:] > reach[:, :-1]
    run = np.cumsum(new, axis=1) - 1
    width = max(1, int(new.sum(axis=1).max(initial=1)))
    row = np.broadcast_to(np.arange(lo.shape[0])[:, None], lo.shape)
    out_lo = np.zeros((lo.shape[0], width))
    out_lo[row[new], run[new]] = lo[new]  # sorted: a run's first interval has its lowest lo
    out_hi = np.full((lo.shape[0], width), -np.inf)
    np.maximum.at(out_hi, (row[valid], run[valid]), hi[valid])
    out_hi = np.where(np.isfinite(out_hi), out_hi, 0.0)
    return out_lo.reshape(shape[:-1] + (width,)), out_hi.reshape(shape[:-1] + (width,))


def general_sums(tool: Tool, coeffs: CuttingCoefficients, phi: np.ndarray,
                 se: SliceEngagement) -> np.ndarray:
    """Forces ``[cut x, y, z, torque, edge x, y, z, torque]`` (c, k, 8) at angles ``phi``
    (c, k) of tooth 1 for the slice engagement ``se`` of c samples, summed directly over
    teeth, slices and intervals (module docstring)."""
    out = np.zeros(phi.shape + (8,))
    c, k = phi.shape
    n_l, width = se.lo.shape[1:]
    rows = max(1, _BLOCK // max(1, k * n_l * tool.teeth))
    for start in range(0, c, rows):
        sl = slice(start, min(start + rows, c))
        part = se.rows(sl)
        if not np.any(part.lo < part.hi):
            continue
        weights = _slice_matrices(part.sliced, coeffs)  # (r, L, 5, 8)
        if part.feed_x is not None:
            weights = _tilted_matrices(weights, part, coeffs)
        _block(out[sl], phi[sl], (part.lo, part.hi), _lags(tool.helix_rate, part.sliced),
               (tool.teeth, weights))
    return out


def _slice_matrices(sliced: Slices, k: CuttingCoefficients) -> np.ndarray:
    """Per slice the (5, 8) map from the in-cut sums ``[1, sin, cos, sin cos, sin^2]`` of
    theta to ``[cut x, y, z, torque, edge x, y, z, torque]`` (module docstring), times the
    chip width db: shape (r, L, 5, 8)."""
    sk, ck, radius = sliced.sin_kappa, sliced.cos_kappa, sliced.radius
    cut_n = (-k.krc * sk + k.kac * ck) * sk  # in-plane part of Fr and Fa per unit c
    edge_n = -k.kre * sk + k.kae * ck
    m = np.zeros(sk.shape + (5, 8))
    m[..., 3, 0], m[..., 4, 0] = -k.ktc * sk, cut_n
    m[..., 4, 1], m[..., 3, 1] = k.ktc * sk, cut_n
    m[..., 1, 2] = (k.krc * ck + k.kac * sk) * sk
    m[..., 1, 3] = k.ktc * sk * radius
    m[..., 2, 4], m[..., 1, 4] = -k.kte, edge_n
    m[..., 1, 5], m[..., 2, 5] = k.kte, edge_n
    m[..., 0, 6] = k.kre * ck + k.kae * sk
    m[..., 0, 7] = k.kte * radius
    return m * sliced.width[:, None, None, None]


def _tilted_matrices(flat: np.ndarray, se: SliceEngagement, k: CuttingCoefficients
                     ) -> np.ndarray:
    """:func:`_slice_matrices` for a feed ``(fx, 0, fz)`` in the tool frame: the chip
    ``c (fx sin(kappa) sin(theta) - fz cos(kappa))`` (module docstring) scales the cutting
    columns by fx and adds the axial feed's terms; the edge columns stay."""
    sliced = se.sliced
    fx, fz = se.feed_x[:, None, None, None], se.feed_z[:, None]
    sk, ck, radius = sliced.sin_kappa, sliced.cos_kappa, sliced.radius
    db = sliced.width[:, None]
    n_in = -k.krc * sk + k.kac * ck  # in-plane part of Fr and Fa per unit chip
    m = flat.copy()
    m[..., :4] *= fx
    m[..., 2, 0] += k.ktc * ck * fz * db
    m[..., 1, 0] += -n_in * ck * fz * db
    m[..., 1, 1] += -k.ktc * ck * fz * db
    m[..., 2, 1] += -n_in * ck * fz * db
    m[..., 0, 2] += -(k.krc * ck + k.kac * sk) * ck * fz * db
    m[..., 0, 3] += -k.ktc * ck * radius * fz * db
    return m


def _block(out: np.ndarray, phi: np.ndarray, interval: tuple[np.ndarray, np.ndarray],
           lag: np.ndarray, tool: tuple[int, np.ndarray]) -> None:
    """Add the slices' forces of one block into ``out`` (r, k, 8): the in-cut sums of every
    (tooth, slice) at every angle, mapped by the slices' matrices in one batched product."""
    teeth, weights = tool
    r, k = phi.shape
    n_l = lag.shape[1]
    lead = phi[:, :, None, None] + (np.arange(teeth) * (_TWO_PI / teeth))[None, None, :, None]
    # (phi + t p) - lag_j: the arithmetic of general_critical_angles, so that a slice at a
    # critical angle is classified identically
    theta = np.mod(lead - lag[:, None, None, :], _TWO_PI).reshape(r, k, teeth * n_l)
    basis = np.empty(theta.shape + (5,))
    w = basis[..., 0]
    w.fill(0.0)
    lo, hi = interval  # (r, L, W)
    for v in range(lo.shape[2]):
        lo_v = np.tile(lo[:, :, v], (1, teeth))[:, None, :]  # (r, 1, N L)
        hi_v = np.tile(hi[:, :, v], (1, teeth))[:, None, :]
        w += (theta >= lo_v) & (theta < hi_v)  # disjoint intervals: at most one holds
    # sin and cos of theta by angle addition from the (r, k, N) leads and (r, L) lags: four
    # products instead of two transcendental calls per element (equal to ~1e-16)
    s_lead, c_lead = np.sin(lead), np.cos(lead)  # (r, k, N, 1)
    s_lag, c_lag = np.sin(lag)[:, None, None, :], np.cos(lag)[:, None, None, :]
    s = (s_lead * c_lag - c_lead * s_lag).reshape(theta.shape)
    c = np.multiply(c_lead, c_lag, out=theta.reshape(lead.shape[:3] + (n_l,)))
    c += s_lead * s_lag
    c = c.reshape(theta.shape)
    np.multiply(w, s, out=basis[..., 1])
    np.multiply(w, c, out=basis[..., 2])
    np.multiply(basis[..., 1], c, out=basis[..., 3])
    np.multiply(basis[..., 1], s, out=basis[..., 4])
    mats = np.tile(weights, (1, teeth, 1, 1)).reshape(r, teeth * n_l * 5, 8)
    out += np.matmul(basis.reshape(r, k, teeth * n_l * 5), mats)


def general_critical_angles(tool: Tool, se: SliceEngagement) -> np.ndarray:
    """Rotation angles of tooth 1 (n, 2 L W) in one pitch at which a slice enters one of its
    intervals (the first L W columns) or is at ``hi - 1e-9`` rad (the last L W), as
    :func:`feedopt.process.forces.critical_angles` for the per-slice intervals of a general
    cutter; nudged by a few ulps where rounding would put the slice outside its interval
    under the in-cut test of :func:`general_sums`. Empty intervals give harmless angles."""
    n = se.lo.shape[0]
    lag = np.repeat(_lags(tool.helix_rate, se.sliced)[:, :, None], se.lo.shape[2], axis=2)
    lo, hi, lag = (a.reshape(n, -1) for a in (se.lo, se.hi, lag))
    target = np.concatenate([lo, hi - _EXIT_BACKOFF], axis=1)
    interval = (np.concatenate([lo, lo], axis=1), np.concatenate([hi, hi], axis=1))
    return settle_critical(target, np.concatenate([lag, lag], axis=1), interval,
                           tool.pitch, tool.teeth)


#: Profile slices of the revolution averages (exact in the angle; the profile's quadrature).
AVERAGE_SLICES = 200


def slice_average(tool: Tool, coeffs: CuttingCoefficients, se: SliceEngagement
                  ) -> np.ndarray:
    """Mean over one revolution of ``[cut x, y, z, torque, edge x, y, z, torque]`` (n, 8) for
    the slice engagement ``se`` (a leaning feed included): ``N / (2 pi)`` times each slice's
    exact integral of ``[1, sin, cos, sin cos, sin^2]`` of theta over its intervals, mapped by
    the slice's matrix (:func:`general_sums`; the helix lag drops out of a whole
    revolution)."""
    def prim(t: np.ndarray) -> np.ndarray:  # (..., 5): int of 1, s, c, s c, s^2
        s = np.sin(t)
        return np.stack([t, -np.cos(t), s, 0.5 * s * s, 0.5 * t - 0.25 * np.sin(2.0 * t)],
                        axis=-1)

    weights = _slice_matrices(se.sliced, coeffs)
    if se.feed_x is not None:
        weights = _tilted_matrices(weights, se, coeffs)
    ints = (prim(se.hi) - prim(se.lo)).sum(axis=2)  # (n, L, 5)
    return tool.teeth / _TWO_PI * np.einsum("nlb,nlbo->no", ints, weights)


def general_average(tool: Tool, coeffs: CuttingCoefficients,
                    engagement: tuple[np.ndarray, np.ndarray, np.ndarray],
                    feed_per_tooth: np.ndarray, slices: int = AVERAGE_SLICES) -> np.ndarray:
    """Mean force on the tool over one revolution [N] (..., 3) of a general cutter: per
    slice the exact integral over its interval of the forces of the module docstring,
    ``N / (2 pi) int dF dtheta`` (the helix lag drops out of a whole revolution; the closed
    form of :mod:`feedopt.process.averages` per slice), summed over ``slices`` slices.
    Inputs (entry, exit, depth, feed per tooth) broadcast against each other; computed in
    blocks of rows (bounded memory)."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (*engagement,
                                                                          feed_per_tooth)))
    shape = arrays[0].shape
    flat = [a.reshape(-1) for a in arrays]
    out = np.empty((flat[0].size, 3))
    rows = max(1, _BLOCK // slices)
    for start in range(0, out.shape[0], rows):
        sl = slice(start, start + rows)
        out[sl] = _average_rows(tool, coeffs, [a[sl] for a in flat], slices)
    return out.reshape(shape + (3,))


def _average_rows(tool: Tool, coeffs: CuttingCoefficients, rows: list[np.ndarray],
                  slices: int) -> np.ndarray:
    """:func:`general_average` of 1-D (entry, exit, depth, feed per tooth) rows, (r, 3)."""
    diameter, teeth, profile = tool.diameter, tool.teeth, tool.profile
    entry, exit_, depth, c = rows
    exit_ = np.maximum(exit_, entry)
    sliced = profile_slices(profile, depth, slices)
    lo, hi = slice_intervals(diameter / 2.0, sliced, entry, exit_)

    def prim(t: np.ndarray) -> tuple[np.ndarray, ...]:  # int of 1, s, c, s c, s^2
        s = np.sin(t)
        return t, -np.cos(t), s, 0.5 * s * s, 0.5 * t - 0.25 * np.sin(2.0 * t)

    one, si, co, sc, s2 = (b - a for a, b in zip(prim(lo), prim(hi), strict=True))
    k, sk, ck = coeffs, sliced.sin_kappa, sliced.cos_kappa
    cut_n, edge_n = -k.krc * sk + k.kac * ck, -k.kre * sk + k.kae * ck
    cut = np.stack([sk * (-k.ktc * sc + cut_n * s2), sk * (k.ktc * s2 + cut_n * sc),
                    sk * (k.krc * ck + k.kac * sk) * si], axis=-1)
    edge = np.stack([-k.kte * co + edge_n * si, k.kte * si + edge_n * co,
                     (k.kre * ck + k.kae * sk) * one], axis=-1)
    total = np.sum(c[:, None, None] * cut + edge, axis=1)
    return (teeth * sliced.width / (2.0 * math.pi))[:, None] * total
