"""Reading APT CL files (cutter location data) into the G-code reader's :class:`Program`.

An APT CL file (``.cls``, ``.apt``, ``.aptsource``, ``.cl``: NX CLSF, SolidWorks CAM/CAMWorks,
Autodesk/HSM APT posts, CATIA, NCL) lists the tool-tip positions ("CL points") and tool
vectors a CAM system computed, one statement ``MAJOR/arguments`` per line: keywords in any
case, ``$`` at the end of a line continues the statement on the next, ``$$`` and ``;`` start
comments, numbers like ``1.``, ``-.5``, ``1E-3``. :func:`parse_apt` reads them into
:class:`~feedopt.gcode.moves.Move` s in millimetres; five-axis moves carry their tool vectors
(:attr:`Move.axis_start`, :attr:`Move.axis_end`: unit vectors from the tool tip into the
spindle, normalised from the ``i,j,k`` written).

Read: ``GOTO/x,y,z[,i,j,k]`` (a 3-value GOTO keeps the last tool vector, as NX writes them; it
is refused while ``MULTAX/ON`` is in force), ``FROM``, ``GODLTA/dx,dy,dz`` (or ``/d`` along the
tool axis), ``RAPID`` (the next motion only), ``CIRCLE``/``MOVARC`` + ``GOTO`` (arcs, below),
``GOHOME/x,y,z`` (a rapid there; bare ``GOHOME``: the position becomes unknown), ``TLAXIS/i,j,k``,
``MULTAX``, ``UNITS``/``UNIT``, ``FEDRAT`` (``f``, ``f,MMPM|IPM|MMPR|IPR``, ``MMPM,f``; per-rev
feeds with the SPINDL speed of the move), ``SPINDL``, ``LOADTL/n`` and ``LOAD/TOOL,n`` (tool
change stop; the position becomes unknown as after M6), ``CUTTER``/``TLDATA`` (tool headers),
``DELAY`` (dwell), ``STOP``, ``OPSTOP``, ``FINI`` (nothing after it is read). Statements without
effect on the tool path (``COOLNT``, ``CUTCOM``, ``PAINT``, ``MSYS``, ``INSERT``, ...) are
noted once each with their first line; comments (``$$``, ``PPRINT``) are counted. ``CSYS``
(SolidWorks CAM's setup frame) only sets the tool vector to its Z axis: that CAM writes the
GOTOs after it in the world frame with their vectors. Everything else that could move the tool
(``CYCLE``, ``NURBS``, ``ROTABL``, APT source motion like ``GOFWD``, unknown statements) is an
InputError naming the line and the statement.

Units: ``UNITS/INCHES`` (or the ``units`` option) scales coordinates, radii and unqualified
feeds by 25.4. A file without a UNITS statement (NX writes none: its CLSF is in the part's
units) whose feeds are all in inches (``IPM``/``IPR``) is read in inches, and the warnings say
so; otherwise in millimetres.

CIRCLE direction. ``CIRCLE/xc,yc,zc,i,j,k[,r,...]`` (then a GOTO to the end) is an arc about
the axis ``(i,j,k)`` through the centre. CAM systems disagree on its direction when only the
end point is given: NX CLSF (a CIRCLE with its tolerance and tool fields: 11 values, or a file
with ``TOOL PATH``/``TLDATA``) turns clockwise about the axis (NX's own post writes G3 for
``CIRCLE/...,0,0,-1``), ISO 4343-style files (SolidWorks CAM, Autodesk's ``MOVARC``, which
negates the normal of a clockwise arc) counter-clockwise: the arcs of the public NX and
SolidWorks CAM files read continue their neighbouring moves tangentially that way. When the
file (not NX) lists points along the arc (two or more consecutive GOTOs on the circle, each
less than 90 degrees on from the last, in one direction), their order gives the direction and
they are all on the arc; otherwise the GOTO after the CIRCLE is its end and the next GOTO a
line. ``circle_direction="ccw"``/``"cw"`` forces the direction. NX's ``CIRCLE/...,TIMES,n``
adds n - 1 full turns. An arc about an X, Y or Z axis is a Move of kind ARC in that plane
(split into full turns at most); others are cut into lines within ``arc_tolerance_mm``. The
warnings say which convention each arc followed, and if most arcs start against the move
before them (a sign of the other convention).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

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
    ToolHeader,
    ToolShape,
)
from feedopt.gcode.notes import line_list
from feedopt.gcode.resolution import (
    MM_PER_INCH,
    radius_tolerance_mm,
    resolution_mm,
    unit_scale,
)
from feedopt.textio import max_bytes_for, read_user_bytes

Vec3 = tuple[float, float, float]

#: Largest magnitude of a number read (beyond it floats lose meaning), as the G-code lexer.
MAX_ABS_VALUE = 1e9
#: More decimals than this say nothing about a post's rounding (float noise): capped.
MAX_DECIMALS = 12
#: Most lines one arc about a skew axis is cut into; more is refused.
MAX_ARC_LINES = 100_000
#: A CIRCLE axis is along X, Y or Z when its other components are at most this.
AXIS_ALIGNED = 1e-6
#: Listed points of an arc follow each other by at most this angle [rad].
MAX_LISTED_STEP = 0.5 * math.pi
#: Cosine under which an arc is taken to start against the move before.
REVERSAL_COS = -0.9

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][+-]?\d+)?")
_MAJOR = re.compile(r"[A-Z][A-Z0-9_-]*(?: [A-Z0-9_-]+)*")
_TEXT = re.compile(r"\s*(PPRINT|PARTNO|INSERT|TPRINT)(?=[\s/]|$)\s*/?(.*)$", re.I)
_NX_LISTING = re.compile(r"(?:Information listing created by|Date|Current work part|Node name)"
                         r"\t.*|Tool Path Listing has \d+ lines\.?", re.I)
_PLANES = {2: Plane.XY, 1: Plane.ZX, 0: Plane.YZ}

#: Statements without effect on the tool path: noted once each (with what they are).
_NO_EFFECT = {
    "PARTNO": "part name", "COOLNT": "coolant", "CUTCOM": "cutter compensation for the "
    "controller (the GOTO points are read as tool-tip points)", "MACHIN": "post selection",
    "CLRSRF": "clearance surface", "INSERT": "text for the controller, not read",
    "OPSKIP": "optional skip", "SELCTL": "tool preselection", "SELECT": "tool preselection",
    "TOOLNO": "tool number", "TPRINT": "tool list", "AUTOPS": "APT source directive",
    "PITCH": "thread pitch", "ORIGIN": "machine origin for the post (positions are read in "
    "the program frame)", "END": "end of a section", "PAINT": "display", "TOOL PATH":
    "operation header", "END-OF-PATH": "operation end", "MSYS": "machine coordinate system "
    "(positions are read in its frame)", "TRNTYP": "transformation type", "SETUP": "setup "
    "marker", "MODE": "machining mode", "AUXFUN": "auxiliary function for the controller, not "
    "read", "PREFUN": "preparatory function for the controller, not read", "SEQNO":
    "sequence numbers", "INTOL": "CAM tolerance", "OUTTOL": "CAM tolerance", "TOLER": "CAM "
    "tolerance", "LINTOL": "CAM tolerance", "DISPLY": "display", "OPNAME": "operation name",
    "CLAMP": "clamping", "UNCLMP": "clamping", "REWIND": "tape rewind", "LEADER": "tape leader",
    "CYCLE/OFF": "end of a canned cycle", "CSYS": "setup frame; the GOTOs are read as written "
    "(world frame), its Z axis is the tool vector",
}
_SOURCE_MOTION = ("APT part-program motion (surface-driven, for the APT processor) is not CL "
                  "data: give the CL file the APT processor or the CAM computed")
_SPLINE = "spline motion is not read: have the CAM write it as GOTO points (linearised)"
_REFUSED = {
    "NURBS": _SPLINE, "KNOT": _SPLINE, "CNTRL": _SPLINE, "SPLINE": _SPLINE,
    **{m: _SOURCE_MOTION for m in ("GO", "GOFWD", "GOLFT", "GORGT", "GOBACK", "GOUP",
                                   "GODOWN", "INDIRV", "INDIRP", "TLON", "TLLFT", "TLRGT",
                                   "PSIS", "OFFSET")},
    **{m: "rotary-axis motion is not read: have the CAM write tool vectors (MULTAX/ON, "
          "GOTO/x,y,z,i,j,k)" for m in ("ROTABL", "ROTATE", "ROTHED")},
    **{m: "coordinate transformations and repeats are not applied: have the CAM write the "
          "transformed GOTOs" for m in ("TRACUT", "TRANS", "COPY", "INDEX", "REFSYS")},
    "RETRCT": "a retract to a machine-specific height is not read: write it as a GOTO",
    "THREAD": "threading is not read", "TURRET": "lathe turrets are not read",
}
_GROUPS = {
    "comments": "comment(s) ($$, PPRINT) not read",
    "omitted": ("rapid(s) from a position the reader does not know (program start without "
                "FROM, after a tool change or a bare GOHOME) are not in the move list"),
    "approach": ("feed move(s) from a position the reader does not know: the path approaches "
                 "their end through the air (the next move carries the approach)"),
    "zero_length": "zero-length motion(s) dropped",
    "turn": ("tool vector turned in place (a zero-length GOTO or TLAXIS): the next move starts "
             "from the turned vector"),
    "gohome": "GOHOME/x,y,z read as a rapid to the point given",
    "from": "FROM after the first motion: the position jumps there without a move",
    "no_spindle": "feed move(s) with no spindle speed given (no SPINDL before them)",
    "spindle_off": "feed move(s) after SPINDL/OFF",
    "tessellated": "arc(s) about an axis not along X, Y or Z cut into lines",
    "times": ("CIRCLE ...,TIMES,n arc(s) read as n - 1 full turns and then on to the GOTO "
              "(as HumMan's CLSFProcessor reads NX helices)"),
    "arc_back": ("arc(s), most of those following a feed move, start against its direction "
                 "(a reversal): the CAM may write its CIRCLE axes the other way round; check "
                 "and set circle_direction"),
}
_SENSE_TEXT = {
    "nx": "clockwise about the CIRCLE axis (NX CLSF convention: CIRCLE with tolerance and "
          "tool fields)",
    "iso": "counter-clockwise about the CIRCLE axis (right-hand rule: ISO 4343 style, "
           "SolidWorks CAM, Autodesk MOVARC)",
    "points": "in the order of the points listed along them",
    "option": "as circle_direction says",
}


@dataclass(frozen=True)
class Statement:
    """One APT statement (continuation lines joined).

    line : first physical line (1-based)
    text : as written (continued lines joined by a space)
    major : the major word, upper case (``"GOTO"``, ``"TOOL PATH"``)
    args : the comma-separated arguments after ``/``, stripped
    rest : everything after the ``/`` (free text of PPRINT, PARTNO, INSERT)
    """

    line: int
    text: str
    major: str
    args: tuple[str, ...]
    rest: str


@dataclass
class _Lexed:
    """Statements of a file and what was skipped while splitting it."""

    statements: list[Statement] = field(default_factory=list)
    comments: list[int] = field(default_factory=list)
    listing: list[int] = field(default_factory=list)


def _short(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _strip_comment(code: str) -> str:
    """``code`` without a ``$$`` or ``;`` comment."""
    cut = [i for i in (code.find("$$"), code.find(";")) if i >= 0]
    return code[:min(cut)] if cut else code


def _statement(line: int, written: str, code: str, source: str) -> Statement:
    """Parse one logical statement ``code`` (comments and continuations removed)."""
    text = _TEXT.match(code)
    if text:
        return Statement(line, written, text.group(1).upper(), (), text.group(2).strip())
    major, slash, rest = code.partition("/")
    name = " ".join(major.upper().split())
    if not _MAJOR.fullmatch(name):
        raise InputError(f"{source} line {line}: cannot read {_short(written)!r}: not an APT "
                         "statement (a major word, then '/' and arguments, e.g. GOTO/1,2,3)")
    args = tuple(a.strip() for a in rest.split(",")) if slash else ()
    return Statement(line, written, name, () if args == ("",) else args, rest.strip())


def split_statements(text: str, source: str = "<APT>") -> _Lexed:
    """The statements of an APT CL text (see the module docstring for the syntax)."""
    out = _Lexed()
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    first, written, code = 0, [], []
    for i, raw in enumerate(lines, start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("$$") or (not code and _NX_LISTING.fullmatch(stripped)):
            (out.comments if stripped.startswith("$$") else out.listing).append(i)
            continue
        part = stripped if (not code and _TEXT.match(stripped)) else _strip_comment(stripped)
        part = part.rstrip()
        if not code:
            first, written = i, []
        written.append(stripped)
        if part.endswith("$") and not _TEXT.match(stripped):
            code.append(part[:-1])
            continue
        code.append(part)
        joined = "".join(code).strip()
        code = []
        if joined:
            out.statements.append(_statement(first, " ".join(written), joined, source))
    if code:
        raise InputError(f"{source} line {first}: the statement is continued ('$' at the end "
                         "of its last line) but the file ends: is it complete?")
    return out


def _unit(v: Vec3) -> Vec3 | None:
    """``v`` normalised; None for a zero or non-finite vector."""
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if not (math.isfinite(n) and n > 1e-12):
        return None
    return (v[0] / n, v[1] / n, v[2] / n)


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _axpy(s: float, a: Vec3, b: Vec3) -> Vec3:
    """``s * a + b``."""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


def _norm(a: Vec3) -> float:
    return math.sqrt(_dot(a, a))


def radial(p: Vec3, centre: Vec3, axis: Vec3) -> tuple[Vec3, float]:
    """The part of ``p - centre`` square to the unit ``axis`` and the part along it."""
    v = _sub(p, centre)
    h = _dot(v, axis)
    return _axpy(-h, axis, v), h


def signed_angle(u: Vec3, w: Vec3, axis: Vec3) -> float:
    """Angle [rad] in (-pi, pi] turning ``u`` into ``w`` about the unit ``axis``."""
    return math.atan2(_dot(_cross(u, w), axis), _dot(u, w))


def slerp(a: Vec3, b: Vec3, t: float) -> Vec3:
    """Unit vector a fraction ``t`` along the great circle from unit ``a`` to unit ``b``."""
    c = max(-1.0, min(1.0, _dot(a, b)))
    ang = math.acos(c)
    if ang < 1e-9:
        return b
    if math.pi - ang < 1e-9:  # opposite: no unique great circle; turn about any normal
        p = _unit(_cross(a, (1.0, 0.0, 0.0))) or _unit(_cross(a, (0.0, 1.0, 0.0)))
        assert p is not None
        c_t, s_t = math.cos(t * math.pi), math.sin(t * math.pi)
        return (c_t * a[0] + s_t * p[0], c_t * a[1] + s_t * p[1], c_t * a[2] + s_t * p[2])
    s0 = math.sin((1.0 - t) * ang) / math.sin(ang)
    s1 = math.sin(t * ang) / math.sin(ang)
    return _unit(_axpy(s0, a, _axpy(s1, b, (0.0, 0.0, 0.0)))) or b


@dataclass(frozen=True)
class _Feed:
    """A FEDRAT: ``mm`` per minute (or per revolution if ``per_rev``)."""

    mm: float
    per_rev: bool
    line: int


@dataclass(frozen=True)
class _Circle:
    """A CIRCLE waiting for its GOTO."""

    centre: Vec3
    axis: Vec3
    radius: float | None
    sense: int  # +1 counter-clockwise about axis, -1 clockwise (unless points say otherwise)
    forced: bool  # the sense holds even if points are listed
    why: str  # key of _SENSE_TEXT
    statement: Statement
    turns: int = 0  # full turns before the end (NX's TIMES,n: n - 1)


@dataclass
class _State:
    """Modal state of the reader."""

    inch: bool = False
    units_line: int | None = None
    multax: int | None = None  # line of the MULTAX/ON in force
    position: Vec3 | None = None
    unknown_why: str = "the program start (no FROM or GOTO yet)"
    axis: Vec3 | None = None
    feed: _Feed | None = None
    rapid: Statement | None = None
    rpm: float | None = None
    direction: int = 0
    last_direction: int = 1
    spindle_off: bool = False
    tool: int | None = None
    moved: bool = False
    circle: _Circle | None = None
    approach: bool = False
    decimals: int | None = None
    nx: bool = False


@dataclass
class _Notes:
    """Warnings: single items, lines grouped by kind, statements noted once."""

    items: list[str] = field(default_factory=list)
    groups: dict[str, list[int]] = field(default_factory=dict)
    once: dict[str, list[int]] = field(default_factory=dict)
    senses: dict[str, list[int]] = field(default_factory=dict)

    def add(self, kind: str, line: int) -> None:
        """Record ``line`` under the grouped note ``kind`` (a key of ``_GROUPS``)."""
        lines = self.groups.setdefault(kind, [])
        if not lines or lines[-1] != line:
            lines.append(line)

    def finish(self) -> tuple[str, ...]:
        """Every note: single ones, statements noted once, arc directions, then groups."""
        out = list(self.items)
        for major, lines in self.once.items():
            what = _NO_EFFECT.get(major, "no effect on the tool path")
            out.append(f"{major} ({what}): {len(lines)} statement(s) (first at line "
                       f"{lines[0]})")
        for why, lines in self.senses.items():
            out.append(f"{len(lines)} arc(s) taken {_SENSE_TEXT[why]} (lines "
                       f"{line_list(lines)})")
        for kind, text in _GROUPS.items():
            lines = self.groups.get(kind)
            if lines:
                out.append(f"{len(lines)} {text} (lines {line_list(lines)})")
        return tuple(out)


@dataclass
class _Header:
    """A CUTTER/TLDATA tool; its number is that of the tool change after it (before any move),
    else that of the tool in the spindle."""

    diameter: float | None
    corner: float | None
    shape: ToolShape
    statement: Statement
    number: int | None = None


@dataclass(frozen=True)
class _Seg:
    """A stretch of motion: end points and tool vectors (None: three-axis)."""

    start: Vec3
    end: Vec3
    a0: Vec3 | None
    a1: Vec3 | None


@dataclass(frozen=True)
class _Options:
    """parse_apt's options (see there)."""

    arc_tolerance_mm: float
    circle_direction: str
    units: str | None


