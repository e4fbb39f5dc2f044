"""The stock stage of a five-axis run: the engagement of a tilted tool from a tri-dexel stock.

When a scenario with a tilted tool path (tool vectors) has ``stock:``,
:func:`engagement_from_dexel` builds the tri-dexel (:mod:`feedopt.process.dexel`: a box, or a
closed mesh) and walks the path in blocks of at most :data:`BLOCK` samples, cut where the
feed or the tool axis turns by :data:`BLOCK_TURN_DEG` (:func:`blocks`). Per block:

1. the height of the material in front of the cutter (a coarse pass,
   :func:`~feedopt.process.tilted_engagement.material_height`), which also finds material
   above the flutes;
2. the engaged intervals of every profile slice over that height
   (:func:`~feedopt.process.tilted_engagement.tilted_slice_engagement`: edge points in the
   material and on the front of the tool, boundaries refined by bisection), gaps narrower
   than two ray spacings along a slice's edge closed (dexel noise); the force model takes
   them as they are (``Engagement.by_slice``);
3. the swept volume removed from the stock (:meth:`TriDexel.sweep_tool_removing`) up to
   :func:`lag` samples behind the block's end (six ray spacings of arc length), its volume
   shared among the samples removed.

Every sample thus sees the stock without the poses of the last lag or block. That is exact
on a straight feed: a point on the front of the tool (``f . n > 0``) is outside every earlier
pose along the feed (for a ball ``|P - c + d f|^2 = R^2 + 2 d R (n . f) + d^2 > R^2``, and so
for every slice of any profile, the earlier pose being shifted by ``-d f``), and the lag
keeps the just-cut surfaces, which the dexel misreads within 0.6 h, away from the front's
thin-chip edge (removed one sample behind, a level ball finishing pass read 28 % short at
its worst sample). Where the feed turns, the blocks end; poses within the lag can then
reach the front: more material than there is, on the safe side, within six ray spacings of
a turn. ``benchmarks/bench_dexel_run.py`` measures the walk against an exact reference (no
dexel) on a line and an 8 mm arc.

A plunge of a cutter with a flat bottom (feed within :data:`PLUNGE_DEG` of the tool axis,
downwards, with material under the bottom) is a full plunge of its end edges
(``Engagement.plunge``, :mod:`feedopt.process.plunge`); a rounded bottom plunging is in the
slices already. A plunge deeper than the flutes below where it met material is material
above the flutes (as the Z-map's check). On a program, a rapid that meets material is
refused, naming the line, and so is a plunge deeper than the flutes. A path that meets no
material at all is refused unless ``stock.air_cut``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.cutter import SliceEngagement, profile_slices
from feedopt.process.dexel import TriDexel
from feedopt.process.engagement import Engagement
from feedopt.process.general_forces import merge_intervals
from feedopt.process.plunge import check_plunge_depth
from feedopt.process.stl import read_stl
from feedopt.process.tilted_engagement import (
    lateral_hull,
    material_height,
    tilted_slice_engagement,
    tool_frame,
)
from feedopt.process.tool import Tool
from feedopt.units import MM

__all__ = ["BLOCK", "DexelFound", "DexelMaterialAlongPath", "DexelStockFacts", "axis_reach",
           "blocks", "build_dexel_stock", "engagement_from_dexel", "lag", "sweep_dexel"]

#: Samples per block of the walk (module docstring).
BLOCK = 16
#: Profile slices of the engagement over the material's height (the force model's).
SLICES = 30
#: Angles per turn tested before the boundaries are refined (1 deg).
ANGLES = 360
#: A feed within this angle [deg] of the tool axis, downwards, is a plunge.
PLUNGE_DEG = 5.0


@dataclass(frozen=True, eq=False)
class DexelFound:
    """What the walk found at ``n`` samples.

    engagement : per slice (``by_slice``), its lateral hull as entry/exit, the slicing height
        as axial depth (the flute length in air); plunges of a flat bottom in ``plunge``
    in_air : (n,) no material in front of the cutter, no plunge
    axial_depth : (n,) [m] the height the material in front reaches above the tip, 0 in air
    beyond_flutes : (n,) material in front of the cutter above the flutes
    removed : (n,) [m^3] the volume each removal took, shared among its samples by their
        arc-length steps (their sum is the stock's volume before minus after)
    rapid_hits : (n,) the samples of a rapid whose own sweep removed material (thicker than
        half a ray spacing over a part of :data:`RAPID_CHUNK` samples): a crash
    """

    engagement: Engagement
    in_air: np.ndarray
    axial_depth: np.ndarray
    beyond_flutes: np.ndarray
    removed: np.ndarray
    rapid_hits: np.ndarray


@dataclass(frozen=True)
class DexelStockFacts:
    """What a run keeps of the stock before the walk (not a copy of it)."""

    rays: tuple[int, int, int]
    spacing: float
    nbytes: int
    volume_m3: float
    box: tuple[np.ndarray, np.ndarray]

    @classmethod
    def of(cls, stock: TriDexel) -> DexelStockFacts:
        return cls(stock.rays, stock.spacing, stock.nbytes, stock.volume(), stock.bounds())

    def volume(self) -> float:
        """Material volume [m^3] (:meth:`TriDexel.volume`)."""
        return self.volume_m3

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The grids' box (:meth:`TriDexel.bounds`)."""
        return self.box


@dataclass(frozen=True, eq=False)
class DexelMaterialAlongPath:
    """The tri-dexel stock before the run (its facts), what the walk found, the stock
    after."""

    before: DexelStockFacts
    after: TriDexel
    found: DexelFound
    warnings: tuple[str, ...] = ()

    @property
    def removed_volume(self) -> float:
        """Material removed by the whole path [m^3]."""
        return self.before.volume() - self.after.volume()


def build_dexel_stock(section, resolve: Callable[[str, str], Path]) -> TriDexel:
    """The tri-dexel of a scenario's ``stock`` section, rays every ``stock.cell_mm``
    (bounded in size before anything is allocated, :data:`feedopt.process.dexel.MAX_RAYS`)."""
    spacing = section.cell_mm * MM
    if section.from_program:
        raise InputError("stock.from_program: the box made from the program follows a tool "
                         "along the workpiece's z; this path tilts the tool (its tool "
                         "vectors): give stock.box_mm or stock.mesh")
    if section.box_mm is not None:
        v = np.asarray(section.box_mm, dtype=float) * MM
        try:
            return TriDexel.box(v[:3], v[3:], spacing)
        except InputError as exc:
            raise InputError(f"stock.box_mm {list(section.box_mm)} at stock.cell_mm "
                             f"{section.cell_mm:g}: {exc}") from None
    units = section.units or "mm"
    file = resolve(section.mesh, "stock.mesh (STL)")
    tri = read_stl(file, f"stock.mesh {file}") * (MM if units == "mm" else 1.0)
    where = f"stock.mesh {file} (read in {units}: stock.units)"
    span = np.ptp(tri.reshape(-1, 3), axis=0)
    if np.any(span < spacing):
        raise InputError(f"{where} is {' x '.join(f'{v / MM:.4g}' for v in span)} mm: thinner "
                         f"than stock.cell_mm {section.cell_mm:g} mm in a direction, no ray "
                         "meets it (if the STL is in metres, set stock.units: m; else use a "
                         "finer stock.cell_mm)")
    try:
        stock = TriDexel.from_mesh(tri, spacing)
    except InputError as exc:
        hint = (" (if the STL is in millimetres, set stock.units: mm)" if units == "m" else "")
        raise InputError(f"{where}, {' x '.join(f'{v / MM:.4g}' for v in span)} mm at "
                         f"stock.cell_mm {section.cell_mm:g}: {exc}{hint}") from None
    _check_enclosed(stock, tri, where)
    return stock


#: Largest relative difference between the mesh's enclosed volume and the tri-dexel's.
VOLUME_TOLERANCE = 0.05


def _check_enclosed(stock: TriDexel, tri: np.ndarray, where: str) -> None:
    """InputError when the tri-dexel's volume differs from the volume the mesh encloses (the
    divergence theorem: the sum of v0 . (v1 x v2) / 6 over the triangles) by more than
    :data:`VOLUME_TOLERANCE`: the rays pair crossings even-odd, so overlapping shells (a
    union not merged) read hollow where they overlap."""
    enclosed = abs(float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum())
                   / 6.0)
    got = stock.volume()
    if abs(got - enclosed) <= VOLUME_TOLERANCE * max(enclosed, got):
        return
    raise InputError(f"{where}: the mesh encloses {enclosed / MM**3:.6g} mm^3 but its rays "
                     f"hold {got / MM**3:.6g} mm^3: overlapping shells (merge them into one "
                     "solid: a boolean union) or faces turned inward; the stock would be "
                     "hollow where they overlap")


