"""The program's own description of its tool, checked against the scenario's tool file.

CAM posts write the tool into the program as a comment (Fusion/HSM ``(T1 D=3.175 CR=0. -
ZMIN=-5. - flat end mill)``, Mastercam, CAMotics; read by :mod:`feedopt.gcode`). The force
model and the stock sweep use the scenario's tool file (teeth, helix and flute length are in
no header), so the header is a cross-check: a diameter, shape (flat, ball, bull nose, chamfer)
or corner radius that differs from the tool file's, or a drill, means the plan would be for
another cutter.
"""

from __future__ import annotations

from feedopt.errors import InputError
from feedopt.gcode.moves import ToolHeader, ToolShape
from feedopt.process.cutter import CutterShape
from feedopt.units import MM

#: Largest difference between the header's and the tool file's diameter [mm]: posts write
#: 3-4 decimals (an inch post's 0.1250 in is 3.175 mm).
DIAMETER_TOL_MM = 0.01


def header_for(headers: tuple[ToolHeader, ...], tool_number: int | None) -> ToolHeader | None:
    """The header describing ``tool_number`` (the one the program cuts with); the only header
    when the program or the header names no number; None when none applies."""
    if not headers:
        return None
    numbered = [h for h in headers if h.number is not None and h.number == tool_number]
    if numbered:
        return numbered[0]
    if len(headers) == 1 and (headers[0].number is None or tool_number is None):
        return headers[0]
    return None


#: The tool-file shapes a program comment's shape may describe.
_SHAPES = {ToolShape.FLAT: (CutterShape.FLAT,), ToolShape.BALL: (CutterShape.BALL,),
           ToolShape.BULL: (CutterShape.BULL,),
           ToolShape.CHAMFER: (CutterShape.TAPERED, CutterShape.FACE)}


def check_tool_header(header: ToolHeader | None, tool, source: str, tool_file: str) -> list[str]:
    """InputError when the program's tool comment contradicts the tool file (its shape, its
    diameter or its corner radius); a warning when it gives no diameter to compare; nothing
    when it agrees (or there is no comment).

    ``tool`` is a :class:`feedopt.process.tool.Tool` (SI units).
    """
    if header is None:
        return []
    where = f"{source} line {header.line}: tool comment ({header.text.strip()})"
    _check_shape(header, tool, where, tool_file)
    if header.diameter_mm is None:
        return [f"{where}: no diameter to compare with the tool file {tool_file}"]
    d_file = tool.diameter / MM
    if abs(header.diameter_mm - d_file) > DIAMETER_TOL_MM:
        raise InputError(
            f"{where}: the program's tool is {header.diameter_mm:g} mm across, the tool file "
            f"{tool_file} describes {d_file:g} mm: the tool path was computed for the "
            "program's cutter; use a tool file for that cutter (scenario field tool)")
    return []


def _check_shape(header: ToolHeader, tool, where: str, tool_file: str) -> None:
    """InputError when the comment names another shape or corner radius than the tool file
    (a comment of shape OTHER names none; a drill is not a milling cutter)."""
    rc_file = tool.corner_radius / MM
    rc = header.corner_radius_mm
    shape = header.shape
    if shape is ToolShape.FLAT and rc is not None and rc > 1e-9:
        shape = ToolShape.BULL  # Fusion writes "flat end mill" with CR= for a bull nose
    if shape is ToolShape.DRILL:
        raise InputError(f"{where}: the program was made for a drill; feedopt models milling "
                         "cutters (flat, ball, bull, tapered, face mills)")
    allowed = _SHAPES.get(shape)
    if shape is ToolShape.BALL and tool.corner_radius == tool.diameter / 2:
        allowed = (CutterShape.BALL, CutterShape.TAPERED)  # a tapered ball-nose is a ball
    if allowed is not None and tool.shape not in allowed:
        raise InputError(
            f"{where}: the program was made for a {shape.value}, the tool file {tool_file} "
            f"describes a {tool.shape.value} cutter (shape: {tool.shape.value}): the tool "
            "path was computed for the program's cutter; use a tool file for it (shape: "
            f"{' or '.join(s.value for s in allowed)})")
    if rc is not None and shape is not ToolShape.CHAMFER and abs(rc - rc_file) > DIAMETER_TOL_MM:
        raise InputError(
            f"{where}: the program's corner radius is {rc:g} mm, the tool file {tool_file} "
            f"has {rc_file:g} mm (corner_radius_mm; a ball-nose's is half its diameter)")


def check_program_tool(path, tool, source: str, tool_file: str) -> list[str]:
    """:func:`check_tool_header` of a program path (its ``tool_headers`` and the tool its
    cutting moves use); nothing for other paths."""
    moves = path.moves
    headers = path.tool_headers
    if moves is None or not headers:
        return []
    cutting = moves.tool[(moves.category == "cut") & (moves.tool >= 0)]
    number = int(cutting[0]) if cutting.size else None
    return check_tool_header(header_for(tuple(headers), number), tool, source, tool_file)
