"""Reading HEIDENHAIN Klartext (conversational, ``.h``) programs into the G-code reader's
:class:`~feedopt.gcode.moves.Program`, five-axis ``LN`` blocks with their tool vectors included.

A Klartext program is one block per line, an optional block number first (``12 L X+10 Y-5 R0
F500``), ``;`` starting a comment, ``*`` a structure line, ``/`` a block the operator may skip
(skipped, noted), ``~`` at the end continuing a block on the next line (cycle parameters);
numbers usually carry their sign (``X+10.5``). CAM posts (the HSM/Fusion Heidenhain post among
them) write five-axis tool paths under TCPM as ``LN X.. Y.. Z.. TX.. TY.. TZ..``: the tool tip
and the tool vector (from the tip into the spindle; normalised here), the TNC turning the vector
along the great circle between blocks (iTNC 530 / TNC 640 user's manuals, "LN: straight line
with vector", "M128/FUNCTION TCPM").

Read: ``BEGIN PGM name MM`` / ``END PGM`` (an ``INCH`` program is refused: its feeds' unit
differs), ``L`` and ``LN`` with ``X Y Z`` (absolute, modal), ``IX IY IZ`` (incremental),
``TX TY TZ`` (the tool vector; an ``LN`` without it and an ``L`` keep the last), ``NX NY NZ``
(the surface normal of 3D tool compensation: noted, no offset), ``R0`` (``RL``/``RR`` radius
compensation is refused), ``F`` [mm/min] (modal), ``FMAX`` (a rapid, this block only),
``F AUTO`` (the feed of the last ``TOOL CALL``, which is also the feed in force after it);
``CC X Y`` and ``C X Y [Z] DR+|DR-`` (an arc
about the pole in the XY plane, a helix with Z; counter-clockwise for ``DR+``) with a tool
along +Z; ``TOOL CALL n Z S.. [F..]`` (a tool change: the position becomes unknown, as after
M6); ``M0``/``M1`` (stops), ``M3``/``M4``/``M5``/``M13``/``M14`` (spindle), ``M91``/``M92``
(machine coordinates: the position becomes unknown, as after G53), ``M2``/``M30`` and
``END PGM`` (the end); ``CYCL DEF 9`` (dwell), ``STOP``. Blocks without effect on the tool
path (``BLK FORM``, ``TOOL DEF``, ``CYCL DEF 32`` tolerance, ``FUNCTION TCPM``, ``M128``,
coolant, ...) are noted once each. Everything else that could move the tool (``CR``, ``CT``,
``CP``, ``RND``, ``CHF``, ``APPR``/``DEP``, FK, ``PLANE``, datum and other cycles, ``CALL``,
``LBL``, Q parameters, ``M140``, A/B/C axis words) is an InputError naming the line.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

from feedopt.errors import InputError
from feedopt.gcode.moves import (
    SAME_POINT_MM,
    Move,
    MoveCategory,
    MoveKind,
    Plane,
    Program,
    Stop,
    StopKind,
)
from feedopt.gcode.notes import Notes, line_list
from feedopt.gcode.resolution import radius_tolerance_mm, resolution_mm
from feedopt.textio import max_bytes_for, read_user_bytes

__all__ = ["parse_heidenhain", "read_heidenhain"]

Vec3 = tuple[float, float, float]
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)"
_WORD = re.compile(rf"^(I?[XYZ]|[ABC]|TX|TY|TZ|NX|NY|NZ|F|S|M|DR|DL)({_NUMBER}|[-+])$")
_BLOCK = re.compile(r"^\s*(\d+)?\s*(.*?)\s*$")
#: blocks that could move the tool and are not read -> what to do instead
_REFUSED = {
    "CR": "arcs by radius", "CT": "tangential arcs", "CP": "polar arcs",
    "LP": "polar lines", "RND": "rounded corners", "CHF": "chamfers",
    "APPR": "approach contours", "DEP": "departure contours", "FL": "FK free contours",
    "FLT": "FK free contours", "FC": "FK free contours", "FCT": "FK free contours",
    "FPOL": "FK free contours", "PLANE": "a tilted working plane", "TRANS": "a datum shift",
    "CALL": "subprograms and cycle calls", "LBL": "labels (program parts repeated)",
    "FN": "Q-parameter programming", "SPL": "splines", "CYCL": "cycles",
}
_NOTED_M = {7, 8, 9, 94, 126, 127, 128, 129, 136, 137, 118, 120, 116, 117, 6}


@dataclass
class _State:
    """What the blocks read so far leave in force."""

    position: list[float | None] = field(default_factory=lambda: [None, None, None])
    axis: Vec3 | None = None
    feed: float | None = None  # mm/min
    auto_feed: float | None = None  # TOOL CALL F, mm/min
    rpm: float | None = None
    direction: int = 0
    tool: int | None = None
    pole: tuple[float, float] | None = None
    unknown_why: str = "the program start"
    approach: bool = False
    decimals: int | None = None
    five_axis: bool = False


@dataclass
class _Block:
    line: int
    n: int | None
    text: str
    words: list[str]


def _err(source: str, b: _Block, msg: str) -> InputError:
    shown = b.text if len(b.text) <= 60 else b.text[:57] + "..."
    return InputError(f"{source} line {b.line} ({shown!r}): {msg}")


def _blocks(text: str, notes: Notes) -> list[_Block]:
    """The program's blocks: comments and structure lines dropped, a block ending in ``~``
    joined with the lines after it (cycle parameters), ``/`` (block delete) skipped and
    noted."""
    out: list[_Block] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        first, raw = i + 1, lines[i]
        code = raw.split(";", 1)[0].rstrip()
        while code.endswith("~") and i + 1 < len(lines):
            i += 1
            code = code[:-1] + " " + lines[i].split(";", 1)[0].rstrip()
        i += 1
        if code.lstrip().startswith("/"):
            notes.add("deleted", first)
            continue
        m = _BLOCK.match(code)
        body = m.group(2) if m else ""
        if not body or body.startswith("*"):
            continue
        n = int(m.group(1)) if m and m.group(1) else None
        out.append(_Block(first, n, raw.strip(), body.upper().split()))
    return out


class _Reader:
    def __init__(self, source: str, arc_tolerance_mm: float) -> None:
        self.source = source
        self.arc_tol = arc_tolerance_mm
        self.s = _State()
        self.moves: list[Move] = []
        self.stops: list[Stop] = []
        self.tools: list[int] = []
        self.notes = Notes()
        self.once: dict[str, list[int]] = {}
        self.machine_lines: list[int] = []
        self.ended = False

    def err(self, b: _Block, msg: str) -> InputError:
        return _err(self.source, b, msg)

    def note_once(self, what: str, line: int) -> None:
        self.once.setdefault(what, []).append(line)

    # -------------------------------------------------------------------- blocks
    def run(self, blocks: list[_Block]) -> None:
        self.s.five_axis = any(b.words[0] == "LN" and any(w[:2] in ("TX", "TY", "TZ")
                                                           for w in b.words[1:])
                               for b in blocks)
        if self.s.five_axis:
            self.s.axis = (0.0, 0.0, 1.0)
        for b in blocks:
            if self.ended:
                break
            self.block(b)

    def block(self, b: _Block) -> None:
        head = b.words[0]
        two = " ".join(b.words[:2])
        if head in ("L", "LN"):
            self.linear(b)
        elif head == "CC":
            self.pole(b)
        elif head == "C":
            self.arc(b)
        elif two == "BEGIN PGM":
            if b.words[-1] == "INCH":
                raise self.err(b, "an INCH program: the TNC's feeds in inch programs are not "
                                  "in inch/min, and the reader does not take them; post the "
                                  "program in MM")
        elif two == "END PGM" or head in ("M2", "M30"):
            self.ended = True
        elif two == "TOOL CALL":
            self.tool_call(b)
        elif head == "STOP":
            self.stop(b, StopKind.PROGRAM_STOP)
            self.m_words(b, b.words[1:])
        elif two == "CYCL DEF":
            self.cycle(b)
        elif head.startswith("M") and _WORD.match(head):
            self.m_words(b, b.words)
        else:
            self.other(b, head, two)

    def other(self, b: _Block, head: str, two: str) -> None:
        if two == "TOOL DEF" or head in ("BLK", "FUNCTION", "SEL", "DECLARE"):
            if two in ("FUNCTION PARAX", "FUNCTION DCM") or (head == "FUNCTION" and "TCPM"
                                                              not in b.words):
                raise self.err(b, f"{two} is not read (it may change how the axes move)")
            self.note_once(two if head in ("TOOL", "FUNCTION") else head, b.line)
            return
        if head in _REFUSED or head.startswith("Q") or head.startswith("FN"):
            what = _REFUSED.get(head, "Q-parameter programming")
            raise self.err(b, f"{head}: {what} are not read; post the program with L/LN "
                              "blocks (and C arcs about a CC pole), expanded")
        raise self.err(b, "unknown block: the reader cannot tell whether it moves the tool. "
                          "Read: L, LN, CC, C, TOOL CALL, CYCL DEF 9/32, STOP, M words and "
                          "blocks without effect on the path (BLK FORM, TOOL DEF, FUNCTION "
                          "TCPM)")

    def cycle(self, b: _Block) -> None:
        number = b.words[2] if len(b.words) > 2 else ""
        major = number.split(".")[0]
        if major == "32":
            self.note_once("CYCL DEF 32", b.line)
        elif major == "9":
            if number == "9.1":
                values = [float(w) for w in b.words[3:] if re.fullmatch(_NUMBER, w)]
                if not values:
                    raise self.err(b, "CYCL DEF 9.1 without a dwell time [s]")
                self.stop(b, StopKind.DWELL, values[-1])
        else:
            raise self.err(b, f"CYCL DEF {number}: cycles (machining, datum shift, "
                              "rotation, scaling, mirroring, tilting) are not read; post the "
                              "program expanded into L/LN blocks")

    # ------------------------------------------------------------------- words
    def words(self, b: _Block, tokens: list[str]) -> dict[str, float | str]:
        """The block's address words: name -> value (``FMAX``/``F AUTO``/``R0``/``DR+`` as
        text)."""
        out: dict[str, float | str] = {}
        i = 0
        while i < len(tokens):
            t = tokens[i]
            if t in ("FMAX", "R0", "RL", "RR", "RF", "R+", "R-"):
                out["F" if t == "FMAX" else "R"] = t
            elif t == "F" and i + 1 < len(tokens) and tokens[i + 1] in ("AUTO", "MAX"):
                out["F"] = "F" + tokens[i + 1]
                i += 1
            elif t in ("FAUTO", "FU", "FZ") or t.startswith(("FU", "FZ")):
                out["F"] = t
            else:
                m = _WORD.match(t)
                if not m:
                    why = ("Q parameters are not read; post the program with numbers" if "Q"
                           in t else "not an address word the reader takes (X, Y, Z, IX, IY, "
                           "IZ, TX, TY, TZ, NX, NY, NZ, R0, F, FMAX, F AUTO, DR+, DR-, M)")
                    raise self.err(b, f"{t!r}: {why}")
                name, value = m.groups()
                if name == "M":
                    out.setdefault("M", [])  # type: ignore[arg-type]
                    out["M"].append(int(float(value)))  # type: ignore[union-attr]
                elif name in out:
                    raise self.err(b, f"{name} given twice in one block")
                elif name == "DR":
                    out["DR"] = value
                else:
                    out[name] = float(value)
                    if name in ("X", "Y", "Z", "IX", "IY", "IZ"):
                        self.count_decimals(value)
            i += 1
        return out

    def count_decimals(self, token: str) -> None:
        d = len(token.split(".", 1)[1]) if "." in token else 0
        self.s.decimals = d if self.s.decimals is None else max(self.s.decimals, d)

    def resolution(self) -> float | None:
        return resolution_mm(self.s.decimals, False)

    # ------------------------------------------------------------------- motion
    def target(self, b: _Block, w: dict) -> list[float | None]:
        end = list(self.s.position)
        for k, name in enumerate("XYZ"):
            if name in w and f"I{name}" in w:
                raise self.err(b, f"{name} and I{name} in one block")
            if name in w:
                end[k] = float(w[name])
            elif f"I{name}" in w:
                if end[k] is None:
                    raise self.err(b, f"I{name}: an incremental move from a position the "
                                      f"reader does not know ({self.s.unknown_why})")
                end[k] = end[k] + float(w[f"I{name}"])
        return end

    def feed_of(self, b: _Block, w: dict) -> float | None:
        """mm/s of this block, None for a rapid; sets the modal feed."""
        f = w.get("F")
        if f == "FMAX":
            return None
        if f == "FAUTO":
            if self.s.auto_feed is None:
                raise self.err(b, "F AUTO without a feed in the last TOOL CALL")
            self.s.feed = self.s.auto_feed
        elif isinstance(f, str):
            raise self.err(b, f"{f}: feeds per revolution or per tooth are not read; post "
                              "the feed in mm/min")
        elif f is not None:
            if not f > 0:
                raise self.err(b, f"F{f:g}: a feed must be > 0 mm/min (FMAX for a rapid)")
            self.s.feed = float(f)
        if self.s.feed is None:
            raise self.err(b, "a feed move without a feed rate (write F in mm/min, F AUTO "
                              "after a TOOL CALL with F, or FMAX for a rapid)")
        return self.s.feed / 60.0

    def check_words(self, b: _Block, w: dict) -> None:
        if any(k in w for k in "ABC"):
            raise self.err(b, "rotary axis words (A, B, C) need the machine's kinematics; "
                              "post the program with tool vectors (LN ... TX TY TZ)")
        if w.get("R") not in (None, "R0"):
            raise self.err(b, f"{w['R']}: radius compensation is not modelled; post the tool "
                              "centre (tip) path with R0")
        if "DL" in w:
            self.note_once("DL/DR in a block", b.line)
        if any(k in w for k in ("NX", "NY", "NZ")):
            self.note_once("NX NY NZ (3D tool compensation's surface normal)", b.line)

    def vector(self, b: _Block, w: dict) -> Vec3 | None:
        given = [k in w for k in ("TX", "TY", "TZ")]
        if not any(given):
            return self.s.axis
        if b.words[0] != "LN":
            raise self.err(b, "TX TY TZ only in LN blocks")
        v = [float(w.get(k, 0.0)) for k in ("TX", "TY", "TZ")]
        n = math.sqrt(sum(x * x for x in v))
        if not n > 1e-9:
            raise self.err(b, "a zero tool vector TX TY TZ")
        return (v[0] / n, v[1] / n, v[2] / n)

    def linear(self, b: _Block) -> None:
        w = self.words(b, b.words[1:])
        self.check_words(b, w)
        machine = any(m in (91, 92) for m in w.get("M", []))  # type: ignore[union-attr]
        rapid = w.get("F") == "FMAX"
        feed = None if rapid else (self.feed_of(b, w) if any(
            k in w for k in ("X", "Y", "Z", "IX", "IY", "IZ")) or "F" in w else None)
        end, axis = self.target(b, w), self.vector(b, w)
        self.m_words(b, [f"M{m}" for m in w.get("M", []) if m not in (91, 92)])  # type: ignore[union-attr]
        if machine:
            self.s.position, self.s.axis = [None, None, None], axis
            self.s.unknown_why = f"the M91/M92 block at line {b.line} (machine coordinates)"
            self.machine_lines.append(b.line)
            return
        if not any(k in w for k in ("X", "Y", "Z", "IX", "IY", "IZ", "TX", "TY", "TZ")):
            return  # a feed or M words alone
        self.move_to(b, end, axis, None if rapid else feed)

    def move_to(self, b: _Block, end: list[float | None], axis: Vec3 | None,
                feed: float | None) -> None:
        s = self.s
        start, a0 = s.position, s.axis
        s.position, s.axis = end, axis
        if any(v is None for v in start) or any(v is None for v in end):
            if feed is None:
                self.notes.add("omitted", b.line)
            elif all(v is not None for v in end):
                self.notes.add("approach", b.line)
                s.approach = True
            return
        p0, p1 = tuple(start), tuple(end)  # type: ignore[arg-type]
        if math.dist(p0, p1) <= SAME_POINT_MM:
            turned = a0 is not None and axis is not None and _dot(a0, axis) < 1.0 - 1e-12
            self.notes.add("turn" if turned else "zero_length", b.line)
            return
        kind = MoveKind.RAPID if feed is None else MoveKind.LINE
        self.append(b, kind, self.category(p0, p1, axis, feed), (p0, p1), feed,
                    axes=(a0, axis))

    def category(self, p0: Vec3, p1: Vec3, axis: Vec3 | None, feed: float | None
                 ) -> MoveCategory:
        if feed is None:
            return MoveCategory.RAPID
        d = (p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2])
        k = axis if axis is not None else (0.0, 0.0, 1.0)
        along = _dot(d, k)
        lateral = math.sqrt(max(0.0, _dot(d, d) - along * along))
        if lateral <= max(SAME_POINT_MM, self.resolution() or 0.0) + 1e-5 * math.sqrt(_dot(d, d)):
            return MoveCategory.PLUNGE if along < 0 else MoveCategory.RETRACT
        return MoveCategory.CUT

    def append(self, b: _Block, kind: MoveKind, cat: MoveCategory, ends: tuple,
               feed: float | None, axes: tuple = (None, None), **arc) -> None:
        s = self.s
        if s.tool is not None and s.tool not in self.tools:
            self.tools.append(s.tool)
        if feed is not None and s.direction == 0:
            self.notes.add("spindle_off", b.line)
        approach, s.approach = s.approach, False
        a0, a1 = axes
        self.moves.append(Move(kind, cat, ends[0], ends[1], feed, s.rpm, s.direction, s.tool,
                               None, None, b.line, b.n, b.text, approach=approach, **arc,
                               axis_start=a0 if a0 is not None else a1, axis_end=a1))

    # --------------------------------------------------------------------- arcs
    def pole(self, b: _Block) -> None:
        w = self.words(b, b.words[1:])
        if any(k not in ("X", "Y", "IX", "IY") for k in w):
            raise self.err(b, "only a pole in the XY plane (CC X.. Y..) is read")
        if not w:
            x, y = self.s.position[0], self.s.position[1]
            if x is None or y is None:
                raise self.err(b, "CC without coordinates at a position the reader does "
                                  "not know")
            self.s.pole = (x, y)
            return
        end = self.target(b, w)
        if end[0] is None or end[1] is None:
            raise self.err(b, "CC needs both X and Y (or a known position)")
        self.s.pole = (end[0], end[1])

    def arc(self, b: _Block) -> None:
        w = self.words(b, b.words[1:])
        self.check_words(b, w)
        s = self.s
        if s.pole is None:
            raise self.err(b, "C without a CC pole before it")
        if s.axis is not None and s.axis[2] < 1.0 - 1e-12:
            raise self.err(b, "an arc with a tilted tool vector is not read")
        if w.get("DR") not in ("+", "-"):
            raise self.err(b, "C needs its direction DR+ (counter-clockwise) or DR-")
        feed = self.feed_of(b, w)
        if feed is None:
            raise self.err(b, "C with FMAX: arcs are feed moves")
        end = self.target(b, w)
        if any(v is None for v in s.position) or any(v is None for v in end):
            raise self.err(b, f"an arc from a position the reader does not know "
                              f"({s.unknown_why})")
        self.m_words(b, [f"M{m}" for m in w.get("M", [])])  # type: ignore[union-attr]
        self.arc_move(b, (tuple(s.position), tuple(end)), 1 if w["DR"] == "+" else -1, feed)
        s.position = end

    def arc_move(self, b: _Block, ends: tuple, direction: int, feed: float) -> None:
        (x0, y0, z0), (x1, y1, _) = ends
        cx, cy = self.s.pole  # type: ignore[misc]
        r0, r1 = math.hypot(x0 - cx, y0 - cy), math.hypot(x1 - cx, y1 - cy)
        tol = radius_tolerance_mm(self.arc_tol, self.resolution())
        if abs(r0 - r1) > tol or r0 <= tol:
            raise self.err(b, f"the arc's start and end are {r0:.6g} and {r1:.6g} mm from "
                              f"the pole CC X{cx:+g} Y{cy:+g}: not one circle (tolerance "
                              f"{tol:g} mm)")
        a0, a1 = math.atan2(y0 - cy, x0 - cx), math.atan2(y1 - cy, x1 - cx)
        sweep = (direction * (a1 - a0)) % (2.0 * math.pi)
        if sweep * r0 <= tol:
            sweep = 2.0 * math.pi  # back at the start: a full circle
        self.append(b, MoveKind.ARC, MoveCategory.CUT, ends, feed, axes=(self.s.axis,
                    self.s.axis), centre=(cx, cy, z0), plane=Plane.XY, direction=direction,
                    sweep_rad=sweep, radius_mm=r0)

    # ------------------------------------------------------------ tools, M, stops
    def tool_call(self, b: _Block) -> None:
        rest = b.words[2:]
        if rest and re.fullmatch(r"\d+", rest[0]):
            self.s.tool = int(rest[0])
            rest = rest[1:]
        elif rest and rest[0].startswith('"'):
            self.note_once("TOOL CALL by name (tool number unknown)", b.line)
            while rest and not rest[0].endswith('"'):
                rest = rest[1:]
            rest = rest[1:]
        if rest and rest[0] in ("X", "Y"):
            raise self.err(b, f"a spindle along {rest[0]}: the reader takes the tool along Z "
                              "(its vectors, LN TX TY TZ, give any other orientation)")
        for t in rest:
            if t.startswith("S") and re.fullmatch(_NUMBER, t[1:]):
                self.s.rpm = float(t[1:])
            elif t.startswith("F") and re.fullmatch(_NUMBER, t[1:]):
                self.s.auto_feed = self.s.feed = float(t[1:])
        self.stop(b, StopKind.TOOL_CHANGE)
        self.s.position = [None, None, None]
        self.s.unknown_why = f"the TOOL CALL at line {b.line}"

    def m_words(self, b: _Block, tokens: list[str]) -> None:
        for t in tokens:
            m = re.fullmatch(r"M(\d+)", t)
            if not m:
                raise self.err(b, f"{t!r} where M words were expected")
            self.m_word(b, int(m.group(1)))

    def m_word(self, b: _Block, m: int) -> None:
        s = self.s
        if m in (0, 1):
            self.stop(b, StopKind.PROGRAM_STOP if m == 0 else StopKind.OPTIONAL_STOP)
        elif m in (3, 13):
            s.direction = 1
        elif m in (4, 14):
            s.direction = -1
        elif m == 5:
            s.direction = 0
        elif m in (2, 30):
            self.ended = True
        elif m in (91, 92):
            raise self.err(b, f"M{m} (machine coordinates) in a block that is not L")
        elif m == 140:
            raise self.err(b, "M140 (retract along the tool axis by MB) moves the tool by an "
                              "amount the reader cannot take; post the retract as an L block")
        elif m in _NOTED_M:
            self.note_once("M-words", b.line)
        else:
            raise self.err(b, f"M{m}: an M function the reader does not know (it may move "
                              "the tool)")

    def stop(self, b: _Block, kind: StopKind, hold_s: float = 0.0) -> None:
        self.stops.append(Stop(len(self.moves) - 1, kind, hold_s, b.line, b.n, b.text))

    def program(self) -> Program:
        if self.s.five_axis:
            self.notes.items.append("five-axis program (LN blocks with TX TY TZ): the moves "
                                    "before its first tool vector are read with the tool "
                                    "along +Z")
        if self.machine_lines:
            self.notes.items.append(
                f"{len(self.machine_lines)} block(s) in machine coordinates (M91/M92): the "
                "position after them is not known, so the rapid after them is not in the move "
                f"list and the path links through the air (lines "
                f"{line_list(self.machine_lines)})")
        for what, lines in self.once.items():
            self.notes.items.append(f"{what}: {len(lines)} block(s) without effect on the "
                                    f"tool path, not modelled (first at line {lines[0]})")
        return Program(moves=tuple(self.moves), units="mm", work_offsets=(),
                       tools=tuple(self.tools), warnings=self.notes.finish(),
                       source=self.source, stops=tuple(self.stops),
                       resolution_mm=self.resolution())


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def parse_heidenhain(text: str, source: str = "<Klartext>", *,
                     arc_tolerance_mm: float = 0.001) -> Program:
    """Read a Klartext program from text (module docstring): moves in mm with tool vectors
    for five-axis ``LN`` programs, stops, warnings. InputError names the line of a block
    that is not read and could move the tool."""
    if not (math.isfinite(arc_tolerance_mm) and arc_tolerance_mm > 0):
        raise ValueError("arc_tolerance_mm must be > 0")
    reader = _Reader(source, arc_tolerance_mm)
    blocks = _blocks(text, reader.notes)
    if not blocks:
        raise InputError(f"{source}: no blocks (an empty Klartext program)")
    reader.run(blocks)
    return reader.program()


def read_heidenhain(path: str | Path, **options) -> Program:
    """Read a Klartext program file (UTF-8, else Latin-1); options as
    :func:`parse_heidenhain`."""
    data = read_user_bytes(path, "Klartext program", max_bytes_for("G-code program"))
    try:
        return parse_heidenhain(data.decode("utf-8-sig"), source=str(path), **options)
    except UnicodeDecodeError as exc:  # TNC files are often Latin-1 (comments in German)
        program = parse_heidenhain(data.decode("latin-1"), source=str(path), **options)
        note = (f"not UTF-8 text (undecodable byte at offset {exc.start}): read as Latin-1 "
                "(the blocks are ASCII; only comments can differ)")
        return replace(program, warnings=(note, *program.warnings))
