"""The stock stage of a run: the engagement of every sample from the material it meets.

When a scenario has ``stock:``, :func:`engagement_from_stock` builds the Z-map
(:mod:`feedopt.process.stock`: a box, or a closed mesh), sweeps the scenario's end mill along
the sampled path in order and hands the force model the engagement the material gives
(entry/exit angles and axial depth per sample; air samples carry no force). On a G-code
program it also refuses what the force model cannot describe and a CNC would crash on: a rapid
that meets material, and a plunge straight down into it (a drilling move), naming the line.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.stock import FlatEndMill, StockEngagement, ZMap, sweep
from feedopt.process.tool import Tool
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class MaterialAlongPath:
    """The stock before the run, what the sweep found at every sample, the stock after."""

    before: ZMap
    after: ZMap
    found: StockEngagement

    @property
    def removed_volume(self) -> float:
        """Material removed by the whole path [m^3]."""
        return self.before.volume() - self.after.volume()


def build_stock(section, resolve: Callable[[str, str], Path]) -> ZMap:
    """The Z-map of a scenario's ``stock`` section (mm -> m)."""
    cell = section.cell_mm * MM
    if section.box_mm is not None:
        x0, y0, z0, x1, y1, z1 = (v * MM for v in section.box_mm)
        return ZMap.box(x0, x1, y0, y1, z0, z1, cell=cell)
    return ZMap.from_mesh(resolve(section.mesh, "stock.mesh (STL)"), cell)


def _feed_tangents(tangents: np.ndarray) -> np.ndarray:
    """Tangents with a feed direction across the tool axis everywhere: a vertical sample
    (a plunge or retract) takes the last horizontal direction before it (or the first after)."""
    t = np.asarray(tangents, dtype=float).copy()
    flat = np.linalg.norm(t[:, :2], axis=1) > 1e-6
    if not flat.any():
        t[:, :2] = (1.0, 0.0)
        return t
    idx = np.where(flat, np.arange(t.shape[0]), -1)
    last = np.maximum.accumulate(idx)
    first = np.flatnonzero(flat)[0]
    src = np.where(last >= 0, last, first)
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
    if moves is not None:
        _check_program_contacts(found, moves, samples, source, vertical)
    if vertical.any():  # moves along the tool axis do not mill: no force (a plunge into the
        found = _without(found, vertical)  # material was refused above)
    return MaterialAlongPath(before=before, after=after, found=found)


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
                            vertical: np.ndarray) -> None:
    """Rapids across the tool axis and plunges that meet material are refused. A vertical
    rapid (a retract) is not checked: the sweep's material in front of the cutter is ahead
    along the last feed direction, not where a vertical move goes."""
    move = moves.index_at(samples.s)
    cat = moves.category[move].copy()
    cat[(cat == "rapid") & vertical & (samples.tangent[:, 2] > 0)] = "retract"
    for what, why in (("rapid", "a rapid (G0) meets material: the cutter would crash into "
                                "the stock; rapid above it or cut with G1"),
                      ("plunge", "a plunge straight down meets material: a drilling move the "
                                 "milling force model does not cover; enter by a ramp or a "
                                 "helix")):
        hit = (cat == what) & ~found.in_air
        if hit.any():
            i = int(np.argmax(hit))
            raise InputError(
                f"{source} {moves.label(int(move[i]))}: {why} (at s = {samples.s[i] / MM:.3f} "
                f"mm, {found.axial_depth[i] / MM:.3g} mm deep)")
