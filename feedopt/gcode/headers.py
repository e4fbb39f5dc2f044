"""Tools described in a program's comments (:class:`~feedopt.gcode.moves.ToolHeader`).

CAM posts list their tools in comments; the forms read here:

- Fusion 360 / HSM / Inventor CAM: ``(T1 D=3.175 CR=0. - ZMIN=-5. - flat end mill)``, with
  optional fields (``ID=...``, ``TAPER=118deg``, a description before ``D=``) and the type in
  any case (``FLAT END MILL``, ``bullnose end mill``, ``ball end mill``, ``chamfer mill``,
  ``drill``, ...). D, CR and ZMIN are written in the program's units.
- Mastercam, table style: ``( T1 | 1/4 FLAT ENDMILL | H1 | D1 | TOOL DIA. - .25 )``. The
  ``D1`` field is the cutter-compensation register, not a diameter; the diameter is the
  ``TOOL DIA. - x`` field (program units) or else the number the tool's name starts with.
- Mastercam, line style: ``( 1/16 FLAT ENDMILL TOOL - 1 DIA. OFF. - 1 LEN. - 1 DIA. -
  .0625)``: the number after ``TOOL -``, the diameter after the last ``DIA. -``.
- Other ``(T1 ...)`` comments (CAMotics, LinuxCNC tool-table style, hand-written):
  ``(T1 D0.125 ;1/8 ball end mill)``, ``(T3 6mm ball end mill)``: a ``D<number>`` word or
  the number the description starts with, and the shape named in it; such a comment is only
  taken as a tool when it gives a diameter or names a shape.
- FreeCAD: ``(TC: 5mm Endmill)`` (no tool number).

Units: numbers written without a unit are in the program's units (G20: inch, else mm; the
program's units, not those in force at the comment's line: posts write the tool list before
G20/G21); a fraction (``1/4``) or a number followed by ``"``, ``in`` or ``inch`` is in inches,
one followed by ``mm`` in millimetres. Nothing here raises: a comment that cannot be read as a
tool is not a tool.
"""

from __future__ import annotations

import math
import re

from feedopt.gcode.moves import ToolHeader, ToolShape

MM_PER_INCH = 25.4
#: Largest diameter, corner radius or |ZMIN| taken from a comment [mm]; beyond: not a tool.
MAX_TOOL_MM = 1e5

_NUM = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)"
_T_FIRST = re.compile(r"^\s*T\s*(\d{1,9})(?=$|[\s|,:;=(-])", re.I)
_FIELD = {name: re.compile(rf"(?<![A-Z]){name}\s*=\s*({_NUM})", re.I)
          for name in ("D", "CR", "ZMIN")}
_MC_LINE_TOOL = re.compile(r"\bTOOL\s*-\s*(\d{1,9})\b", re.I)
_MC_DIA = re.compile(rf"\bDIA\.?\s*-\s*({_NUM})", re.I)
_MC_DIA_OFF = re.compile(r"\bDIA\.?\s*OFF\.?", re.I)
_D_WORD = re.compile(rf"(?:^|\s)D\s*({_NUM})(?=\s|$|;)", re.I)
_SIZE = re.compile(rf"^\s*(?:(\d+)\s*/\s*(\d+)|({_NUM}))\s*(\"|mm\b|inch\b|in\b)?"
                   r"(?![\w.])(?!\s*(?:fl(?:utes?)?|teeth|z)\b)", re.I)
_FREECAD = re.compile(r"^\s*TC\s*:\s*(.*)$", re.I)
_SHAPES: tuple[tuple[re.Pattern[str], ToolShape], ...] = (
    (re.compile(r"\bball", re.I), ToolShape.BALL),
    (re.compile(r"\bbull|corner\s*radius|toroid", re.I), ToolShape.BULL),
    (re.compile(r"chamfer", re.I), ToolShape.CHAMFER),
    (re.compile(r"drill", re.I), ToolShape.DRILL),
    (re.compile(r"\bflat|square\s*end", re.I), ToolShape.FLAT),
)


def shape_named(text: str) -> ToolShape:
    """The cutter shape a tool description names (:attr:`ToolShape.OTHER` if none)."""
    for pattern, shape in _SHAPES:
        if pattern.search(text):
            return shape
    return ToolShape.OTHER


def _length(text: str | None, mm_per_unit: float, *, signed: bool = False) -> float | None:
    """``text`` (a number in program units) in mm; None if absent, out of range or (unless
    ``signed``) not > 0."""
    if text is None:
        return None
    try:
        value = float(text) * mm_per_unit
    except ValueError:
        return None
    if not math.isfinite(value) or abs(value) > MAX_TOOL_MM or (not signed and value <= 0):
        return None
    return value


def size_in_name(name: str, mm_per_unit: float) -> float | None:
    """The diameter a tool's name starts with (``1/4 FLAT ENDMILL``: 6.35 mm, ``6mm ball``,
    ``3. FLAT ENDMILL`` in program units) [mm], None if it starts with no size."""
    m = _SIZE.match(name)
    if m is None:
        return None
    whole, den, number, unit = m.groups()
    unit = (unit or "").lower()
    if whole is not None:
        if int(den) == 0:
            return None
        return _length(str(int(whole) / int(den)), 1.0 if unit == "mm" else MM_PER_INCH)
    scale = {"mm": 1.0, '"': MM_PER_INCH, "in": MM_PER_INCH, "inch": MM_PER_INCH}
    return _length(number, scale.get(unit, mm_per_unit))


