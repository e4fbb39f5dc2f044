"""Tri-dexel stock for five-axis milling: material as intervals on rays along x, y and z.

A dexel grid (Van Hook, "Real-time shaded NC milling display", SIGGRAPH 1986) holds, for every
ray of a regular grid of spacing h in two coordinates (u, v), the sorted disjoint intervals
[enter, exit] of the third coordinate that lie in the material. Three grids along x, y and z
(the tri-dexel model of Benouamer & Michelucci, "Bridging the gap between CSG and Brep via a
triple ray representation", ACM Solid Modeling 1997) keep every face of the part sampled
densely by the grid most normal to it, which a Z-map cannot when the tool axis tilts
(undercuts, walls).

Layout
------
Grid ``axis`` a has u = (a + 1) % 3, v = (a + 2) % 3 (x: (y, z); y: (z, x); z: (x, y)); ray
(i, j), stored at row ``i nv + j``, runs at ``u = u0 + (i + 1/2) h, v = v0 + (j + 1/2) h``.
Intervals are a padded array (rays, K, 2) with a count per ray; padding is ``(inf, inf)``.
K grows when a removal splits an interval.

Queries and resolution
----------------------
:meth:`TriDexel.contains` looks a point up on the nearest ray of each grid (the ray of the cell
it lies in) and takes the **majority of the three**. One grid misreads a point within
``h/2 (|n_u| + |n_v|)`` (<= h / sqrt 2) of a plane boundary of normal n (the ray is up to half a
cell off in u and v); two grids must misread for the majority to, so it errs only within
``h/2`` of a face normal to an axis and at most ``0.61 h`` of any plane (``h/2 (c1 + c3)`` for
the sorted |n| components, largest at n ~ (2, 1, 1) / sqrt 6), and on features thinner than h.
:meth:`TriDexel.volume` is the mean of the three grids' volumes (each the midpoint rule over
its cells of the exact lengths along its rays).

Tool removal
------------
The cutter is the solid of revolution ``{rho <= R, height_at_radius(rho) <= w <= H}`` about its
axis (w the height above the tip along the axis, rho the distance from it,
:meth:`feedopt.process.cutter.Profile.height_at_radius` the lower surface, R the profile's
radius at H: above the flutes of a flat, ball or bull mill a cylinder of the tool radius). Its
profile is concave, so the solid is convex and a ray meets it in one interval:

* flat end mill: the infinite cylinder ``rho^2 = A t^2 + 2 B t + C <= R^2`` (a quadratic in
  the ray coordinate t) intersected with the slab ``0 <= w <= H`` (w linear in t);
* ball-nose: the ball ``|p - (tip + R k)| <= R`` cut to ``w <= min(H, R)``, joined with the
  cylinder over ``R <= w <= H`` (both convex pieces of one convex section: their hull);
* any other profile (bull-nose, tapered): the cylinder-and-slab interval, then the convex
  ``g(t) = height_at_radius(rho(t)) - w(t)``: its minimum by golden section, its roots by
  bisection, to 1e-6 R.

:meth:`TriDexel.sweep_tool` sub-steps the poses so that no point of the cutter moves more than
h/2 between two (tip step plus ``sqrt(H^2 + R^2)`` times the axis rotation, axes slerped) and
removes all of them, vectorised over (pose, ray) pairs of the rays in each pose's bounding box;
the cuts of a block of poses are subtracted at once by sorting enter/exit events per ray.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.process.cutter import Profile
from feedopt.process.stock_mesh import vertical_crossings
from feedopt.process.stock_sweep import expand

__all__ = ["DexelGrid", "ToolSolid", "TriDexel", "ray_tool_intervals", "tool_solid"]

#: Largest number of rays of the three grids together (about 48 bytes a ray at K = 1 with the
#: count, 2.9 GB at the cap).
MAX_RAYS = 60_000_000
# (pose, ray) pairs computed at once in a removal.
_PAIR_BUDGET = 1 << 20
# Pieces shorter than this fraction of h left by a removal are dropped (rounding slivers).
_SLIVER = 1e-9
# A ray this close to parallel to the tool axis (or its slab) is treated as parallel.
_PARALLEL = 1e-12


@dataclass
class DexelGrid:
    """The rays along coordinate ``axis`` (module docstring, Layout): SI units."""

    axis: int
    origin: np.ndarray  # (2,) (u0, v0) [m]
    spacing: float  # h [m]
    shape: tuple[int, int]  # (nu, nv)
    intervals: np.ndarray  # (nu nv, K, 2) [m], padded with inf
    count: np.ndarray  # (nu nv,) int

    @property
    def uv(self) -> tuple[int, int]:
        """The coordinates (u, v) the rays are spread over."""
        return (self.axis + 1) % 3, (self.axis + 2) % 3

    def ray_points(self, rays: np.ndarray) -> np.ndarray:
        """A point (coordinate ``axis`` = 0) on each of the ``rays`` (p, 3) [m]."""
        i, j = np.divmod(rays, self.shape[1])
        out = np.zeros((rays.size, 3))
        u, v = self.uv
        out[:, u] = self.origin[0] + (i + 0.5) * self.spacing
        out[:, v] = self.origin[1] + (j + 0.5) * self.spacing
        return out

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether each point (m, 3) lies in an interval of the ray of its cell (m,)."""
        u, v = self.uv
        i = np.floor((points[:, u] - self.origin[0]) / self.spacing)
        j = np.floor((points[:, v] - self.origin[1]) / self.spacing)
        ok = (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
        rays = np.where(ok, i * self.shape[1] + j, 0).astype(np.int64)
        t = points[:, self.axis, None]
        iv = self.intervals[rays]
        return ok & np.any((iv[..., 0] <= t) & (t < iv[..., 1]), axis=1)

    def volume(self) -> float:
        """Material volume [m^3]: the summed interval lengths times h^2."""
        iv = self.intervals
        valid = np.arange(iv.shape[1])[None, :] < self.count[:, None]
        length = np.where(valid, iv[..., 1], 0.0) - np.where(valid, iv[..., 0], 0.0)
        return float(np.sum(length)) * self.spacing**2

    def store(self, rays: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              touched: np.ndarray) -> None:
        """Replace the intervals of the rays ``touched`` by (``rays``, ``lo``, ``hi``),
        sorted by ray then ``lo`` (the rays a subset of ``touched``)."""
        count = np.bincount(rays, minlength=self.count.size)
        k_new = int(count[touched].max(initial=0))
        if k_new > self.intervals.shape[1]:
            grown = np.full((self.count.size, k_new, 2), np.inf)
            grown[:, : self.intervals.shape[1]] = self.intervals
            self.intervals = grown
        self.intervals[touched] = np.inf
        self.count[touched] = count[touched]
        if rays.size:
            starts = np.r_[0, np.flatnonzero(np.diff(rays)) + 1]
            rank = np.arange(rays.size) - np.repeat(starts, np.diff(np.r_[starts, rays.size]))
            self.intervals[rays, rank, 0] = lo
            self.intervals[rays, rank, 1] = hi

    def subtract(self, rays: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        """Remove the cuts ``[a, b]`` from the ``rays`` (several cuts per ray allowed): the
        events (material enter/exit, cut enter/exit) of every touched ray sorted, material
        left where the material count is 1 and the cut count 0. Returns the length of
        material removed [m] (summed over the rays)."""
        keep = a < b
        rays, a, b = rays[keep], a[keep], b[keep]
        if rays.size == 0:
            return 0.0
        rays, a, b = _chain_union(rays, a, b)
        touched = np.unique(rays)
        iv = self.intervals[touched]
        valid = np.arange(iv.shape[1])[None, :] < self.count[touched][:, None]
        owner = np.broadcast_to(touched[:, None], valid.shape)[valid]
        m_lo, m_hi = iv[..., 0][valid], iv[..., 1][valid]
        ray = np.concatenate([owner, owner, rays, rays])
        t = np.concatenate([m_lo, m_hi, a, b])
        m, c = owner.size, rays.size
        dm = np.repeat(np.array([1, -1, 0, 0]), [m, m, c, c])
        dc = np.repeat(np.array([0, 0, 1, -1]), [m, m, c, c])
        order = np.lexsort((t, ray))
        on = (np.cumsum(dm[order]) > 0) & (np.cumsum(dc[order]) == 0)
        before = np.r_[False, on[:-1]]
        start, end = order[on & ~before], order[~on & before]
        lo, hi, owner = t[start], t[end], ray[start]
        solid = hi - lo > _SLIVER * self.spacing
        self.store(owner[solid], lo[solid], hi[solid], touched)
        return float(np.sum(m_hi - m_lo) - np.sum(hi[solid] - lo[solid]))


def _chain_union(rays: np.ndarray, a: np.ndarray, b: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fewer cuts with the same union per ray: cuts grouped by ray (keeping their order,
    pose order from a sweep), runs in which each cut overlaps the one before joined into
    their hull (a chain of overlapping intervals is one interval)."""
    order = np.argsort(rays, kind="stable")
    rays, a, b = rays[order], a[order], b[order]
    new = np.r_[True, (rays[1:] != rays[:-1]) | (a[1:] > b[:-1]) | (b[1:] < a[:-1])]
    start = np.flatnonzero(new)
    return rays[start], np.minimum.reduceat(a, start), np.maximum.reduceat(b, start)


@dataclass(frozen=True)
class ToolSolid:
    """The cutter as a solid of revolution (module docstring): ``kind`` 'flat', 'ball' or
    'general', radius R and height H [m] above the tip."""

    profile: Profile
    radius: float
    height: float
    kind: str


def tool_solid(profile: Profile, height: float, exact: bool = True) -> ToolSolid:
    """The solid of ``profile`` up to ``height`` [m] above the tip; ``exact=False`` takes the
    numerical ray intersection even for a flat or ball end mill (tests)."""
    if not (math.isfinite(height) and height > 0):
        raise InputError(f"tool solid: height must be > 0, got {height!r} m")
    r_top = float(profile.at_length(profile.length_to_height(height))[0])
    kind = "general"
    if exact and profile.is_cylinder:
        kind = "flat"
    elif exact and profile.r0 == 0.0 and profile.kappa1 == math.pi / 2:
        kind = "ball"
    return ToolSolid(profile, r_top, float(height), kind)


def _cylinder(q: np.ndarray, a: int, k: np.ndarray, radius: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters where the ray ``q + t e_a`` is within ``radius`` of the axis ``k``
    through the origin (empty as (inf, -inf))."""
    qk = np.einsum("ij,ij->i", q, k)
    ka = k[:, a]
    quad = 1.0 - ka * ka
    lin = q[:, a] - qk * ka
    const = np.einsum("ij,ij->i", q, q) - qk * qk - radius**2
    parallel = quad < _PARALLEL
    disc = lin * lin - quad * const
    root = np.sqrt(np.maximum(disc, 0.0))
    safe = np.where(parallel, 1.0, quad)
    t0 = np.where(parallel, -np.inf, (-lin - root) / safe)
    t1 = np.where(parallel, np.inf, (-lin + root) / safe)
    empty = np.where(parallel, const > 0.0, disc < 0.0)
    return np.where(empty, np.inf, t0), np.where(empty, -np.inf, t1)


def _slab(qk: np.ndarray, ka: np.ndarray, w0: float, w1: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters where the height ``w = qk + t ka`` lies in [w0, w1]."""
    parallel = np.abs(ka) < _PARALLEL
    safe = np.where(parallel, 1.0, ka)
    s0, s1 = (w0 - qk) / safe, (w1 - qk) / safe
    inside = (qk >= w0) & (qk <= w1) & (w0 <= w1)
    t0 = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(s0, s1))
    t1 = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(s0, s1))
    return t0, t1


def _ball(q: np.ndarray, a: int, k: np.ndarray, rc: float) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters inside the ball of radius ``rc`` about ``rc k``."""
    c = q - rc * k
    half = c[:, a]
    disc = half * half - (np.einsum("ij,ij->i", c, c) - rc * rc)
    root = np.sqrt(np.maximum(disc, 0.0))
    empty = disc < 0.0
    return np.where(empty, np.inf, -half - root), np.where(empty, -np.inf, -half + root)


def ray_tool_intervals(solid: ToolSolid, points: np.ndarray, a: int, tips: np.ndarray,
                       axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pair p the interval ``[t0, t1]`` of the coordinate ``a`` along the ray through
    ``points[p]`` (parallel to axis ``a``) inside the cutter ``solid`` at tip ``tips[p]``, unit
    axis ``axes[p]`` (module docstring); ``t0 >= t1`` where it misses. Inputs (p, 3)."""
    q = points - tips
    q[:, a] = -tips[:, a]  # the ray coordinate t is measured from 0, not from points[:, a]
    qk = np.einsum("ij,ij->i", q, axes)
    ka = axes[:, a]
    radius, height = solid.radius, solid.height
    c0, c1 = _cylinder(q, a, axes, radius)
    if solid.kind == "ball":
        rc = solid.profile.corner
        b0, b1 = _ball(q, a, axes, rc)
        s0, s1 = _slab(qk, ka, 0.0, min(height, rc))
        b0, b1 = np.maximum(b0, s0), np.minimum(b1, s1)
        s0, s1 = _slab(qk, ka, rc, height)
        u0, u1 = np.maximum(c0, s0), np.minimum(c1, s1)
        lo = np.minimum(np.where(b0 < b1, b0, np.inf), np.where(u0 < u1, u0, np.inf))
        hi = np.maximum(np.where(b0 < b1, b1, -np.inf), np.where(u0 < u1, u1, -np.inf))
        return lo, hi
    s0, s1 = _slab(qk, ka, 0.0, height)
    t0, t1 = np.maximum(c0, s0), np.minimum(c1, s1)
    if solid.kind == "flat":
        return t0, t1
    return _profile_interval(solid, (q, a, axes, qk), t0, t1)


def _profile_interval(solid: ToolSolid, ray: tuple, t0: np.ndarray, t1: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The part of ``[t0, t1]`` (inside the cylinder and the slab) above the cutter's lower
    surface: ``g(t) = height_at_radius(rho(t)) - w(t) <= 0``, g convex (module docstring)."""
    q, a, k, qk = ray
    ka = k[:, a]
    quad, lin = 1.0 - ka * ka, q[:, a] - qk * ka
    const = np.einsum("ij,ij->i", q, q) - qk * qk
    hit = np.flatnonzero(t0 < t1)
    lo, hi = np.full(t0.shape, np.inf), np.full(t0.shape, -np.inf)
    if hit.size == 0:
        return lo, hi
    quad, lin, const, qk, ka = quad[hit], lin[hit], const[hit], qk[hit], ka[hit]
    radius, profile = solid.radius, solid.profile

    def g(t: np.ndarray) -> np.ndarray:
        rho = np.sqrt(np.clip(quad * t * t + 2.0 * lin * t + const, 0.0, radius**2))
        return profile.height_at_radius(rho) - (qk + ka * t)

    a0, b0 = t0[hit], t1[hit]
    tol = 1e-6 * max(solid.radius, 1e-3)
    steps = int(math.ceil(math.log(max(float(np.max(b0 - a0)), tol) / tol) / math.log(1.618)))
    x, y = a0.copy(), b0.copy()
    inv_phi = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(steps + 1):  # golden section for the minimum of the convex g
        m1, m2 = y - inv_phi * (y - x), x + inv_phi * (y - x)
        left = g(m1) < g(m2)
        y = np.where(left, m2, y)
        x = np.where(left, x, m1)
    best = 0.5 * (x + y)
    inside = g(best) <= 0.0
    r0 = _root(g, a0, best, steps)  # g > 0 then <= 0
    r1 = _root(g, b0, best, steps)
    lo[hit] = np.where(inside, r0, np.inf)
    hi[hit] = np.where(inside, r1, -np.inf)
    return lo, hi


def _root(g, out: np.ndarray, inside: np.ndarray, steps: int) -> np.ndarray:
    """Bisection between ``out`` (where g may be > 0) and ``inside`` (g <= 0): the boundary
    (``out`` itself where g(out) <= 0)."""
    x, y = out.copy(), inside.copy()
    done = g(x) <= 0.0
    for _ in range(steps):
        mid = 0.5 * (x + y)
        neg = g(mid) <= 0.0
        y = np.where(neg, mid, y)
        x = np.where(neg, x, mid)
    return np.where(done, out, 0.5 * (x + y))


class TriDexel:
    """Material as three dexel grids along x, y and z (module docstring). Mutable: the
    removals cut it."""

    def __init__(self, grids: tuple[DexelGrid, DexelGrid, DexelGrid]) -> None:
        self.grids = grids

    @property
    def spacing(self) -> float:
        """Ray spacing h [m]."""
        return self.grids[0].spacing

    @property
    def rays(self) -> tuple[int, int, int]:
        """Number of rays of each grid (x, y, z)."""
        return tuple(int(g.count.size) for g in self.grids)

    @property
    def nbytes(self) -> int:
        """Memory of the intervals and counts [bytes]."""
        return sum(int(g.intervals.nbytes + g.count.nbytes) for g in self.grids)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box (lo (3,), hi (3,)) [m] the grids cover."""
        lo, hi = np.zeros(3), np.zeros(3)
        for g in self.grids:
            u, v = g.uv
            lo[u], lo[v] = g.origin
            hi[u] = g.origin[0] + g.shape[0] * g.spacing
            hi[v] = g.origin[1] + g.shape[1] * g.spacing
        return lo, hi

    def copy(self) -> TriDexel:
        """An independent copy (removals from one leave the other)."""
        return TriDexel(tuple(DexelGrid(g.axis, g.origin.copy(), g.spacing, g.shape,
                                        g.intervals.copy(), g.count.copy())
                              for g in self.grids))

    @staticmethod
    def _layout(lo: np.ndarray, hi: np.ndarray, spacing: float) -> list[tuple]:
        """Per grid (axis, (u0, v0), (nu, nv)) covering the box [lo, hi] [m]."""
        if not (math.isfinite(spacing) and spacing > 0):
            raise InputError(f"tri-dexel: spacing must be > 0, got {spacing!r} m")
        if not np.all(np.isfinite(lo) & np.isfinite(hi) & (hi > lo)):
            raise InputError(f"tri-dexel: the box needs lo < hi, got {lo} and {hi}")
        n = np.maximum(1, np.ceil((hi - lo) / spacing - 1e-9)).astype(np.int64)
        out, rays = [], 0
        for a in range(3):
            u, v = (a + 1) % 3, (a + 2) % 3
            out.append((a, np.array([lo[u], lo[v]]), (int(n[u]), int(n[v]))))
            rays += int(n[u]) * int(n[v])
        if rays > MAX_RAYS:
            raise InputError(f"tri-dexel: {rays:,} rays at {spacing * 1e3:g} mm spacing, more "
                             f"than {MAX_RAYS:,}: use a coarser spacing or a smaller stock")
        return out

    @classmethod
    def box(cls, lo, hi, spacing: float) -> TriDexel:
        """The box ``[lo, hi]`` (3,) [m], rays every ``spacing`` [m] from ``lo``."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        grids = []
        for a, origin, shape in cls._layout(lo, hi, spacing):
            grid = DexelGrid(a, origin, float(spacing), shape,
                             np.full((shape[0] * shape[1], 1, 2), np.inf),
                             np.zeros(shape[0] * shape[1], dtype=np.int64))
            pts = grid.ray_points(np.arange(grid.count.size))
            u, v = grid.uv
            inside = ((pts[:, u] <= hi[u]) & (pts[:, v] <= hi[v]))
            grid.intervals[inside, 0] = (lo[a], hi[a])
            grid.count[inside] = 1
            grids.append(grid)
        return cls(tuple(grids))

    @classmethod
    def from_mesh(cls, mesh, spacing: float) -> TriDexel:
        """The solid bounded by a closed triangle mesh (a ``trimesh.Trimesh`` or its triangles
        (m, 3, 3)) [m]: every ray crossed with the triangles (the Z-map's line casting,
        :func:`feedopt.process.stock_mesh.vertical_crossings`, along each axis), crossings
        paired in order; InputError where a ray crosses the surface an odd number of times."""
        tri = np.asarray(getattr(mesh, "triangles", mesh), dtype=float)
        if getattr(mesh, "is_watertight", True) is False:
            raise InputError("tri-dexel: the mesh is not watertight (not a closed solid)")
        pts = tri.reshape(-1, 3)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        tol = 1e-9 * float(np.max(hi - lo))
        grids = []
        for a, origin, shape in cls._layout(lo, hi, spacing):
            u, v = (a + 1) % 3, (a + 2) % 3
            rays, t = vertical_crossings(tri[..., [u, v, a]], origin, spacing, shape)
            order = np.lexsort((t, rays))
            rays, t = rays[order], t[order]
            dup = np.zeros(rays.size, dtype=bool)
            dup[1:] = (rays[1:] == rays[:-1]) & (np.diff(t) <= tol)
            rays, t = rays[~dup], t[~dup]
            n = shape[0] * shape[1]
            odd = np.flatnonzero(np.bincount(rays, minlength=n) % 2)
            if odd.size:
                i, j = divmod(int(odd[0]), shape[1])
                at = origin + (np.array([i, j]) + 0.5) * spacing
                raise InputError(
                    f"tri-dexel: the ray along {'xyz'[a]} at {'xyz'[u]} = {at[0] * 1e3:.4g} mm, "
                    f"{'xyz'[v]} = {at[1] * 1e3:.4g} mm crosses the mesh an odd number of "
                    f"times ({odd.size} such rays): the mesh is not a closed solid there (a "
                    "hole, a missing or flipped face); close or repair it")
            grid = DexelGrid(a, origin, float(spacing), shape, np.full((n, 1, 2), np.inf),
                             np.zeros(n, dtype=np.int64))
            grid.store(rays[0::2], t[0::2], t[1::2], np.arange(n))
            grids.append(grid)
        return cls(tuple(grids))

    def contains(self, points, rule: str = "majority") -> np.ndarray:
        """Whether each point (m, 3) [m] is material (m,): ``rule`` 'majority' of the three
        grids (module docstring), 'any' of them, or 'z' (the z-grid alone)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if rule not in ("majority", "any", "z"):
            raise ValueError(f"unknown contains rule {rule!r}")
        lo, hi = self.bounds()
        # outside the grids' box no grid has material: only the points inside are looked up
        inside = np.flatnonzero(np.all((points >= lo) & (points < hi), axis=1))
        out = np.zeros(points.shape[0], dtype=bool)
        if inside.size == 0:
            return out
        pts = points[inside]
        if rule == "z":
            out[inside] = self.grids[2].contains(pts)
            return out
        first, second = self.grids[0].contains(pts), self.grids[1].contains(pts)
        # the third grid decides only where the first two disagree (the majority), or where
        # neither holds (any)
        open_ = first != second if rule == "majority" else ~(first | second)
        third = np.zeros(pts.shape[0], dtype=bool)
        third[open_] = self.grids[2].contains(pts[open_])
        out[inside] = ((first & second) | third if rule == "majority"
                       else first | second | third)
        return out

    def volumes(self) -> np.ndarray:
        """The material volume [m^3] by each grid (x, y, z)."""
        return np.array([g.volume() for g in self.grids])

    def volume(self) -> float:
        """The material volume [m^3], the mean of the three grids'."""
        return float(np.mean(self.volumes()))

    def remove_tool(self, tip, axis, profile: Profile, height: float) -> None:
        """Remove the cutter (``profile`` up to ``height`` [m] above the tip, module docstring)
        at one pose (tip (3,), axis (3,)) or at each of several poses ((n, 3) each) [m]."""
        tips = np.asarray(tip, dtype=float).reshape(-1, 3)
        axes = np.asarray(axis, dtype=float).reshape(-1, 3)
        axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
        tips, axes = np.broadcast_arrays(tips, axes)
        solid = tool_solid(profile, height)
        for grid in self.grids:
            _remove_poses(grid, solid, tips, axes)

    def sweep_tool(self, tips, axes, profile: Profile, height: float) -> int:
        """Remove the volume the cutter sweeps along the poses (n, 3) tips and axes [m],
        sub-stepped so no point of it moves more than h/2 between removed poses (module
        docstring); returns the number of poses removed."""
        return self.sweep_tool_removing(tips, axes, profile, height)[0]

    def sweep_tool_removing(self, tips, axes, profile: Profile, height: float
                            ) -> tuple[int, float]:
        """:meth:`sweep_tool`, and the volume it removed [m^3] (the mean of the three grids',
        as :meth:`volume`; found from the rays it touched, not by a scan of the stock)."""
        solid = tool_solid(profile, height)
        tips_s, axes_s = substeps(np.asarray(tips, dtype=float).reshape(-1, 3),
                                  np.asarray(axes, dtype=float).reshape(-1, 3),
                                  math.hypot(solid.height, solid.radius), 0.5 * self.spacing)
        removed = [_remove_poses(grid, solid, tips_s, axes_s) for grid in self.grids]
        return tips_s.shape[0], float(np.mean(removed)) * self.spacing**2


def substeps(tips: np.ndarray, axes: np.ndarray, reach: float, step: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """Poses between consecutive ``tips``/``axes`` (n, 3) so that a point within ``reach`` of
    the tip moves at most ``step`` between two: tips linear, axes slerped; the first pose and
    every given pose included."""
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    if tips.shape[0] < 2:
        return tips.copy(), axes.copy()
    d_tip = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    cos = np.clip(np.einsum("ij,ij->i", axes[:-1], axes[1:]), -1.0, 1.0)
    omega = np.arccos(cos)
    count = np.maximum(1, np.ceil((d_tip + reach * omega) / step)).astype(np.int64)
    local, seg = expand(np.ones(count.size, dtype=np.int64), count)
    s = (local / count[seg])[:, None]
    w = omega[seg][:, None]
    small = w < 1e-9
    sin_w = np.where(small, 1.0, np.sin(w))
    wa = np.where(small, 1.0 - s, np.sin((1.0 - s) * w) / sin_w)
    wb = np.where(small, s, np.sin(s * w) / sin_w)
    ax = wa * axes[seg] + wb * axes[seg + 1]
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    tp = tips[seg] + s * (tips[seg + 1] - tips[seg])
    return np.vstack([tips[:1], tp]), np.vstack([axes[:1], ax])


def _remove_poses(grid: DexelGrid, solid: ToolSolid, tips: np.ndarray,
                  axes: np.ndarray) -> float:
    """Subtract the cutter at every pose from ``grid``: the rays in each pose's bounding box
    (clipped to the grid), in blocks of about :data:`_PAIR_BUDGET` (pose, ray) pairs.
    Returns the length of material removed along the rays [m]."""
    u, v = grid.uv
    h, (nu, nv) = grid.spacing, grid.shape
    lat = solid.radius * np.sqrt(np.clip(1.0 - axes**2, 0.0, 1.0))  # disc extent per coord
    top = tips + solid.height * axes
    box_lo = np.minimum(tips, top) - lat
    box_hi = np.maximum(tips, top) + lat
    i0 = np.clip(np.ceil((box_lo[:, u] - grid.origin[0]) / h - 0.5), 0, nu).astype(np.int64)
    i1 = np.clip(np.floor((box_hi[:, u] - grid.origin[0]) / h - 0.5), -1, nu - 1)
    j0 = np.clip(np.ceil((box_lo[:, v] - grid.origin[1]) / h - 0.5), 0, nv).astype(np.int64)
    j1 = np.clip(np.floor((box_hi[:, v] - grid.origin[1]) / h - 0.5), -1, nv - 1)
    ni = np.maximum(i1.astype(np.int64) - i0 + 1, 0)
    nj = np.maximum(j1.astype(np.int64) - j0 + 1, 0)
    count = ni * nj
    cum = np.cumsum(count)
    start, removed = 0, 0.0
    while start < count.size:
        base = cum[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(cum, base + _PAIR_BUDGET, "right")))
        stop = min(stop, count.size)
        local, pose = expand(np.zeros(stop - start, dtype=np.int64), count[start:stop])
        pose += start
        rays = (i0[pose] + local // nj[pose]) * nv + j0[pose] + local % nj[pose]
        live = grid.count[rays] > 0
        rays, pose = rays[live], pose[live]
        t0, t1 = ray_tool_intervals(solid, grid.ray_points(rays), grid.axis, tips[pose],
                                    axes[pose])
        removed += grid.subtract(rays, t0, t1)
        start = stop
    return removed
