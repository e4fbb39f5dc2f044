"""Engagement of a tilted (five-axis) general cutter by slice: the cutting-edge points that are
in the material and on the front of the tool.

Tool frame
----------
Per sample, z = the unit tool axis k (tip towards the spindle), x = the feed direction f with
its component along k removed (normalised), y = z x x. The feed in this frame is
``f = (fx, 0, fz)`` with ``fx = |f - (f.k) k| >= 0`` and ``fz = f.k`` (a lead or tilt of the tool
against its path, a ramp or a plunge along the axis: fz != 0). Where f is along k (a pure
plunge) x is any direction normal to k (world x, else world y, projected) and fx = 0.

The edge point of slice j (radius r_j, height z_j above the tip, axial immersion kappa_j,
:mod:`feedopt.process.cutter`) at immersion phi is, as in :mod:`feedopt.process.general_forces`
(phi clockwise from +y seen from the spindle, the tooth at ``r (sin phi x + cos phi y)``)::

    P = tip + r_j (sin(phi) x + cos(phi) y) + z_j k

with the outward normal of the cutter envelope
``n = sin(kappa_j) (sin(phi) x + cos(phi) y) - cos(kappa_j) k`` (Engin & Altintas 2001, Eq. 11's
normal; on a ball-nose ``P = centre + R n``).

Engagement rule
---------------
P is in the cut iff (a) it is inside the material (``stock_contains``) and (b) it is on the
front of the tool, ``f . n > 0``: the tool surface there moves into the material, i.e. the
chip thickness below is positive (the engagement rule of the 5-axis ball-end models: Ozturk &
Budak, "Modeling of 5-axis milling processes", Machining Science and Technology 11, 2007;
Lazoglu, "Sculpture surface machining: a generalized model of ball-end milling force system",
IJMTM 43, 2003; Ozturk, Tunc & Budak, "Investigation of lead and tilt angle effects in 5-axis
ball-end milling processes", IJMTM 49, 2009).

Chip thickness (derived; not used by the force model here)
---------------------------------------------------------
The tool advances by c (the feed per tooth) along f between two teeth; the uncut chip at P is
that advance projected on the surface normal (E&A Eq. 11, ``h = c sin(phi) sin(kappa)`` for
f = x, generalised as in Ozturk & Budak 2007 and Lazoglu 2003)::

    h = c (f . n) = c (sin(kappa) (fx sin(phi) + fy cos(phi)) - fz cos(kappa))

and in this module's frame (fy = 0) ``h = c (fx sin(kappa) sin(phi) - fz cos(kappa))``, where
``fx = cos(lead)``, ``fz = sin(lead)`` for a tool leaning by the lead angle towards the feed
(its top ahead of its tip) over a level path. Rule (b) is h > 0. The same h holds in a frame
whose x is not the feed (with fy != 0), e.g. the frame of a programmed tool orientation.

Numerics
--------
The angles ``phi_m = 2 pi m / M`` are tested for every slice; each change between m and m + 1
is refined by bisection on both conditions to 1e-8 rad (about 21 steps at M = 360), runs of
engaged angles become intervals ``[lo, hi)`` in [0, 2 pi) (a run through phi = 0 is split at
2 pi), padded with empty ``lo == hi == 0`` to the widest sample. Runs narrower than the angle
step 2 pi / M can be missed. The samples are processed in blocks of about 2^18 edge points.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from feedopt.process.cutter import Profile, Slices, profile_slices
from feedopt.process.general_forces import SliceEngagement

__all__ = ["TiltedEngagement", "edge_points", "front_of_tool", "lateral_hull",
           "material_height", "tilted_slice_engagement", "tool_frame"]

_TWO_PI = 2.0 * math.pi
# Edge points (samples x slices x angles) per block.
_POINTS = 1 << 18
# The refined boundaries' accuracy [rad]; boundaries this close to 0 or 2 pi snap to them.
_ANGLE_TOL = 1e-8

Contains = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class TiltedEngagement:
    """The slice engagement of a tilted cutter (module docstring).

    Attributes
    ----------
    slices : SliceEngagement whose intervals lie in [0, 2 pi) [rad]
    feed_x, feed_z : (n,) the unit feed's components along the tool frame's x and axis
    frame : (n, 3, 3) rows x, y, z of the tool frame in the stock's frame
    """

    slices: SliceEngagement
    feed_x: np.ndarray
    feed_z: np.ndarray
    frame: np.ndarray


def tool_frame(axis: np.ndarray, feed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frame (n, 3, 3) rows x, y, z; fx (n,); fz (n,)) of unit tool axes and feeds (n, 3)."""
    k = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    f = feed / np.linalg.norm(feed, axis=1, keepdims=True)
    fz = np.einsum("ij,ij->i", f, k)
    side = f - fz[:, None] * k
    fx = np.linalg.norm(side, axis=1)
    plunge = fx < 1e-12
    if np.any(plunge):  # any normal to k: world x, else world y, projected
        ref = np.where(np.abs(k[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        alt = ref - np.einsum("ij,ij->i", ref, k)[:, None] * k
        side = np.where(plunge[:, None], alt, side)
        fx = np.where(plunge, 0.0, fx)
    x = side / np.linalg.norm(side, axis=1, keepdims=True)
    y = np.cross(k, x)
    return np.stack([x, y, k], axis=1), fx, fz


def edge_points(tip: np.ndarray, frame: np.ndarray, sliced: Slices, phi: np.ndarray
                ) -> np.ndarray:
    """Edge points (n, L, M, 3) [m] of the slices (n, L) at angles ``phi`` (M,) or
    (n, L, M) [rad] (module docstring)."""
    r = sliced.radius[..., None]
    lat_x, lat_y = r * np.sin(phi), r * np.cos(phi)  # (n, L, M): sin, cos once per angle
    out = np.empty(lat_x.shape + (3,))
    for c in range(3):  # per coordinate: no (n, L, M, 3) temporaries
        base = tip[:, c, None] + sliced.height * frame[:, 2, c, None]  # (n, L)
        col = out[..., c]
        np.multiply(lat_x, frame[:, 0, c, None, None], out=col)
        col += lat_y * frame[:, 1, c, None, None]
        col += base[..., None]
    return out


def front_of_tool(sliced: Slices, fx: np.ndarray, fz: np.ndarray, phi: np.ndarray
                  ) -> np.ndarray:
    """``f . n > 0`` (n, L, M) at angles ``phi`` (M,) or (n, L, M): the chip of the module
    docstring is positive."""
    sk, ck = sliced.sin_kappa[..., None], sliced.cos_kappa[..., None]
    return (fx[:, None, None] * sk) * np.sin(phi) > fz[:, None, None] * ck


def _engaged(stock_contains: Contains, pose: tuple, sliced: Slices, phi: np.ndarray
             ) -> np.ndarray:
    """Both conditions (n, L, M) at angles ``phi`` (M,) or (n, L, M)."""
    tip, frame, fx, fz = pose
    ahead = front_of_tool(sliced, fx, fz, phi)
    pts = edge_points(tip, frame, sliced, phi)
    inside = np.asarray(stock_contains(pts.reshape(-1, 3)), dtype=bool).reshape(ahead.shape)
    return ahead & inside


def tilted_slice_engagement(stock_contains: Contains, tip: np.ndarray, axis: np.ndarray,
                            feed: np.ndarray, profile: Profile, depth: np.ndarray | float,
                            slices: int = 30, angles: int = 360) -> TiltedEngagement:
    """The engaged intervals per sample and slice of a cutter of ``profile`` at tips, unit
    axes and unit feeds (n, 3) [m] in material ``stock_contains`` ((m, 3) points -> (m,)
    bool), its profile cut into ``slices`` slices of equal length over the axial length
    ``depth`` (n,) or scalar [m] above the tip, tested at ``angles`` angles then refined
    (module docstring)."""
    tip = np.atleast_2d(np.asarray(tip, dtype=float))
    axis = np.broadcast_to(np.asarray(axis, dtype=float), tip.shape)
    feed = np.broadcast_to(np.asarray(feed, dtype=float), tip.shape)
    n = tip.shape[0]
    depth = np.broadcast_to(np.asarray(depth, dtype=float).reshape(-1), (n,))
    frame, fx, fz = tool_frame(axis, feed)
    sliced = profile_slices(profile, depth, slices)
    rows = max(1, _POINTS // (slices * angles))
    los, his = [], []
    for start in range(0, n, rows):
        sl = slice(start, min(start + rows, n))
        part = Slices(sliced.radius[sl], sliced.height[sl], sliced.sin_kappa[sl],
                      sliced.cos_kappa[sl], sliced.width[sl])
        lo, hi = _block_intervals(stock_contains, (tip[sl], frame[sl], fx[sl], fz[sl]), part,
                                  angles)
        los.append(lo)
        his.append(hi)
    width = max(a.shape[2] for a in los)
    lo = np.concatenate([np.pad(a, ((0, 0), (0, 0), (0, width - a.shape[2]))) for a in los])
    hi = np.concatenate([np.pad(a, ((0, 0), (0, 0), (0, width - a.shape[2]))) for a in his])
    return TiltedEngagement(SliceEngagement(sliced, lo, hi), fx, fz, frame)


def _block_intervals(stock_contains: Contains, pose: tuple, sliced: Slices, angles: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The intervals (b, L, W) of one block of samples: sampled, refined, paired."""
    step = _TWO_PI / angles
    phi = np.arange(angles) * step
    on = _engaged(stock_contains, pose, sliced, phi)  # (b, L, M)
    b, n_l, m = on.shape
    flat = on.reshape(-1, m)
    after = np.roll(flat, -1, axis=1)  # the state at m + 1 (cyclic)
    row, col = np.nonzero(flat != after)  # row-major: by row, then by angle
    refined = _refine(stock_contains, pose, sliced, (row, col), (flat[row, col], step))
    lo, hi = _pair_runs(flat, (row, col, flat[row, col]), refined)
    return lo.reshape(b, n_l, -1), hi.reshape(b, n_l, -1)


def _refine(stock_contains: Contains, pose: tuple, sliced: Slices, where: tuple,
            state: tuple) -> np.ndarray:
    """Bisection of each change of state between angles ``col`` and ``col + 1`` of row
    (sample x slice) ``row``, to :data:`_ANGLE_TOL`; the boundary angles [rad]."""
    row, col = where
    left_state, step = state
    if row.size == 0:
        return np.zeros(0)
    n_l = sliced.radius.shape[1]
    sample, sl = np.divmod(row, n_l)
    tip, frame, fx, fz = pose
    one = Slices(sliced.radius[sample, sl][:, None], sliced.height[sample, sl][:, None],
                 sliced.sin_kappa[sample, sl][:, None], sliced.cos_kappa[sample, sl][:, None],
                 sliced.width[sample])
    sub = (tip[sample], frame[sample], fx[sample], fz[sample])
    a, b = col * step, (col + 1) * step
    for _ in range(max(1, math.ceil(math.log2(step / _ANGLE_TOL)))):
        mid = 0.5 * (a + b)
        same = _engaged(stock_contains, sub, one, mid[:, None, None])[:, 0, 0] == left_state
        a = np.where(same, mid, a)
        b = np.where(same, b, mid)
    return 0.5 * (a + b)


def _pair_runs(on: np.ndarray, changes: tuple, angle: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Intervals (R, W) from the refined changes of state of each row: an exit (engaged at
    m) closes the run its row's previous entry opened, cyclically; a run through 2 pi is split
    in two; rows engaged everywhere give [0, 2 pi). Sorted by ``lo``, padded with (0, 0)."""
    row, _, was_on = changes
    n_rows = on.shape[0]
    angle = np.where(angle < _ANGLE_TOL, 0.0, np.where(angle > _TWO_PI - _ANGLE_TOL, _TWO_PI,
                                                        angle))
    entry, exit_ = ~was_on, was_on
    count = np.bincount(row[entry], minlength=n_rows)  # = exits per row
    width = int(count.max(initial=0)) + 1
    first = np.r_[0, np.cumsum(count)[:-1]]
    e_row, x_row = row[entry], row[exit_]
    rank_e = np.arange(e_row.size) - first[e_row]
    rank_x = np.arange(x_row.size) - first[x_row]
    first_e = np.full(n_rows, -1)
    first_e[e_row[rank_e == 0]] = np.flatnonzero(entry)[rank_e == 0]
    first_x = np.full(n_rows, -1)
    first_x[x_row[rank_x == 0]] = np.flatnonzero(exit_)[rank_x == 0]
    wrap = (count > 0) & (first_x < first_e)  # the row's first change is an exit
    lo, hi = np.zeros((n_rows, width)), np.zeros((n_rows, width))
    lo[e_row, rank_e] = angle[entry]
    pair = np.where(wrap[x_row], (rank_x - 1) % np.maximum(count[x_row], 1), rank_x)
    hi[x_row, pair] = angle[exit_]
    wrapped = np.flatnonzero(wrap)  # its last run [lo, 2 pi) and [0, first exit)
    last = count[wrapped] - 1
    hi[wrapped, width - 1] = hi[wrapped, last]
    hi[wrapped, last] = _TWO_PI
    full = (count == 0) & on[:, 0]
    hi[full, 0] = _TWO_PI
    return _sorted(lo, hi)


def _sorted(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Intervals per row by increasing ``lo``, empty ones (``lo >= hi``) last as (0, 0),
    trimmed to the widest row (at least one column)."""
    empty = lo >= hi
    order = np.argsort(np.where(empty, np.inf, lo), axis=1, kind="stable")
    lo, hi = np.take_along_axis(lo, order, 1), np.take_along_axis(hi, order, 1)
    empty = np.take_along_axis(empty, order, 1)
    lo, hi = np.where(empty, 0.0, lo), np.where(empty, 0.0, hi)
    width = max(1, int((~empty).sum(axis=1).max(initial=1)))
    return lo[:, :width], hi[:, :width]


#: Angles per turn of the coarse pass of :func:`material_height` (5 deg).
HEIGHT_ANGLES = 72


def material_height(stock_contains: Contains, tip: np.ndarray, axis: np.ndarray,
                    feed: np.ndarray, profile: Profile, limits: tuple[float, float]
                    ) -> tuple[np.ndarray, np.ndarray]:
    """How high the material in front of the cutter reaches, per sample: (depth (n,) [m],
    above (n,) bool).

    ``limits = (height, step)``: the profile is cut into slices about ``step`` [m] long up
    to ``height + 2 step`` (the flutes' length and a little above); an edge point is tested
    by the engagement rule (module docstring) at :data:`HEIGHT_ANGLES` angles. ``depth`` is
    the mid-height of the slice above the highest engaged one (at most ``height``; 0 where
    nothing is engaged): the axial length to slice finely for :func:`tilted_slice_engagement`.
    ``above`` marks material in front of the cutter above ``height`` (the shank would rub).
    Material thinner than half a slice and runs narrower than 5 deg can be missed."""
    height, step = limits
    tip = np.atleast_2d(np.asarray(tip, dtype=float))
    n = tip.shape[0]
    frame, fx, fz = tool_frame(np.broadcast_to(axis, tip.shape), np.broadcast_to(feed, tip.shape))
    reach = height + 2.0 * step
    count = int(np.clip(math.ceil(float(profile.length_to_height(reach)) / step), 8, 400))
    sliced = profile_slices(profile, np.full(n, reach), count)
    phi = np.arange(HEIGHT_ANGLES) * (_TWO_PI / HEIGHT_ANGLES)
    rows = max(1, _POINTS // (count * HEIGHT_ANGLES))
    hit = np.empty((n, count), dtype=bool)
    for start in range(0, n, rows):
        sl = slice(start, min(start + rows, n))
        part = Slices(sliced.radius[sl], sliced.height[sl], sliced.sin_kappa[sl],
                      sliced.cos_kappa[sl], sliced.width[sl])
        hit[sl] = _engaged(stock_contains, (tip[sl], frame[sl], fx[sl], fz[sl]), part,
                           phi).any(axis=2)
    z = sliced.height
    top = count - 1 - np.argmax(hit[:, ::-1], axis=1)  # the highest engaged slice
    above_top = np.concatenate([z[:, 1:], np.full((n, 1), reach)], axis=1)
    depth = np.where(hit.any(axis=1), np.minimum(above_top[np.arange(n), top], height), 0.0)
    return depth, np.any(hit & (z > height), axis=1)


def lateral_hull(se: SliceEngagement) -> tuple[np.ndarray, np.ndarray]:
    """(entry, exit) (n,) [rad] in [0, pi]: the lateral extent of every engaged interval of a
    sample, folded onto the front (an angle theta behind the tool, in (pi, 2 pi), is at the
    lateral position of 2 pi - theta); entry == exit == 0 where nothing is engaged. For
    reports and the engagement's summary columns."""
    lo, hi = se.lo, se.hi
    on = lo < hi
    back_lo, back_hi = _TWO_PI - hi, _TWO_PI - lo  # the folded ends of a back interval
    low = np.where(hi <= np.pi, lo, np.where(lo >= np.pi, back_lo, np.minimum(lo, back_lo)))
    high = np.where(hi <= np.pi, hi, np.where(lo >= np.pi, back_hi, np.pi))
    entry = np.min(np.where(on, low, np.inf), axis=(1, 2))
    exit_ = np.max(np.where(on, high, -np.inf), axis=(1, 2))
    cutting = np.isfinite(entry)
    entry = np.where(cutting, np.clip(entry, 0.0, np.pi), 0.0)
    exit_ = np.where(cutting, np.clip(exit_, 0.0, np.pi), 0.0)
    thin = cutting & (exit_ <= entry)  # a zero-width hull still counts as cutting
    entry = np.where(thin, np.minimum(entry, np.pi - 1e-12), entry)
    return entry, np.where(thin, entry + 1e-12, exit_)