def sweep_dexel(stock: TriDexel, tool: Tool, samples, block: int = BLOCK,
                slices: int = SLICES, lag_samples: int | None = None,
                rapid: np.ndarray | None = None) -> DexelFound:
    """Walk ``tool`` along ``samples`` (positions, unit tangents and unit tool axes in the
    stock's frame) through ``stock`` in blocks of at most ``block`` samples, cut where the
    feed or the tool axis turns by :data:`BLOCK_TURN_DEG`, removing what it cuts
    ``lag_samples`` (default :func:`lag`) samples behind (module docstring); the engagement
    on ``slices`` profile slices. ``rapid`` (n,) marks the samples of rapid moves: they
    carry no engagement, and :attr:`DexelFound.rapid_hits` where their own sweep removes
    material."""
    tips, axes, feed = samples.position, samples.axis, samples.tangent
    n, height = tips.shape[0], tool.flute_length
    depth, beyond = np.zeros(n), np.zeros(n, dtype=bool)
    bottom = np.zeros(n, dtype=bool)
    plunging = _feed_along_axis(samples) < -math.cos(math.radians(PLUNGE_DEG))
    parts: list[tuple[np.ndarray, SliceEngagement]] = []
    removal = _Removal(stock, tool, samples, lag(stock.spacing, samples.s)
                       if lag_samples is None else max(1, int(lag_samples)), rapid)
    for start, stop in blocks(samples, block):
        sl = slice(start, stop)
        depth[sl], beyond[sl] = material_height(stock.contains, tips[sl], axes[sl], feed[sl],
                                                tool.profile, (height, stock.spacing))
        pose = (tips[sl], axes[sl], feed[sl])
        bottom[sl] = _disc_hits(stock, pose, -0.5 * stock.spacing, tool.profile.r0)
        on = np.flatnonzero(depth[sl] > 0.0) + start
        if on.size:
            te = tilted_slice_engagement(stock.contains, tips[on], axes[on], feed[on],
                                         tool.profile, depth[on], slices, ANGLES)
            parts.append((on, _without_noise(te.slices, stock.spacing)))
        removal.upto(stop if stop == n else stop - removal.lag)
    table = _table(tool, samples, depth, parts, slices)
    beyond |= _plunge_depth(samples, plunging, bottom, stock.spacing) > height
    if rapid is not None:  # a rapid cuts nothing (its sweep is judged: rapid_hits)
        table = table.without(np.asarray(rapid, dtype=bool))
        bottom &= ~np.asarray(rapid, dtype=bool)
    plunge = bottom & plunging
    engagement = _engagement(tool, table, depth, plunge)
    in_air = ~(table.cutting | plunge)
    return DexelFound(engagement, in_air, np.where(in_air, 0.0, depth), beyond,
                      removal.per_sample(), removal.rapid_hits)


