"""The stock stage of a five-axis run: the engagement of a tilted tool from a tri-dexel stock.

When a scenario with a tilted tool path (tool vectors) has ``stock:``,
:func:`engagement_from_dexel` builds the tri-dexel (:mod:`feedopt.process.dexel`: a box, or a
closed mesh) and walks the path in blocks of :data:`BLOCK` samples. Per block:

1. the height of the material in front of the cutter (a coarse pass,
   :func:`~feedopt.process.tilted_engagement.material_height`), which also finds material
   above the flutes;
2. the engaged intervals of every profile slice over that height
   (:func:`~feedopt.process.tilted_engagement.tilted_slice_engagement`: edge points in the
   material and on the front of the tool, boundaries refined by bisection), which the force
   model takes as they are (``Engagement.by_slice``);
3. the block's swept volume removed from the stock (:meth:`TriDexel.sweep_tool`, from the
   last pose of the previous block), its volume the block's removal.

Within a block every sample sees the stock as the block began. That is exact on a straight
feed: a point on the front of the tool (``f . n > 0``) is outside every earlier pose of the
tool along ``f`` (for a ball ``|P - c + d f|^2 = R^2 + 2 d R (n . f) + d^2 > R^2``, and so
for every slice of any profile, the earlier pose being shifted by ``-d f``). Where the feed
turns, an earlier pose of the block can reach the front's rim (theta near 0 or pi). The
dexel's own resolution matters more: the first sample of a block sees the pose just before
it removed, whose surface passes within 0.6 h of the front's thin-chip edge and is misread
as cut there. ``benchmarks/bench_dexel_run.py`` measures both against an exact reference
(no dexel): the mean cutting force of a ball at 10 deg lead, 0.1 mm rays, is exact (median
0.00 %) but at the blocks' first samples (up to 2.4 % low), on a straight line and on an 8 mm
arc alike; blocks of one sample are 2.4 % low everywhere.

A plunge of a cutter with a flat bottom (feed within :data:`PLUNGE_DEG` of the tool axis,
downwards, with material under the bottom) is a full plunge of its end edges
(``Engagement.plunge``, :mod:`feedopt.process.plunge`); a rounded bottom plunging is in the
slices already. On a program, a rapid that meets material is refused, naming the line. A path
that meets no material at all is refused unless ``stock.air_cut``.
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

__all__ = ["BLOCK", "DexelFound", "DexelMaterialAlongPath", "build_dexel_stock",
           "engagement_from_dexel", "sweep_dexel"]

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
    removed : (n,) [m^3] the volume each block removed, shared among its samples by their
        arc-length steps (their sum is the stock's volume before minus after)
    """

    engagement: Engagement
    in_air: np.ndarray
    axial_depth: np.ndarray
    beyond_flutes: np.ndarray
    removed: np.ndarray


@dataclass(frozen=True, eq=False)
class DexelMaterialAlongPath:
    """The tri-dexel stock before the run, what the walk found, the stock after."""

    before: TriDexel
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
    try:
        if section.box_mm is not None:
            v = np.asarray(section.box_mm, dtype=float) * MM
            return TriDexel.box(v[:3], v[3:], spacing)
        units = section.units or "mm"
        file = resolve(section.mesh, "stock.mesh (STL)")
        tri = read_stl(file, f"stock.mesh {file}") * (MM if units == "mm" else 1.0)
        return TriDexel.from_mesh(tri, spacing)
    except InputError as exc:
        raise InputError(f"stock: {exc}") from None


def sweep_dexel(stock: TriDexel, tool: Tool, samples, block: int = BLOCK) -> DexelFound:
    """Walk ``tool`` along ``samples`` (positions, unit tangents and unit tool axes in the
    stock's frame) through ``stock`` in blocks of ``block`` samples, removing what it cuts
    (module docstring)."""
    tips, axes, feed = samples.position, samples.axis, samples.tangent
    n, profile, height = tips.shape[0], tool.profile, tool.flute_length
    depth, beyond = np.zeros(n), np.zeros(n, dtype=bool)
    bottom = np.zeros(n, dtype=bool)
    parts: list[tuple[np.ndarray, SliceEngagement]] = []
    removed_block = []
    for start in range(0, n, block):
        sl = slice(start, min(start + block, n))
        depth[sl], beyond[sl] = material_height(stock.contains, tips[sl], axes[sl], feed[sl],
                                                profile, (height, stock.spacing))
        on = np.flatnonzero(depth[sl] > 0.0) + start
        if on.size:
            te = tilted_slice_engagement(stock.contains, tips[on], axes[on], feed[on], profile,
                                         depth[on], SLICES, ANGLES)
            parts.append((on, te.slices))
        bottom[sl] = _under_bottom(stock, tool, (tips[sl], axes[sl], feed[sl]))
        first = max(start - 1, 0)
        reach = min(height, float(np.max(axis_reach(stock, tips[first:sl.stop],
                                                    axes[first:sl.stop], tool))))
        before = stock.volume() if reach > 0.0 else 0.0
        if reach > 0.0:  # the cutter up to where its axis leaves the stock's box
            stock.sweep_tool(tips[first:sl.stop], axes[first:sl.stop], profile, reach)
        removed_block.append(before - stock.volume() if reach > 0.0 else 0.0)
    table = _table(tool, samples, depth, parts)
    plunge = bottom & (_feed_along_axis(samples) < -math.cos(math.radians(PLUNGE_DEG)))
    engagement = _engagement(tool, table, depth, plunge)
    in_air = ~(table.cutting | plunge)
    return DexelFound(engagement, in_air, np.where(in_air, 0.0, depth), beyond,
                      _shared(np.asarray(removed_block), samples.s, block))


