"""Reading a stock from a closed triangle mesh (STL) into Z-map heights: vertical lines
through the cell centres crossed with the triangles, with numpy (no ray-tracing backend);
used by :meth:`feedopt.process.stock.ZMap.from_mesh`, which sizes the grid."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.stock_sweep import expand as _expand
from feedopt.units import MM

# Vertical lines of ZMap.from_mesh are nudged by these fractions of a cell from the cell
# centres, so that they miss the edges and vertices of meshes with round coordinates.
_NUDGE = (0.7071067811865476e-6, 0.5773502691896258e-6)
_CROSSING_BUDGET = 2_000_000


def vertical_crossings(
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

def unit_text(scale: float) -> str:
    """The unit a mesh scale [m per unit] reads a file in."""
    return {MM: "mm", 1.0: "m"}.get(scale, f"units of {scale:g} m")

def closed_mesh_triangles(file: Path, where: str) -> np.ndarray:
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

def mesh_tops(tri: np.ndarray, lo: np.ndarray, tol: float, cell: float, shape,
               where: str) -> np.ndarray:
    """Top of the material per cell (flat, length nx * ny) [m] of the closed mesh ``tri``
    [m] whose bounds start at ``lo``; InputError where a column is not one solid on z0."""
    nx, ny = shape
    cells, z = vertical_crossings(tri, (lo[0], lo[1]), cell, (nx, ny))
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
