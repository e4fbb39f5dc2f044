"""geometry stage of feedopt (see shared/design.md): waypoints -> Path (lines + corner blends)
parameterised by arc length, thesis 3.3 and appendix B.1.

Blend kinds live in the registry (:mod:`feedopt.geometry.registry`); importing this package
registers the built-in ones (:mod:`feedopt.geometry.blend_kinds`) and the segment kinds of
program paths: arcs, G2 transitions and smoothed chains (:mod:`feedopt.geometry.arcs`,
:mod:`~feedopt.geometry.transitions`, :mod:`~feedopt.geometry.smoothing`);
:mod:`feedopt.geometry.program_path` turns a G-code program into a path.
"""

from feedopt.geometry import arcs, smoothing, transitions  # noqa: F401 - register kinds
from feedopt.geometry.continuity import ContinuityReport, continuity_report
from feedopt.geometry.path import Path, PathPoints, Segment, build_lipb_path
from feedopt.geometry.registry import BlendKind, blend_names, register_blend, unregister_blend
from feedopt.geometry.stage import path_from_section
from feedopt.geometry.waves import square_wave, straight_line, triangle_wave
from feedopt.geometry.waypoints import read_waypoints_csv

__all__ = [
    "BlendKind",
    "ContinuityReport",
    "Path",
    "PathPoints",
    "Segment",
    "blend_names",
    "build_lipb_path",
    "continuity_report",
    "path_from_section",
    "read_waypoints_csv",
    "register_blend",
    "square_wave",
    "straight_line",
    "triangle_wave",
    "unregister_blend",
]