def axis_reach(stock: TriDexel, tips: np.ndarray, axes: np.ndarray, tool: Tool
               ) -> np.ndarray:
    """(b,) the height above the tip [m] where each pose's axis leaves the stock's box
    widened by the tool's largest radius (slab method; <= 0 where it never enters): above
    it no point of the cutter is in the box, so removing the cutter up to it removes all it
    cuts."""
    lo, hi = stock.bounds()
    top = tool.profile.length_to_height(tool.flute_length)
    widen = max(0.5 * tool.diameter, float(tool.profile.at_length(top)[0]))  # widest radius
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
           parts: list[tuple[np.ndarray, SliceEngagement]]) -> SliceEngagement:
    """The slice engagement of all samples: the engaged ones' intervals, the others sliced
    over the flute length with nothing engaged."""
    n = depth.size
    _, fx, fz = tool_frame(samples.axis, samples.tangent)
    sliced = profile_slices(tool.profile, np.where(depth > 0.0, depth, tool.flute_length),
                            SLICES)
    width = max([p.lo.shape[2] for _, p in parts], default=1)
    lo, hi = np.zeros((n, SLICES, width)), np.zeros((n, SLICES, width))
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


def _under_bottom(stock: TriDexel, tool: Tool, pose: tuple) -> np.ndarray:
    """(b,) whether material lies just under a flat bottom (within half a ray spacing along
    the axis, at 17 points of the bottom disc); False for a cutter without a flat bottom."""
    tips, axes, feed = pose
    r0 = tool.profile.r0
    if r0 <= 0.0:
        return np.zeros(tips.shape[0], dtype=bool)
    frame, _, _ = tool_frame(axes, feed)
    ang = np.arange(8) * (math.pi / 4.0)
    disc = np.concatenate([[[0.0, 0.0]], *(rf * r0 * np.stack([np.cos(ang), np.sin(ang)], 1)
                                           for rf in (0.5, 0.95))])  # (17, 2)
    pts = (tips[:, None, :] + disc[None, :, :1] * frame[:, None, 0]
           + disc[None, :, 1:] * frame[:, None, 1]
           - 0.5 * stock.spacing * frame[:, None, 2])
    return stock.contains(pts.reshape(-1, 3)).reshape(tips.shape[0], -1).any(axis=1)


def _shared(per_block: np.ndarray, s: np.ndarray, block: int) -> np.ndarray:
    """Each block's volume shared among its samples by their arc-length steps (the first
    sample's step is 0; a block of zero length shares evenly)."""
    n = s.size
    ds = np.diff(s, prepend=s[0])
    index = np.arange(n) // block
    total = np.bincount(index, weights=ds, minlength=per_block.size)
    count = np.bincount(index, minlength=per_block.size)
    share = np.where(total[index] > 0.0, ds / np.where(total > 0.0, total, 1.0)[index],
                     1.0 / count[index])
    return per_block[index] * share


def engagement_from_dexel(section, resolve: Callable[[str, str], Path], tool: Tool, samples,
                          moves=None, source: str = "the program") -> DexelMaterialAlongPath:
    """Walk ``tool`` along the tilted path ``samples`` (workpiece frame) through the
    scenario's stock (module docstring). ``moves`` (a program's move table) adds the
    program checks: no rapid may meet material, no plunge may reach above the flutes."""
    before = build_dexel_stock(section, resolve)
    after = before.copy()
    found = sweep_dexel(after, tool, samples)
    if moves is not None:
        _check_program_contacts(found, moves, samples, source, tool)
    return DexelMaterialAlongPath(before, after, found,
                                  _nothing_cut(section, before, found, samples.position))


def _check_program_contacts(found: DexelFound, moves, samples, source: str,
                            tool: Tool) -> None:
    """A rapid that meets material in front of the cutter or under its bottom is refused,
    naming the line; so is a plunge whose material reaches above the flutes."""
    move = moves.index_at(samples.s)
    cat = moves.category[move]
    hit = (cat == "rapid") & ~found.in_air
    deep = (cat == "plunge") & found.beyond_flutes & ~found.in_air
    if hit.any() and not (deep.any() and np.argmax(deep) < np.argmax(hit)):
        i = int(np.argmax(hit))
        raise InputError(
            f"{source} {moves.label(int(move[i]))}: a rapid meets material: the cutter would "
            f"crash into the stock; rapid clear of it or cut with a feed move (at s = "
            f"{samples.s[i] / MM:.3f} mm, {_where_material(found, i)})")
    check_plunge_depth(deep, move, moves, tool, source)


def _where_material(found: DexelFound, i: int) -> str:
    """Where sample ``i`` meets material, for messages."""
    if found.axial_depth[i] > 0.0:
        return (f"material in front of the cutter up to {found.axial_depth[i] / MM:.3g} mm "
                "above its tip")
    return "material under its flat bottom"


def _nothing_cut(section, before: TriDexel, found: DexelFound,
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
    span = ", ".join(f"{a} {p_lo[k] / MM:.6g}..{p_hi[k] / MM:.6g}" for k, a in enumerate("xyz"))
    box = ", ".join(f"{a} {lo[k] / MM:.6g}..{hi[k] / MM:.6g}" for k, a in enumerate("xyz"))
    text = (f"stock: the path meets no material at any of its {found.in_air.size} samples: "
            f"the tool tips span {span} mm, the stock's grids {box} mm (both in the workpiece "
            "frame W)")
    if section.mesh is not None:
        text += f"; the STL was read in {section.units or 'mm'} (stock.units)"
    if air_cut:
        return (text + "; planned as an air cut (stock.air_cut: true)",)
    raise InputError(text + ". Place the stock where the path cuts, or set stock.air_cut: "
                     "true if an air cut is meant")