#: A block ends where the feed direction and the tool axis have turned by this much [deg]
#: since its first sample (an earlier pose of a block that turns can reach the front).
BLOCK_TURN_DEG = 3.0


def blocks(samples, block: int) -> list[tuple[int, int]]:
    """(start, stop) of the walk's blocks: at most ``block`` samples, and cut where the
    tangent and the tool axis together turn by more than :data:`BLOCK_TURN_DEG`."""
    turn = sum(np.arccos(np.clip(np.einsum("ij,ij->i", v[:-1], v[1:]), -1.0, 1.0))
               for v in (samples.tangent, samples.axis))
    cum = np.concatenate([[0.0], np.cumsum(turn)])
    limit = math.radians(BLOCK_TURN_DEG)
    n, out, start = cum.size, [], 0
    while start < n:
        stop = min(start + block, int(np.searchsorted(cum, cum[start] + limit, "right")))
        stop = max(stop, start + 1)
        out.append((start, stop))
        start = stop
    return out


#: Samples of a rapid swept at once: a part whose swept volume is thicker than half a ray
#: spacing over the tool's diameter and its length is a crash (a blended corner into a
#: retract shaves a sliver of a few thousandths of a millimetre: no crash).
RAPID_CHUNK = 8
#: How far behind the walk removes what the cutter swept, in ray spacings of arc length.
LAG_SPACINGS = 6.0
#: The most samples the removal lags.
MAX_LAG = 64


