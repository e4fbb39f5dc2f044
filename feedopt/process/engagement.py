"""Cutter engagement per path sample: entry/exit angles and axial depth.

Angles follow Altintas [39] (thesis Fig. 3.10): the immersion angle phi is measured clockwise
from the +y (normal) axis of the force-model frame, the chip thickness is h = c sin(phi), and a
tooth cuts while ``entry <= phi < exit`` with ``0 <= entry <= exit <= pi``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.cutter import SliceEngagement
from feedopt.units import MM, MM_PER_M

MILLING_MODES = ("up", "down")


@dataclass(frozen=True)
class EngagementPieces:
    """Engaged angular intervals, each with its own axial depth, of some path samples.

    Where the material in front of the cutter is not one interval of one axial depth (two
    separate contacts at an inside corner cut with a small radial depth, a step or a slope of
    the material top across the cutter), the engaged set of a sample is the union of its
    pieces ``[entry_k, exit_k)`` of depth ``a_k``. A slice at height z of a tooth at immersion
    phi cuts iff phi lies in a piece k and z < a_k, so the force of the sample is the sum of
    the forces of its pieces (Algorithm 1 is a sum over slices; disjoint pieces share none).

    Attributes
    ----------
    sample : (p,) int, the sample each piece belongs to, non-decreasing.
    entry, exit : (p,) [rad], ``0 <= entry < exit <= pi``; the pieces of one sample are
        disjoint (in increasing angle).
    axial_depth : (p,) [m], > 0.
    """

    sample: np.ndarray
    entry: np.ndarray
    exit: np.ndarray
    axial_depth: np.ndarray

    def __post_init__(self) -> None:
        sample = np.asarray(self.sample, dtype=np.int64).reshape(-1)
        arrays = [np.asarray(getattr(self, k), dtype=float).reshape(-1)
                  for k in ("entry", "exit", "axial_depth")]
        if any(a.shape != sample.shape for a in arrays):
            raise InputError("engagement pieces: sample, entry, exit and axial_depth must have "
                             "the same length")
        entry, exit_, depth = arrays
        bad = (~np.isfinite(entry) | ~np.isfinite(exit_) | ~np.isfinite(depth) | (entry < 0)
               | (exit_ <= entry) | (exit_ > np.pi) | (depth <= 0))
        if sample.size > 1:
            same = sample[1:] == sample[:-1]
            bad[1:] |= (sample[1:] < sample[:-1]) | (same & (entry[1:] < exit_[:-1] - 1e-12))
        if np.any(bad):
            k = int(np.argmax(bad))
            raise InputError(
                f"engagement piece {k} (sample {int(sample[k])}): entry {np.degrees(entry[k]):.6g}"
                f" deg, exit {np.degrees(exit_[k]):.6g} deg, depth {depth[k] / MM:.6g} mm: pieces "
                "need 0 <= entry < exit <= 180 deg, depth > 0, in sample order and disjoint")
        for name, value in zip(("sample", "entry", "exit", "axial_depth"),
                               (sample, entry, exit_, depth), strict=True):
            object.__setattr__(self, name, value)

    @property
    def count(self) -> int:
        """Number of pieces p."""
        return int(self.sample.size)

    def as_engagement(self) -> Engagement:
        """The pieces as an engagement of ``p`` samples (one piece each)."""
        return Engagement(self.entry, self.exit, self.axial_depth)

    def select(self, keep: np.ndarray, renumber: bool = True) -> EngagementPieces:
        """The pieces of the samples where ``keep`` (an (n,) bool mask over the samples)
        holds, renumbered to the kept samples unless ``renumber`` is False."""
        keep = np.asarray(keep, dtype=bool)
        mine = keep[self.sample]
        sample = self.sample[mine]
        if renumber:
            sample = (np.cumsum(keep) - 1)[sample]
        return EngagementPieces(sample, self.entry[mine], self.exit[mine],
                                self.axial_depth[mine])


@dataclass(frozen=True)
class Engagement:
    """Engagement of the cutter at ``n`` path samples (arrays of shape ``(n,)``).

    Attributes
    ----------
    entry : phi_st [rad]
    exit : phi_ex [rad]; ``exit == entry`` means the tool is not cutting.
    axial_depth : a [m]
    pieces : optional :class:`EngagementPieces`. The samples it names are engaged on the
        union of their pieces, each with its own axial depth, instead of on one interval;
        ``entry``/``exit`` are then their hull (first and last engaged angle) and
        ``axial_depth`` their largest depth, for reports. The force model sums the pieces.
    plunge : optional (n,) end cutting per sample (:mod:`feedopt.process.plunge`): 0 = the
        end edges cut nothing, 1 = a full plunge into material along the tool axis (no
        other value: a partial footprint is not modelled). None (or all 0) = no plunge;
        the force model adds the plunge force to whatever side engagement the sample has.
    feed_axial : optional (n,) the unit feed direction's component along the tool axis,
        ``f . k`` in [-1, 1] (the sine of the lean of a five-axis tool against its path;
        + towards the spindle): the chip of a tilted tool
        (:mod:`feedopt.process.general_forces`, "Feed along the axis"). None: the feed is
        across the axis.
    by_slice : optional :class:`~feedopt.process.cutter.SliceEngagement` of all ``n``
        samples: per sample and profile slice the engaged intervals in [0, 2 pi), found in a
        stock by a tilted tool (:mod:`feedopt.process.tilted_engagement`). The force model
        then takes these (the cutter of any shape on the profile's slices,
        :mod:`feedopt.process.general_forces`) instead of entry/exit/depth, which are their
        lateral hull (for reports) and the slicing height.
    """

    entry: np.ndarray
    exit: np.ndarray
    axial_depth: np.ndarray
    pieces: EngagementPieces | None = None
    plunge: np.ndarray | None = None
    feed_axial: np.ndarray | None = None
    by_slice: SliceEngagement | None = None

    def __post_init__(self) -> None:
        arrays = [np.asarray(getattr(self, k), dtype=float) for k in ("entry", "exit")]
        depth = np.asarray(self.axial_depth, dtype=float)
        if arrays[0].ndim != 1 or arrays[0].shape != arrays[1].shape:
            raise InputError(
                "engagement: entry and exit must be 1-D arrays of the same length, got "
                f"shapes {arrays[0].shape} and {arrays[1].shape}"
            )
        depth = np.broadcast_to(depth, arrays[0].shape).copy() if depth.ndim == 0 else depth
        if depth.shape != arrays[0].shape:
            raise InputError(
                f"engagement: axial_depth has shape {depth.shape}, expected {arrays[0].shape}"
            )
        object.__setattr__(self, "entry", arrays[0])
        object.__setattr__(self, "exit", arrays[1])
        object.__setattr__(self, "axial_depth", depth)
        validate_engagement(self)
        object.__setattr__(self, "plunge", _plunge_column(self.plunge, self.n))
        object.__setattr__(self, "feed_axial", _feed_axial_column(self.feed_axial, self.n))
        if self.by_slice is not None and self.by_slice.n != self.n:
            raise InputError(f"engagement: by_slice has {self.by_slice.n} samples, expected "
                             f"{self.n}")
        p = self.pieces
        if p is not None:
            if p.count == 0:
                object.__setattr__(self, "pieces", None)
            elif p.sample[0] < 0 or p.sample[-1] >= self.n:
                raise InputError(f"engagement pieces name samples {int(p.sample[0])}.."
                                 f"{int(p.sample[-1])} of an engagement of {self.n} samples")

    @property
    def n(self) -> int:
        """Number of path samples."""
        return int(self.entry.size)

    @property
    def pieced(self) -> np.ndarray:
        """(n,) bool: samples engaged on pieces rather than on one interval."""
        mask = np.zeros(self.n, dtype=bool)
        if self.pieces is not None:
            mask[self.pieces.sample] = True
        return mask

    def take(self, index: np.ndarray | slice) -> Engagement:
        """The engagement of samples ``index`` (a slice or increasing indices), with their
        pieces."""
        idx = np.arange(self.n)[index]
        pieces = None
        if self.pieces is not None:
            keep = np.zeros(self.n, dtype=bool)
            keep[idx] = True
            if idx.size > 1 and np.any(np.diff(idx) <= 0):
                raise ValueError("Engagement.take needs increasing sample indices")
            pieces = self.pieces.select(keep)
        plunge = None if self.plunge is None else self.plunge[idx]
        lean = None if self.feed_axial is None else self.feed_axial[idx]
        table = None if self.by_slice is None else self.by_slice.rows(idx)
        return Engagement(self.entry[idx], self.exit[idx], self.axial_depth[idx], pieces,
                          plunge, lean, table)

    def without(self, drop: np.ndarray) -> Engagement:
        """This engagement with the samples where ``drop`` holds not cutting (in air, no
        plunge either)."""
        drop = np.asarray(drop, dtype=bool)
        pieces = None if self.pieces is None else self.pieces.select(~drop, renumber=False)
        plunge = None if self.plunge is None else np.where(drop, 0.0, self.plunge)
        table = None if self.by_slice is None else self.by_slice.without(drop)
        return Engagement(np.where(drop, 0.0, self.entry), np.where(drop, 0.0, self.exit),
                          self.axial_depth, pieces, plunge, self.feed_axial, table)

    def hull_only(self) -> Engagement:
        """Every sample on one interval: the pieced samples not cutting (entry = exit = 0),
        without the plunge.

        With ``pieces.as_engagement()``, the two parts the force model sums for the side
        (peripheral) edges."""
        return Engagement(np.where(self.pieced, 0.0, self.entry),
                          np.where(self.pieced, 0.0, self.exit), self.axial_depth,
                          feed_axial=self.feed_axial)

    def side_only(self) -> Engagement:
        """This engagement without its plunge (the side edges only)."""
        if self.plunge is None:
            return self
        return Engagement(self.entry, self.exit, self.axial_depth, self.pieces,
                          feed_axial=self.feed_axial, by_slice=self.by_slice)

    def with_plunge(self, plunge: np.ndarray | None) -> Engagement:
        """This engagement with the plunge column ``plunge`` (n,) (0/1; None: no plunge)."""
        return Engagement(self.entry, self.exit, self.axial_depth, self.pieces, plunge,
                          self.feed_axial, self.by_slice)

    def with_feed_axial(self, feed_axial: np.ndarray | None) -> Engagement:
        """This engagement with the feed's component along the tool axis ``feed_axial`` (n,)
        (None: across the axis)."""
        return Engagement(self.entry, self.exit, self.axial_depth, self.pieces, self.plunge,
                          feed_axial, self.by_slice)

    @property
    def cutting(self) -> np.ndarray:
        """(n,) bool: the side edges cut (an engaged interval; the plunge not counted)."""
        if self.by_slice is not None:
            return self.by_slice.cutting
        return self.exit > self.entry

    @property
    def plunging(self) -> np.ndarray:
        """(n,) bool: samples whose end edges plunge into material."""
        if self.plunge is None:
            return np.zeros(self.n, dtype=bool)
        return self.plunge > 0


def _plunge_column(plunge, n: int) -> np.ndarray | None:
    """The plunge column as a float (n,) array of 0 and 1, or None when absent or all 0."""
    if plunge is None:
        return None
    p = np.asarray(plunge, dtype=float)
    if p.shape != (n,):
        raise InputError(f"engagement: plunge has shape {p.shape}, expected ({n},)")
    bad = (p != 0.0) & (p != 1.0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(f"engagement.plunge at sample {i} is {float(p[i])!r}: must be 0 (no end "
                         "cutting) or 1 (a full plunge into material); a partial footprint "
                         "is not modelled")
    return p.copy() if p.any() else None


def _feed_axial_column(feed_axial, n: int) -> np.ndarray | None:
    """The feed-along-axis column as a float (n,) array in [-1, 1], or None when absent or
    all 0."""
    if feed_axial is None:
        return None
    f = np.asarray(feed_axial, dtype=float)
    if f.shape != (n,):
        raise InputError(f"engagement: feed_axial has shape {f.shape}, expected ({n},)")
    bad = ~np.isfinite(f) | (np.abs(f) > 1.0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(f"engagement.feed_axial at sample {i} is {float(f[i])!r}: the feed "
                         "direction's component along the tool axis must be in [-1, 1]")
    return f.copy() if f.any() else None


def validate_engagement(eng: Engagement, flute_length: float | None = None) -> None:
    """Raise InputError naming the first bad sample (angles out of [0, pi], depth <= 0, ...)."""
    # (bad mask, field, scale from SI to the unit shown, unit, rule)
    checks = [
        (
            ~np.isfinite(eng.entry) | (eng.entry < 0) | (eng.entry > np.pi),
            "entry",
            180.0 / np.pi,
            "deg",
            "must be in [0, 180] deg",
        ),
        (
            ~np.isfinite(eng.exit) | (eng.exit < eng.entry) | (eng.exit > np.pi),
            "exit",
            180.0 / np.pi,
            "deg",
            "must be in [entry, 180] deg",
        ),
        (
            ~np.isfinite(eng.axial_depth) | (eng.axial_depth <= 0),
            "axial_depth",
            1.0 / MM,
            "mm",
            "must be > 0",
        ),
    ]
    if flute_length is not None:
        checks.append(
            (
                eng.axial_depth > flute_length * (1 + 1e-12),
                "axial_depth",
                1.0 / MM,
                "mm",
                f"exceeds the tool's flute length {flute_length / MM:g} mm",
            )
        )
    for bad, name, scale, unit, rule in checks:
        if np.any(bad):
            i = int(np.argmax(bad))
            value = float(getattr(eng, name)[i]) * scale
            raise InputError(f"engagement.{name} at sample {i} is {value:.6g} {unit}: {rule}")


def slot_engagement(n: int, axial_depth: float | np.ndarray) -> Engagement:
    """Full immersion (slotting): phi_st = 0, phi_ex = pi at ``n`` samples."""
    if int(n) != n or n < 0:
        raise InputError(f"slot_engagement: sample count must be a whole number >= 0, got {n!r}")
    n = int(n)
    depth = np.broadcast_to(np.asarray(axial_depth, dtype=float), (n,)).copy()
    return Engagement(np.zeros(n), np.full(n, np.pi), depth)


def peripheral_engagement(
    radial_depth: np.ndarray,
    diameter: float,
    axial_depth: float | np.ndarray,
    milling: str,
) -> Engagement:
    """Peripheral (side) milling with radial depth of cut a_e per sample.

    Up milling: phi_st = 0, phi_ex = arccos(1 - 2 a_e / D).
    Down milling: phi_st = pi - arccos(1 - 2 a_e / D), phi_ex = pi (Altintas [39]).
    ``a_e = D`` is a slot; ``a_e = 0`` is allowed and means no contact at that sample (the
    chapter-4 ramp starts there).
    """
    if milling not in MILLING_MODES:
        raise InputError(f"milling must be 'up' or 'down', got {milling!r}")
    if not (np.isfinite(diameter) and diameter > 0):
        raise InputError(f"tool diameter must be > 0 mm, got {diameter / MM:g} mm")
    ae = np.atleast_1d(np.asarray(radial_depth, dtype=float))
    if ae.ndim != 1:
        raise InputError(f"radial_depth must be a 1-D array, got shape {ae.shape}")
    bad = ~np.isfinite(ae) | (ae < 0) | (ae > diameter * (1 + 1e-12))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"radial_depth at sample {i} is {ae[i] * MM_PER_M:g} mm: must be in [0, D] = "
            f"[0, {diameter * MM_PER_M:g}] mm"
        )
    sweep = np.arccos(np.clip(1.0 - 2.0 * ae / diameter, -1.0, 1.0))
    depth = np.broadcast_to(np.asarray(axial_depth, dtype=float), ae.shape).copy()
    if milling == "up":
        return Engagement(np.zeros_like(sweep), sweep, depth)
    return Engagement(np.pi - sweep, np.full_like(sweep, np.pi), depth)


def radial_depth_profile(s: np.ndarray, table_s: np.ndarray, table_depth: np.ndarray) -> np.ndarray:
    """Radial depth at arc lengths ``s`` by linear interpolation of a table.

    Chapter 4 of the thesis ramps a_e from 0 to 9.525 mm over 203.2 mm:
    ``radial_depth_profile(s, [0, 0.2032], [0, 0.009525])``. ``s`` outside the table (beyond
    a 1 um rounding tolerance) is refused rather than silently clamped.
    """
    s = np.asarray(s, dtype=float)
    ts = np.asarray(table_s, dtype=float).reshape(-1)
    td = np.asarray(table_depth, dtype=float).reshape(-1)
    if ts.size < 1 or ts.size != td.size:
        raise InputError(
            f"radial depth table: s and depth need the same non-zero length, got {ts.size} "
            f"and {td.size}"
        )
    if np.any(~np.isfinite(ts)) or np.any(np.diff(ts) <= 0):
        raise InputError("radial depth table: s must be finite and strictly increasing")
    bad = ~np.isfinite(td) | (td < 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(f"radial depth table: depth[{i}] is {td[i] / MM:g} mm, must be >= 0")
    tol = 1e-6
    out = (s < ts[0] - tol) | (s > ts[-1] + tol) | ~np.isfinite(s)
    if np.any(out):
        i = int(np.argmax(out.reshape(-1)))
        raise InputError(
            f"radial depth profile: s = {s.reshape(-1)[i] * MM_PER_M:g} mm (sample {i}) is outside "
            f"the table's {ts[0] * MM_PER_M:g}..{ts[-1] * MM_PER_M:g} mm"
        )
    return np.interp(s, ts, td)