def _fusion(text: str, number: int, line: int, mm_per_unit: float) -> ToolHeader:
    """``T1 D=3.175 CR=0. - ZMIN=-5. - flat end mill``: fields by name, type last."""
    found = {k: p.search(text) for k, p in _FIELD.items()}
    fields = {k: (m.group(1) if m else None) for k, m in found.items()}
    parts = [p.strip() for p in re.split(r"\s+-\s+", text)]
    kind = parts[-1] if len(parts) > 1 and "=" not in parts[-1] else ""
    return ToolHeader(number=number, diameter_mm=_length(fields["D"], mm_per_unit),
                      corner_radius_mm=_length(fields["CR"], mm_per_unit, signed=True),
                      shape=shape_named(kind), z_min_mm=_length(fields["ZMIN"], mm_per_unit,
                                                                signed=True),
                      line=line, text=text)


def _mastercam_table(text: str, number: int, line: int, mm_per_unit: float) -> ToolHeader:
    """``T1 | 1/4 FLAT ENDMILL | H1 | D1 | TOOL DIA. - .25``."""
    fields = [f.strip() for f in text.split("|")]
    name = fields[1] if len(fields) > 1 else ""
    dia = None
    for f in fields[2:]:
        m = _MC_DIA.search(f)
        if m and not _MC_DIA_OFF.search(f):
            dia = _length(m.group(1), mm_per_unit)
    if dia is None:
        dia = size_in_name(name, mm_per_unit)
    return ToolHeader(number=number, diameter_mm=dia, corner_radius_mm=None,
                      shape=shape_named(name), z_min_mm=None, line=line, text=text)


def _mastercam_line(text: str, line: int, mm_per_unit: float) -> ToolHeader | None:
    """``1/16 FLAT ENDMILL TOOL - 1 DIA. OFF. - 1 LEN. - 1 DIA. - .0625``."""
    m = _MC_LINE_TOOL.search(text)
    if m is None or not _MC_DIA_OFF.search(text):
        return None
    dias = [d for d in _MC_DIA.finditer(text) if not _MC_DIA_OFF.match(text, d.start())]
    dia = _length(dias[-1].group(1), mm_per_unit) if dias else None
    name = text[:m.start()].strip() or text[m.end():_MC_DIA_OFF.search(text).start()].strip()
    if dia is None:
        dia = size_in_name(name, mm_per_unit)
    return ToolHeader(number=int(m.group(1)), diameter_mm=dia, corner_radius_mm=None,
                      shape=shape_named(name), z_min_mm=None, line=line, text=text)


def _generic(text: str, number: int | None, rest: str, line: int,
             mm_per_unit: float) -> ToolHeader | None:
    """``T1 D0.125 ;1/8 end mill``, ``T3 6mm ball end mill`` or ``T1 D2 CR=0.3 ;bull nose``:
    kept when it gives a diameter or names a shape."""
    m = _D_WORD.search(" " + rest)
    dia = _length(m.group(1), mm_per_unit) if m else None
    if dia is None:
        dia = size_in_name(rest.split(";")[-1] if ";" in rest else rest, mm_per_unit)
    shape = shape_named(rest)
    if dia is None and shape is ToolShape.OTHER:
        return None
    cr = _FIELD["CR"].search(rest)  # a corner radius written Fusion-style: CR=0.3
    return ToolHeader(number=number, diameter_mm=dia,
                      corner_radius_mm=_length(cr.group(1), mm_per_unit, signed=True)
                      if cr else None, shape=shape, z_min_mm=None, line=line, text=text)


def tool_header(comment: str, line: int, mm_per_unit: float) -> ToolHeader | None:
    """The tool ``comment`` (the text inside ``( )`` or after ``;``) describes, or None.

    Parameters
    ----------
    comment : str
        The comment's text.
    line : int
        Its 1-based line in the program.
    mm_per_unit : float
        Millimetres per program unit (25.4 for a G20 program, else 1).
    """
    text = comment.strip()
    if not text or len(text) > 1000:
        return None
    t = _T_FIRST.match(text)
    if t is not None:
        number = int(t.group(1))
        rest = text[t.end():]
        if rest.lstrip().startswith("|"):
            return _mastercam_table(text, number, line, mm_per_unit)
        if _FIELD["D"].search(rest):
            return _fusion(text, number, line, mm_per_unit)
        return _generic(text, number, rest, line, mm_per_unit)
    if _MC_LINE_TOOL.search(text):
        return _mastercam_line(text, line, mm_per_unit)
    f = _FREECAD.match(text)
    if f is not None:
        return _generic(text, None, f.group(1), line, mm_per_unit)
    return None


def looks_like_tool(comment: str) -> bool:
    """Cheap test: could ``comment`` be a tool comment (worth keeping until the program's
    units are known)?"""
    return bool(_T_FIRST.match(comment) or _FREECAD.match(comment)
                or ("TOOL" in comment.upper() and _MC_LINE_TOOL.search(comment)))