def lag(spacing: float, s: np.ndarray) -> int:
    """How many samples behind the walk removes what the cutter swept: :data:`LAG_SPACINGS`
    ray spacings of arc length (at least one sample, at most :data:`MAX_LAG`). A surface cut
    by an earlier pose lies a distance d (n . f) from the front's edge point (d the arc
    length between them, n . f the chip's sign, small near the tip and the sides) and the
    dexel misreads points within 0.6 h of a surface, so poses closer than a few h make the
    thin-chip edge read as cut; on a straight feed the poses not yet removed cannot reach the
    front at all (module docstring). Measured on a level 0.5 mm ball finishing pass: the
    worst sample reads 13-30 % short with 4 h and less, exact with 6 h
    (``tests/process/test_dexel_material.py``)."""
    if s.size < 2:
        return 1
    step = float(np.median(np.diff(s)))
    return int(np.clip(math.ceil(LAG_SPACINGS * spacing / max(step, 1e-12)), 1, MAX_LAG))


class _Removal:
    """The poses removed so far from the stock, the volume each removal took and, for the
    rapids, whether their own sweep met material."""

    def __init__(self, stock: TriDexel, tool: Tool, samples, lag_samples: int,
                 rapid: np.ndarray | None = None) -> None:
        self.stock, self.tool, self.samples, self.lag = stock, tool, samples, lag_samples
        n = samples.s.size
        self.done = 0  # poses [0, done) removed
        self.removed = np.zeros(n)
        rapid = np.zeros(n, dtype=bool) if rapid is None else np.asarray(rapid, dtype=bool)
        # the step into sample i is a rapid's when it leaves a rapid sample too (the first
        # step of a rapid still ends the feed move before it, as for the Z-map)
        self.rapid_step = rapid & np.r_[False, rapid[:-1]]
        self.rapid_hits = np.zeros(n, dtype=bool)

    def upto(self, target: int) -> None:
        """Remove the cutter swept from the last removed pose to pose ``target - 1``, in runs
        of rapid and other steps (a rapid's sweep is judged on its own)."""
        if target <= self.done:
            return
        kind = self.rapid_step[self.done:target]
        cuts = np.flatnonzero(np.diff(kind.astype(np.int8))) + 1 + self.done
        for a, b in zip(np.r_[self.done, cuts], np.r_[cuts, target], strict=True):
            self._sweep(int(a), int(b))
        self.done = target

    def _sweep(self, a: int, b: int) -> None:
        if not self.rapid_step[a]:
            self._sweep_part(a, b)
            return
        for start in range(a, b, RAPID_CHUNK):  # a rapid in parts: where it crashes
            stop = min(start + RAPID_CHUNK, b)
            volume = self._sweep_part(start, stop)
            length = self.samples.s[stop - 1] - self.samples.s[max(start - 1, 0)]
            area = self.tool.diameter * max(length, self.stock.spacing)
            self.rapid_hits[start:stop] = volume / area > 0.5 * self.stock.spacing

    def _sweep_part(self, a: int, b: int) -> float:
        """Sweep poses a - 1 .. b - 1; the volume removed [m^3], shared among a .. b - 1."""
        first = max(a - 1, 0)
        tips, axes = self.samples.position[first:b], self.samples.axis[first:b]
        reach = min(self.tool.flute_length,
                    float(np.max(axis_reach(self.stock, tips, axes, self.tool))))
        if reach <= 0.0:  # the cutter up to where its axis leaves the stock's box
            return 0.0
        volume = self.stock.sweep_tool_removing(tips, axes, self.tool.profile, reach)[1]
        self.removed[a:b] = _share(volume, self.samples.s[first:b], b - a)
        return volume

    def per_sample(self) -> np.ndarray:
        return self.removed


def _share(volume: float, s: np.ndarray, count: int) -> np.ndarray:
    """``volume`` shared among the last ``count`` samples of ``s`` by their arc-length
    steps (evenly where they have none)."""
    ds = np.diff(s, prepend=s[0])[-count:]
    total = float(ds.sum())
    return volume * (ds / total if total > 0.0 else np.full(count, 1.0 / count))


