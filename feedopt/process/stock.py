"""Stock model for 3-axis milling: a Z-map of the workpiece and the engagement it gives.

The workpiece is a height field (Z-map) in its frame W: one column of material per cell of a
regular grid, from the bottom ``z0`` up to a stored top height. This is the classic Z-map /
height-field NC simulation (Anderson 1978, "Detection of milling tool collision and
interference"; Choi & Jerard, "Sculptured Surface Machining", 1998, ch. on Z-map
verification), valid while the tool axis stays along +z of W (3-axis milling, no undercuts).

A flat end mill of radius R is swept along a sampled path. Before sample i removes its
material, the material still present in front of the cutter gives the engagement of sample i
in the force-model frame of :mod:`feedopt.process.forces` (x = feed, y = z x x, z = tool axis
into the spindle = +z of W), angles as in :mod:`feedopt.process.engagement` (Altintas: phi
clockwise from +y seen from the spindle, a tooth at phi is at ``R (sin phi x + cos phi y)``,
the leading half is phi in [0, pi]). Up milling (material on the +y side, left of the feed)
gives ``[0, arccos(1 - ae / R)]``, down milling ``[pi - arccos(1 - ae / R), pi]``.

Resolution and memory
---------------------
Cell size h (default 0.25 mm); heights are float32, so the Z-map takes 4 bytes per cell
(a 200 x 100 mm box at 0.25 mm: 800 x 400 cells, 1.28 MB). See :func:`angle_error_bound`
for the accuracy of the angles: about (h / sqrt 2) / (R sin phi) rad where the material
boundary crosses the cutter rim (1.1 deg at phi = 90 deg for h = 0.25 mm, R = 9.525 mm).

Removal (the swept-area choice)
-------------------------------
Sample i removes the swept capsule from sample i-1 to sample i (every cell whose centre is
within R of that segment in xy is lowered to the tool tip height interpolated along the
segment, never below z0); sample 0 removes its disc. Using segments instead of discs leaves
no scallops between samples and lets the path be curved and coarsely sampled. The volume
each step removes is reported (:attr:`StockEngagement.removed`).

Speed
-----
The cells in front of each sample and the cells its capsule cuts depend on the path only;
:func:`sweep` finds them for blocks of samples with numpy, and its Python loop over samples
reads and lowers only those cells, leaving out the ones the previous sample has already cut
to the same height, with the same results cell by cell as the per-sample window sweep it
replaced. 1e5 samples of a pocket path at 0.1 mm steps take about 4 s on two cores (21 s
before; ``benchmarks/bench_stock.py``); samples where the tip descends (ramps, helices) still
use the window of cells, about 0.2 ms each.

Stock from a mesh
-----------------
:meth:`ZMap.from_mesh` reads a closed triangle mesh (STL, binary or ASCII, in mm by default:
STL has no units and CAD writes mm; :mod:`feedopt.process.stl` checks its structure) and casts
a vertical line through every cell centre; it refuses solids a Z-map cannot hold (overhangs,
material not standing on the bottom).

Size bound
----------
Both :meth:`ZMap.box` and :meth:`ZMap.from_mesh` refuse, before allocating anything, a grid of
more than :data:`MAX_CELLS` cells (40 million: 160 MB of float32 heights; a run keeps the stock
before and after the path, and reading a mesh needs about 40 bytes a cell for a moment, 1.6 GB
at the cap). That is 1.58 x 1.58 m at the default 0.25 mm cells, 3.16 x 3.16 m at 0.5 mm.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.engagement import Engagement, EngagementPieces
from feedopt.process.tool import Tool
from feedopt.units import MM

__all__ = [
    "DEFAULT_CELL",
    "DEPTH_STEP",
    "FlatEndMill",
    "StockEngagement",
    "ZMap",
    "angle_error_bound",
    "lookahead_reach",
    "snap_angle",
    "sweep",
]

#: Default Z-map cell size [m].
DEFAULT_CELL = 0.25 * MM
#: Largest number of cells of a Z-map (module docstring: 160 MB of heights, 1.6 GB to read a
#: mesh for a moment).
MAX_CELLS = 40_000_000
#: The largest cell size a scenario allows (stock.cell_mm) [m].
_MAX_CELL = 5.0 * MM
# Material thinner than this above the tool tip is not material (float32 heights round to
# ~4e-9 m at |z| = 0.05 m, far below it).
_MIN_DEPTH = 1e-6


# Vertical lines of ZMap.from_mesh are nudged by these fractions of a cell from the cell
# centres, so that they miss the edges and vertices of meshes with round coordinates.
_NUDGE = (0.7071067811865476e-6, 0.5773502691896258e-6)
_CROSSING_BUDGET = 2_000_000


def _vertical_crossings(
    tri: np.ndarray, origin, cell: float, shape
) -> tuple[np.ndarray, np.ndarray]:
    """Where the vertical lines through the (nudged) cell centres cross the triangles.

    ``tri``: (m, 3, 3) vertices [m]. Returns the flat cell index and the z of each crossing.
    A line crosses a triangle when its point lies inside the triangle's xy projection
    (edge functions of one sign, zero included); vertical triangles are skipped.
    """
    nx, ny = shape
    ox = origin[0] + (0.5 + _NUDGE[0]) * cell  # x of cell 0's line
    oy = origin[1] + (0.5 + _NUDGE[1]) * cell
    x, y, zv = tri[:, :, 0], tri[:, :, 1], tri[:, :, 2]
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    keep = area != 0.0
    x, y, zv, area = x[keep], y[keep], zv[keep], area[keep]
    i_lo = np.clip(np.ceil((x.min(axis=1) - ox) / cell), 0, nx).astype(np.int64)
    i_hi = np.clip(np.floor((x.max(axis=1) - ox) / cell), -1, nx - 1).astype(np.int64)
    j_lo = np.clip(np.ceil((y.min(axis=1) - oy) / cell), 0, ny).astype(np.int64)
    j_hi = np.clip(np.floor((y.max(axis=1) - oy) / cell), -1, ny - 1).astype(np.int64)
    ni, nj = np.maximum(i_hi - i_lo + 1, 0), np.maximum(j_hi - j_lo + 1, 0)
    count = ni * nj
    out_c, out_z = [], []
    cum = np.cumsum(count)
    t0 = 0
    while t0 < count.size:
        base = cum[t0 - 1] if t0 else 0
        t1 = max(t0 + 1, int(np.searchsorted(cum, base + _CROSSING_BUDGET, "right")))
        t1 = min(t1, count.size)
        local, t = _expand(np.zeros(t1 - t0, dtype=np.int64), count[t0:t1])
        t += t0
        i = i_lo[t] + local // nj[t]
        j = j_lo[t] + local % nj[t]
        px, py = ox + i * cell, oy + j * cell
        s = np.sign(area[t])
        e = []
        for a, b in ((1, 2), (2, 0), (0, 1)):  # edge opposite vertex 0, 1, 2
            e.append(
                (x[t, b] - x[t, a]) * (py - y[t, a]) - (y[t, b] - y[t, a]) * (px - x[t, a])
            )
        inside = (e[0] * s >= 0) & (e[1] * s >= 0) & (e[2] * s >= 0)
        zc = (e[0] * zv[t, 0] + e[1] * zv[t, 1] + e[2] * zv[t, 2]) / area[t]
        out_c.append((i * ny + j)[inside])
        out_z.append(zc[inside])
        t0 = t1
    if not out_c:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    return np.concatenate(out_c), np.concatenate(out_z)


def _unit_text(scale: float) -> str:
    """The unit a mesh scale [m per unit] reads a file in."""
    return {MM: "mm", 1.0: "m"}.get(scale, f"units of {scale:g} m")


def grid_shape(span_x: float, span_y: float, cell: float, where: str,
               slack: float = 1e-9) -> tuple[int, int]:
    """Cells (nx, ny) covering ``span_x`` x ``span_y`` [m] at cell size ``cell`` [m] (a span
    at most ``slack`` cells above a whole number of cells is that number).

    InputError naming ``where`` when that is more than :data:`MAX_CELLS` cells (or not a
    finite number of cells), with the cell count and memory it would take and what would fit.
    Nothing is allocated.
    """
    fx, fy = span_x / cell, span_y / cell
    if math.isfinite(fx) and math.isfinite(fy):
        nx, ny = max(1, math.ceil(fx - slack)), max(1, math.ceil(fy - slack))
        if nx * ny <= MAX_CELLS:
            return nx, ny
        count = (f"{nx:,} x {ny:,} = {float(nx * ny):.3g} cells ({nx * ny * 4 / 1024**3:.3g} "
                 "GiB of float32 heights; a run keeps two copies)")
    else:
        count = "more cells than a float can count (the span overflows)"
    need = _cell_that_fits(span_x, span_y, cell) if math.isfinite(fx * fy) else math.inf
    if need <= _MAX_CELL:
        fix = (f"use cells of at least {need / MM:g} mm (stock.cell_mm, "
               "at most 5 mm) or a smaller stock (the part the path cuts)")
    else:
        fix = ("even 5 mm cells (the largest stock.cell_mm) are too many: use a smaller stock "
               "(the part the path cuts)")
    raise InputError(
        f"{where}: a Z-map of {span_x / MM:.6g} x {span_y / MM:.6g} mm at {cell / MM:g} mm cells "
        f"needs {count}; feedopt builds at most "
        f"{MAX_CELLS:,} cells ({MAX_CELLS * 4 / 1e6:.0f} MB): {fix}")


def _cell_that_fits(span_x: float, span_y: float, cell: float) -> float:
    """The smallest cell size [m], in steps of 0.01 mm, that covers the span in at most
    :data:`MAX_CELLS` cells (inf above the largest scenario cell size)."""
    step = 0.01 * MM
    k = math.ceil(cell * math.sqrt(span_x / cell * span_y / cell / MAX_CELLS) / step)
    while k * step <= _MAX_CELL:
        h = k * step
        if max(1, math.ceil(span_x / h - 1e-9)) * max(1, math.ceil(span_y / h - 1e-9)) <= MAX_CELLS:
            return h
        k += 1
    return math.inf


def _closed_mesh_triangles(file: Path, where: str) -> np.ndarray:
    """The triangles (m, 3, 3) of the STL ``file`` [file units]; InputError unless they form
    a closed surface (after merging equal vertices every edge belongs to exactly two)."""
    from feedopt.process.stl import read_stl

    if not file.is_file():
        raise InputError(f"{where}: no such file")
    if file.suffix.lower() != ".stl":
        raise InputError(f"{where}: stock.mesh must be an STL file (binary or ASCII, .stl), "
                         f"got {file.suffix or 'no suffix'}; export the stock as STL")
    tri = read_stl(file, what=where)
    flat = np.round(tri.reshape(-1, 3), 8) + 0.0  # + 0.0: -0.0 and 0.0 are one vertex
    _, ids = np.unique(flat, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    edges = np.sort(np.concatenate([ids[:, [0, 1]], ids[:, [1, 2]], ids[:, [2, 0]]]), axis=1)
    _, first, count = np.unique(edges, axis=0, return_index=True, return_counts=True)
    if np.all(count == 2):
        return tri
    k = int(first[np.argmax(count != 2)]) % ids.shape[0]
    single = int(np.sum(count == 1))
    raise InputError(
        f"{where}: is not closed (not watertight: {single:,} edge(s) belong to one triangle "
        f"only, {int(np.sum(count > 2)):,} to more than two; the first at triangle {k}, from 0, "
        f"near {', '.join(f'{v:g}' for v in tri[k].mean(axis=0))}); a stock needs a closed solid")


def _mesh_tops(tri: np.ndarray, lo: np.ndarray, tol: float, cell: float, shape,
               where: str) -> np.ndarray:
    """Top of the material per cell (flat, length nx * ny) [m] of the closed mesh ``tri``
    [m] whose bounds start at ``lo``; InputError where a column is not one solid on z0."""
    nx, ny = shape
    cells, z = _vertical_crossings(tri, (lo[0], lo[1]), cell, (nx, ny))
    if cells.size == 0:
        raise InputError(
            f"{where}: no cell centre lies inside the mesh: its x-y extent, "
            f"{(tri[..., 0].max() - lo[0]) / MM:.4g} x {(tri[..., 1].max() - lo[1]) / MM:.4g} mm, "
            f"is smaller than the {cell / MM:g} mm cells (check the units)")
    # sort per cell, merge crossings within tol (a line through a shared edge)
    order = np.lexsort((z, cells))
    cells, z = cells[order], z[order]
    dup = np.concatenate([[False], (cells[1:] == cells[:-1]) & (np.diff(z) <= tol)])
    cells, z = cells[~dup], z[~dup]
    count = np.bincount(cells, minlength=nx * ny)
    first = np.cumsum(count) - count

    def at(c: int) -> str:
        i, j = divmod(int(c), ny)
        x, y = lo[0] + (i + 0.5) * cell, lo[1] + (j + 0.5) * cell
        return f"x = {x / MM:g} mm, y = {y / MM:g} mm"

    odd = np.flatnonzero(count % 2 == 1)
    if odd.size:
        raise InputError(
            f"{where}: the vertical line at {at(odd[0])} crosses its surface "
            f"{count[odd[0]]} times (an odd number: the mesh is not a consistent solid there)"
        )
    many = np.flatnonzero(count > 2)
    if many.size:
        c = many[0]
        zs = ", ".join(f"{v / MM:g}" for v in z[first[c] : first[c] + count[c]])
        raise InputError(
            f"{where}: the vertical line at {at(c)} passes through material, "
            f"air and material again (surface at z = {zs} mm): an overhang, undercut or "
            "cavity, which a Z-map (one column of material per cell) cannot represent"
        )
    solid = np.flatnonzero(count == 2)
    bottoms, tops = z[first[solid]], z[first[solid] + 1]
    floating = bottoms > lo[2] + tol
    if np.any(floating):
        k = int(np.argmax(floating))
        raise InputError(
            f"{where}: at {at(solid[k])} the material starts at z = "
            f"{bottoms[k] / MM:g} mm, above the mesh's bottom z = {lo[2] / MM:g} mm: a Z-map's "
            "columns all stand on one flat bottom"
        )
    heights = np.full(nx * ny, lo[2], dtype=np.float32)
    heights[solid] = tops
    return heights


@dataclass(frozen=True)
class FlatEndMill:
    """A flat end mill for the stock sweep, SI units.

    Attributes
    ----------
    radius : float
        Cutter radius R [m].
    flute_length : float
        Length of cut [m]: the reported axial depth is clipped to it (deeper material is
        flagged ``beyond_flutes``).
    """

    radius: float
    flute_length: float

    def __post_init__(self) -> None:
        for name in ("radius", "flute_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"end mill {name} must be > 0 mm, got {value / MM:g} mm")

    @classmethod
    def from_tool(cls, tool: Tool) -> FlatEndMill:
        """The end mill of a process :class:`~feedopt.process.tool.Tool`."""
        return cls(radius=tool.diameter / 2.0, flute_length=tool.flute_length)


class ZMap:
    """Height field of the workpiece in its frame W (mutable: :func:`sweep` cuts it).

    Cell (i, j) covers ``x0 + [i, i+1) h`` by ``y0 + [j, j+1) h``; its column of material
    runs from ``bottom`` to ``heights[i, j]`` (empty when ``heights <= bottom``). Material
    outside the grid does not exist.

    Parameters
    ----------
    heights : (nx, ny) array
        Top of material per cell [m], stored as float32 (4 bytes per cell).
    origin : (x0, y0) [m]
        Lower corner of the grid.
    cell : float
        Cell size h [m].
    bottom : float
        Bottom z0 of the workpiece [m].
    """

    def __init__(
        self, heights: np.ndarray, origin: tuple[float, float], cell: float, bottom: float
    ) -> None:
        h = np.array(heights, dtype=np.float32)
        if h.ndim != 2 or h.size == 0:
            raise InputError(f"Z-map heights must be a non-empty 2-D array, got shape {h.shape}")
        if not (math.isfinite(cell) and cell > 0):
            raise InputError(f"Z-map cell size must be > 0 mm, got {cell / MM:g} mm")
        if not all(math.isfinite(v) for v in (*origin, bottom)) or not np.all(np.isfinite(h)):
            raise InputError("Z-map origin, bottom and heights must be finite")
        self.heights = np.maximum(h, np.float32(bottom))
        self.origin = (float(origin[0]), float(origin[1]))
        self.cell = float(cell)
        self.bottom = float(bottom)

    @classmethod
    def box(
        cls,
        x0: float,
        x1: float,
        y0: float,
        y1: float,
        z0: float,
        z1: float,
        cell: float = DEFAULT_CELL,
        where: str = "stock box",
    ) -> ZMap:
        """A box of stock ``[x0, x1] x [y0, y1] x [z0, z1]`` [m] on cells of size ``cell``.

        The x and y extents are rounded up to whole cells (to ``x0 + nx h``, ``y0 + ny h``);
        more than :data:`MAX_CELLS` cells are refused (:func:`grid_shape`), ``where`` naming
        the box in the message.
        """
        if not all(math.isfinite(v) for v in (x0, x1, y0, y1, z0, z1)):
            raise InputError(f"{where}: every corner coordinate must be a finite number of mm, "
                             f"got x {x0 / MM:g}..{x1 / MM:g}, y {y0 / MM:g}..{y1 / MM:g}, "
                             f"z {z0 / MM:g}..{z1 / MM:g} mm")
        if not (x1 > x0 and y1 > y0 and z1 > z0):
            raise InputError(
                f"{where} needs x1 > x0, y1 > y0 and z1 > z0, got "
                f"x {x0 / MM:g}..{x1 / MM:g}, y {y0 / MM:g}..{y1 / MM:g}, "
                f"z {z0 / MM:g}..{z1 / MM:g} mm"
            )
        if not (math.isfinite(cell) and cell > 0):
            raise InputError(f"Z-map cell size must be > 0 mm, got {cell / MM:g} mm")
        nx, ny = grid_shape(x1 - x0, y1 - y0, cell, where)
        return cls(np.full((nx, ny), z1, dtype=np.float32), (x0, y0), cell, z0)

    @classmethod
    def from_mesh(
        cls,
        path: str | os.PathLike[str],
        cell: float = DEFAULT_CELL,
        *,
        scale: float = MM,
        where: str | None = None,
    ) -> ZMap:
        """A stock from a closed triangle mesh in an STL file (binary or ASCII).

        The grid covers the mesh's xy bounds from their lower corner, rounded up to whole
        cells as in :meth:`box` (a span within 1e-3 cells of whole cells, float32 rounding,
        is rounded down; at most :data:`MAX_CELLS`, checked before allocating); the
        bottom z0 is the mesh's lowest z. Each cell's top is where the vertical line through
        its centre (nudged by 1e-6 h, so that it misses the edges of meshes with round
        coordinates) leaves the solid: the crossings with every triangle that is not
        vertical, found with numpy (no ray-tracing backend needed).

        A Z-map holds one column of material per cell, standing on the bottom. A mesh it
        cannot represent is refused with InputError naming the place: a line through
        material, air and material again (an overhang, undercut or closed cavity), and
        material whose column starts above z0 (a solid not standing on one flat bottom).

        Parameters
        ----------
        path : the STL file.
        cell : cell size h [m].
        scale : metres per mesh unit (STL has no units): 1e-3 (the default) for a mesh in
            mm, the CAD convention; 1.0 for a mesh in metres.
        where : how messages name the mesh (default: the file and the unit it is read in).
        """
        if not (math.isfinite(cell) and cell > 0):
            raise InputError(f"Z-map cell size must be > 0 mm, got {cell / MM:g} mm")
        if not (math.isfinite(scale) and scale > 0):
            raise InputError(f"stock mesh scale must be > 0, got {scale:g}")
        file = Path(path)
        where = where or f"stock mesh {file} (read in {_unit_text(scale)})"
        tri = _closed_mesh_triangles(file, where) * scale
        lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        if not np.all(np.isfinite(hi - lo)):
            raise InputError(f"{where}: its coordinates times {scale:g} m overflow")
        if not (hi[0] > lo[0] and hi[1] > lo[1] and hi[2] > lo[2]):
            raise InputError(f"{where}: is flat (no volume)")
        # STL coordinates are float32: a span of whole cells may come out 1e-4 cells longer
        nx, ny = grid_shape(hi[0] - lo[0], hi[1] - lo[1], cell, where, slack=1e-3)
        heights = _mesh_tops(tri, lo, 1e-6 * float(np.max(hi - lo)), cell, (nx, ny), where)
        return cls(heights.reshape(nx, ny), (float(lo[0]), float(lo[1])), cell, float(lo[2]))

    @property
    def shape(self) -> tuple[int, int]:
        """Number of cells (nx, ny)."""
        return self.heights.shape  # type: ignore[return-value]

    @property
    def nbytes(self) -> int:
        """Memory of the height field [bytes] (4 per cell)."""
        return int(self.heights.nbytes)

    @property
    def x_centres(self) -> np.ndarray:
        """(nx,) x of the cell centres [m]."""
        return self.origin[0] + (np.arange(self.shape[0]) + 0.5) * self.cell

    @property
    def y_centres(self) -> np.ndarray:
        """(ny,) y of the cell centres [m]."""
        return self.origin[1] + (np.arange(self.shape[1]) + 0.5) * self.cell

    def volume(self) -> float:
        """Volume of material [m^3]."""
        return float(np.sum(self.heights.astype(float) - self.bottom)) * self.cell**2

    def copy(self) -> ZMap:
        """An independent copy."""
        return ZMap(self.heights.copy(), self.origin, self.cell, self.bottom)


@dataclass(frozen=True)
class StockEngagement:
    """Engagement found in the stock at ``n`` path samples.

    Attributes
    ----------
    engagement : Engagement
        Entry/exit [rad] and axial depth [m] for the force model. A sample in air has
        ``entry == exit == 0`` (not cutting, as :class:`Engagement` defines it) and, because
        :class:`Engagement` needs a positive depth, the flute length as its axial depth.
    in_air : (n,) bool
        No material in front of the cutter.
    axial_depth : (n,) float
        Axial depth of cut [m], 0 in air (top of the material in front minus the tool tip,
        or minus the bottom when the tip is below it; clipped to the flute length).
    beyond_flutes : (n,) bool
        Material in front of the cutter reaches above the flutes (shank contact).
    lateral : (n, 2) float
        Lateral extent [y_lo, y_hi] [m] of the material in front, in the force-model frame,
        clipped to [-R, R]; NaN in air. ``entry = arccos(y_hi / R)``,
        ``exit = arccos(y_lo / R)``.
    removed : (n,) float
        Volume of material [m^3] removed by each sample's sweep step (the capsule from
        sample i-1 to sample i; sample 0 its disc). Their sum is the stock volume before
        minus after (:meth:`ZMap.volume`), exact up to float64 summation; ``removed / dt``
        is the material removal rate.
    intervals : EngagementPieces
        Every engaged piece of every engaged sample (angles and the axial depth of each,
        see :func:`sweep`); ``engagement.pieces`` holds those of the samples with more than
        one piece (the others are their hull).
    """

    engagement: Engagement
    in_air: np.ndarray
    axial_depth: np.ndarray
    beyond_flutes: np.ndarray
    lateral: np.ndarray
    removed: np.ndarray
    intervals: EngagementPieces
    radius: float

    def interval_summary(self) -> tuple[np.ndarray, np.ndarray]:
        """Per sample the number of engaged intervals (runs of contiguous pieces: separate
        contacts) and the radial depth [m] of the widest, ``R (cos entry - cos exit)``."""
        iv, n = self.intervals, self.in_air.size
        if iv.count == 0:
            return np.zeros(n, dtype=np.int64), np.zeros(n)
        new_run = np.r_[True, (iv.sample[1:] != iv.sample[:-1]) | (iv.entry[1:] != iv.exit[:-1])]
        run = np.cumsum(new_run) - 1
        width = np.bincount(run, weights=self.radius * (np.cos(iv.entry) - np.cos(iv.exit)))
        owner = iv.sample[new_run]
        widest = np.zeros(n)
        np.maximum.at(widest, owner, width)
        return np.bincount(owner, minlength=n), widest


def snap_angle(cell: float, radius: float) -> float:
    """Angle [rad] from 0 (or pi) inside which a material end is reported at 0 (or pi).

    Material within ``sqrt(2) h`` (laterally) of the rim side of the cutter is taken to reach
    it: a grid of spacing h cannot resolve a boundary tangent to the rim more finely. Equals
    ``arccos(1 - sqrt(2) h / R)`` (0.23 rad = 13 deg for h = 0.25 mm, R = 9.525 mm); there the
    chip thickness c sin(phi) is below 0.23 c.
    """
    return math.acos(max(-1.0, 1.0 - math.sqrt(2.0) * cell / radius))


def angle_error_bound(
    angle: float | np.ndarray,
    cell: float,
    radius: float,
    lateral: float | np.ndarray = 0.0,
) -> np.ndarray:
    """Bound [rad] on the error of an entry or exit angle ``angle`` [rad] from the Z-map.

    For a straight cut the reported material boundary is within ``delta = h / sqrt 2``
    laterally of the true one (half the largest projected cell width), so the angle, which is
    ``arccos(y / R)`` of the lateral position y, is within
    ``max |arccos(cos(angle) +- delta / R) - angle|``: about ``delta / (R sin(angle))`` where
    the boundary crosses the rim, at most ``sqrt(2 delta / R)`` where it is tangent. Within
    :func:`snap_angle` of 0 or pi the end is reported at 0 or pi, so the bound there is the
    snap angle.

    ``lateral`` [m] is added to delta for boundaries that are not parallel to the feed. The
    material is seen from ``lookahead_reach`` beyond the rim (along the feed) to about the
    step ds inside it (the crescent the previous sample left), so where the boundary's
    lateral position changes by ``slope`` per unit of feed at the rim crossing, the reported
    crossing moves laterally by up to ``slope * (lookahead_reach + ds)``: pass that (an
    inclined wall: slope = tan of its angle to the feed; a circular boundary of radius
    r_m crossed at dx = R sin(angle): slope = dx / sqrt(r_m^2 - dx^2)). A wall straight
    across the feed is better bounded in feed distance (see the tests).
    """
    phi = np.asarray(angle, dtype=float)
    delta = cell / math.sqrt(2.0) + np.asarray(lateral, dtype=float)
    c = np.cos(phi)
    err = np.maximum(
        np.abs(np.arccos(np.clip(c + delta / radius, -1.0, 1.0)) - phi),
        np.abs(np.arccos(np.clip(c - delta / radius, -1.0, 1.0)) - phi),
    )
    snap = snap_angle(cell, radius)
    in_snap = (phi <= snap) | (phi >= math.pi - snap)
    return np.where(in_snap, np.maximum(err, snap), err)


def lookahead_reach(
    angle: float | np.ndarray,
    cell: float,
    radius: float,
    step: float = 0.0,
    lookahead: float | None = None,
) -> np.ndarray:
    """How far beyond the rim [m], along the feed, :func:`sweep` sees material at tooth angle
    ``angle`` [rad]: ``lookahead / sin(angle) - step``, capped at its value at the snap angle
    less the step, never below 0 (``lookahead`` defaults to sqrt(2) h; ``step`` is the
    distance from the previous sample). Not clipped to the end of the path."""
    look = math.sqrt(2.0) * cell if lookahead is None else float(lookahead)
    cap = look / max(math.sin(snap_angle(cell, radius)), 1e-12)
    sin = np.maximum(np.sin(np.asarray(angle, dtype=float)), 1e-300)
    return np.clip(look / sin - step, 0.0, max(0.0, cap - step))


def _feed_directions(tangents: np.ndarray, n: int) -> np.ndarray:
    t = np.asarray(tangents, dtype=float)
    if t.shape != (n, 3) or not np.all(np.isfinite(t)):
        raise InputError(f"tangents must be a finite (n, 3) array like positions, got {t.shape}")
    xy = t[:, :2]
    norm = np.linalg.norm(xy, axis=1)
    bad = norm < 1e-9 * np.maximum(np.linalg.norm(t, axis=1), 1e-300)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"tangent at sample {i} runs along the tool axis (z): a 3-axis stock sweep needs "
            "a feed direction across it"
        )
    return xy / norm[:, None]


# Margin [m] of the candidate cell sets of :func:`sweep`: far above the float64 rounding of
# the coordinates (~1e-16 m at 1 m), far below a cell.
_EPS = 1e-9
# Samples whose per-row intervals are computed at once, and candidate cells expanded at once
# (bounds the temporaries to some 10 arrays of this many float64).
_BLOCK = 512
_CELL_BUDGET = 250_000


def _expand(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ranges ``[starts[k], starts[k] + counts[k])`` concatenated, and each element's k."""
    owner = np.repeat(np.arange(counts.size), counts)
    shift = np.repeat(starts - (np.cumsum(counts) - counts), counts)
    return shift + np.arange(owner.size), owner


