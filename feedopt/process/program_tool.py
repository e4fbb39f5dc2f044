"""The program's own description of its tool, checked against the scenario's tool file.

CAM posts write the tool into the program as a comment (Fusion/HSM ``(T1 D=3.175 CR=0. -
ZMIN=-5. - flat end mill)``, Mastercam, CAMotics; read by :mod:`feedopt.gcode`). The force
model and the stock sweep use the scenario's tool file (teeth, helix and flute length are in
no header), so the header is a cross-check: a diameter that differs, or a shape feedopt does
not model (ball, bull nose, chamfer, drill), means the plan would be for another cutter.
"""

from __future__ import annotations

from feedopt.errors import InputError
from feedopt.gcode.moves import ToolHeader, ToolShape
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


def check_tool_header(header: ToolHeader | None, tool, source: str, tool_file: str) -> list[str]:
    """InputError when the program's tool comment contradicts the tool file; a warning when
    it gives no diameter to compare; nothing when it agrees (or there is no comment).

    ``tool`` is a :class:`feedopt.process.tool.Tool` (SI units).
    """
    if header is None:
        return []
    where = f"{source} line {header.line}: tool comment ({header.text.strip()})"
    if header.shape not in (ToolShape.FLAT, ToolShape.OTHER) or (
            header.corner_radius_mm is not None and header.corner_radius_mm > 1e-9):
        shape = header.shape.value
        if header.corner_radius_mm:
            shape += f" with a corner radius of {header.corner_radius_mm:g} mm"
        raise InputError(
            f"{where}: the program was made for a {shape}; feedopt models flat end mills "
            "(no corner radius) only, in the force model and in the stock: plan it with the "
            "flat end mill the tool file describes only if that is what will cut")
    if header.diameter_mm is None:
        return [f"{where}: no diameter to compare with the tool file {tool_file}"]
    d_file = tool.diameter / MM
    if abs(header.diameter_mm - d_file) > DIAMETER_TOL_MM:
        raise InputError(
            f"{where}: the program's tool is {header.diameter_mm:g} mm across, the tool file "
            f"{tool_file} describes {d_file:g} mm: the tool path was computed for the "
            "program's cutter; use a tool file for that cutter (scenario field tool)")
    return []


def check_program_tool(path, tool, source: str, tool_file: str) -> list[str]:
    """:func:`check_tool_header` of a program path (its ``tool_headers`` and the tool its
    cutting moves use); nothing for other paths."""
    moves = path.moves
    headers = getattr(path, "tool_headers", ())
    if moves is None or not headers:
        return []
    cutting = moves.tool[(moves.category == "cut") & (moves.tool >= 0)]
    number = int(cutting[0]) if cutting.size else None
    return check_tool_header(header_for(tuple(headers), number), tool, source, tool_file)