def _without_noise(se: SliceEngagement, spacing: float) -> SliceEngagement:
    """``se`` with the gaps between a slice's intervals narrower than two ray spacings along
    its edge (2 h / r rad, at most :data:`MAX_GAP_DEG`) closed: the dexel misreads points
    within 0.6 h of a surface, which splits a contact into slivers (on the saddle up to ten
    per slice). Each interval is widened by half the gap, merged, narrowed back."""
    r = np.maximum(se.sliced.radius, 1e-12)[..., None]
    half = 0.5 * np.minimum(2.0 * spacing / r, math.radians(MAX_GAP_DEG))
    on = se.lo < se.hi
    lo, hi = merge_intervals(np.where(on, se.lo - half, 0.0), np.where(on, se.hi + half, 0.0))
    keep = lo < hi
    width = keep.shape[2]
    half_w = np.broadcast_to(half, half.shape[:2] + (1,))[..., :1]
    lo = np.where(keep, lo + half_w, 0.0)
    hi = np.where(keep, hi - half_w, 0.0)
    return SliceEngagement(se.sliced, lo[..., :width], hi[..., :width], se.feed_x, se.feed_z)


#: Largest gap [deg] between two contacts of one slice that :func:`_without_noise` closes.
MAX_GAP_DEG = 10.0


def axis_reach(stock: TriDexel, tips: np.ndarray, axes: np.ndarray, tool: Tool
               ) -> np.ndarray:
    """(b,) the height above the tip [m] where each pose's axis leaves the stock's box
    widened by the tool's largest radius (slab method; <= 0 where it never enters): above
    it no point of the cutter is in the box, so removing the cutter up to it removes all it
    cuts."""
    lo, hi = stock.bounds()
    widen = max(0.5 * tool.diameter, _widest_radius(tool))
    lo, hi = lo - widen, hi + widen
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - tips) / axes, (hi - tips) / axes
    near, far = np.minimum(t0, t1), np.maximum(t0, t1)
    parallel = np.abs(axes) < 1e-12
    inside = (tips >= lo) & (tips <= hi)
    near = np.where(parallel, np.where(inside, -np.inf, np.inf), near)
    far = np.where(parallel, np.where(inside, np.inf, -np.inf), far)
    enter, leave = near.max(axis=1), far.min(axis=1)
    return np.where(leave >= np.maximum(enter, 0.0), leave, 0.0)


def _feed_along_axis(samples) -> np.ndarray:
    return np.einsum("ij,ij->i", samples.tangent, samples.axis)


def _table(tool: Tool, samples, depth: np.ndarray,
           parts: list[tuple[np.ndarray, SliceEngagement]], slices: int) -> SliceEngagement:
    """The slice engagement of all samples: the engaged ones' intervals, the others sliced
    over the flute length with nothing engaged."""
    n = depth.size
    _, fx, fz = tool_frame(samples.axis, samples.tangent)
    sliced = profile_slices(tool.profile, np.where(depth > 0.0, depth, tool.flute_length),
                            slices)
    width = max([p.lo.shape[2] for _, p in parts], default=1)
    lo, hi = np.zeros((n, slices, width)), np.zeros((n, slices, width))
    for rows, p in parts:
        lo[rows, :, :p.lo.shape[2]] = p.lo
        hi[rows, :, :p.hi.shape[2]] = p.hi
    return SliceEngagement(sliced, lo, hi, fx, fz)


def _engagement(tool: Tool, table: SliceEngagement, depth: np.ndarray,
                plunge: np.ndarray) -> Engagement:
    entry, exit_ = lateral_hull(table)
    lean = np.where(table.cutting, table.feed_z, 0.0)
    flat_bottom = tool.profile.r0 > 0.0
    return Engagement(entry, exit_, np.where(depth > 0.0, depth, tool.flute_length),
                      plunge=plunge.astype(float) if flat_bottom else None,
                      feed_axial=lean, by_slice=table)


