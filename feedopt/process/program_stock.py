"""A stock made from a G-code program (``stock: {from_program: true}``).

CAM programs are written for a stock whose top is the program's Z0 (or the scenario's
``path.stock_top_mm``); when the scenario gives no stock model, the smallest box that holds
everything the program cuts is the honest guess: from the stock top down to the deepest cut,
around every sample that cuts or plunges below the top, widened by the tool radius and one
sample spacing (the path is known at the samples only). The box is stated in the console.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.tool import load_tool
from feedopt.units import MM


@dataclass(frozen=True)
class ProgramStock:
    """The box [x0, y0, z0, x1, y1, z1] in mm (workpiece frame) and the sentence saying so."""

    box_mm: tuple[float, float, float, float, float, float]
    note: str


def program_stock_box(position: np.ndarray, category: np.ndarray, stock_top: float,
                      tool_radius: float, spacing: float) -> ProgramStock:
    """The stock box of a program path.

    Parameters
    ----------
    position : (n, 3) tool-tip positions of the path samples in the workpiece frame [m]
    category : (n,) move category of each sample (``"cut"``, ``"plunge"``, ...)
    stock_top : Z of the stock's top face [m] (``path.stock_top_mm``)
    tool_radius : [m]
    spacing : sample spacing [m], added around the cut (the path between samples)

    Raises
    ------
    InputError
        No sample cuts below the stock top (nothing to cut: the top or the program is wrong).
    """
    z = position[:, 2]
    cutting = np.isin(category, ("cut", "plunge")) & (z < stock_top - 1e-9)
    if not cutting.any():
        raise InputError(
            f"stock.from_program: no cutting move of the program goes below the stock top "
            f"path.stock_top_mm = {stock_top / MM:g} mm (its lowest cutting point is at Z"
            f"{_lowest(z, category) / MM:.4g} mm): set path.stock_top_mm to the top of the "
            "stock the program was written for")
    pts = position[cutting]
    grow = tool_radius + spacing
    lo = pts[:, :2].min(axis=0) - grow
    hi = pts[:, :2].max(axis=0) + grow
    bottom = float(pts[:, 2].min())
    box = tuple(float(v) / MM for v in (lo[0], lo[1], bottom, hi[0], hi[1], stock_top))
    note = (f"stock.from_program: a box x {box[0]:.3f}..{box[3]:.3f}, y {box[1]:.3f}.."
            f"{box[4]:.3f}, z {box[2]:.3f}..{box[5]:.3f} mm (the stock top "
            "path.stock_top_mm down to the deepest cut, around the cutting moves widened by "
            f"the tool radius {tool_radius / MM:g} mm and the spacing {spacing / MM:g} mm)")
    return ProgramStock(box_mm=box, note=note)  # type: ignore[arg-type]


def _lowest(z: np.ndarray, category: np.ndarray) -> float:
    cut = np.isin(category, ("cut", "plunge"))
    return float(z[cut].min() if cut.any() else z.min())


def resolve_program_stock(scenario, tool_radius: float, samples, moves, spacing: float):
    """``scenario`` with a ``stock.from_program`` section replaced by its box
    (:func:`program_stock_box`), and the note saying so (None: nothing to replace)."""
    section = scenario.stock
    if section is None or not section.from_program or moves is None:
        return scenario, None
    category = moves.category[moves.index_at(samples.s)]
    made = program_stock_box(samples.position, category, scenario.path.stock_top_mm * MM,
                             tool_radius, spacing)
    stock = section.model_copy(update={"box_mm": list(made.box_mm), "from_program": False})
    return scenario.model_copy(update={"stock": stock}), made.note


def program_stock(scenario, resolve: Callable[[str, str], Path], samples, moves,
                  spacing: float):
    """:func:`resolve_program_stock` with the radius of the scenario's tool file
    (``resolve(relative, what)`` finds it): ``(scenario, note)``, or ``(scenario, None)``
    unchanged unless the scenario asks for ``stock.from_program``."""
    if scenario.stock is None or not scenario.stock.from_program:
        return scenario, None
    if samples.axis is not None:
        raise InputError("stock.from_program: the box made from the program follows a tool "
                         "along the workpiece's z; this path tilts the tool (its tool "
                         "vectors): give stock.box_mm or stock.mesh")
    radius = 0.5 * load_tool(resolve(scenario.tool, "tool file")).diameter
    return resolve_program_stock(scenario, radius, samples, moves, spacing)