def decimals_of(token: str) -> int:
    """Digits a number is written to after the point (``1.250``: 3, ``12``: 0, ``1.5E-2``: 3),
    at most :data:`MAX_DECIMALS`."""
    parts = re.split("[EeDd]", token)
    frac = parts[0].split(".")[1] if "." in parts[0] else ""
    exp = int(parts[1]) if len(parts) > 1 else 0
    return max(0, min(len(frac) - exp, MAX_DECIMALS))


def _words(args: tuple[str, ...]) -> tuple[list[str], list[str]]:
    """Upper-case keywords and numbers of ``args``, each in order."""
    words = [a.upper() for a in args if not _NUMBER.fullmatch(a)]
    return words, [a for a in args if _NUMBER.fullmatch(a)]


def _end_direction(move: Move) -> Vec3:
    """Direction of travel at the end of ``move`` (not normalised)."""
    if move.kind is not MoveKind.ARC or move.plane is None or move.centre is None:
        return _sub(move.end, move.start)
    u, v, _ = move.plane.value
    r = [0.0, 0.0, 0.0]
    r[u], r[v] = move.end[u] - move.centre[u], move.end[v] - move.centre[v]
    t = _cross(move.plane.normal, (r[0], r[1], r[2]))
    return (move.direction * t[0], move.direction * t[1], move.direction * t[2])