def _disc_hits(stock: TriDexel, pose: tuple, height: float, radius: float) -> np.ndarray:
    """(b,) whether the disc of ``radius`` [m] across the tool axis at ``height`` above the
    tip (17 points: the centre and 8 at half and 0.95 of the radius) meets material; False
    everywhere for a radius of 0 (no flat bottom)."""
    tips, axes, feed = pose
    if radius <= 0.0:
        return np.zeros(tips.shape[0], dtype=bool)
    frame, _, _ = tool_frame(axes, feed)
    ang = np.arange(8) * (math.pi / 4.0)
    disc = np.concatenate([[[0.0, 0.0]], *(rf * radius * np.stack([np.cos(ang), np.sin(ang)],
                                                                   1) for rf in (0.5, 0.95))])
    pts = (tips[:, None, :] + disc[None, :, :1] * frame[:, None, 0]
           + disc[None, :, 1:] * frame[:, None, 1] + height * frame[:, None, 2])
    return stock.contains(pts.reshape(-1, 3)).reshape(tips.shape[0], -1).any(axis=1)


def _plunge_depth(samples, plunging: np.ndarray, bottom: np.ndarray, spacing: float
                  ) -> np.ndarray:
    """(n,) how far each sample of a plunge (a run of ``plunging`` samples) is below where
    its bottom met material (the first sample of the run with material under it, half a ray
    spacing below its tip), along the tool axis [m]; 0 elsewhere. As the Z-map's plunge
    check: deeper than the flutes, the shank follows the tool into its own hole."""
    out = np.zeros(plunging.size)
    edges = np.diff(np.r_[0, plunging.astype(np.int8), 0])
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        met = np.flatnonzero(bottom[a:b])
        if met.size:
            m = a + int(met[0])
            out[m:b] = 0.5 * spacing + np.einsum(
                "ij,ij->i", samples.position[m] - samples.position[m:b], samples.axis[m:b])
    return out


def _widest_radius(tool: Tool) -> float:
    """The cutter's radius at the top of its flutes [m]."""
    return float(tool.profile.at_length(tool.profile.length_to_height(tool.flute_length))[0])


def engagement_from_dexel(section, resolve: Callable[[str, str], Path], tool: Tool, samples,
                          moves=None, source: str = "the program", slices: int = SLICES
                          ) -> DexelMaterialAlongPath:
    """Walk ``tool`` along the tilted path ``samples`` (workpiece frame) through the
    scenario's stock (module docstring), the engagement on ``slices`` profile slices.
    ``moves`` (a program's move table) adds the program checks: no rapid may meet material,
    no plunge may reach above the flutes."""
    after = build_dexel_stock(section, resolve)
    check_walk_cost(section, tool, samples, after)
    before = DexelStockFacts.of(after)
    rapid = (None if moves is None
             else moves.category[moves.index_at(samples.s)] == "rapid")
    found = sweep_dexel(after, tool, samples, slices=slices, rapid=rapid)
    if moves is not None:
        _check_program_contacts(found, moves, samples, source, tool)
    notes = _nothing_cut(section, before, found, samples.position) + _coarse(section, found)
    return DexelMaterialAlongPath(before, after, found, notes)


#: Largest (pose, ray) pairs the walk's removal may test (a few minutes: 2.9e9 pairs took 67 s
#: on a 0.05 mm tri-dexel, a 206 mm ball path through a 40 x 20 x 15 mm saddle stock).
MAX_REMOVAL_PAIRS = 8e9


def check_walk_cost(section, tool: Tool, samples, stock: TriDexel) -> None:
    """InputError naming ``stock.cell_mm`` (and a spacing that would fit) when removing the
    cutter along the path would test more than :data:`MAX_REMOVAL_PAIRS` (pose, ray) pairs:
    poses every half a ray spacing of the path, each against the rays of its box in the
    three grids (the work grows as 1 / h^3)."""
    h = stock.spacing
    lo, hi = stock.bounds()
    width = 2.0 * max(0.5 * tool.diameter, _widest_radius(tool))
    length = min(tool.flute_length, float(np.linalg.norm(hi - lo)))
    poses = max(float(samples.s[-1]) if samples.s.size else 0.0, h) / (0.5 * h)
    pairs = poses * 3.0 * (width / h) * ((width + length) / h)
    if pairs <= MAX_REMOVAL_PAIRS:
        return
    fits = section.cell_mm * (pairs / MAX_REMOVAL_PAIRS) ** (1.0 / 3.0)
    raise InputError(f"stock.cell_mm {section.cell_mm:g} mm: removing the cutter along this "
                     f"{samples.s[-1] / MM:.0f} mm path would test about {pairs:.2g} (pose, "
                     f"ray) pairs, more than the {MAX_REMOVAL_PAIRS:.0e} a run may (several "
                     f"minutes of work); use stock.cell_mm >= {fits:.2g} or a shorter path")


