"""Reading CAM G-code programs (ISO 6983 / RS-274, 3-axis milling subset) into typed moves.

:func:`read_gcode` reads a file, :func:`parse_gcode` text; both return a :class:`Program` of
:class:`Move` s in millimetres in the work-offset frame. Anything outside the supported subset
is an :class:`~feedopt.errors.InputError` naming the line, the N number and the word.
"""

from feedopt.gcode.apt import parse_apt, read_apt
from feedopt.gcode.heidenhain import parse_heidenhain, read_heidenhain
from feedopt.gcode.interpreter import parse_gcode, read_gcode
from feedopt.gcode.moves import (
    SAME_POINT_MM,
    Move,
    MoveCategory,
    MoveKind,
    Plane,
    Program,
    Stop,
    StopKind,
    ToolHeader,
    ToolShape,
    sample_move,
)
from feedopt.gcode.resolution import MM_PER_INCH

__all__ = [
    "MM_PER_INCH",
    "SAME_POINT_MM",
    "Move",
    "MoveCategory",
    "MoveKind",
    "Plane",
    "Program",
    "Stop",
    "StopKind",
    "ToolHeader",
    "ToolShape",
    "parse_apt",
    "parse_gcode",
    "parse_heidenhain",
    "read_apt",
    "read_gcode",
    "read_heidenhain",
    "sample_move",
]