def _turn(seg: _Seg, t: float) -> Vec3 | None:
    """The tool vector a fraction ``t`` along ``seg`` (great circle; None if three-axis)."""
    if seg.a0 is None or seg.a1 is None:
        return seg.a1
    return slerp(seg.a0, seg.a1, t)


def arc_point(centre: Vec3, axis: Vec3, seg: _Seg, u0: Vec3, angle: float, t: float) -> Vec3:
    """The point a fraction ``t`` along an arc about ``axis`` through ``centre`` from
    ``seg.start`` (radial part ``u0``) to ``seg.end`` turning ``angle`` [rad] in all: the
    radius and the height along the axis change in proportion to the angle."""
    r0 = _norm(u0)
    r1, h1 = radial(seg.end, centre, axis)
    h0 = radial(seg.start, centre, axis)[1]
    r = r0 + (_norm(r1) - r0) * t
    h = h0 + (h1 - h0) * t
    e0 = (u0[0] / r0, u0[1] / r0, u0[2] / r0)
    e1 = _cross(axis, e0)
    a = angle * t
    return _axpy(h, axis, _axpy(r * math.sin(a), e1, _axpy(r * math.cos(a), e0, centre)))


class _Reader:
    """Runs the statements through the modal state; collects moves, stops and notes."""

    def __init__(self, source: str, options: _Options, lexed: _Lexed) -> None:
        self.source = source
        self.opt = options
        self.sts = lexed.statements
        self.s = _State()
        self.notes = _Notes()
        self.moves: list[Move] = []
        self.stops: list[Stop] = []
        self.tools: list[int] = []
        self.headers: list[_Header] = []
        self.pending_headers: list[_Header] = []  # waiting for the tool change after them
        self.arcs_after_feed = 0
        self.i = 0
        for line in lexed.comments:
            self.notes.add("comments", line)
        if lexed.listing:
            self.notes.items.append(
                f"{len(lexed.listing)} line(s) of an NX information-window listing (not APT) "
                f"skipped (lines {line_list(lexed.listing)})")
        self.handlers = {
            "GOTO": self._goto, "FROM": self._from, "GODLTA": self._godlta,
            "GOHOME": self._gohome, "RAPID": self._rapid, "CIRCLE": self._circle,
            "MOVARC": self._circle, "TLAXIS": self._tlaxis, "MULTAX": self._multax,
            "UNITS": self._units, "UNIT": self._units, "FEDRAT": self._fedrat,
            "SPINDL": self._spindl, "LOADTL": lambda st: self._load_tool(st, st.args),
            "LOAD": self._load, "CUTTER": self._cutter, "TLDATA": self._tldata,
            "DELAY": self._delay, "STOP": lambda st: self._stop(st, StopKind.PROGRAM_STOP),
            "OPSTOP": lambda st: self._stop(st, StopKind.OPTIONAL_STOP),
            "CYCLE": self._cycle, "CSYS": self._csys,
            "PPRINT": lambda st: self.notes.add("comments", st.line),
        }

    # ----------------------------------------------------------------- helpers
    def _err(self, st: Statement, msg: str) -> InputError:
        return InputError(f"{self.source} line {st.line}: {st.major}: {msg}")

    @property
    def _scale(self) -> float:
        return unit_scale(self.s.inch)

    def resolution_mm(self) -> float | None:
        """One unit of the last decimal of the coordinates read so far [mm]."""
        return resolution_mm(self.s.decimals, self.s.inch)

    def _radius_tol(self) -> float:
        return radius_tolerance_mm(self.opt.arc_tolerance_mm, self.resolution_mm())

    def _count(self, tokens: tuple[str, ...]) -> None:
        """Record the decimals of coordinates ``tokens`` (for the resolution)."""
        for t in tokens:
            d = decimals_of(t)
            self.s.decimals = d if self.s.decimals is None else max(self.s.decimals, d)

    def _num(self, st: Statement, token: str) -> float:
        if not _NUMBER.fullmatch(token):
            raise self._err(st, f"cannot read {_short(token, 30)!r} as a number (in "
                                f"{_short(st.text)!r})")
        value = float(token.replace("D", "E").replace("d", "e"))
        if not (math.isfinite(value) and abs(value) <= MAX_ABS_VALUE):
            raise self._err(st, f"{token}: out of range (at most 1e9 in magnitude)")
        return value

    def _nums(self, st: Statement, counts: tuple[int, ...], what: str) -> list[float]:
        if len(st.args) not in counts:
            raise self._err(st, f"expected {what}, got {len(st.args)} value(s) in "
                                f"{_short(st.text)!r}")
        return [self._num(st, a) for a in st.args]

    def _point(self, values: list[float]) -> Vec3:
        k = self._scale
        return (values[0] * k, values[1] * k, values[2] * k)

    def _vector(self, st: Statement, values: list[float], what: str = "tool vector") -> Vec3:
        v = _unit((values[0], values[1], values[2]))
        if v is None:
            raise self._err(st, f"the {what} ({', '.join(f'{x:g}' for x in values)}) has no "
                                "direction (zero length): give a unit vector")
        return v

    def _goto_values(self, st: Statement) -> tuple[Vec3, Vec3 | None]:
        """A GOTO's point [mm] and tool vector (None if not written)."""
        values = self._nums(st, (3, 6), "GOTO/x,y,z or GOTO/x,y,z,i,j,k")
        return self._point(values), (self._vector(st, values[3:]) if len(values) == 6
                                     else None)

    def _resolve(self, st: Statement, vector: Vec3 | None) -> Vec3 | None:
        """The tool vector of a motion: the one written, else the last (modal)."""
        if vector is not None:
            return vector
        if self.s.multax is not None:
            raise self._err(st, f"x,y,z only while MULTAX/ON (line {self.s.multax}) is in "
                                "force: give the tool vector (GOTO/x,y,z,i,j,k)")
        return self.s.axis

    def _take_rapid(self) -> bool:
        rapid = self.s.rapid is not None
        self.s.rapid = None
        return rapid

    def _stop(self, st: Statement, kind: StopKind, hold_s: float = 0.0) -> None:
        self.stops.append(Stop(after_move=len(self.moves) - 1, kind=kind, hold_s=hold_s,
                               line=st.line, n_number=None, text=st.text))

    def _feed_mm_s(self, st: Statement) -> float:
        f = self.s.feed
        if f is None:
            raise self._err(st, "feed move without a feed rate: no FEDRAT before this line "
                                "(write FEDRAT/f,MMPM before it, or RAPID for a rapid)")
        if not f.per_rev:
            return f.mm / 60.0
        rpm = self.s.rpm
        if rpm is None or not rpm > 0:
            raise self._err(st, f"feed per revolution (FEDRAT at line {f.line}) without a "
                                "spindle speed: give SPINDL/rpm before the move")
        return f.mm * rpm / 60.0

    def _check_spindle(self, st: Statement) -> None:
        if self.s.spindle_off:
            self.notes.add("spindle_off", st.line)
        elif self.s.rpm is None and self.s.direction == 0:
            self.notes.add("no_spindle", st.line)

    def _common(self, st: Statement) -> dict:
        s = self.s
        if s.tool is not None and s.tool not in self.tools:
            self.tools.append(s.tool)
        approach, s.approach = s.approach, False
        self.pending_headers.clear()  # a tool header followed by moves is the tool's in use
        return dict(spindle_rpm=s.rpm, spindle_direction=s.direction, tool=s.tool,
                    work_offset=None, length_offset=None, line=st.line, n_number=None,
                    text=st.text, approach=approach)

    def _append(self, st: Statement, kind: MoveKind, cat: MoveCategory, seg: _Seg,
                feed: float | None, **arc) -> None:
        a_start = seg.a0 if seg.a0 is not None else seg.a1
        self.moves.append(Move(kind, cat, seg.start, seg.end, feed, **self._common(st), **arc,
                               axis_start=a_start, axis_end=seg.a1))

    # ------------------------------------------------------------------- lines
    def _line(self, st: Statement, seg: _Seg, feed: float | None) -> None:
        """A straight move (RAPID when ``feed`` is None); a zero-length one is noted."""
        d = _sub(seg.end, seg.start)
        if _norm(d) <= SAME_POINT_MM:
            turned = (seg.a0 is not None and seg.a1 is not None
                      and _dot(seg.a0, seg.a1) < 1.0 - 1e-12)
            self.notes.add("turn" if turned else "zero_length", st.line)
            return
        if feed is None:
            self._append(st, MoveKind.RAPID, MoveCategory.RAPID, seg, None)
            return
        axis = seg.a1 if seg.a1 is not None else (0.0, 0.0, 1.0)
        along = _dot(d, axis)
        category = MoveCategory.CUT
        # along the axis within the written numbers: the coordinates' last decimal and the
        # vector's (1e-6 per unit of length: six decimals)
        lateral = max(SAME_POINT_MM, self.resolution_mm() or 0.0) + 1e-5 * _norm(d)
        if _norm(_axpy(-along, axis, d)) <= lateral:
            category = MoveCategory.PLUNGE if along < 0 else MoveCategory.RETRACT
        self._check_spindle(st)
        self._append(st, MoveKind.LINE, category, seg, feed)

    def _move_to(self, st: Statement, end: Vec3, vector: Vec3 | None, rapid: bool) -> None:
        """A straight motion to ``end`` from the current position (if known)."""
        s = self.s
        feed = None if rapid else self._feed_mm_s(st)
        start, a0 = s.position, s.axis
        s.moved = True
        s.position, s.axis = end, vector
        if start is not None:
            self._line(st, _Seg(start, end, a0, vector), feed)
        elif rapid:
            self.notes.add("omitted", st.line)
        else:
            self.notes.add("approach", st.line)
            s.approach = True

    def _no_pending_circle(self, st: Statement) -> None:
        c = self.s.circle
        if c is not None:
            raise self._err(st, f"the CIRCLE at line {c.statement.line} must be followed by "
                                "the GOTO to the end of its arc")

    def _goto(self, st: Statement) -> None:
        end, vector = self._goto_values(st)
        self._count(st.args[:3])
        vector = self._resolve(st, vector)
        if self.s.circle is not None:
            self._arc(st, end, vector)
        else:
            self._move_to(st, end, vector, self._take_rapid())

    def _from(self, st: Statement) -> None:
        self._no_pending_circle(st)
        values = self._nums(st, (3, 6), "FROM/x,y,z or FROM/x,y,z,i,j,k")
        self._count(st.args[:3])
        point = self._point(values)
        s = self.s
        if s.moved and s.position is not None and _norm(_sub(point, s.position)) > SAME_POINT_MM:
            self.notes.add("from", st.line)
        s.position = point
        if len(values) == 6:
            s.axis = self._vector(st, values[3:])

    def _godlta(self, st: Statement) -> None:
        self._no_pending_circle(st)
        values = self._nums(st, (1, 3), "GODLTA/dx,dy,dz or GODLTA/d (along the tool axis)")
        s = self.s
        if s.position is None:
            raise self._err(st, f"a relative move from a position the reader does not know "
                                f"({s.unknown_why}): give FROM or a GOTO first")
        self._count(st.args)
        if len(values) == 1:
            end = _axpy(values[0] * self._scale, s.axis or (0.0, 0.0, 1.0), s.position)
        else:
            end = _axpy(1.0, self._point(values), s.position)
        self._move_to(st, end, s.axis, self._take_rapid())

    def _gohome(self, st: Statement) -> None:
        self._no_pending_circle(st)
        s = self.s
        self._take_rapid()
        if not st.args:
            s.position, s.moved = None, True
            s.unknown_why = f"the GOHOME at line {st.line} (machine home is machine-specific)"
            self.notes.items.append(f"line {st.line}: GOHOME returns to a machine home the "
                                    "reader does not know: the next rapid is not in the move "
                                    "list")
            return
        end, vector = self._goto_values(st)
        self._count(st.args[:3])
        self.notes.add("gohome", st.line)
        self._move_to(st, end, vector if vector is not None else s.axis, True)

    def _rapid(self, st: Statement) -> None:
        self._no_pending_circle(st)
        if st.args:
            raise self._err(st, f"expected RAPID alone (the next motion is a rapid), got "
                                f"{_short(st.text)!r}")
        self.s.rapid = st

    def _tlaxis(self, st: Statement) -> None:
        self._no_pending_circle(st)
        if len(st.args) != 3 or not all(_NUMBER.fullmatch(a) for a in st.args):
            raise self._err(st, "only TLAXIS/i,j,k (a tool vector) is read; surface-driven "
                                "tool axes are APT source, not CL data")
        vector = self._vector(st, [self._num(st, a) for a in st.args])
        if self.s.axis is not None and _dot(self.s.axis, vector) < 1.0 - 1e-12:
            self.notes.add("turn", st.line)
        self.s.axis = vector

    def _multax(self, st: Statement) -> None:
        word = st.args[0].upper() if st.args else "ON"
        if len(st.args) > 1 or word not in ("ON", "OFF"):
            raise self._err(st, f"expected MULTAX/ON or MULTAX/OFF, got {_short(st.text)!r}")
        if word == "ON":
            self.s.multax = st.line
            return
        self.s.multax = None
        if self.s.axis is not None and self.s.axis != (0.0, 0.0, 1.0):
            self.notes.add("turn", st.line)
            self.s.axis = (0.0, 0.0, 1.0)

    # ------------------------------------------------------------------- modes
    def _units(self, st: Statement) -> None:
        word = st.args[0].upper() if len(st.args) == 1 else ""
        if word not in ("MM", "INCHES", "INCH", "IN"):
            raise self._err(st, f"expected UNITS/MM or UNITS/INCHES, got {_short(st.text)!r}")
        inch = word != "MM"
        if inch != self.s.inch and self.s.moved:
            raise self._err(st, "switching units after the first motion is not supported (the "
                                f"file was in {'inches' if self.s.inch else 'mm'} until here)")
        self.s.inch = inch
        self.s.units_line = st.line

    def _fedrat(self, st: Statement) -> None:
        words, numbers = _words(st.args)
        if len(numbers) != 1 or len(words) > 1:
            raise self._err(st, f"cannot read {_short(st.text)!r}: expected FEDRAT/f, "
                                "FEDRAT/f,MMPM (IPM, MMPR, IPR) or FEDRAT/MMPM,f")
        value = self._num(st, numbers[0])
        if not value > 0:
            raise self._err(st, f"{numbers[0]}: the feed must be > 0")
        unit = words[0] if words else None
        units = {None: (self._scale, False), "MMPM": (1.0, False), "IPM": (MM_PER_INCH, False),
                 "MMPR": (1.0, True), "IPR": (MM_PER_INCH, True)}
        if unit == "INVERS":
            raise self._err(st, "inverse-time feeds are not supported: have the CAM write "
                                "feeds per minute (MMPM, IPM)")
        if unit not in units:
            raise self._err(st, f"{unit}: unknown feed unit (MMPM, IPM, MMPR or IPR)")
        k, per_rev = units[unit]
        self.s.feed = _Feed(value * k, per_rev, st.line)

    def _spindl(self, st: Statement) -> None:
        s = self.s
        words, numbers = _words(st.args)
        if len(numbers) > 1 or not st.args:
            raise self._err(st, f"cannot read {_short(st.text)!r}: expected SPINDL/rpm[,RPM]"
                                "[,CLW|CCLW], SPINDL/ON or SPINDL/OFF")
        direction = None
        for w in words:
            if w in ("SFM", "SMM"):
                raise self._err(st, f"{w}: constant surface speed is not supported: give the "
                                    "spindle speed in rpm")
            if w not in ("RPM", "CLW", "CCLW", "ON", "OFF"):
                raise self._err(st, f"{w}: not read (SPINDL/rpm[,RPM][,CLW|CCLW], ON, OFF)")
            direction = {"CLW": 1, "CCLW": -1, "ON": s.last_direction, "OFF": 0}.get(w, direction)
        if numbers:
            rpm = self._num(st, numbers[0])
            if rpm < 0:
                raise self._err(st, f"{numbers[0]}: the spindle speed must be >= 0")
            s.rpm = rpm
            direction = (s.last_direction if direction is None else direction) if rpm else 0
        if direction is not None:
            s.direction = direction
            s.spindle_off = direction == 0
            if direction:
                s.last_direction = direction

    def _load(self, st: Statement) -> None:
        if not st.args or st.args[0].upper() != "TOOL":
            raise self._err(st, f"only LOAD/TOOL,n (a tool change) is read, not "
                                f"{_short(st.text)!r}")
        self._load_tool(st, st.args[1:])

    def _load_tool(self, st: Statement, args: tuple[str, ...]) -> None:
        self._no_pending_circle(st)
        if not args:
            raise self._err(st, "expected the tool number (LOADTL/n or LOAD/TOOL,n)")
        value = self._num(st, args[0])
        if value < 0 or value != int(value):
            raise self._err(st, f"{args[0]}: the tool number must be a whole number >= 0")
        s = self.s
        s.tool = int(value)
        s.position = None
        s.unknown_why = (f"the tool change at line {st.line} (its position is "
                         "machine-specific)")
        self._stop(st, StopKind.TOOL_CHANGE)
        for h in self.pending_headers:
            h.number = s.tool
        self.pending_headers.clear()

    def _header(self, st: Statement, numbers: list[float], shape: ToolShape | None) -> None:
        """A tool header from a diameter and corner radius in program units."""
        k = self._scale
        d = numbers[0] * k if numbers else None
        r = numbers[1] * k if len(numbers) > 1 else 0.0
        if d is None or not 0 < d <= MAX_ABS_VALUE or not 0 <= r <= d / 2 + 1e-9:
            self.notes.items.append(f"line {st.line}: {st.major} not read as a tool (diameter "
                                    f"and corner radius out of range): {_short(st.text)}")
            return
        if shape is None:
            if r <= 1e-9:
                shape = ToolShape.FLAT
            elif abs(r - d / 2) <= 1e-6 * max(1.0, d):
                shape = ToolShape.BALL
            else:
                shape = ToolShape.BULL
        header = _Header(d, r, shape, st, number=self.s.tool)
        self.headers.append(header)
        self.pending_headers.append(header)

    def _cutter(self, st: Statement) -> None:
        words, numbers = _words(st.args)
        if words:
            self.notes.once.setdefault(st.major, []).append(st.line)
            return
        values = [self._num(st, a) for a in numbers]
        tip = len(values) > 4 and values[1] <= 0 and values[4] > 0  # a pointed tool
        self._header(st, values, ToolShape.OTHER if tip else None)

    def _tldata(self, st: Statement) -> None:
        words, numbers = _words(st.args)
        values = [self._num(st, a) for a in numbers]
        if "DRILL" in words:
            self._header(st, values[:1], ToolShape.DRILL)
        elif words[:1] == ["MILL"]:
            self._header(st, values, None)
        else:
            self.notes.once.setdefault(st.major, []).append(st.line)

    def _delay(self, st: Statement) -> None:
        words, numbers = _words(st.args)
        if len(numbers) != 1 or any(w not in ("SEC", "SECONDS", "REV", "REVS") for w in words):
            raise self._err(st, f"cannot read {_short(st.text)!r}: expected DELAY/seconds or "
                                "DELAY/n,REV")
        value = self._num(st, numbers[0])
        if value < 0:
            raise self._err(st, f"{numbers[0]}: the dwell time must be >= 0")
        if "REV" in words or "REVS" in words:
            if not (self.s.rpm or 0.0) > 0:
                raise self._err(st, "a dwell in spindle revolutions without a spindle speed "
                                    "(SPINDL/rpm before it)")
            value = value * 60.0 / (self.s.rpm or 1.0)
        self._stop(st, StopKind.DWELL, value)

    def _cycle(self, st: Statement) -> None:
        if [a.upper() for a in st.args] == ["OFF"]:
            self.notes.once.setdefault("CYCLE/OFF", []).append(st.line)
            return
        raise self._err(st, "canned cycles (drilling, tapping) are not read: have the CAM "
                            "write the cycle's moves as GOTOs (expand cycles)")

    def _csys(self, st: Statement) -> None:
        """CSYS/[R|t] (3 x 4, by rows): SolidWorks CAM writes the GOTOs after it in the world
        frame with their tool vectors, so they are read as written; the tool vector becomes
        its Z axis (the third column)."""
        self._no_pending_circle(st)
        values = self._nums(st, (12,), "CSYS with a 3 x 4 matrix (12 values)")
        z = _unit((values[2], values[6], values[10]))
        if z is None:
            raise self._err(st, "the matrix has no Z axis (its third column is zero)")
        if self.s.axis is not None or z != (0.0, 0.0, 1.0):
            if self.s.axis is not None and _dot(self.s.axis, z) < 1.0 - 1e-12:
                self.notes.add("turn", st.line)
            self.s.axis = z
        self.notes.once.setdefault(st.major, []).append(st.line)

    # -------------------------------------------------------------------- arcs
    def _circle(self, st: Statement) -> None:
        self._no_pending_circle(st)
        if self.s.rapid is not None:
            raise self._err(st, f"RAPID (line {self.s.rapid.line}) before an arc: rapid arcs "
                                "are not read")
        k = next((n for n, a in enumerate(st.args) if not _NUMBER.fullmatch(a)), len(st.args))
        tail = [a.upper() for a in st.args[k:]]
        if k < 6 or (tail and (tail[0] not in ("ANGLE", "TIMES") or len(tail) != 2)):
            raise self._err(st, f"cannot read {_short(st.text)!r}: expected "
                                f"{st.major}/xc,yc,zc,i,j,k,r[,...]")
        values = [self._num(st, a) for a in st.args[:k]]
        radius = values[6] * self._scale if k > 6 else None
        if radius is not None and not radius > 0:
            raise self._err(st, f"{st.args[6]}: the radius must be > 0")
        turns = 0
        if tail and tail[0] == "TIMES":
            times = self._num(st, tail[1])
            if times != int(times) or not 1 <= times <= 1000:
                raise self._err(st, f"TIMES,{tail[1]}: the number of turns must be a whole "
                                    "number from 1 to 1000")
            turns = int(times) - 1
            self.notes.add("times", st.line)
        self._count(st.args[:3] + st.args[6:min(k, 7)])
        forced = self.opt.circle_direction != "auto"
        if forced:
            sense, why = (1 if self.opt.circle_direction == "ccw" else -1), "option"
        elif st.major == "MOVARC":
            sense, why, forced = 1, "iso", True
        elif k >= 11 or self.s.nx:
            sense, why = -1, "nx"
        else:
            sense, why = 1, "iso"
        self.s.circle = _Circle(self._point(values), self._vector(st, values[3:6], "circle axis"),
                                radius, sense, forced, why, st, turns)

    def _on_circle(self, c: _Circle, radius: float, tol: float, most: int) -> list[tuple]:
        """The GOTOs right after the current one whose points lie on the circle (``most`` of
        them at most)."""
        out: list[tuple] = []
        j = self.i + 1
        while j < len(self.sts) and self.sts[j].major == "GOTO" and len(out) < most:
            end, vector = self._goto_values(self.sts[j])
            if abs(_norm(radial(end, c.centre, c.axis)[0]) - radius) > tol:
                break
            out.append((self.sts[j], end, vector))
            j += 1
        return out

    def _sense(self, c: _Circle, start: Vec3, points: list[tuple]) -> tuple[int, str]:
        """Direction about the circle axis: from the points if two or more follow each other
        on it in one direction by less than 90 degrees (not in NX files, which give the end
        only), else the convention."""
        if c.forced or c.why == "nx" or len(points) < 2:
            return c.sense, c.why
        u = [radial(p, c.centre, c.axis)[0] for p in (start, points[0][1], points[1][1])]
        steps = [signed_angle(u[k], u[k + 1], c.axis) for k in range(2)]
        if steps[0] * steps[1] > 0 and max(abs(t) for t in steps) < MAX_LISTED_STEP:
            return (1 if steps[0] > 0 else -1), "points"
        return c.sense, c.why

    def _listed(self, c: _Circle, sense: int, points: list[tuple]) -> int:
        """How many of ``points`` are on the arc: the first, then each following the last by
        at most :data:`MAX_LISTED_STEP` in the arc's direction."""
        n = 1
        prev = points[0][1]
        for _, p, _ in points[1:]:
            if _norm(_sub(p, prev)) > SAME_POINT_MM:
                step = (sense * signed_angle(radial(prev, c.centre, c.axis)[0],
                                             radial(p, c.centre, c.axis)[0], c.axis))
                if not 0.0 < step <= MAX_LISTED_STEP + 1e-12:
                    break
            n += 1
            prev = p
        return n

    def _arc(self, st: Statement, end: Vec3, vector: Vec3 | None) -> None:
        """The GOTO ``st`` after a CIRCLE: the arc to it (and to the points listed after)."""
        s = self.s
        c = s.circle
        assert c is not None
        s.circle = None
        if s.position is None:
            raise self._err(st, f"the arc of the CIRCLE at line {c.statement.line} starts "
                                f"from a position the reader does not know ({s.unknown_why}): "
                                "position the tool with FROM or a GOTO first")
        feed = self._feed_mm_s(st)
        start = s.position
        tol = self._radius_tol()
        r0 = _norm(radial(start, c.centre, c.axis)[0])
        radius = c.radius if c.radius is not None else r0
        if r0 <= SAME_POINT_MM:
            raise self._err(st, f"the arc starts on the axis of the CIRCLE at line "
                                f"{c.statement.line} (radius 0)")
        for what, r in (("starts", r0), ("ends", _norm(radial(end, c.centre, c.axis)[0]))):
            if abs(r - radius) > tol:
                raise self._err(st, f"the arc {what} {r:.4f} mm from the axis of the CIRCLE at "
                                    f"line {c.statement.line}, whose radius is {radius:.4f} mm "
                                    f"(tolerance {tol:.4g} mm)")
        points = [(st, end, vector), *self._on_circle(c, radius, tol, 1)]
        sense, why = self._sense(c, start, points)
        n = 1
        if why == "points":
            points = [(st, end, vector), *self._on_circle(c, radius, tol, len(self.sts))]
            n = self._listed(c, sense, points)
        self.notes.senses.setdefault(why, []).append(c.statement.line)
        prev, a_prev = start, s.axis
        for k, (pst, p, vec) in enumerate(points[:n]):
            if k:
                self._count(pst.args[:3])
                vec = self._resolve(pst, vec)
            self._arc_piece(pst, c, _Seg(prev, p, a_prev, vec), feed, sense,
                            first=why if k == 0 else "")
            prev, a_prev = p, vec
            s.position, s.axis = p, vec
        s.moved = True
        self.i += n - 1

    def _arc_piece(self, st: Statement, c: _Circle, seg: _Seg, feed: float, sense: int,
                   first: str) -> None:
        """The arc from ``seg.start`` to ``seg.end`` about the circle ``c`` (a full circle if
        they coincide in its plane and it is the first piece); ``first``: how the direction
        of the first piece was chosen (empty for the listed points after it)."""
        u0 = radial(seg.start, c.centre, c.axis)[0]
        u1 = radial(seg.end, c.centre, c.axis)[0]
        if _norm(_sub(u1, u0)) <= SAME_POINT_MM:
            sweep = 2.0 * math.pi if first else 0.0
        else:
            sweep = (sense * signed_angle(u0, u1, c.axis)) % (2.0 * math.pi)
        if sweep <= 0.0:
            self._line(st, seg, feed)  # no turn: straight along the axis, or nothing
            return
        if first:
            sweep += 2.0 * math.pi * c.turns
        self._check_spindle(st)
        if first in ("nx", "iso"):
            self._reversal(st, seg.start, _cross(c.axis, u0), sense)
        idx = max(range(3), key=lambda i: abs(c.axis[i]))
        aligned = all(abs(c.axis[i]) <= AXIS_ALIGNED for i in range(3) if i != idx)
        chunks = max(1, math.ceil(sweep / (2.0 * math.pi) - 1e-9))
        prev, a_prev = seg.start, seg.a0
        for k in range(1, chunks + 1):
            t = k / chunks
            p = seg.end if k == chunks else arc_point(c.centre, c.axis, seg, u0, sense * sweep,
                                                      t)
            a = _turn(seg, t)
            piece = _Seg(prev, p, a_prev, a)
            r_prev = _norm(radial(prev, c.centre, c.axis)[0])
            if r_prev <= SAME_POINT_MM:  # from the axis (a radius within tolerance of 0)
                self._line(st, piece, feed)
            elif aligned:
                centre = list(c.centre)
                centre[idx] = prev[idx]
                self._append(st, MoveKind.ARC, MoveCategory.CUT, piece, feed,
                             centre=(centre[0], centre[1], centre[2]), plane=_PLANES[idx],
                             direction=sense * (1 if c.axis[idx] > 0 else -1),
                             sweep_rad=sweep / chunks, radius_mm=r_prev)
            else:
                self._tessellate(st, c, piece, feed, sense * sweep / chunks)
            prev, a_prev = p, a

    def _reversal(self, st: Statement, start: Vec3, tangent: Vec3, sense: int) -> None:
        """Count an arc that starts where a feed move ends, and note it if it starts against
        that move's direction (if most do, the file writes its CIRCLE axes the other way)."""
        if not self.moves:
            return
        last = self.moves[-1]
        if last.feed_mm_s is None or _norm(_sub(last.end, start)) > SAME_POINT_MM:
            return
        self.arcs_after_feed += 1
        d = _end_direction(last)
        n = _norm(d) * _norm(tangent)
        if n > 0 and sense * _dot(d, tangent) / n < REVERSAL_COS:
            self.notes.add("arc_back", st.line)

    def _tessellate(self, st: Statement, c: _Circle, seg: _Seg, feed: float,
                    angle: float) -> None:
        """The arc turning ``angle`` [rad, signed about the axis] as lines within the arc
        tolerance (chord error)."""
        u0 = radial(seg.start, c.centre, c.axis)[0]
        r = max(_norm(u0), _norm(radial(seg.end, c.centre, c.axis)[0]))
        x = 1.0 - self.opt.arc_tolerance_mm / r
        step = 2.0 * math.acos(x) if x > -1.0 else 2.0 * math.pi
        count = max(math.ceil(abs(angle) / step), math.ceil(abs(angle) / (0.5 * math.pi)), 1)
        if count > MAX_ARC_LINES:
            raise self._err(st, f"the arc (radius {r:.4g} mm) needs {count} lines to keep "
                                f"within arc_tolerance_mm {self.opt.arc_tolerance_mm:g} mm, "
                                f"more than {MAX_ARC_LINES}: raise the tolerance")
        prev, a_prev = seg.start, seg.a0
        for j in range(1, count + 1):
            t = j / count
            p = seg.end if j == count else arc_point(c.centre, c.axis, seg, u0, angle, t)
            a = _turn(seg, t)
            self._line(st, _Seg(prev, p, a_prev, a), feed)
            prev, a_prev = p, a
        self.notes.add("tessellated", st.line)

    # ------------------------------------------------------------------ result
    def run(self) -> None:
        """Execute every statement."""
        while self.i < len(self.sts):
            st = self.sts[self.i]
            if st.major == "FINI":
                after = self.sts[self.i + 1:]
                if after:
                    self.notes.items.append(
                        f"{len(after)} statement(s) after FINI (line {st.line}) are not read "
                        f"(first: line {after[0].line})")
                break
            self._dispatch(st)
            self.i += 1
        if self.s.circle is not None:
            raise self._err(self.s.circle.statement, "the file ends before the GOTO to the end "
                                                     "of its arc")

    def _dispatch(self, st: Statement) -> None:
        handler = self.handlers.get(st.major)
        if handler is not None:
            handler(st)
        elif st.major in _REFUSED:
            raise self._err(st, _REFUSED[st.major])
        elif st.major in _NO_EFFECT or st.major.startswith("CSI_"):
            self.notes.once.setdefault(st.major, []).append(st.line)
        else:
            raise self._err(st, "unknown APT statement: the reader cannot tell whether it "
                                "moves the tool (remove the line if it does not). Read: GOTO, "
                                "FROM, GODLTA, GOHOME, RAPID, CIRCLE, MOVARC, TLAXIS, MULTAX, "
                                "UNITS, FEDRAT, SPINDL, LOADTL, CUTTER, TLDATA, DELAY, STOP, "
                                "OPSTOP, FINI and statements without effect on the path")

    def prepare(self) -> None:
        """Settle what the whole file decides: NX style, units without a UNITS statement."""
        majors = {st.major for st in self.sts}
        self.s.nx = bool(majors & {"TOOL PATH", "TLDATA", "MSYS", "END-OF-PATH"})
        if majors & {"UNITS", "UNIT"}:
            return
        if self.opt.units is not None:
            self.s.inch = self.opt.units == "inch"
            return
        feeds = [_words(st.args)[0] for st in self.sts if st.major == "FEDRAT"]
        if feeds and all(w and w[0] in ("IPM", "IPR") for w in feeds):
            self.s.inch = True
            self.notes.items.append(
                "no UNITS statement and every FEDRAT is in inches (IPM/IPR): the coordinates "
                "are read as inches too (NX writes its CLSF in the part's units); give the "
                "reader's units option if they are millimetres")

    def program(self) -> Program:
        """The result."""
        if 2 * len(self.notes.groups.get("arc_back", [])) <= self.arcs_after_feed:
            self.notes.groups.pop("arc_back", None)  # a few cusps: the convention holds
        headers = tuple(ToolHeader(number=h.number, diameter_mm=h.diameter,
                                   corner_radius_mm=h.corner, shape=h.shape, z_min_mm=None,
                                   line=h.statement.line, text=h.statement.text)
                        for h in self.headers)
        return Program(moves=tuple(self.moves), units="inch" if self.s.inch else "mm",
                       work_offsets=(), tools=tuple(self.tools), warnings=self.notes.finish(),
                       source=self.source, stops=tuple(self.stops), tool_headers=headers,
                       resolution_mm=self.resolution_mm())


