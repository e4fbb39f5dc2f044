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

Along the path (issue 28)
-------------------------
The material a tooth meets is the material the cutter's disc sweeps along the path ahead, in
the tool frame of the path's own tangent, for lines, arcs, helices, ramps and rising moves
alike (:mod:`feedopt.process.stock_sweep`: the path near a sample is its osculating arc, and a
cell is given to the tooth that meets it there, at ``phi = arccos(y' / R)`` with y' from the
triangle of the arc's centre, the cutter's centre and the cell; Kardes & Altintas 2007). The
material under the disc the previous sample left is not met by the side edges: only the
bottom cuts it, on a descending step (a ramp, a helix, a plunge; the layer down from the
previous tip height, :attr:`StockEngagement.bottom_depth`); a level or rising step leaves it
as it is.

Removal (the swept volume)
--------------------------
Sample i removes the volume the cylinder sweeps from sample i-1 to sample i: every cell whose
centre is within R of that segment in xy is lowered to the lowest height the flat bottom passes
over it (the tip height at the last point of the step that covers it when the tip descends,
the first when it rises), never below z0; sample 0 removes its disc. Using segments instead of
discs leaves no scallops between samples and lets the path be curved and coarsely sampled.
The volume each step removes and the thickest material it cuts are reported
(:attr:`StockEngagement.removed`, :attr:`StockEngagement.swept_depth`): a rapid whose swept
volume meets material is a crash (:mod:`feedopt.process.material`).

Speed
-----
The cells in front of each sample and the cells its step cuts depend on the path only;
:func:`sweep` finds them for blocks of samples with numpy, and its Python loop over samples
only reads and lowers those cells, leaving out, on a level or rising step, the disc the
previous sample left (not cut again, and not material). 1e5 samples of a pocket path at
0.1 mm steps take about 4-4.5 s on two cores (``benchmarks/bench_stock.py``; 3.6 s with the
straight lookahead before issue 28).

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
from feedopt.process.cutter import Profile
from feedopt.process.engagement import Engagement, EngagementPieces
from feedopt.process.stock_mesh import closed_mesh_triangles, mesh_tops, unit_text
from feedopt.process.stock_sweep import (
    Grid,
    LateralBins,
    cut_along,
    intervals,
    make_setup,
    sweep_geometry,
)
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


@dataclass(frozen=True)
class FlatEndMill:
    """The cutter of the stock sweep, SI units: a flat end mill, or with ``profile`` a
    ball-nose, bull-nose, tapered or face mill (:mod:`feedopt.process.cutter`).

    Attributes
    ----------
    radius : float
        Cutter radius R [m].
    flute_length : float
        Length of cut [m]: the reported axial depth is clipped to it (deeper material is
        flagged ``beyond_flutes``).
    profile : Profile or None
        The cutting edges' envelope; None (or a cylinder) for a flat end mill. The sweep
        then removes the cutter's own shape, ``tip + profile.height_at_radius(rho)`` at a
        cell rho from the swept axis (a ball leaves scallops), and material in front counts
        only where it stands above that surface at its lateral offset.
    """

    radius: float
    flute_length: float
    profile: Profile | None = None

    def __post_init__(self) -> None:
        for name in ("radius", "flute_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"end mill {name} must be > 0 mm, got {value / MM:g} mm")

    @classmethod
    def from_tool(cls, tool: Tool) -> FlatEndMill:
        """The end mill of a process :class:`~feedopt.process.tool.Tool`."""
        return cls(radius=tool.diameter / 2.0, flute_length=tool.flute_length,
                   profile=None if tool.is_flat else tool.profile)


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
        where = where or f"stock mesh {file} (read in {unit_text(scale)})"
        tri = closed_mesh_triangles(file, where) * scale
        lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        if not np.all(np.isfinite(hi - lo)):
            raise InputError(f"{where}: its coordinates times {scale:g} m overflow")
        if not (hi[0] > lo[0] and hi[1] > lo[1] and hi[2] > lo[2]):
            raise InputError(f"{where}: is flat (no volume)")
        # STL coordinates are float32: a span of whole cells may come out 1e-4 cells longer
        nx, ny = grid_shape(hi[0] - lo[0], hi[1] - lo[1], cell, where, slack=1e-3)
        heights = mesh_tops(tri, lo, 1e-6 * float(np.max(hi - lo)), cell, (nx, ny), where)
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
    radius : float
        Cutter radius R [m].
    swept_depth : (n,) float
        The thickest material [m] each step cuts (the largest height drop of a cell of its
        swept volume); 0 where the cutter's swept volume meets no material.
    bottom_depth : (n,) float
        The thickest layer of material [m] the flat bottom cuts on a descending step: the
        step's cut between the previous tip height and this one (the floor of a ramp or a
        helix, a plunge's); 0 on level and rising steps (a rising bottom takes no material)
        and at sample 0.
    """

    engagement: Engagement
    in_air: np.ndarray
    axial_depth: np.ndarray
    beyond_flutes: np.ndarray
    lateral: np.ndarray
    removed: np.ndarray
    intervals: EngagementPieces
    radius: float
    swept_depth: np.ndarray
    bottom_depth: np.ndarray

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


#: Default depth step [m] of the angle-dependent axial depth: material tops across the
#: cutter that differ by less than this share one piece, at the largest depth among them (so
#: the force is overestimated by less than this much depth, never underestimated). 0.1 mm
#: gives a helical entry of 0.5 mm per turn about 5 pieces per sample; the force model's
#: cost grows with the pieces (scenario: stock.depth_step_mm).
DEPTH_STEP = 0.1 * MM



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
    material still present (top above the tool tip by > 1 um) that the cutter's disc meets
    along the path (:mod:`feedopt.process.stock_sweep`): outside the disc sample i-1 left
    (under it only the bottom cuts, :attr:`StockEngagement.bottom_depth`), in the leading half
    of the disc (``x >= 0`` along the feed: the crescent the step swept), and beyond the rim
    up to an arc length ``lookahead / sin(phi) - ds`` along the path at the tooth angle phi
    that meets it (capped at its value at :func:`snap_angle`, about 1.5 mm for h = 0.25 mm,
    R = 9.525 mm, less the step ds from sample i-1, never past the end of the path, and none
    where the path turns by more than 90 deg within it): a crescent ``lookahead`` thick normal
    to the rim, so that every part of the rim shows its material even when the samples are
    closer than the cells (a wall ahead is seen that much early; on a straight path the
    lookahead of :func:`lookahead_reach`).

    Each material cell is attributed to the tooth that meets it: phi = arccos(y' / R), with y'
    its lateral offset, in the frame of the path's tangent, where the rim meets it (on a
    straight path its lateral offset y). One interval per sample: the hull of the engaged
    angles, ``entry = arccos(y_hi / R)``, ``exit = arccos(y_lo / R)`` with [y_lo, y_hi] the
    lateral extent of the material (cell centres widened by half the projected cell width; an
    end within sqrt(2) h of the rim is put on the rim, see :func:`snap_angle`). That hull and
    the largest depth are the sample's summary (``engagement.entry/exit/axial_depth``).

    What the force model sums is finer (:class:`~feedopt.process.engagement.EngagementPieces`):
    the material cells are binned by y' in bins of width h, each bin keeping its highest top;
    runs of material bins are the engaged intervals (two separate contacts, e.g. at an inside
    corner cut with a small radial depth, are two intervals when more than one bin of air lies
    between them), and a run is split into pieces where the axial depth (top minus tip) changes
    by a ``depth_step`` (each piece at its largest depth). A sample with one piece is its hull.

    ``stock`` (a :class:`ZMap`) is cut in place (use ``stock.copy()`` to keep it);
    ``positions`` (n, 3): tool tips in W [m] in cutting order; ``tangents`` (n, 3): path
    tangents in W (their xy part is the feed direction; need not be unit); ``lookahead``: the
    crescent's thickness [m], default ``sqrt(2) h``; ``depth_step``: the axial depth
    resolution of the pieces [m] (:data:`DEPTH_STEP`). Returns a :class:`StockEngagement`.
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise InputError(f"positions must be a finite (n, 3) array [m], got shape {p.shape}")
    n = p.shape[0]
    feed = _feed_directions(tangents, n)
    h, radius = stock.cell, tool.radius
    look = math.sqrt(2.0) * h if lookahead is None else float(lookahead)
    if not (math.isfinite(look) and look >= 0):
        raise InputError(f"lookahead must be >= 0 mm, got {look / MM:g} mm")
    if not (math.isfinite(depth_step) and depth_step > 0):
        raise InputError(f"depth_step must be > 0 mm, got {depth_step / MM:g} mm")
    snap = math.sqrt(2.0) * h
    look_cap = look / max(math.sin(snap_angle(h, radius)), 1e-12)
    work = np.ascontiguousarray(stock.heights, dtype=np.float32)
    found = None
    if n:
        geometry = sweep_geometry(p, feed, radius, look, look_cap, stock.bottom, h)
        (gx0, gy0), (nx, ny) = stock.origin, stock.shape
        grid = Grid(gx0, gy0, h, nx, ny, stock.x_centres, stock.y_centres)
        bins = LateralBins(radius, h, tool.flute_length, snap, float(depth_step))
        setup = make_setup(geometry, grid, bins, radius, look, stock.bottom,
                           profile=tool.profile)
        found = cut_along(work.reshape(-1), setup)
    if work is not stock.heights:
        np.copyto(stock.heights, work)
    return _stock_engagement(found, p, feed, tool, stock)


def _stock_engagement(found, p: np.ndarray, feed: np.ndarray, tool: FlatEndMill,
                      stock: ZMap) -> StockEngagement:
    """The sweep's report from what its loop found (:class:`~.stock_sweep.Found`)."""
    n, h, radius = p.shape[0], stock.cell, tool.radius
    if found is None:
        empty = np.zeros(0)
        return StockEngagement(Engagement(empty, empty, empty), np.zeros(0, dtype=bool), empty,
                               np.zeros(0, dtype=bool), np.zeros((0, 2)), empty,
                               EngagementPieces(np.zeros(0, dtype=np.int64), empty, empty,
                                                empty), radius, empty, empty)
    snap = math.sqrt(2.0) * h
    engaged = found.engaged
    w_half = 0.5 * h * (np.abs(feed[:, 0]) + np.abs(feed[:, 1]))
    y_hi = np.where(found.y_hi >= radius - snap, radius, np.minimum(radius, found.y_hi + w_half))
    y_lo = np.where(found.y_lo <= -radius + snap, -radius,
                    np.maximum(-radius, found.y_lo - w_half))
    entry, exit_, depth = np.zeros(n), np.zeros(n), np.zeros(n)
    entry[engaged] = np.arccos(y_hi[engaged] / radius)
    exit_[engaged] = np.arccos(y_lo[engaged] / radius)
    above = found.top - np.maximum(p[:, 2], stock.bottom)
    depth[engaged] = np.minimum(above[engaged], tool.flute_length)
    beyond = engaged & (above > tool.flute_length)
    lateral = np.full((n, 2), np.nan)
    lateral[engaged] = np.column_stack([y_lo[engaged], y_hi[engaged]])
    sample, iv_entry, iv_exit, iv_depth = intervals(found.pieces, radius)
    all_pieces = EngagementPieces(sample, iv_entry, iv_exit, iv_depth)
    several = np.bincount(sample, minlength=n)[sample] > 1
    pieces = EngagementPieces(sample[several], iv_entry[several], iv_exit[several],
                              iv_depth[several])
    eng = Engagement(entry, exit_, np.where(engaged, depth, tool.flute_length), pieces)
    return StockEngagement(eng, ~engaged, depth, beyond, lateral, found.removed * h**2,
                           all_pieces, radius, swept_depth=found.swept,
                           bottom_depth=found.bottom)
