"""Generate a 3D finishing raster cut with a ball-nose end mill, in the style of CAMotics' examples.

CAMotics' 3D examples (bear.nc, a 1/8 in ball; cameo.nc, a 2 mm ball) are rasters: rows of short
G1 X Y Z moves following a free-form surface. This writes our own such program (no third-party
text): a smooth bump field z = f(x, y) (:func:`surface_mm`: Gaussian bumps, one dimple and a
ripple, a few mm high, top near Z0 as CAM programs place the stock top) over a ``width`` x
``length`` mm patch, finished by a ball of radius R in a zigzag raster: rows along X at a
step-over in Y, a point every ``step`` along the row, coordinates with 4 decimals.

The programmed point is the tool TIP (the lowest point of the ball; posts program the tip, the
tool length being set to it). For a ball touching the surface from above without gouging it is
the inverse tool offset ("drop cutter")

    z_tip(x, y) = max over u^2 + v^2 <= R^2 of  f(x + u, y + v) - R + sqrt(R^2 - u^2 - v^2)

(:func:`drop_ball_tip_mm`: the disc sampled on a square grid of ``spacing_frac * R`` plus its
rim, then each point's best sample refined by a shrinking local search; written Z is rounded
up to the 4th decimal, so the program never gouges by rounding). The step-over leaves scallops
of height h = R - sqrt(R^2 - (stepover/2)^2) on flat areas (:func:`scallop_height_mm`).

The layout follows benchmarks/raster_program.py: a header, the tool comment (``--style
fusion``: ``(T1 D=2. CR=1. - ZMIN=-3.2 - ball end mill)``; ``--style camotics``: ``(T1 D2
;2mm ball end mill)``; both read by feedopt.gcode.headers as a ball end mill), safety line,
M6 T1, S, M3, a G0 approach, a G1 plunge at the plunge feed, the rows (F on the first cutting
move; a row's first point is the step-over from the previous row's end), a retract, M5 M30.

With ``--stock-stl`` it also writes the stock such a finishing pass cuts
(:func:`roughed_stock_stl`): the part as roughed, f + ``--allowance-mm`` over the patch grown
by ``--margin-mm`` on every side (default R + 1 mm, so the outermost rows and points have
material beside them), down to a flat bottom (default 3 mm below the surface's minimum there),
as a closed binary STL in mm (its top piecewise linear on a grid of ``--stock-cell-mm``).

    .venv/bin/python benchmarks/ballnose_raster.py /tmp/ballnose.nc --ball-mm 2 --width-mm 25 \
        --length-mm 20 --stepover-mm 0.2 --step-mm 0.25 --stock-stl /tmp/ballnose_stock.stl
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

WIDTH_MM = 40.0
LENGTH_MM = 30.0
HEIGHT_MM = 4.0
BALL_MM = 2.0  # diameter
STEP_MM = 0.25
STEP_OVER_MM = 0.2
CLEARANCE_MM = 5.0
FEED_MM_MIN = 1500.0
PLUNGE_MM_MIN = 300.0
SPINDLE_RPM = 18000
SPACING_FRAC = 0.02
ALLOWANCE_MM = 0.3  # roughing allowance the finishing pass removes
STOCK_CELL_MM = 0.1  # stock top grid spacing
STOCK_DEPTH_MM = 3.0  # default stock bottom: this far below the surface's minimum
REFINE_STEPS = 16
STYLES = ("fusion", "camotics")
#: (x, y as fractions of the patch, sigma as a fraction of min(width, length), height as a
#: fraction of height_mm); the negative one is a dimple
BUMPS = ((0.30, 0.40, 0.22, 0.80), (0.72, 0.62, 0.16, 0.55), (0.62, 0.22, 0.10, -0.30),
         (0.15, 0.85, 0.12, 0.35))

Surface = Callable[[np.ndarray, np.ndarray], np.ndarray]


def surface_mm(x: np.ndarray, y: np.ndarray, *, width_mm: float = WIDTH_MM,
               length_mm: float = LENGTH_MM, height_mm: float = HEIGHT_MM) -> np.ndarray:
    """z of the bump field [mm] at (x, y) [mm]: Gaussian bumps (and a dimple) placed relative to
    the ``width_mm`` x ``length_mm`` patch from (0, 0), a sine ripple, about -height_mm .. 0.
    Smooth and defined everywhere (the ball samples it beyond the patch)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    size = min(width_mm, length_mm)
    z = np.full(np.broadcast(x, y).shape, -float(height_mm))
    for fx, fy, fs, fh in BUMPS:
        r2 = (x - fx * width_mm) ** 2 + (y - fy * length_mm) ** 2
        z += fh * height_mm * np.exp(-0.5 * r2 / (fs * size) ** 2)
    z += 0.06 * height_mm * np.sin(2 * np.pi * x / (0.35 * width_mm)) * np.cos(
        2 * np.pi * y / (0.5 * length_mm))
    return z


