"""The stock stage of a run: the engagement of every sample from the material it meets.

When a scenario has ``stock:``, :func:`engagement_from_stock` builds the Z-map
(:mod:`feedopt.process.stock`: a box, or a closed mesh), sweeps the scenario's end mill along
the sampled path in order and hands the force model the engagement the material gives
(entry/exit angles and axial depth per sample; air samples carry no force). On a G-code
program it also refuses what a CNC would crash on: a rapid whose swept volume meets material
(the volume the cutter sweeps over the step, :attr:`StockEngagement.swept_depth`: a G0 straight
up out of a bore is no crash, a G0 sideways or down through material is), and a plunge deeper
than the flutes, naming the line. A plunge straight down (G1 along -Z) whose bottom cuts
material (:attr:`StockEngagement.bottom_depth`) is a full plunge of the end edges
(``Engagement.plunge = 1``, :mod:`feedopt.process.plunge`), its footprint taken as full.
Rapids carry no engagement (their swept volume meets none, or the run is refused).

A path that cuts no material at any sample is refused (the stock is elsewhere, or the mesh is
in other units: the message gives both extents in mm) unless ``stock.air_cut`` says an air cut
is meant; then it is a warning. A run that plans only air is a run of nothing the user asked
for, and exit 0 with a warning among others is easily missed, hence the error by default.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.plunge import check_plunge_depth
from feedopt.process.stock import FlatEndMill, StockEngagement, ZMap, sweep
from feedopt.process.tool import Tool, wider_above_tip
from feedopt.units import MM

# Material thinner than this in a swept volume is no contact (as the sweep's material
# threshold, :data:`feedopt.process.stock_sweep.MIN_DEPTH`).
_MIN_DEPTH = 1e-6


@dataclass(frozen=True, eq=False)
class MaterialAlongPath:
    """The stock before the run, what the sweep found at every sample, the stock after."""

    before: ZMap
    after: ZMap
    found: StockEngagement
    warnings: tuple[str, ...] = ()

    @property
    def removed_volume(self) -> float:
        """Material removed by the whole path [m^3]."""
        return self.before.volume() - self.after.volume()


def build_stock(section, resolve: Callable[[str, str], Path]) -> ZMap:
    """The Z-map of a scenario's ``stock`` section (mm -> m; a mesh in ``stock.units``),
    bounded in size (:func:`~feedopt.process.stock.grid_shape`) before anything is allocated."""
    cell = section.cell_mm * MM
    if section.box_mm is not None:
        x0, y0, z0, x1, y1, z1 = (v * MM for v in section.box_mm)
        return ZMap.box(x0, x1, y0, y1, z0, z1, cell=cell,
                        where=f"stock.box_mm {list(section.box_mm)} (mm)")
    units = section.units or "mm"
    file = resolve(section.mesh, "stock.mesh (STL)")
    return ZMap.from_mesh(file, cell, scale=MM if units == "mm" else 1.0,
                          where=f"stock.mesh {file} (coordinates read in {units}: "
                                f"stock.units)")


def _span(lo: np.ndarray, hi: np.ndarray) -> str:
    return ", ".join(f"{a} {lo[k] / MM:.6g}..{hi[k] / MM:.6g}" for k, a in enumerate("xyz"))


def apart_text(stock: ZMap, positions: np.ndarray, radius: float) -> str | None:
    """Why the tool along ``positions`` (tool tips in W [m]) cannot meet ``stock`` at all
    (their boxes do not overlap), with both extents in mm; None when the boxes overlap."""
    nx, ny = stock.shape
    s_lo = np.array([*stock.origin, stock.bottom])
    s_hi = np.array([stock.origin[0] + nx * stock.cell, stock.origin[1] + ny * stock.cell,
                     float(stock.heights.max())])
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    widen = np.array([radius, radius, 0.0])
    p_lo, p_hi = p.min(axis=0) - widen, p.max(axis=0) + widen
    if np.all(p_lo[:2] < s_hi[:2]) and np.all(p_hi[:2] > s_lo[:2]) and p_lo[2] < s_hi[2]:
        return None
    why = ("the tool tip stays at or above the stock's top" if np.all(p_lo[:2] < s_hi[:2])
           and np.all(p_hi[:2] > s_lo[:2]) else "they do not overlap in x and y")
    return (f"{why}: the path (tool tip, x and y widened by the tool radius "
            f"{radius / MM:g} mm) spans {_span(p_lo, p_hi)} mm, the stock {_span(s_lo, s_hi)} "
            "mm (both in the workpiece frame W)")


def check_stock(section, resolve: Callable[[str, str], Path], tool: Tool,
                positions: np.ndarray) -> tuple[ZMap, tuple[str, ...]]:
    """What ``feedopt validate`` checks of a ``stock`` section without sweeping: the stock
    builds (bounded, the mesh read and checked) and, unless stock.air_cut, the path's tool
    tips ``positions`` (W [m]) come near it (InputError as a run gives). Returns the stock and
    the warnings a run would give about it before sweeping (a mesh that looks like metres)."""
    stock = build_stock(section, resolve)
    apart = apart_text(stock, positions, 0.5 * tool.diameter)
    if apart is not None and not section.air_cut:
        raise InputError(f"stock: the path cannot cut the stock: {apart}. Place the stock "
                         "where the path cuts, or set stock.air_cut: true if an air cut is meant")
    return stock, _units_note(section, stock)


def _units_note(section, stock: ZMap) -> tuple[str, ...]:
    """A warning when a mesh read in mm is less than 2 mm across in every direction (a mesh
    in metres read as mm: a 2 m stock would look 2 mm large)."""
    if section.mesh is None or (section.units or "mm") != "mm":
        return ()
    nx, ny = stock.shape
    size = (nx * stock.cell, ny * stock.cell, float(stock.heights.max()) - stock.bottom)
    if max(size) >= 2 * MM:
        return ()
    return (f"stock.mesh is read in mm and is only {' x '.join(f'{v / MM:.3g}' for v in size)} "
            "mm: if the STL is in metres, set stock.units: m",)


def _nothing_cut(section, before: ZMap, found: StockEngagement, positions: np.ndarray,
                 radius: float) -> tuple[str, ...]:
    """Refuse (or, with stock.air_cut, warn about) a path that cuts no material at all; warn
    when stock.air_cut is set but the path cuts."""
    cutting = int(np.sum(~found.in_air | found.engagement.plunging))
    air_cut = bool(getattr(section, "air_cut", False))
    if cutting and air_cut:
        return (f"stock.air_cut is set but the path cuts material at {cutting} of "
                f"{found.in_air.size} samples; the plan includes their forces",)
    if cutting:
        return ()
    reason = apart_text(before, positions, radius) or (
        "the path passes through the stock's box but meets no material in front of the "
        "cutter (it runs in a cut-out part, or only along the tool axis)")
    text = f"stock: the path cuts no material at any of its {found.in_air.size} samples: {reason}"
    if section.mesh is not None:
        text += f"; the STL was read in {section.units or 'mm'} (stock.units)"
    if air_cut:
        return (text + "; planned as an air cut (stock.air_cut: true)",)
    raise InputError(text + ". Place the stock where the path cuts (path and stock are both in "
                     "W), or set stock.air_cut: true if an air cut is meant")


def _feed_tangents(tangents: np.ndarray) -> np.ndarray:
    """Tangents with a feed direction across the tool axis everywhere: a vertical sample
    (a plunge or retract) takes the first horizontal direction after it, where the path goes
    on (or the last before it at the end of the path)."""
    t = np.asarray(tangents, dtype=float).copy()
    flat = np.linalg.norm(t[:, :2], axis=1) > 1e-6
    if not flat.any():
        t[:, :2] = (1.0, 0.0)
        return t
    n = t.shape[0]
    idx = np.where(flat, np.arange(n), n)
    nxt = np.minimum.accumulate(idx[::-1])[::-1]
    src = np.where(nxt < n, nxt, np.flatnonzero(flat)[-1])
    t[~flat, :2] = t[src[~flat], :2]
    return t


def engagement_from_stock(section, resolve: Callable[[str, str], Path], tool: Tool, samples,
                          moves=None, source: str = "the program") -> MaterialAlongPath:
    """Sweep ``tool`` along ``samples`` (workpiece frame) through the scenario's stock.

    ``moves`` (a program's :class:`~feedopt.geometry.program_path.MoveTable`) adds the
    program checks: no rapid may meet material, no plunge may enter it.
    """
    before = build_stock(section, resolve)
    after = before.copy()
    found = sweep(after, FlatEndMill.from_tool(tool), samples.position,
                  _feed_tangents(samples.tangent), depth_step=section.depth_step_mm * MM)
    vertical = np.linalg.norm(samples.tangent[:, :2], axis=1) <= 1e-6
    plunge, air = None, vertical  # moves along the tool axis do not mill with the side edges
    if moves is not None:
        plunge, rapid = _check_program_contacts(found, moves, samples, source, tool)
        air = air | rapid  # their swept volume meets no material (else refused)
    if air.any():
        found = _without(found, air)
    if plunge is not None and plunge.any():  # ... but a plunge cuts with the end edges
        found = dataclasses.replace(found, engagement=found.engagement.with_plunge(plunge))
    warnings = _units_note(section, before)
    warnings += _nothing_cut(section, before, found, samples.position, 0.5 * tool.diameter)
    note = wider_above_tip(tool)
    warnings += () if note is None else (note + " (the stock sweep removes material within "
                                         "the tip diameter only: what the wider edge above "
                                         "cuts is left standing, and later samples meet it "
                                         "again)",)
    return MaterialAlongPath(before=before, after=after, found=found, warnings=warnings)


def _without(found: StockEngagement, drop: np.ndarray) -> StockEngagement:
    """``found`` with the samples ``drop`` in air."""
    e = found.engagement
    return dataclasses.replace(
        found,
        engagement=e.without(drop),
        intervals=found.intervals.select(~drop, renumber=False),
        in_air=found.in_air | drop,
        axial_depth=np.where(drop, 0.0, found.axial_depth),
        lateral=np.where(drop[:, None], np.nan, found.lateral))


def _check_program_contacts(found: StockEngagement, moves, samples, source: str,
                            tool: Tool) -> tuple[np.ndarray, np.ndarray]:
    """Rapids whose swept volume meets material are refused (a G0 straight up out of a bore
    is not; a G0 sideways or down through material is; a step that starts on a feed move is
    the feed move's), and plunges that meet it deeper than the flute length below its top.
    Returns the plunge column (1 where a plunge's bottom cuts
    material) and the mask of rapid samples (their swept volume meets none)."""
    move = moves.index_at(samples.s)
    cat = moves.category[move]
    rapid = cat == "rapid"
    # the step into sample i is swept at sample i: a rapid's when it starts on one too (the
    # first step of a G0 still ends the feed move before it)
    hit = rapid & np.r_[True, rapid[:-1]] & (found.swept_depth > _MIN_DEPTH)
    plunge = (cat == "plunge") & (found.bottom_depth > _MIN_DEPTH)
    deep = plunge & found.beyond_flutes
    if hit.any() and not (deep.any() and np.argmax(deep) < np.argmax(hit)):  # the first one
        i = int(np.argmax(hit))
        raise InputError(
            f"{source} {moves.label(int(move[i]))}: a rapid (G0) meets material: the cutter "
            "would crash into the stock; rapid above it or cut with G1 (at s = "
            f"{samples.s[i] / MM:.3f} mm, its swept volume cuts {found.swept_depth[i] / MM:.3g} "
            "mm of material)")
    check_plunge_depth(deep, move, moves, tool, source)
    return plunge.astype(float), rapid