#: A ray spacing over this fraction of the typical depth of cut gets a warning (the
#: saddle's 0.5 mm allowance: 0.2 mm rays remove 80 mm^3, 0.1 mm rays 77, 1 mm rays 114).
COARSE_FRACTION = 0.3


def _coarse(section, found: DexelFound) -> tuple[str, ...]:
    """A warning when ``stock.cell_mm`` is coarse against the material the path meets: the
    tri-dexel reads material within about 0.6 of a ray spacing of its surfaces, so a
    spacing near the depth of cut gives an engagement that is mostly that error."""
    depth = found.axial_depth[~found.in_air]
    if depth.size == 0:
        return ()
    typical = float(np.median(depth))
    if section.cell_mm * MM <= COARSE_FRACTION * typical:
        return ()
    return (f"stock.cell_mm {section.cell_mm:g} mm is coarse for the material this path meets "
            f"(its median depth along the tool is {typical / MM:.3g} mm): the tri-dexel reads "
            "material within about 0.6 of its ray spacing, so engagement and removed volume "
            f"may be far off; use stock.cell_mm <= {COARSE_FRACTION * typical / MM:.2g}",)


def _check_program_contacts(found: DexelFound, moves, samples, source: str,
                            tool: Tool) -> None:
    """A rapid whose own swept volume removes material (:attr:`DexelFound.rapid_hits`; a
    retract along the tool axis out of its own hole removes none) is refused, naming the
    line; so is a plunge deeper than the flutes."""
    move = moves.index_at(samples.s)
    cat = moves.category[move]
    hit = found.rapid_hits
    deep = (cat == "plunge") & found.beyond_flutes & ~found.in_air
    if hit.any() and not (deep.any() and np.argmax(deep) < np.argmax(hit)):
        i = int(np.argmax(hit))
        run = found.removed[i:][:int(np.argmin(hit[i:])) or None]
        raise InputError(
            f"{source} {moves.label(int(move[i]))}: a rapid meets material: the cutter would "
            f"crash into the stock; rapid clear of it or cut with a feed move (at s = "
            f"{samples.s[i] / MM:.3f} mm, its swept volume cuts {run.sum() / MM**3:.3g} mm^3 "
            "of material)")
    check_plunge_depth(deep, move, moves, tool, source)


def _nothing_cut(section, before: DexelStockFacts, found: DexelFound,
                 positions: np.ndarray) -> tuple[str, ...]:
    """Refuse (or, with stock.air_cut, warn about) a path that meets no material; warn when
    stock.air_cut is set but the path cuts."""
    cutting = int(np.sum(~found.in_air))
    air_cut = bool(section.air_cut)
    if cutting and air_cut:
        return (f"stock.air_cut is set but the path cuts material at {cutting} of "
                f"{found.in_air.size} samples; the plan includes their forces",)
    if cutting:
        return ()
    lo, hi = before.bounds()
    p_lo, p_hi = positions.min(axis=0), positions.max(axis=0)
    inside = bool(np.all(p_lo < hi) and np.all(p_hi > lo))
    span = ", ".join(f"{a} {p_lo[k] / MM:.6g}..{p_hi[k] / MM:.6g}" for k, a in enumerate("xyz"))
    box = ", ".join(f"{a} {lo[k] / MM:.6g}..{hi[k] / MM:.6g}" for k, a in enumerate("xyz"))
    text = (f"stock: the path meets no material at any of its {found.in_air.size} samples: "
            f"the tool tips span {span} mm, the stock's grids {box} mm (both in the workpiece "
            "frame W)")
    if inside:
        text += (f"; the path passes through the stock's box: is stock.cell_mm "
                 f"{section.cell_mm:g} mm too coarse for the material it meets?")
    if section.mesh is not None:
        text += f"; the STL was read in {section.units or 'mm'} (stock.units)"
    if air_cut:
        return (text + "; planned as an air cut (stock.air_cut: true)",)
    raise InputError(text + ". Place the stock where the path cuts, or set stock.air_cut: "
                     "true if an air cut is meant")
