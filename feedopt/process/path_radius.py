"""Is the engagement model meaningful where the path turns? Path radius vs cutter radius.

The engagement models of :mod:`feedopt.process.engagement` assume every point of the cutter
moves with the feed of its centre (a straight cut). On a path of radius r the cutter edge on
the inside of the turn moves with ``v (1 - R / r)`` (R the cutter radius): below r = R the
inner flutes move backwards and the chip-thickness model (``h = c sin(phi)``) is wrong on the
inside; below r = R/2 a quarter of the cutter diameter moves backwards and the model says
nothing useful. Until the stock model computes the engagement (issue 12), feedopt warns
below R and refuses below R/2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from feedopt.errors import InputError
from feedopt.units import MM

if TYPE_CHECKING:
    from feedopt.geometry.path import PathPoints

#: Below this fraction of the cutter radius the straight-cut engagement model is refused.
REFUSE_BELOW = 0.5


def check_path_radius(points: PathPoints, segment_names: list[str], tool_radius: float,
                      cutting: np.ndarray | None = None,
                      tool_axis: np.ndarray | None = None, refuse: bool = True) -> list[str]:
    """Warnings for path radii below the cutter radius; InputError below ``REFUSE_BELOW`` R.

    Parameters
    ----------
    points : the sampled path: arc length ``s`` [m], unit ``tangent``, ``curvature`` vector
        [1/m] and ``segment`` index of each sample
    segment_names : a readable name per segment
    tool_radius : cutter radius R [m]
    cutting : (n,) samples where the tool cuts (default: all); the others are not checked
    tool_axis : (3,) tool axis, or (n, 3) one per sample: then the radius is that of the
        path projected on the plane across the axis, |T_h x K_h| / |T_h|^3 (T_h, K_h the
        projected tangent and curvature vector), the turn the cutter sees; a path bending up
        out of the cut (a retract) does not turn there.
    refuse : False (a G-code program, whose sharp corners are the programmer's): warn below
        R/2 as well instead of refusing
    """
    s, segment, tangent = points.s, points.segment, points.tangent
    curvature = np.asarray(points.curvature, dtype=float)
    if tool_axis is not None and np.ndim(tool_axis) == 2:  # a five-axis path's, per sample
        axis = np.asarray(tool_axis, dtype=float)
        axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
        th = tangent - np.einsum("ij,ij->i", tangent, axis)[:, None] * axis
        kh = curvature - np.einsum("ij,ij->i", curvature, axis)[:, None] * axis
    elif tool_axis is not None:
        axis = np.asarray(tool_axis, dtype=float) / np.linalg.norm(tool_axis)
        th = tangent - np.outer(tangent @ axis, axis)
        kh = curvature - np.outer(curvature @ axis, axis)
    if tool_axis is not None:
        speed = np.linalg.norm(th, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            kappa = np.where(speed > 1e-6,
                             np.linalg.norm(np.cross(th, kh), axis=1) / speed**3, 0.0)
    else:
        kappa = np.linalg.norm(curvature, axis=1)
    if cutting is not None:
        kappa = np.where(cutting, kappa, 0.0)
    tight = kappa * tool_radius > 1.0
    if not np.any(tight):
        return []
    i = int(np.argmax(kappa))
    r = 1.0 / kappa[i]
    where = (f"{segment_names[int(segment[i])]} at s = {s[i] / MM:.2f} mm "
             f"(sample {i})")
    # Stretches of consecutive tight samples, for the count of places.
    places = int(np.count_nonzero(np.diff(tight.astype(np.int8)) == 1) + tight[0])
    numbers = (f"the tightest path radius is {r / MM:.3g} mm, {where}, for a cutter radius of "
               f"{tool_radius / MM:.4g} mm")
    if r < REFUSE_BELOW * tool_radius and not refuse:
        return [f"{numbers} ({places} place(s) tighter than the cutter): the program turns "
                "sharply in the material there and the stated straight-cut engagement does not "
                "describe the cutter going round the corner; feeds there are approximate"]
    if r < REFUSE_BELOW * tool_radius:
        raise InputError(
            f"{numbers}: below half the cutter radius a quarter of the cutter moves against the "
            "feed and the straight-cut engagement model is meaningless there; use a blend of at "
            f"least {tool_radius / MM:.4g} mm (path.blend_size_mm) or a coarser path")
    return [f"{numbers} ({places} place(s) tighter than the cutter): the inner flutes move "
            "backwards there and the straight-cut engagement model over-predicts the chip on "
            f"the inside; feeds there are approximate (a blend of at least {tool_radius / MM:.4g}"
            " mm avoids it)"]
