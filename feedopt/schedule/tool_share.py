"""How much of the deflection is the tool's own bending (summary.json ``scenario.tool``).

The tool tip's compliance is the robot's and the tool's in series (their compliances add,
:func:`feedopt.schedule.stage.tip_compliance`), so under the revolution-mean force F of a
sample the tool's share of the mean deflection is ``|C_tool F| / |(C_robot + C_tool) F|``
(:func:`feedopt.process.tool_bending.tool_share`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from feedopt.process.tool_bending import compliance_matrices, tool_share
from feedopt.units import MM

#: N/m per N/um.
_PER_UM = 1e6


def tool_shape_summary(tool) -> dict:
    """The cutter's shape fields in user units."""
    return {"shape": tool.shape.value, "corner_radius_mm": tool.corner_radius / MM,
            "taper_deg": math.degrees(tool.taper)}


def tool_bending_summary(tool, model, feed: float) -> dict:
    """The tool's stiffness and its share of the mean deflection at path feed ``feed``
    [m/s] (every sample at that feed): its median over the cutting samples and at the sample
    of the largest mean deflection; ``model`` is the run's
    :class:`~feedopt.schedule.deflection.DeflectionModel` (tool included)."""
    if not tool.bends:
        return {"model": "rigid", "note": "no stickout_mm or tip_stiffness_n_per_um in the "
                "tool file: the tool's own bending is not modelled"}
    lateral, axial = tool.tip_compliance()
    out = {"model": "measured tip stiffness" if tool.tip_stiffness is not None
           else "stepped Euler-Bernoulli cantilever (flutes at 0.8 D, Kops & Vo 1990)",
           "lateral_stiffness_n_per_um": 1.0 / lateral / _PER_UM,
           "axial_stiffness_n_per_um": (1.0 / axial / _PER_UM) if axial > 0 else None,
           "stickout_mm": None if tool.stickout is None else tool.stickout / MM,
           "youngs_modulus_gpa": (None if tool.youngs_modulus is None
                                  else tool.youngs_modulus / 1e9)}
    c_tool = compliance_matrices(lateral, axial, model.frames[:, :, 2])
    robot = dataclasses.replace(model, compliance=model.compliance - c_tool)
    feeds = np.full(model.n, float(feed))
    c = feeds / model.feed_per_unit_c
    forces = _mean_forces(model, c)
    share = tool_share(robot.compliance, c_tool, forces)
    total = np.linalg.norm(np.einsum("kij,kj->ki", model.compliance, forces), axis=1)
    cutting = np.isfinite(share) & (model.engagement.exit > model.engagement.entry)
    if cutting.any():
        worst = int(np.argmax(np.where(cutting, total, -np.inf)))
        out["share_of_mean_deflection"] = {
            "median": float(np.median(share[cutting])), "at_largest": float(share[worst]),
            "feed_mm_s": float(feed) / MM}
    return out


def _mean_forces(model, c: np.ndarray) -> np.ndarray:
    """Revolution-mean force on the tool per sample, base frame (n, 3) [N]: the mean terms
    with an identity compliance."""
    unit = dataclasses.replace(model, compliance=np.broadcast_to(np.eye(3), (model.n, 3, 3)))
    a, b = unit.mean_terms(slice(0, model.n))
    return c[:, None] * a + b