def scallop_height_mm(radius_mm: float, stepover_mm: float) -> float:
    """Cusp height [mm] a ball of ``radius_mm`` leaves between passes ``stepover_mm`` apart on a
    flat area: R - sqrt(R^2 - (stepover/2)^2)."""
    half = 0.5 * stepover_mm
    if not 0 <= half <= radius_mm:
        raise ValueError("the step-over must be between 0 and the ball's diameter")
    return radius_mm - math.sqrt(radius_mm ** 2 - half ** 2)


def disc_samples(radius_mm: float, spacing_frac: float = SPACING_FRAC) -> np.ndarray:
    """Offsets (u, v) [mm] sampling the disc of ``radius_mm``: a square grid of spacing
    ``spacing_frac * R`` through the centre, plus the rim at the same spacing; shape (k, 2)."""
    h = spacing_frac * radius_mm
    n = int(math.floor(1.0 / spacing_frac))
    g = np.arange(-n, n + 1) * h
    u, v = np.meshgrid(g, g)
    inside = u ** 2 + v ** 2 <= radius_mm ** 2
    a = np.linspace(0.0, 2 * np.pi, int(math.ceil(2 * np.pi / spacing_frac)), endpoint=False)
    rim = radius_mm * np.column_stack([np.cos(a), np.sin(a)])
    return np.vstack([np.column_stack([u[inside], v[inside]]), rim])


def _lift(surface: Surface, x, y, u, v, radius_mm: float) -> np.ndarray:
    """Tip height at which the ball's point over offset (u, v) touches f there; (u, v) outside
    the disc are first pulled radially onto its rim."""
    rho = np.hypot(u, v)
    scale = np.where(rho > radius_mm, radius_mm / np.maximum(rho, 1e-300), 1.0)
    u, v = u * scale, v * scale
    gap = np.sqrt(np.maximum(radius_mm ** 2 - u * u - v * v, 0.0))
    return surface(x + u, y + v) - radius_mm + gap


def _drop_chunk(surface: Surface, x, y, radius_mm: float, disc: np.ndarray, h: float,
                refine: int) -> np.ndarray:
    """:func:`drop_ball_tip_mm` for one chunk of points (1-D arrays)."""
    lift = _lift(surface, x[:, None], y[:, None], disc[None, :, 0], disc[None, :, 1], radius_mm)
    best = np.argmax(lift, axis=1)
    z = lift[np.arange(x.size), best]
    u, v = disc[best, 0].copy(), disc[best, 1].copy()
    k = np.arange(-2, 3, dtype=float)
    du, dv = (a.ravel() for a in np.meshgrid(k, k))
    s = 0.5 * h
    for _ in range(refine):  # pattern search: 5 x 5 stencil, step halved each time
        cu, cv = u[:, None] + s * du, v[:, None] + s * dv
        rho = np.hypot(cu, cv)
        scale = np.where(rho > radius_mm, radius_mm / np.maximum(rho, 1e-300), 1.0)
        cu, cv = cu * scale, cv * scale
        val = _lift(surface, x[:, None], y[:, None], cu, cv, radius_mm)
        j = np.argmax(val, axis=1)
        rows = np.arange(x.size)
        better = val[rows, j] > z
        z = np.where(better, val[rows, j], z)
        u = np.where(better, cu[rows, j], u)
        v = np.where(better, cv[rows, j], v)
        s *= 0.5
    return z