def parse_apt(text: str, source: str = "<APT>", *, arc_tolerance_mm: float = 0.001,
              circle_direction: Literal["auto", "ccw", "cw"] = "auto",
              units: Literal["mm", "inch"] | None = None) -> Program:
    """Read an APT CL file from text (see the module docstring for what is read).

    Parameters
    ----------
    text, source
        The file's text and its name in messages.
    arc_tolerance_mm
        Largest distance of an arc's points from its CIRCLE's radius (the reader allows
        2*sqrt(2) units of the last written decimal if that is more), and the chord error of
        the lines an arc about a skew axis is cut into [mm].
    circle_direction
        ``"auto"``: points listed along an arc give its direction, else NX CLSF arcs turn
        clockwise about the CIRCLE axis and others counter-clockwise; ``"ccw"``/``"cw"``:
        every CIRCLE arc turns so about its axis.
    units
        Units of a file without a UNITS statement (default: millimetres, inches if all its
        feeds are in inches).

    Returns
    -------
    Program
        Moves in mm with tool vectors, stops (LOADTL, DELAY, STOP, OPSTOP), tool headers
        (CUTTER, TLDATA), the number resolution and the warnings.

    Raises
    ------
    InputError
        A statement that is not read and could move the tool, or one that is inconsistent;
        the message names the line and the statement.
    """
    if not (math.isfinite(arc_tolerance_mm) and arc_tolerance_mm > 0):
        raise ValueError("arc_tolerance_mm must be > 0")
    if circle_direction not in ("auto", "ccw", "cw"):
        raise ValueError("circle_direction must be 'auto', 'ccw' or 'cw'")
    if units not in (None, "mm", "inch"):
        raise ValueError("units must be None, 'mm' or 'inch'")
    reader = _Reader(source, _Options(arc_tolerance_mm, circle_direction, units),
                     split_statements(text, source))
    reader.prepare()
    reader.run()
    return reader.program()


def read_apt(path: str | Path, **options) -> Program:
    """Read an APT CL file (UTF-8, or Latin-1 as some posts write it); options as
    :func:`parse_apt`.

    Raises
    ------
    InputError
        The file is missing, too large, or not a CL file the reader can read.
    """
    data = read_user_bytes(path, "APT CL file", max_bytes_for("G-code program"))
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        program = parse_apt(data.decode("latin-1"), source=str(path), **options)
        note = (f"not UTF-8 text (undecodable byte at offset {exc.start}): read as Latin-1 "
                "(the statements are ASCII; only comments can differ)")
        return replace(program, warnings=(note, *program.warnings))
    return parse_apt(text, source=str(path), **options)
