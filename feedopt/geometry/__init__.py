"""geometry stage of feedopt (see shared/design.md): waypoints -> Path (lines + corner blends)
parameterised by arc length, thesis 3.3 and appendix B.1."""

from feedopt.geometry.continuity import ContinuityReport, continuity_report
from feedopt.geometry.path import Path, PathPoints, Segment, build_lipb_path
from feedopt.geometry.waves import square_wave, straight_line, triangle_wave
from feedopt.geometry.waypoints import read_waypoints_csv

__all__ = [
    "ContinuityReport",
    "Path",
    "PathPoints",
    "Segment",
    "build_lipb_path",
    "continuity_report",
    "read_waypoints_csv",
    "square_wave",
    "straight_line",
    "triangle_wave",
]