def drop_ball_tip_mm(x, y, radius_mm: float, surface: Surface | None = None, *,
                     spacing_frac: float = SPACING_FRAC, refine: int = REFINE_STEPS,
                     max_elements: int = 2_000_000) -> np.ndarray:
    """Tip z [mm] of a ball of ``radius_mm`` dropped onto ``surface`` (default
    :func:`surface_mm`) over each (x, y): the max over the disc of f(x+u, y+v) - R +
    sqrt(R^2 - u^2 - v^2), the disc sampled by :func:`disc_samples` then refined by ``refine``
    halvings of a local 5 x 5 search (vectorised; points taken in chunks of ``max_elements``
    samples). Same shape as ``np.broadcast(x, y)``."""
    if not radius_mm > 0:
        raise ValueError("radius_mm must be > 0")
    surface = surface_mm if surface is None else surface
    xb, yb = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    xf, yf = xb.ravel(), yb.ravel()
    disc = disc_samples(radius_mm, spacing_frac)
    chunk = max(1, max_elements // len(disc))
    out = np.empty(xf.size)
    for i in range(0, xf.size, chunk):
        sl = slice(i, i + chunk)
        out[sl] = _drop_chunk(surface, xf[sl], yf[sl], radius_mm, disc,
                              spacing_frac * radius_mm, refine)
    return out.reshape(xb.shape)


def raster_grid(width_mm: float, length_mm: float, step_mm: float,
                stepover_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Row points xs and row positions ys [mm]: 0, step, ... up to ``width_mm`` and 0,
    stepover, ... up to ``length_mm`` (each to the nearest whole number of steps)."""
    if not (step_mm > 0 and stepover_mm > 0 and width_mm > 0 and length_mm >= 0):
        raise ValueError("steps and width must be > 0, length >= 0")
    xs = np.arange(int(round(width_mm / step_mm)) + 1) * step_mm
    ys = np.arange(int(round(length_mm / stepover_mm)) + 1) * stepover_mm
    return xs, ys


def _num(v: float) -> str:
    """A size as Fusion writes it: ``2.``, ``3.175``, ``1.5875``."""
    return f"{v:.4f}".rstrip("0")


def tool_comment(diameter_mm: float, z_min_mm: float, style: str) -> str:
    """The tool comment line in ``style`` (``fusion`` or ``camotics``)."""
    if style == "fusion":
        return (f"(T1 D={_num(diameter_mm)} CR={_num(diameter_mm / 2)} - "
                f"ZMIN={_num(z_min_mm)} - ball end mill)")
    if style == "camotics":
        d = f"{diameter_mm:g}"
        return f"(T1 D{d} ;{d}mm ball end mill)"
    raise ValueError(f"style must be one of {STYLES}")


def _header(style: str, diameter_mm: float, z_min: float, title: str,
            rpm: float = SPINDLE_RPM) -> list[str]:
    """Lines before the approach."""
    tool = tool_comment(diameter_mm, z_min, style)
    if style == "fusion":
        return ["%", f"O2802 ({title})", tool, "G21 G90 G17", "G0 G40 G49 G80", "M6 T1",
                f"S{rpm:g} M3"]
    return [f"({title})", tool, "G21", "G90", "G17", "M6 T1", f"S{rpm:g} M3"]


def _ceil4(z: np.ndarray) -> np.ndarray:
    """z rounded up to 4 decimals (a written tip is never below the computed one)."""
    return np.ceil(np.round(z * 1e4, 6)) / 1e4


@dataclass(frozen=True)
class Raster:
    """What :func:`program_text` writes: the ball, the patch and its surface, the raster's
    spacing, the tool comment style, the feeds [mm/min], the spindle speed and the disc
    sampling of :func:`drop_ball_tip_mm`."""

    ball_mm: float = BALL_MM
    width_mm: float = WIDTH_MM
    length_mm: float = LENGTH_MM
    height_mm: float = HEIGHT_MM
    step_mm: float = STEP_MM
    stepover_mm: float = STEP_OVER_MM
    style: str = "fusion"
    feed_mm_min: float = FEED_MM_MIN
    plunge_mm_min: float = PLUNGE_MM_MIN
    rpm: float = SPINDLE_RPM
    spacing_frac: float = SPACING_FRAC


def program_text(spec: Raster | None = None, **fields) -> str:
    """The program: a zigzag raster of len(ys) rows of len(xs) points (:func:`raster_grid`)
    over :func:`surface_mm` of the patch, the tip heights by :func:`drop_ball_tip_mm`
    (``fields`` replace those of ``spec``, default :class:`Raster`)."""
    job = dataclasses.replace(spec or Raster(), **fields)
    ball_mm, width_mm, length_mm, height_mm = (job.ball_mm, job.width_mm, job.length_mm,
                                               job.height_mm)
    step_mm, stepover_mm, style = job.step_mm, job.stepover_mm, job.style
    feed_mm_min, plunge_mm_min, spacing_frac = (job.feed_mm_min, job.plunge_mm_min,
                                                job.spacing_frac)
    if style not in STYLES:
        raise ValueError(f"style must be one of {STYLES}")
    radius = 0.5 * ball_mm
    xs, ys = raster_grid(width_mm, length_mm, step_mm, stepover_mm)
    surface = functools.partial(surface_mm, width_mm=width_mm, length_mm=length_mm,
                                height_mm=height_mm)
    gx, gy = np.meshgrid(xs, ys)
    z = _ceil4(drop_ball_tip_mm(gx, gy, radius, surface, spacing_frac=spacing_frac))
    clear = max(CLEARANCE_MM, math.ceil(float(z.max())) + 2.0)
    body: list[str] = []
    for r, y in enumerate(ys):
        idx = np.arange(xs.size) if r % 2 == 0 else np.arange(xs.size)[::-1]
        body += [f"G1 X{xs[i]:.4f} Y{y:.4f} Z{z[r, i]:.4f}" for i in idx]
    body[1] += f" F{feed_mm_min:.0f}."  # body[0] is where the plunge ends
    title = (f"BALLNOSE RASTER {ys.size} ROWS X {xs.size} PTS, BALL D{ball_mm:g} MM, "
             f"SCALLOP {scallop_height_mm(radius, stepover_mm):.4f} MM")
    z0 = z[0, 0]
    head = _header(style, ball_mm, float(z.min()), title, job.rpm) + [
        f"G0 X{xs[0]:.4f} Y{ys[0]:.4f}",
        f"G0 Z{clear:.4f}",
        f"G1 Z{z0 + 1.0:.4f} F{plunge_mm_min:.0f}.",
        f"G1 Z{z0:.4f}",
    ]
    tail = [f"G0 Z{clear:.4f}", "M5", "M30"] + (["%"] if style == "fusion" else [])
    return "\n".join(head + body[1:] + tail) + "\n"


def stock_grid(width_mm: float, length_mm: float, margin_mm: float,
               cell_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex positions xs, ys [mm] of the stock's top grid: [-margin, width + margin] and
    [-margin, length + margin] in equal steps of at most ``cell_mm`` (both ends exact)."""
    if not (cell_mm > 0 and margin_mm >= 0 and width_mm > 0 and length_mm >= 0):
        raise ValueError("cell_mm and width_mm must be > 0, margin_mm and length_mm >= 0")
    out = []
    for span in (width_mm, length_mm):
        lo, hi = -margin_mm, span + margin_mm
        n = max(1, math.ceil((hi - lo) / cell_mm - 1e-9))
        out.append(np.linspace(lo, hi, n + 1))
    return out[0], out[1]


def _boundary_loop(nx: int, ny: int) -> np.ndarray:
    """Indices ``i * ny + j`` of the boundary vertices of an nx x ny vertex grid (i along x),
    once each, counter-clockwise seen from +z, starting at (0, 0)."""
    i = np.concatenate([np.arange(nx - 1), np.full(ny - 1, nx - 1),
                        np.arange(nx - 1, 0, -1), np.zeros(ny - 1, dtype=int)])
    j = np.concatenate([np.zeros(nx - 1, dtype=int), np.arange(ny - 1),
                        np.full(nx - 1, ny - 1), np.arange(ny - 1, 0, -1)])
    return i * ny + j


def height_field_solid(xs: np.ndarray, ys: np.ndarray, top: np.ndarray,
                       bottom: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and faces (m, 3) of the closed solid between the height field ``top``
    (len(xs) x len(ys), indexed [i, j] = (xs[i], ys[j])) and the plane z = ``bottom``,
    every face counter-clockwise seen from outside: the top grid (two triangles a cell), four
    walls (a strip of two triangles per boundary edge, down to a copy of the boundary at the
    bottom) and the bottom (a fan from its centre to the boundary)."""
    nx, ny = xs.size, ys.size
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    verts = [np.column_stack([gx.ravel(), gy.ravel(), np.asarray(top, float).ravel()])]
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b, c, d = a + ny, a + ny + 1, a + 1  # (i+1, j), (i+1, j+1), (i, j+1): CCW from above
    faces = [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
    loop = _boundary_loop(nx, ny)
    p_top, q_top = loop, np.roll(loop, -1)
    p_bot = nx * ny + np.arange(loop.size)
    q_bot = np.roll(p_bot, -1)
    centre = nx * ny + loop.size
    verts.append(np.column_stack([verts[0][loop, :2], np.full(loop.size, float(bottom))]))
    verts.append([[0.5 * (xs[0] + xs[-1]), 0.5 * (ys[0] + ys[-1]), float(bottom)]])
    faces += [np.column_stack([p_top, p_bot, q_bot]), np.column_stack([p_top, q_bot, q_top]),
              np.column_stack([np.full(loop.size, centre), q_bot, p_bot])]
    return np.vstack(verts), np.vstack(faces)


def roughed_stock_stl(path: str | Path, *, width_mm: float, length_mm: float,
                      height_mm: float, allowance_mm: float, margin_mm: float,
                      bottom_mm: float, cell_mm: float) -> trimesh.Trimesh:
    """Write the stock a finishing raster of :func:`program_text` (same width, length and
    height) cuts, as a closed, outward-oriented binary STL [mm], and return its mesh: the
    solid x in [-margin, width + margin], y in [-margin, length + margin],
    ``bottom_mm`` <= z <= f(x, y) + ``allowance_mm`` (f = :func:`surface_mm`), its top
    piecewise linear on the :func:`stock_grid` of ``cell_mm``. ValueError when the top
    is not above the bottom everywhere; RuntimeError if the mesh is not a closed solid."""
    xs, ys = stock_grid(width_mm, length_mm, margin_mm, cell_mm)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    top = surface_mm(gx, gy, width_mm=width_mm, length_mm=length_mm,
                     height_mm=height_mm) + allowance_mm
    if not (math.isfinite(bottom_mm) and float(top.min()) > bottom_mm):
        raise ValueError(f"the stock bottom {bottom_mm:g} mm must lie below its top, "
                         f"lowest {float(top.min()):.4f} mm")
    verts, faces = height_field_solid(xs, ys, top, bottom_mm)
    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        raise RuntimeError("the stock mesh is not a closed, outward-oriented solid")
    mesh.export(str(path), file_type="stl")  # binary
    return mesh


def _write_stock(a: argparse.Namespace) -> None:
    """The ``--stock-stl`` part of :func:`main` (defaults filled in here)."""
    radius = 0.5 * a.ball_mm
    margin = radius + 1.0 if a.margin_mm is None else a.margin_mm
    size = dict(width_mm=a.width_mm, length_mm=a.length_mm, height_mm=a.height_mm)
    bottom = a.stock_bottom_mm
    if bottom is None:
        gx, gy = np.meshgrid(*stock_grid(a.width_mm, a.length_mm, margin, a.stock_cell_mm),
                             indexing="ij")
        bottom = float(surface_mm(gx, gy, **size).min()) - STOCK_DEPTH_MM
    xs, ys = raster_grid(a.width_mm, a.length_mm, a.step_mm, a.stepover_mm)
    reach = max(xs[-1] - a.width_mm, ys[-1] - a.length_mm, 0.0) + radius
    if margin < reach:
        print(f"note: margin {margin:g} mm < {reach:g} mm: the ball overhangs the stock's edge")
    mesh = roughed_stock_stl(a.stock_stl, allowance_mm=a.allowance_mm, margin_mm=margin,
                             bottom_mm=bottom, cell_mm=a.stock_cell_mm, **size)
    lo, hi = mesh.bounds
    print(f"wrote stock {a.stock_stl}: {len(mesh.faces)} triangles, "
          f"{a.stock_stl.stat().st_size} bytes, x {lo[0]:g}..{hi[0]:g} y {lo[1]:g}..{hi[1]:g} "
          f"z {lo[2]:.4f}..{hi[2]:.4f} mm, volume {mesh.volume:.2f} mm^3")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path, help="the program file (.nc)")
    p.add_argument("--ball-mm", type=float, default=BALL_MM, help="ball diameter [mm]")
    p.add_argument("--width-mm", type=float, default=WIDTH_MM, help="patch along X [mm]")
    p.add_argument("--length-mm", type=float, default=LENGTH_MM, help="patch along Y [mm]")
    p.add_argument("--height-mm", type=float, default=HEIGHT_MM, help="bump scale [mm]")
    p.add_argument("--step-mm", type=float, default=STEP_MM, help="point spacing [mm]")
    p.add_argument("--stepover-mm", type=float, default=STEP_OVER_MM, help="row spacing [mm]")
    p.add_argument("--style", choices=STYLES, default="fusion", help="tool comment style")
    p.add_argument("--feed", type=float, default=FEED_MM_MIN, help="feed [mm/min]")
    p.add_argument("--plunge-feed", type=float, default=PLUNGE_MM_MIN, help="[mm/min]")
    p.add_argument("--rpm", type=float, default=SPINDLE_RPM, help="spindle speed S [rev/min]")
    p.add_argument("--spacing-frac", type=float, default=SPACING_FRAC,
                   help="disc sampling spacing / ball radius")
    p.add_argument("--stock-stl", type=Path, help="also write the roughed stock (STL, mm)")
    p.add_argument("--allowance-mm", type=float, default=ALLOWANCE_MM,
                   help="stock above the surface [mm]")
    p.add_argument("--margin-mm", type=float, default=None,
                   help="stock beyond the patch on each side [mm] (default: ball radius + 1)")
    p.add_argument("--stock-bottom-mm", type=float, default=None,
                   help=f"stock bottom z [mm] (default: surface minimum - {STOCK_DEPTH_MM:g})")
    p.add_argument("--stock-cell-mm", type=float, default=STOCK_CELL_MM,
                   help="stock top grid spacing [mm]")
    a = p.parse_args(argv)
    text = program_text(Raster(
        ball_mm=a.ball_mm, width_mm=a.width_mm, length_mm=a.length_mm, height_mm=a.height_mm,
        step_mm=a.step_mm, stepover_mm=a.stepover_mm, style=a.style, feed_mm_min=a.feed,
        plunge_mm_min=a.plunge_feed, rpm=a.rpm, spacing_frac=a.spacing_frac))
    a.out.write_text(text, encoding="ascii")
    h = scallop_height_mm(0.5 * a.ball_mm, a.stepover_mm)
    print(f"wrote {text.count(chr(10))} lines to {a.out}; flat-area scallop {h:.4f} mm")
    if a.stock_stl is not None:
        _write_stock(a)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