def _row_span(cx, r, i0, i1, gx0: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``[a0, a1)`` of the window ``[i0, i1)`` whose cell centres are within r of cx."""
    a0 = np.clip(np.ceil((cx - r - gx0) / h - 0.5), i0, i1).astype(np.int64)
    a1 = np.clip(np.floor((cx + r - gx0) / h - 0.5) + 1, a0, i1).astype(np.int64)
    return a0, a1


def _block_pieces(disc_f, halfplane, disc_c, inner, window, active, grid):
    """Candidate cells of a block of samples, as (sample, flat start, count), two a row.

    Front candidates: the cells of the window in the disc ``disc_f`` = (cx, cy, r) and the
    half-plane ``(x - cx) fx + (y - cy) fy >= -_EPS`` (``halfplane`` = (fx, fy)); capsule
    candidates: the cells of the window in the disc ``disc_c``; both less the cells surely
    inside the disc ``inner`` = (px, py, r). Arrays per sample (r may be a scalar);
    ``window`` = (i0, i1, j0, j1); samples not ``active`` get none; ``grid`` = (gx0, gy0,
    h, ny, x_centres). The sets only
    need to hold the cells, so y is in cell units (cell j's centre at j) and the rounding
    (~1e-12 cells) is far inside the 1 nm margin.
    """
    gx0, gy0, h, ny, xc_all = grid
    i0, i1, j0, j1 = window
    a0, a1 = _row_span(disc_f[0], disc_f[2], i0, i1, gx0, h)
    c0, c1 = _row_span(disc_c[0], disc_c[2], i0, i1, gx0, h)
    a0 = np.minimum(a0, c0)
    a1 = np.where(active, np.maximum(a1, c1), a0)
    a, k = _expand(a0, a1 - a0)
    xa = xc_all[a]

    def cells_of_disc(ox, oy, r):
        """[lo, hi] in cell units per row (lo > hi where the row misses the disc)."""
        d = xa - ox[k]
        r = r[k] if np.ndim(r) else r
        w2 = r * r - d * d
        w = np.copysign(np.sqrt(np.abs(w2)), w2) / h
        yc = ((oy - gy0) / h - 0.5)[k]
        return d, yc - w, yc + w

    # (clipped before the integer cast: a bound can be +-1e191 cells)
    _, lo, hi = cells_of_disc(*inner)
    in_hi = np.clip(np.floor(hi), -1, ny).astype(np.int64)
    in_lo = np.clip(np.ceil(lo), -1, in_hi + 1).astype(np.int64)  # empty: in_hi + 1
    j_min, j_max = j0[k], j1[k] - 1

    def pieces(lo, hi):
        j_lo = np.clip(np.ceil(lo), j_min, j_max + 1).astype(np.int64)
        j_hi = np.clip(np.floor(hi), j_min - 1, j_max).astype(np.int64)
        counts = np.empty(2 * a.size, dtype=np.int64)
        starts = np.empty(2 * a.size, dtype=np.int64)
        starts[0::2] = j_lo
        counts[0::2] = np.minimum(j_hi, in_lo - 1) - j_lo + 1
        starts[1::2] = np.maximum(j_lo, in_hi + 1)
        counts[1::2] = j_hi - starts[1::2] + 1
        starts += np.repeat(a * ny, 2)
        return np.repeat(k, 2), starts, np.maximum(counts, 0)

    d, lo, hi = cells_of_disc(*disc_f)
    fx, fy = halfplane
    fy = np.where(fy == 0.0, 1e-200, fy)  # fy = 0: +-1e191 cells, the same cut
    bound = ((disc_f[1] - gy0) / h - 0.5)[k] - (_EPS + d * fx[k]) * (1.0 / (fy * h))[k]
    up = (fy > 0)[k]
    lo = np.where(up, np.maximum(lo, bound), lo)
    hi = np.where(up, hi, np.minimum(hi, bound))
    return [pieces(lo, hi), pieces(*cells_of_disc(*disc_c)[1:])]


#: Default depth step [m] of the angle-dependent axial depth: material tops across the
#: cutter that differ by less than this share one piece, at the largest depth among them (so
#: the force is overestimated by less than this much depth, never underestimated). 0.1 mm
#: gives a helical entry of 0.5 mm per turn about 5 pieces per sample; the force model's
#: cost grows with the pieces (scenario: stock.depth_step_mm).
DEPTH_STEP = 0.1 * MM


@dataclass(frozen=True)
class _Bins:
    """Lateral bins of width h across the cutter (force-model y in [-R, R]) for the pieces."""

    radius: float
    width: float
    flute_length: float
    snap: float
    depth_step: float

    @property
    def count(self) -> int:
        return max(1, math.ceil(2.0 * self.radius / self.width - 1e-9))

    def pieces(self, k_local, dy, height, ng: int, floor, w_half):
        """Pieces of ``ng`` samples from their material cells (sample ``k_local``, lateral
        offset ``dy`` [m], top ``height`` [m]): per lateral bin the highest top and the
        extreme offsets; runs of material bins (one empty bin between two material bins is
        bridged: a grid of cells h apart may leave one empty) split where the depth, in
        steps of :data:`DEPTH_STEP`, changes. A run's ends are widened and snapped to the rim
        like the hull's (:func:`sweep`); depth-split pieces meet on bin edges.

        Returns (local sample, y_lo, y_hi, depth) per piece, in sample then y order.
        """
        nb, r = self.count, self.radius
        key = k_local * nb + np.clip(np.floor((dy + r) / self.width), 0, nb - 1).astype(np.int64)
        top = np.full(ng * nb, -np.inf)
        np.maximum.at(top, key, height.astype(float))
        y_min = np.full(ng * nb, np.inf)
        np.minimum.at(y_min, key, dy)
        y_max = np.full(ng * nb, -np.inf)
        np.maximum.at(y_max, key, dy)
        top, y_min, y_max = (a.reshape(ng, nb) for a in (top, y_min, y_max))
        mat = np.isfinite(top)
        depth = np.where(mat, np.minimum(top - floor[:, None], self.flute_length), 0.0)
        gap = np.zeros_like(mat)
        gap[:, 1:-1] = ~mat[:, 1:-1] & mat[:, :-2] & mat[:, 2:]
        if gap.any():  # a bridged bin takes the larger neighbouring depth
            both = np.maximum(np.roll(depth, 1, axis=1), np.roll(depth, -1, axis=1))
            depth = np.where(gap, both, depth)
        member = mat | gap
        level = np.where(member, np.ceil(depth / self.depth_step - 1e-9), -1.0)
        prev_level = np.concatenate([np.full((ng, 1), -1.0), level[:, :-1]], axis=1)
        next_level = np.concatenate([level[:, 1:], np.full((ng, 1), -1.0)], axis=1)
        starts = member & (level != prev_level)
        ends = member & (level != next_level)
        run_start = member & (prev_level < 0)
        run_end = member & (next_level < 0)
        row, col = np.nonzero(starts)
        _, col_end = np.nonzero(ends)
        flat_member = np.flatnonzero(member.reshape(-1))
        first = np.searchsorted(flat_member, row * nb + col)
        piece_depth = np.maximum.reduceat(depth.reshape(-1)[flat_member], first)
        edge = -r + self.width * np.arange(nb + 1)
        wh = w_half[row]
        lo_raw = y_min[row, col]
        hi_raw = y_max[row, col_end]
        y_lo = np.where(run_start[row, col],
                        np.where(lo_raw <= -r + self.snap, -r, np.maximum(-r, lo_raw - wh)),
                        edge[col])
        y_hi = np.where(run_end[row, col_end],
                        np.where(hi_raw >= r - self.snap, r, np.minimum(r, hi_raw + wh)),
                        edge[col_end + 1])
        return row, y_lo, y_hi, piece_depth


def _front(wx, wy, fx, fy, ds, lam_max, radius: float, look: float):
    """Cells in front of the cutter (see :func:`sweep`) and their lateral offset dy.

    ``wx, wy``: cell centre minus tool centre [m]; the other arguments per cell or scalar.
    """
    dx = wx * fx + wy * fy
    dy = -wx * fy + wy * fx
    half = np.sqrt(np.maximum(radius**2 - dy**2, 0.0))
    lam = np.clip(look * radius / np.maximum(half, 1e-300) - ds, 0.0, lam_max)
    return (dx >= 0.0) & (np.abs(dy) <= radius) & (dx <= half + lam), dy


def _capsule(ux, uy, sx, sy, seg_len2, z_prev, z_tip, z0: float, radius: float):
    """Cells within R of the step from the previous sample, and the height it cuts them to.

    ``ux, uy``: cell centre minus previous tool centre [m]; ``(sx, sy)`` the step.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(seg_len2 > 0.0, np.clip((ux * sx + uy * sy) / seg_len2, 0.0, 1.0), 0.0)
    inside = (ux - s * sx) ** 2 + (uy - s * sy) ** 2 <= radius**2
    return inside, np.maximum(z_prev + s * (z_tip - z_prev), z0)


def sweep(
    stock: ZMap,
    tool: FlatEndMill,
    positions: np.ndarray,
    tangents: np.ndarray,
    lookahead: float | None = None,
    depth_step: float = DEPTH_STEP,
) -> StockEngagement:
    """Sweep a flat end mill along a path through ``stock`` (cut in place) and report engagement.

    At sample i, before its material is removed, the material in front of the cutter is the
    material still present (top above the tool tip by > 1 um) in the leading half of the
    cutter (cells with ``dx >= 0`` along the feed x, ``|dy| <= R`` across it) up to
    ``lookahead / sin(phi)`` beyond the rim along the feed at the lateral offset dy of tooth
    angle phi (capped at its value at :func:`snap_angle`, about 1.5 mm for h = 0.25 mm,
    R = 9.525 mm), less the step ds from sample i-1, never past the end of the path. The
    lookahead gives the crescent in front of the rim a thickness of at least ``lookahead``
    normal to the rim, so every part of the rim shows its material even when the samples
    are closer than the cells (with steps above the cap it is zero). Its price: a wall ahead
    is seen up to that distance early (at most ``lookahead`` normal to the rim).

    Each material cell is attributed to the tooth that meets it, the one at the same lateral
    offset y (force-model frame): phi = arccos(y / R), exact for a straight feed. One interval
    per sample: the hull of the engaged angles, ``entry = arccos(y_hi / R)``,
    ``exit = arccos(y_lo / R)`` with [y_lo, y_hi] the lateral extent of the material (cell
    centres widened by half the projected cell width; an end within sqrt(2) h of the rim is
    put on the rim, see :func:`snap_angle`). That hull and the largest depth are the
    sample's summary (``engagement.entry/exit/axial_depth``).

    What the force model sums is finer (:class:`~feedopt.process.engagement.EngagementPieces`):
    the material cells are binned by lateral offset in bins of width h, each bin keeping
    its highest top; runs of material bins are the engaged intervals (two separate contacts,
    e.g. at an inside corner cut with a small radial depth, are two intervals when more than
    one bin of air lies between them), and a run is split into pieces where the axial depth
    (top minus tip) changes by a ``depth_step`` (each piece at its largest depth). A sample
    with one piece is its hull.

    Implementation: where sample i-1 has left every cell inside its disc no higher than
    sample i cuts and below sample i's material threshold (a level or rising tip), those
    cells are neither material nor cut at sample i, and only the others matter: a crescent a
    few hundred cells large at 0.1 mm steps. Which cells these are depends on the path only,
    so they are found for blocks of samples at once (per grid row an interval that surely
    holds them, with a 1 nm margin, then the exact per-cell tests of the window method), and
    the loop over samples only reads and lowers them. Other samples (a descending tip: ramps,
    helices) use the whole window under the capsule, as before. Both give the same result
    cell by cell. Material is "top > max(tip, bottom) + 1 um", compared in float64.

    Parameters
    ----------
    stock : ZMap
        The workpiece, modified in place (use ``stock.copy()`` to keep it).
    tool : FlatEndMill
    positions : (n, 3) array
        Tool tip in W [m], in cutting order.
    tangents : (n, 3) array
        Path tangents in W (their xy part is the feed direction; need not be unit).
    lookahead : float, optional
        Crescent thickness normal to the rim [m], default ``sqrt(2) h``.
    depth_step : float, optional
        Axial depth resolution of the pieces [m] (:data:`DEPTH_STEP`).

    Returns
    -------
    StockEngagement
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise InputError(f"positions must be a finite (n, 3) array [m], got shape {p.shape}")
    n = p.shape[0]
    feed = _feed_directions(tangents, n)
    h = stock.cell
    radius = tool.radius
    look = math.sqrt(2.0) * h if lookahead is None else float(lookahead)
    if not (math.isfinite(look) and look >= 0):
        raise InputError(f"lookahead must be >= 0 mm, got {look / MM:g} mm")
    snap = math.sqrt(2.0) * h
    if not (math.isfinite(depth_step) and depth_step > 0):
        raise InputError(f"depth_step must be > 0 mm, got {depth_step / MM:g} mm")
    bins = _Bins(radius, h, tool.flute_length, snap, float(depth_step))
    found_pieces: list[tuple[np.ndarray, ...]] = []
    look_cap = look / max(math.sin(snap_angle(h, radius)), 1e-12)

    (gx0, gy0), z0 = stock.origin, stock.bottom
    nx, ny = stock.shape
    xc_all, yc_all = stock.x_centres, stock.y_centres
    work = np.ascontiguousarray(stock.heights, dtype=np.float32)
    flat = work.reshape(-1)

    # per-sample geometry, as the window method computes it sample by sample
    steps = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)
    remaining = np.concatenate([np.cumsum(steps[::-1])[::-1], [0.0]]) if n else np.zeros(0)
    ds = np.concatenate([[0.0], steps]) if n else np.zeros(0)
    prev = np.concatenate([p[:1], p[:-1]]) if n else p
    cx, cy, z = p[:, 0], p[:, 1], p[:, 2]
    fx, fy = feed[:, 0], feed[:, 1]
    lam_max = np.minimum(np.maximum(0.0, look_cap - ds), remaining)
    ax, ay = cx + lam_max * fx, cy + lam_max * fy
    lo_x = np.minimum(np.minimum(cx, prev[:, 0]), ax) - radius
    hi_x = np.maximum(np.maximum(cx, prev[:, 0]), ax) + radius
    lo_y = np.minimum(np.minimum(cy, prev[:, 1]), ay) - radius
    hi_y = np.maximum(np.maximum(cy, prev[:, 1]), ay) + radius
    i0 = np.maximum(0, np.ceil((lo_x - gx0) / h - 0.5)).astype(np.int64)
    i1 = np.minimum(nx, np.floor((hi_x - gx0) / h - 0.5) + 1).astype(np.int64)
    j0 = np.maximum(0, np.ceil((lo_y - gy0) / h - 0.5)).astype(np.int64)
    j1 = np.minimum(ny, np.floor((hi_y - gy0) / h - 0.5) + 1).astype(np.int64)
    floor = np.maximum(z, z0)
    thr = floor + _MIN_DEPTH
    seg_x, seg_y = cx - prev[:, 0], cy - prev[:, 1]
    seg_len2 = seg_x * seg_x + seg_y * seg_y
    # Sample i-1 left the cells inside its disc at most at float32(left) (its capsule's
    # highest cut); they are not cut again when that is at or below sample i's lowest cut,
    # and not material when at or below sample i's threshold.
    left = np.maximum(prev[:, 2], z0)
    if n > 2:
        left[2:] = np.maximum(np.maximum(z[:-2], z[1:-1]), z0)
    lowest_cut = np.maximum(np.minimum(z, prev[:, 2]), z0)
    fast = (left <= lowest_cut) & (left.astype(np.float32) <= thr)
    fast[:1] = False
    # every cell in front is within r_out of the centre (dx <= half + lam with
    # half * lam <= look R and lam <= lam_max); every cut cell within R + ds / 2 of the
    # middle of the step
    r_out = np.sqrt(radius**2 + 2.0 * radius * look + lam_max**2) + _EPS
    r_cap = radius + 0.5 * ds + _EPS
    mx, my = 0.5 * (cx + prev[:, 0]), 0.5 * (cy + prev[:, 1])
    w_in = radius - _EPS

    y_lo_raw = np.zeros(n)
    y_hi_raw = np.zeros(n)
    top = np.zeros(n)
    engaged = np.zeros(n, dtype=bool)
    removed = np.zeros(n)
    w_half = 0.5 * h * (np.abs(fx) + np.abs(fy))

    for b0 in range(0, n, _BLOCK):
        b = slice(b0, min(n, b0 + _BLOCK))
        nb = b.stop - b0
        pieces = _block_pieces(
            (cx[b], cy[b], r_out[b]),
            (fx[b], fy[b]),
            (mx[b], my[b], r_cap[b]),
            (prev[b, 0], prev[b, 1], w_in),
            (i0[b], i1[b], j0[b], j1[b]),
            fast[b],
            (gx0, gy0, h, ny, xc_all),
        )
        per_sample = sum(np.bincount(pk, weights=cnt, minlength=nb) for pk, _, cnt in pieces)
        cum = np.cumsum(per_sample)
        g0 = 0
        while g0 < nb:
            base = cum[g0 - 1] if g0 else 0.0
            g1 = min(nb, max(g0 + 1, int(np.searchsorted(cum, base + _CELL_BUDGET, "right"))))
            cells = []
            for pk, starts, counts in pieces:
                s0, s1 = np.searchsorted(pk, [g0, g1])
                idx, owner = _expand(starts[s0:s1], counts[s0:s1])
                ks = pk[s0:s1][owner] + b0
                a = idx // ny
                cells.append((idx, ks, xc_all[a], yc_all[idx - a * ny]))
            idx, ks, xs, ys = cells[0]
            keep, dy = _front(
                xs - cx[ks], ys - cy[ks], fx[ks], fy[ks], ds[ks], lam_max[ks], radius, look
            )
            f_idx, f_dy, f_k = idx[keep], dy[keep], ks[keep]
            f_off = np.searchsorted(f_k, np.arange(b0 + g0, b0 + g1 + 1))
            idx, ks, xs, ys = cells[1]
            keep, z_cut = _capsule(
                xs - prev[ks, 0], ys - prev[ks, 1], seg_x[ks], seg_y[ks], seg_len2[ks],
                prev[ks, 2], z[ks], z0, radius,
            )
            r_idx, r_z = idx[keep], z_cut[keep]
            r_off = np.searchsorted(ks[keep], np.arange(b0 + g0, b0 + g1 + 1))
            # Per sample its front cells then its capsule cells, read at once (both before
            # the cut); the loop only gathers and scatters, reductions are done per group.
            f_n, r_n = np.diff(f_off), np.diff(r_off)
            lo_all = f_off[:-1] + r_off[:-1]  # where sample m's cells start
            mid_all = lo_all + f_n  # ... its capsule cells start
            pos_f = np.arange(f_idx.size) + np.repeat(r_off[:-1], f_n)
            pos_r = np.arange(r_idx.size) + np.repeat(f_off[1:], r_n)
            both = np.empty(f_idx.size + r_idx.size, dtype=np.int64)
            both[pos_f], both[pos_r] = f_idx, r_idx
            z_both = np.empty(both.size)
            z_both[pos_r] = r_z
            seen = np.empty(both.size, dtype=np.float32)  # heights before the cut
            new = np.empty(both.size)
            bounds = zip(lo_all.tolist(), mid_all.tolist(), (lo_all + f_n + r_n).tolist(),
                         strict=True)
            for m, (lo, mid, hi) in enumerate(bounds):
                i = b0 + g0 + m
                if fast[i]:
                    flat.take(both[lo:hi], out=seen[lo:hi])
                    flat[both[mid:hi]] = np.minimum(seen[mid:hi], z_both[mid:hi],
                                                    out=new[mid:hi])
                    continue
                # the whole window under the capsule and the view ahead
                if i0[i] >= i1[i] or j0[i] >= j1[i]:
                    continue
                wi, wj = slice(i0[i], i1[i]), slice(j0[i], j1[i])
                win = work[wi, wj]
                xw, yw = xc_all[wi, None], yc_all[None, wj]
                front, dy = _front(
                    xw - cx[i], yw - cy[i], fx[i], fy[i], ds[i], lam_max[i], radius, look
                )
                material = front & (win > thr[i])
                if material.any():
                    y_m = dy[material]
                    y_lo_raw[i] = y_m.min()
                    y_hi_raw[i] = y_m.max()
                    top[i] = win[material].max()
                    engaged[i] = True
                    k_i, *rest = bins.pieces(np.zeros(y_m.size, dtype=np.int64), y_m,
                                             win[material], 1, floor[i : i + 1],
                                             w_half[i : i + 1])
                    found_pieces.append((k_i + i, *rest))
                inside, z_cut = _capsule(
                    xw - prev[i, 0], yw - prev[i, 1], seg_x[i], seg_y[i], seg_len2[i],
                    prev[i, 2], z[i], z0, radius,
                )
                cut_old = win[inside]
                cut_new = np.minimum(cut_old, z_cut[inside]).astype(np.float32)
                win[inside] = cut_new
                removed[i] = np.subtract(cut_old, cut_new, dtype=float).sum()

            ks = np.arange(b0 + g0, b0 + g1)
            sel = fast[ks] & (f_n > 0)
            if sel.any():
                # material: top above the threshold; its top and lateral extent
                f_seen = seen[pos_f]
                material = f_seen > thr[f_k]
                starts = f_off[:-1][sel]
                hit = np.add.reduceat(material, starts) > 0
                tops = np.maximum.reduceat(f_seen, starts)
                y_lo_g = np.minimum.reduceat(np.where(material, f_dy, np.inf), starts)
                y_hi_g = np.maximum.reduceat(np.where(material, f_dy, -np.inf), starts)
                k_hit = ks[sel][hit]
                engaged[k_hit] = True
                top[k_hit] = tops[hit]
                y_lo_raw[k_hit] = y_lo_g[hit]
                y_hi_raw[k_hit] = y_hi_g[hit]
                mine = material & fast[f_k]
                if mine.any():
                    k0 = b0 + g0
                    k_g, *rest = bins.pieces(f_k[mine] - k0, f_dy[mine], f_seen[mine], g1 - g0,
                                             floor[k0 : b0 + g1], w_half[k0 : b0 + g1])
                    found_pieces.append((k_g + k0, *rest))
            sel = fast[ks] & (r_n > 0)
            if sel.any():
                cut_new = new[pos_r].astype(np.float32)
                diff = np.subtract(seen[pos_r], cut_new, dtype=float)
                removed[ks[sel]] = np.add.reduceat(diff, r_off[:-1][sel])
            g0 = g1

    if work is not stock.heights:
        np.copyto(stock.heights, work)

    entry = np.zeros(n)
    exit_ = np.zeros(n)
    depth = np.zeros(n)
    lateral = np.full((n, 2), np.nan)
    y_hi = np.where(y_hi_raw >= radius - snap, radius, np.minimum(radius, y_hi_raw + w_half))
    y_lo = np.where(y_lo_raw <= -radius + snap, -radius, np.maximum(-radius, y_lo_raw - w_half))
    entry[engaged] = [math.acos(v) for v in (y_hi[engaged] / radius).tolist()]
    exit_[engaged] = [math.acos(v) for v in (y_lo[engaged] / radius).tolist()]
    above = top - floor
    depth[engaged] = np.minimum(above[engaged], tool.flute_length)
    beyond = engaged & (above > tool.flute_length)
    lateral[engaged, 0] = y_lo[engaged]
    lateral[engaged, 1] = y_hi[engaged]
    in_air = ~engaged
    intervals = _intervals(found_pieces, radius)
    count = np.bincount(intervals.sample, minlength=n)
    several = count[intervals.sample] > 1
    pieces = EngagementPieces(intervals.sample[several], intervals.entry[several],
                              intervals.exit[several], intervals.axial_depth[several])
    eng = Engagement(entry, exit_, np.where(in_air, tool.flute_length, depth), pieces)
    return StockEngagement(eng, in_air, depth, beyond, lateral, removed * h**2, intervals,
                           radius)


def _intervals(found: list[tuple[np.ndarray, ...]], radius: float) -> EngagementPieces:
    """The pieces the sweep found (sample, y_lo, y_hi, depth), as angles in sample order."""
    if not found:
        empty = np.zeros(0)
        return EngagementPieces(np.zeros(0, dtype=np.int64), empty, empty, empty)
    sample, y_lo, y_hi, depth = (np.concatenate(a) for a in zip(*found, strict=True))
    entry = np.arccos(np.clip(y_hi / radius, -1.0, 1.0))
    exit_ = np.arccos(np.clip(y_lo / radius, -1.0, 1.0))
    keep = exit_ > entry  # a sliver on the rim that rounds to no angle cuts nothing
    sample, entry, exit_, depth = sample[keep], entry[keep], exit_[keep], depth[keep]
    order = np.lexsort((entry, sample))
    return EngagementPieces(sample[order], entry[order], exit_[order], depth[order])
