"""Executing lexed G-code blocks with modal state into :class:`~feedopt.gcode.moves.Move` s.

Within a block the words take effect in the RS-274/NGC order: F, S, T, M6, M3/M4/M5, M7-M9,
G4 (dwell), plane, units, G40, G43/G49, work offset, G61/G61.1/G64, G90/G91, G90.1/G91.1,
then motion (G28 or G0-G3, G53 modifying G0), then M0/M1/M2/M30. Everything outside the
supported subset is refused (:mod:`feedopt.gcode.codes` lists the codes).

Stops (:attr:`Program.stops`): a move ending while G61/G61.1 is active or in a G9 block gets
an exact stop after it; G4 a dwell, M0/M1 a (optional) program stop after the block's motion;
M6 a tool change after the moves before its block.

Unknown positions: at the program start and after M6, G28 and G53 the reader does not know
where the tool is (on the named axes). Rapids from there are not in the move list; a feed line
(G1) from there takes its unknown start coordinates from its end and is marked
``approach`` (the path reaches it through the air); an arc from there is refused.

Arc radius check: the start and end radii may differ by ``max(arc_tolerance_mm, 2 sqrt(2) *
resolution)``, the resolution being one unit of the last decimal the program writes its
coordinates with (both points and the centre are rounded by half a unit).

Tool vectors (five-axis). ``G43.5 H..`` (Fanuc tool centre point control type 2; G49 or G43
ends it) and Sinumerik ``TRAORI`` (``TRAFOOF`` ends it) switch tool-vector programming on: X Y Z
stay the tool tip, and a motion block's ``I J K`` (G43.5) or ``A3= B3= C3=`` (TRAORI) is the
tool vector at its end point, from the tip into the spindle, in the program frame (Fanuc
30i/15i and Sinumerik 840D manuals): a block with none keeps the last vector (modal), a block
with some reads the missing components as 0 (Fanuc 15i note 3; Siemens: "vector components
that have not been programmed are set to zero"), the vector is normalised, never scaled by G20
nor made incremental by G91, and a zero vector is refused. Before any vector is given the tool
is along +Z (noted). A move's ``axis_start`` is the vector before its block (its end vector for
the first move of the program), ``axis_end`` the block's; a block that only turns the tool
(no position, or a zero-length move) is not a move: the next move starts from the turned vector
(noted). PLUNGE/RETRACT are feed lines along the move's end vector. G2/G3 are refused under
G43.5 (its I J K are the vector; Fanuc's R-form tool-vector arcs are not read), read under
TRAORI. Once a program uses G43.5 or TRAORI anywhere, every move carries vectors (+Z outside
them, so the path is consistent); three-axis programs keep ``None``. Rotary axis words (A B C,
G43.4) stay refused: their positions need the machine's kinematics.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

from feedopt.errors import InputError
from feedopt.gcode.codes import (
    G4,
    G28,
    G43,
    G43_5,
    G64,
    G80,
    MOTION,
    PLANES,
    SPINDLE_M,
    VECTOR_WORDS,
    sort_words,
)
from feedopt.gcode.headers import looks_like_tool, tool_header
from feedopt.gcode.lexer import Block, Word, lex_line, split_lines, where
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
from feedopt.gcode.notes import Notes
from feedopt.gcode.resolution import (
    radius_tolerance_mm,
    resolution_mm,
    unit_scale,
)
from feedopt.textio import read_user_text

#: A G4 P at least this large (and whole) is probably milliseconds when read as seconds.
DWELL_P_HINT = 100.0
_NAN3 = (math.nan, math.nan, math.nan)
_AXES = "XYZ"
_OFFSETS = "IJK"
_COORDINATES = "XYZIJKR"
_IJK = ("I", "J", "K")
Vec3 = tuple[float, float, float]
#: The tool vector of three-axis moves, and of five-axis ones before any vector is given
PLUS_Z: Vec3 = (0.0, 0.0, 1.0)
_THREE_AXIS = (PLUS_Z, PLUS_Z)


@dataclass(frozen=True)
class _Options:
    """parse_gcode's options (see there)."""

    arc_absolute: bool
    arc_tolerance_mm: float
    block_delete: bool
    dwell_p_ms: bool


@dataclass
class _State:
    """Modal state of the interpreter."""

    inch: bool = False
    absolute: bool = True
    arc_absolute: bool = False
    plane: Plane = Plane.XY
    motion: MoveKind | None = None
    ccw: bool = False
    feed_raw: float | None = None
    spindle_rpm: float | None = None
    spindle_direction: int = 0
    spindle_stopped_at: int | None = None
    next_tool: int | None = None
    tool: int | None = None
    work_offset: str | None = None
    length_offset: int | None = None
    exact_mode: bool = False
    blend_tolerance_mm: float | None = None
    position: Vec3 = _NAN3
    unknown_why: str = "the program start (no G0 to X, Y and Z yet)"
    moved: bool = False
    #: tool-vector programming in force: "G43.5", "TRAORI" or None; the line switching it on
    tcp: str | None = None
    tcp_line: int = 0
    #: a tool vector was given since tcp was switched on
    tcp_vector: bool = False
    #: the tool vector after the last motion block (None before any)
    axis: Vec3 | None = None


@dataclass
class _RadiusCheck:
    """An arc whose radii differ by more than the tolerance but less than the resolution
    allows so far: checked again against the program's final resolution."""

    mismatch_mm: float
    block: Block
    message: Callable[[str], str]


@dataclass
class _Collected:
    """What the reader gathers besides the moves."""

    stops: list[Stop] = field(default_factory=list)
    offsets: list[str] = field(default_factory=list)
    tools: list[int] = field(default_factory=list)
    tool_comments: list[tuple[int, str]] = field(default_factory=list)
    radius_checks: list[_RadiusCheck] = field(default_factory=list)
    decimals: int | None = None
    arcs: int = 0


#: More decimals than this say nothing about a post's rounding (float noise): capped.
MAX_DECIMALS = 12


def _decimals(word: Word) -> int:
    """Digits written after the decimal point of ``word`` (``X1.250``: 3, ``X12``: 0), at most
    :data:`MAX_DECIMALS`."""
    text = word.text
    return min(len(text) - text.index(".") - 1 if "." in text else 0, MAX_DECIMALS)


class _Interpreter:
    """Runs blocks through the modal state; collects moves, stops and warnings."""

    def __init__(self, source: str, options: _Options, start_position: Vec3 | None) -> None:
        self.source = source
        self.opt = options
        self.s = _State(arc_absolute=options.arc_absolute)
        if start_position is not None:
            self.s.position = (float(start_position[0]), float(start_position[1]),
                               float(start_position[2]))
        self.notes = Notes()
        self.moves: list[Move] = []
        self.got = _Collected()
        self.program_number: int | None = None
        self.ended_at: int | None = None
        self.approach_pending = False
        #: tool vectors at the start and end of each move, and of the move being made
        self.axes: list[tuple[Vec3, Vec3]] = []
        self.cur_axes: tuple[Vec3, Vec3] = _THREE_AXIS
        self.five_axis = False

    # ----------------------------------------------------------------- helpers
    def _err(self, b: Block, msg: str) -> InputError:
        return InputError(f"{where(self.source, b.line, b.n_number)}: {msg}")

    @property
    def _scale(self) -> float:
        return unit_scale(self.s.inch)

    def resolution_mm(self) -> float | None:
        """One unit of the last decimal of the coordinates read so far [mm]."""
        return resolution_mm(self.got.decimals, self.s.inch)

    def arc_tolerance_mm(self) -> float:
        """The radius tolerance in force: the option, or the rounding the resolution allows."""
        return radius_tolerance_mm(self.opt.arc_tolerance_mm, self.resolution_mm())

    def _tolerance_text(self, tol: float) -> str:
        if tol <= self.opt.arc_tolerance_mm:
            return (f"tolerance {tol:g} mm: path.arc_tolerance_mm (feedopt path "
                    "--arc-tolerance)")
        return (f"tolerance {tol:.4g} mm: 2*sqrt(2) x the program's resolution "
                f"{self.resolution_mm():g} mm, larger than path.arc_tolerance_mm "
                f"{self.opt.arc_tolerance_mm:g} mm")

    def _stop(self, b: Block, kind: StopKind, hold_s: float = 0.0) -> None:
        self.got.stops.append(Stop(after_move=len(self.moves) - 1, kind=kind, hold_s=hold_s,
                                   line=b.line, n_number=b.n_number, text=b.text))

    # ------------------------------------------------------------------ blocks
    def run(self, text: str) -> None:
        """Execute every block of ``text``."""
        first_code = True
        percent_open = False
        lines = split_lines(text)
        for i, raw in enumerate(lines, start=1):
            b = lex_line(raw, i, self.source)
            self.got.tool_comments.extend((b.line, c) for c in b.comments if looks_like_tool(c))
            if b.percent:
                if first_code:
                    percent_open = True
                    first_code = False
                    continue
                self._after_end(lines, b, "%")
                return
            if not b.words:
                continue
            first_code = False
            if b.block_delete and self.opt.block_delete:
                self.notes.add("deleted", b.line)
                continue
            self.block(b)
            if self.ended_at is not None:
                self._after_end(lines, b, b.text.strip())
                return
        if percent_open:
            self.notes.items.append("the program starts with '%' but has no closing '%'")
        self.notes.items.append("no program end (M2/M30): is the file complete?")

    def _after_end(self, lines: list[str], end: Block, what: str) -> None:
        """Warn about code after the end of the program (which is not read)."""
        ignored = []
        for i in range(end.line + 1, len(lines) + 1):
            try:
                blk = lex_line(lines[i - 1], i, self.source)
            except InputError:
                ignored.append(i)
                continue
            if blk.words:
                ignored.append(i)
        if ignored:
            self.notes.items.append(
                f"{len(ignored)} line(s) with code after the program end (line {end.line}: "
                f"{what}) are not read (first: line {ignored[0]})")

    def block(self, b: Block) -> None:
        """Execute one block."""
        words = sort_words(b, lambda msg: self._err(b, msg))
        gs, vals = words.gs, dict(words.vals)
        mcodes = [m for m, _ in words.ms]
        if "O" in vals:
            self._program_number(b, vals)
            return
        self._feed_speed_tool(b, vals)
        if 6 in mcodes:
            self._tool_change(b)
        self._spindle(b, mcodes)
        if gs.get("non-modal", (0,))[0] == G4:
            self._dwell(b, vals)
        self._modes(b, gs, vals)
        vector = self._tool_vector(b, vals)
        for letter in _COORDINATES:
            if letter in vals:
                d = _decimals(vals[letter])
                self.got.decimals = d if self.got.decimals is None else max(self.got.decimals, d)
        before = len(self.moves)
        self._motion(b, gs, vals, vector)
        if len(self.moves) > before and (self.s.exact_mode or "exact stop" in gs):
            self._stop(b, StopKind.EXACT)
        for m, _ in words.ms:
            if m in (0, 1):
                self._stop(b, StopKind.PROGRAM_STOP if m == 0 else StopKind.OPTIONAL_STOP)
            elif m in (2, 30):
                self.ended_at = b.line

    def _program_number(self, b: Block, vals: dict[str, Word]) -> None:
        w = vals["O"]
        if self.moves or self.s.moved or len(b.words) != 1 + (b.n_number is not None):
            raise self._err(b, f"{w.text}: an O word is only read as the program number alone "
                               "on a line before the first move (subprograms are not "
                               "supported)")
        if not w.text[1:].isdigit():
            raise self._err(b, f"{w.text}: program number must be a whole number")
        self.program_number = int(w.text[1:])

    def _feed_speed_tool(self, b: Block, vals: dict[str, Word]) -> None:
        s = self.s
        if "F" in vals:
            f = vals["F"].value
            if not f > 0:
                raise self._err(b, f"{vals['F'].text}: feed must be > 0")
            s.feed_raw = f
        if "S" in vals:
            if vals["S"].value < 0:
                raise self._err(b, f"{vals['S'].text}: spindle speed must be >= 0")
            s.spindle_rpm = vals["S"].value
        if "T" in vals:
            w = vals["T"]
            if not w.text[1:].isdigit():
                raise self._err(b, f"{w.text}: tool number must be a whole number >= 0")
            s.next_tool = int(w.text[1:])

    def _tool_change(self, b: Block) -> None:
        s = self.s
        if s.next_tool is None:
            raise self._err(b, "M6 without a tool selected (no T word before or on the line)")
        s.tool = s.next_tool
        s.position = _NAN3
        s.unknown_why = f"the tool change at line {b.line} (M6 position is machine-specific)"
        self._stop(b, StopKind.TOOL_CHANGE)

    def _spindle(self, b: Block, mcodes: list[int]) -> None:
        s = self.s
        for m in mcodes:
            if m in SPINDLE_M:
                if m == 5 and s.spindle_direction != 0:
                    s.spindle_stopped_at = b.line
                elif m != 5:
                    s.spindle_stopped_at = None
                s.spindle_direction = SPINDLE_M[m]

    def _dwell(self, b: Block, vals: dict[str, Word]) -> None:
        """G4 P (seconds, or ms with dwell_p_units ms; other words of the block move after
        the dwell as in RS-274/NGC) or Fanuc's G4 X (seconds, alone)."""
        p = vals.get("P")
        word = p
        if p is None and "X" in vals:
            word = vals.pop("X")
            others = [vals[c].text for c in _COORDINATES if c in vals]
            if others:
                raise self._err(b, f"G4 {word.text} (dwell seconds) with {', '.join(others)}: "
                                   "give the dwell as G4 P<seconds> or put the move on its own "
                                   "line")
        if word is None:
            raise self._err(b, "G4 without P: give the dwell time (G4 P<seconds>, or "
                               "milliseconds with path.dwell_p_units: ms)")
        if word.value < 0:
            raise self._err(b, f"G4 {word.text}: the dwell time must be >= 0")
        hold = word.value
        if p is not None and self.opt.dwell_p_ms:
            hold = word.value / 1000.0
        elif p is not None and hold >= DWELL_P_HINT and hold == int(hold):
            self.notes.add("dwell_large", b.line)
        self._stop(b, StopKind.DWELL, hold)

    def _modes(self, b: Block, gs: dict[str, tuple[int, Word]], vals: dict[str, Word]) -> None:
        s = self.s
        if "plane" in gs:
            s.plane = PLANES[gs["plane"][0]]
        if "units" in gs:
            key, w = gs["units"]
            inch = key == 200
            if inch != s.inch and s.moved:
                raise self._err(b, f"{w.text}: switching units after the first move is not "
                                   f"supported (the program was {'inch' if s.inch else 'mm'} "
                                   "until here)")
            s.inch = inch
        self._length_offset(b, gs, vals)
        if "TRAORI" in vals and "TRAFOOF" in vals:
            raise self._err(b, "TRAORI and TRAFOOF in one block")
        if "TRAORI" in vals:
            self._tcp_on(b, "TRAORI")
        elif "TRAFOOF" in vals:
            self._tcp_off(b, "TRAFOOF")
        if "work offset" in gs:
            s.work_offset = f"G{gs['work offset'][0] // 10}"
        if "path control" in gs:
            self._path_control(b, gs["path control"][0], vals)
        if "distance" in gs:
            s.absolute = gs["distance"][0] == 900
        if "arc distance" in gs:
            s.arc_absolute = gs["arc distance"][0] == 901

    def _length_offset(self, b: Block, gs: dict[str, tuple[int, Word]],
                       vals: dict[str, Word]) -> None:
        s = self.s
        if "tool length" in gs:
            key, _ = gs["tool length"]
            if key in (G43, G43_5):
                h = vals.get("H")
                if h is None:  # LinuxCNC: the offset of the tool in the spindle
                    s.length_offset = s.tool if s.tool is not None else 0
                elif not h.text[1:].isdigit():
                    raise self._err(b, f"{h.text}: H must be a whole number >= 0")
                else:
                    s.length_offset = int(h.text[1:])
                if key == G43_5:
                    self._tcp_on(b, "G43.5")
                    self.notes.items.append(
                        f"line {b.line}: G43.5 H{s.length_offset} tool centre point control "
                        "with tool vectors (I J K); H recorded, no geometric effect (moves are "
                        "the programmed tool-tip positions)")
                else:
                    self._tcp_off(b, "G43")
                    self.notes.items.append(
                        f"line {b.line}: G43 H{s.length_offset} tool length offset recorded, "
                        "no geometric effect (moves are the programmed tool-tip positions)")
            else:
                s.length_offset = None
                self._tcp_off(b, "G49")
        if "H" in vals and gs.get("tool length", (0,))[0] not in (G43, G43_5):
            raise self._err(b, f"{vals['H'].text}: H is only read with G43 or G43.5")

    def _path_control(self, b: Block, key: int, vals: dict[str, Word]) -> None:
        """G61/G61.1: exact stop mode; G64: blending, G64 P its tolerance for later moves."""
        s = self.s
        s.exact_mode = key != G64
        s.blend_tolerance_mm = None
        if key != G64:
            return
        p = vals.get("P")
        if p is not None:
            if p.value < 0:
                raise self._err(b, f"G64 {p.text}: the path tolerance must be >= 0")
            if p.value > 0:  # G64 P0 is G64 alone (no limit) as in LinuxCNC
                s.blend_tolerance_mm = p.value * self._scale
        if "Q" in vals:
            self.notes.add("g64_q", b.line)

    # ------------------------------------------------------------- tool vectors
    def _tcp_on(self, b: Block, code: str) -> None:
        """Tool-vector programming on (G43.5 or TRAORI); the same code again changes nothing."""
        s = self.s
        if s.tcp is not None and s.tcp != code:
            off = "G49" if s.tcp == "G43.5" else "TRAFOOF"
            raise self._err(b, f"{code} while {s.tcp} (line {s.tcp_line}) is in force: end it "
                               f"with {off} first")
        if s.tcp is None:
            s.tcp, s.tcp_line, s.tcp_vector = code, b.line, False
        self.five_axis = True

    def _tcp_off(self, b: Block, code: str) -> None:
        """``code`` (G49 or G43: G43.5; TRAFOOF: TRAORI) ends tool-vector programming; the
        tool is along +Z after it."""
        s = self.s
        if s.tcp is None or (code == "TRAFOOF") != (s.tcp == "TRAORI"):
            return
        if s.axis is not None and s.axis != PLUS_Z:
            shown = ", ".join(f"{c:.4g}" for c in s.axis)
            self.notes.items.append(
                f"line {b.line}: {code} ends {s.tcp} with the tool vector ({shown}): the moves "
                "after it are read with the tool along +Z (where the rotary axes stand is not "
                "known without the machine's kinematics)")
            s.axis = PLUS_Z
        s.tcp = None

    def _tool_vector(self, b: Block, vals: dict[str, Word]) -> Vec3 | None:
        """The block's tool vector, normalised (its words are taken out of ``vals``); None if
        it gives none. Components not written are 0."""
        s = self.s
        letters = VECTOR_WORDS if s.tcp == "TRAORI" else _IJK if s.tcp == "G43.5" else ()
        stray = [vals[k].text for k in VECTOR_WORDS if k in vals and k not in letters]
        if stray:
            raise self._err(b, f"{', '.join(stray)}: A3=, B3=, C3= (a Sinumerik tool vector) "
                               "are only read after TRAORI")
        words = {k: vals.pop(k) for k in letters if k in vals}
        if not words:
            return None
        comps = [words[k].value if k in words else 0.0 for k in letters]
        n = math.hypot(*comps)
        text = " ".join(w.text for w in words.values())
        v = tuple(c / n for c in comps) if n > 0.0 and math.isfinite(n) else (math.nan,)
        if not all(math.isfinite(c) for c in v):
            raise self._err(b, f"{text}: the tool vector has no direction (zero length): give "
                               "the direction of the tool, from its tip into the spindle")
        return (v[0], v[1], v[2])

    def _set_axes(self, b: Block, vector: Vec3 | None) -> None:
        """The tool vectors at the start and end of the block's motion (``cur_axes``)."""
        s = self.s
        end = vector or s.axis or PLUS_Z
        if s.tcp is not None:
            if vector is not None:
                s.tcp_vector = True
            elif not s.tcp_vector:
                self.notes.add("plus_z", b.line)
        self.cur_axes = (s.axis or end, end)

    def _turn(self, b: Block, vector: Vec3) -> None:
        """A block that only gives a tool vector: the tool turns in place."""
        s = self.s
        if s.axis is not None and s.axis != vector:
            self.notes.add("turn", b.line)
        s.axis = vector
        s.tcp_vector = True

    def _no_vector(self, b: Block, vector: Vec3 | None, code: str) -> None:
        """Refuse a tool vector on a G28 or G53 line."""
        if vector is not None:
            raise self._err(b, f"a tool vector with {code}: give it on a G0 or G1 line")

    def _feed_category(self, dx: float, dy: float, dz: float) -> MoveCategory:
        """PLUNGE/RETRACT for a feed line along -/+ the move's end tool vector, else CUT."""
        a = self.cur_axes[1]
        if a == PLUS_Z:
            if math.hypot(dx, dy) <= SAME_POINT_MM:
                return MoveCategory.PLUNGE if dz < 0 else MoveCategory.RETRACT
            return MoveCategory.CUT
        along = dx * a[0] + dy * a[1] + dz * a[2]
        lateral = math.sqrt((dx - along * a[0]) ** 2 + (dy - along * a[1]) ** 2
                            + (dz - along * a[2]) ** 2)
        if lateral <= SAME_POINT_MM:
            return MoveCategory.PLUNGE if along < 0 else MoveCategory.RETRACT
        return MoveCategory.CUT

    def _add(self, move: Move) -> None:
        self.moves.append(move)
        self.axes.append(self.cur_axes)

    # ------------------------------------------------------------------ motion
    def _motion(self, b: Block, gs: dict[str, tuple[int, Word]], vals: dict[str, Word],
                vector: Vec3 | None) -> None:
        s = self.s
        axes = {a: vals[a] for a in _AXES if a in vals}
        offsets = {a: vals[a] for a in _OFFSETS if a in vals}
        radius = vals.get("R")
        if "motion" in gs:
            key, _ = gs["motion"]
            if key == G80:
                # G80 cancels canned cycles, which the reader refuses anyway. Fanuc and Haas
                # keep G0/G1/G2/G3 modal across it (their posts write G80 in the safety line
                # and continue with bare coordinates); RS-274/NGC would cancel the motion.
                if axes:
                    raise self._err(b, f"G80 with axis words "
                                       f"({', '.join(x.text for x in axes.values())}): give "
                                       "G0 or G1")
            else:
                s.motion = MOTION[key]
                s.ccw = key == 30
        if gs.get("non-modal", (0,))[0] == G28:
            if "motion" in gs or "machine coordinates" in gs:
                raise self._err(b, "G28 with a motion code or G53 in the same block")
            if offsets or radius:
                raise self._err(b, "I, J, K or R with G28")
            self._no_vector(b, vector, "G28")
            self._set_axes(b, None)
            self._g28(b, axes)
            return
        kind = s.motion
        if s.tcp == "G43.5" and kind is MoveKind.ARC and (axes or vector or radius is not None):
            raise self._err(b, f"{self._code(kind)} under G43.5 (line {s.tcp_line}): I, J, K "
                               "are the tool vector there, and tool-vector arcs (Fanuc's R "
                               "form) are not read: post the arcs as G1 lines")
        if (offsets or radius is not None) and kind is not MoveKind.ARC:
            word = (radius or next(iter(offsets.values()))).text
            raise self._err(b, f"{word}: I, J, K and R are only read with G2/G3 (and as the "
                               "tool vector under G43.5)")
        if "machine coordinates" in gs:
            self._no_vector(b, vector, "G53")
        if not axes and not (kind is MoveKind.ARC and (offsets or radius is not None)):
            if vector is not None:
                self._turn(b, vector)
            return  # G53 without axis words moves nothing
        if kind is None:
            raise self._err(b, f"axis words ({', '.join(x.text for x in axes.values())}) "
                               "without an active motion mode (G0, G1, G2, G3): give one")
        if "machine coordinates" in gs:
            self._g53(b, axes, kind)
            return
        self._set_axes(b, vector)
        self._move(b, kind, axes, offsets, radius)
        s.axis = self.cur_axes[1]

    def _target(self, axes: dict[str, Word]) -> Vec3:
        """Where the axis words send the tool (NaN where that is unknown)."""
        s = self.s
        sc = self._scale
        start = s.position
        target = list(start)
        for a, w in axes.items():
            i = _AXES.index(a)
            target[i] = w.value * sc if s.absolute else start[i] + w.value * sc
        return (target[0], target[1], target[2])

    def _code(self, kind: MoveKind) -> str:
        if kind is MoveKind.ARC:
            return "G3" if self.s.ccw else "G2"
        return "G1" if kind is MoveKind.LINE else "G0"

    def _move(self, b: Block, kind: MoveKind, axes: dict[str, Word],
              offsets: dict[str, Word], radius: Word | None) -> None:
        s = self.s
        start = s.position
        end = self._target(axes)
        s.moved = True
        known = self._known_start(b, kind, start, end)
        if known is None:  # a rapid from an unknown position
            s.position = end
            self.notes.add("omitted", b.line)
            return
        start, approach = known
        if kind is MoveKind.RAPID:
            self._line(b, start, end, None)
        else:
            if s.feed_raw is None:
                raise self._err(b, "feed move without a feed rate: no F word before or on this "
                                   "line")
            feed = s.feed_raw * self._scale / 60.0
            if kind is MoveKind.LINE:
                self._line(b, start, end, feed, approach=approach)
            else:
                self._arc(b, start, end, feed, offsets, radius)
        s.position = end

    def _known_start(self, b: Block, kind: MoveKind, start: Vec3,
                     end: Vec3) -> tuple[Vec3, bool] | None:
        """The move's start and whether it is an approach (its unknown coordinates taken from
        its end); None for a rapid from an unknown position."""
        unknown = [i for i in range(3) if math.isnan(start[i])]
        if not unknown:
            return start, False
        if kind is MoveKind.RAPID:
            return None
        code = self._code(kind)
        names = ", ".join(_AXES[i] for i in unknown)
        why = f"{names} unknown since {self.s.unknown_why}"
        if kind is MoveKind.ARC:
            raise self._err(b, f"{code} from a position the reader does not know ({why}): an "
                               "arc's centre needs its start; position the tool with G0 X Y Z "
                               "(or a G1) first")
        missing = [_AXES[i] for i in unknown if math.isnan(end[i])]
        if missing:
            raise self._err(b, f"{code} from a position the reader does not know ({why}), and "
                               f"the line does not give {', '.join(missing)} in absolute "
                               "coordinates: position the tool with G0 X Y Z first")
        self.notes.add("approach", b.line)
        filled = tuple(end[i] if math.isnan(start[i]) else start[i] for i in range(3))
        return (filled[0], filled[1], filled[2]), True

    def _g53(self, b: Block, axes: dict[str, Word], kind: MoveKind) -> None:
        """G53 G0: to machine coordinates the reader does not know (a retract)."""
        s = self.s
        if kind is not MoveKind.RAPID:
            raise self._err(b, "G53 (machine coordinates) is only read with G0: write G53 G0 "
                               "(controllers differ on G53 in G1 mode)")
        if not s.absolute:
            raise self._err(b, "G53 in incremental mode (G91)")
        end = list(s.position)
        for a in axes:
            end[_AXES.index(a)] = math.nan
        s.position = (end[0], end[1], end[2])
        s.unknown_why = f"the G53 machine-coordinate move at line {b.line}"
        self.notes.add("g53", b.line)
        s.moved = True

    def _g28(self, b: Block, axes: dict[str, Word]) -> None:
        """G28: rapid to the intermediate point, then the named axes go to machine home."""
        s = self.s
        if not axes:
            raise self._err(b, "G28 without axis words: which axes go home is machine-specific; "
                               "name them (e.g. G28 G91 Z0)")
        start = s.position
        mid = self._target(axes)
        s.moved = True
        if any(math.isnan(c) for c in start + mid):
            self.notes.add("omitted", b.line)
        else:  # G28 G91 Z0 (the usual home return) has no intermediate move: no note
            self._line(b, start, mid, None, quiet_if_zero=True)
        home = list(mid)
        for a in axes:
            home[_AXES.index(a)] = math.nan
        s.position = (home[0], home[1], home[2])
        s.unknown_why = f"the G28 return to machine home at line {b.line}"
        self.notes.items.append(
            f"line {b.line}: G28 returns {''.join(axes)} to machine home, which the reader does "
            "not know: that part of the move is not in the move list")

    def _common(self, b: Block) -> dict:
        s = self.s
        got = self.got
        if s.work_offset is not None and s.work_offset not in got.offsets:
            got.offsets.append(s.work_offset)
        if s.tool is not None and s.tool not in got.tools:
            got.tools.append(s.tool)
        approach = self.approach_pending
        self.approach_pending = False
        return dict(spindle_rpm=s.spindle_rpm, spindle_direction=s.spindle_direction,
                    tool=s.tool, work_offset=s.work_offset, length_offset=s.length_offset,
                    line=b.line, n_number=b.n_number, text=b.text,
                    blend_tolerance_mm=s.blend_tolerance_mm, approach=approach)

    def _check_spindle(self, b: Block, category: MoveCategory) -> None:
        """A cut after M5 is refused; other feed moves without the spindle are noted."""
        s = self.s
        if s.spindle_direction != 0:
            return
        if category is MoveCategory.CUT and s.spindle_stopped_at is not None:
            raise self._err(b, f"cut with the spindle stopped (M5 at line "
                               f"{s.spindle_stopped_at}): start it with M3 or M4 before this "
                               "move")
        self.notes.add("spindle_off", b.line)

    def _line(self, b: Block, start: Vec3, end: Vec3, feed: float | None,
              quiet_if_zero: bool = False, approach: bool = False) -> None:
        dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
        if math.sqrt(dx * dx + dy * dy + dz * dz) <= SAME_POINT_MM:
            if approach:
                self.approach_pending = True
            elif not quiet_if_zero:
                a0, a1 = self.cur_axes
                self.notes.add("zero_length" if a0 == a1 else "turn", b.line)
            return
        if feed is None:
            kind, cat = MoveKind.RAPID, MoveCategory.RAPID
        else:
            kind = MoveKind.LINE
            cat = self._feed_category(dx, dy, dz)
            self._check_spindle(b, cat)
        if approach:
            self.approach_pending = True
        self._add(Move(kind, cat, start, end, feed, **self._common(b)))

    # -------------------------------------------------------------------- arcs
    def _radius_check(self, b: Block, mismatch_mm: float,
                      message: Callable[[str], str]) -> None:
        """Refuse ``mismatch_mm`` over the tolerance; keep it for the final check if only the
        resolution read so far allows it."""
        if mismatch_mm <= self.opt.arc_tolerance_mm:
            return
        tol = self.arc_tolerance_mm()
        if mismatch_mm > tol:
            raise self._err(b, message(self._tolerance_text(tol)))
        self.got.radius_checks.append(_RadiusCheck(mismatch_mm, b, message))

    def _centre_r(self, b: Block, code: str, start: Vec3, end: Vec3,
                  radius: Word) -> tuple[float, float]:
        """In-plane centre of an R-form arc."""
        u, v, _ = self.s.plane.value
        su, sv, eu, ev = start[u], start[v], end[u], end[v]
        chord = math.hypot(eu - su, ev - sv)
        r = radius.value * self._scale
        if r == 0:
            raise self._err(b, f"{code} {radius.text}: radius must not be 0")
        if chord <= SAME_POINT_MM:
            raise self._err(b, f"{code} {radius.text}: start and end are the same point in the "
                               f"{self.s.plane.gcode} plane; a full circle needs I/J/K, not R")
        half = chord / 2.0
        rr = abs(r)
        h = 0.0
        if half > rr:
            self._radius_check(b, half - rr, lambda tol: (
                f"{code} {radius.text}: radius {rr:.4f} mm is too small for the chord "
                f"{chord:.4f} mm (end not reachable; {tol})"))
        else:
            h = math.sqrt(rr * rr - half * half)
        direction = 1 if self.s.ccw else -1
        side = direction * (1 if r > 0 else -1)
        mu, mv = (su + eu) / 2.0, (sv + ev) / 2.0
        lu, lv = -(ev - sv) / chord, (eu - su) / chord
        return mu + side * h * lu, mv + side * h * lv

    def _centre_ijk(self, b: Block, code: str, start: Vec3,
                    offsets: dict[str, Word]) -> tuple[float, float]:
        """In-plane centre of an I/J/K arc (incremental from the start, or G90.1 absolute)."""
        plane = self.s.plane
        u, v, n = plane.value
        if not offsets:
            raise self._err(b, f"{code} without a centre (I, J, K) or a radius (R)")
        normal_letter = _OFFSETS[n]
        if normal_letter in offsets and offsets[normal_letter].value != 0:
            raise self._err(b, f"{offsets[normal_letter].text}: {normal_letter} is not a centre "
                               f"offset in the {plane.gcode} plane")
        cc = [0.0, 0.0, 0.0]
        for i in (u, v):
            letter = _OFFSETS[i]
            if self.s.arc_absolute:
                if letter not in offsets:
                    raise self._err(b, f"{code} with absolute arc centres (G90.1) needs "
                                       f"{_OFFSETS[u]} and {_OFFSETS[v]}: {letter} missing")
                cc[i] = offsets[letter].value * self._scale
            else:
                cc[i] = start[i] + (offsets[letter].value * self._scale
                                    if letter in offsets else 0.0)
        return cc[u], cc[v]

    def _arc(self, b: Block, start: Vec3, end: Vec3, feed: float, offsets: dict[str, Word],
             radius: Word | None) -> None:
        s = self.s
        plane = s.plane
        u, v, n = plane.value
        code = "G3" if s.ccw else "G2"
        if radius is not None:
            if offsets:
                raise self._err(b, f"{code} with both R and I/J/K: give one")
            cu, cv = self._centre_r(b, code, start, end, radius)
        else:
            cu, cv = self._centre_ijk(b, code, start, offsets)
        su, sv, eu, ev = start[u], start[v], end[u], end[v]
        r0 = math.hypot(su - cu, sv - cv)
        r1 = math.hypot(eu - cu, ev - cv)
        if r0 <= SAME_POINT_MM:
            raise self._err(b, f"{code}: the centre is at the start point (radius 0)")
        self._radius_check(b, abs(r0 - r1), lambda tol: (
            f"{code}: start and end are not on one circle: start radius {r0:.4f} mm, end "
            f"radius {r1:.4f} mm (differ by {abs(r0 - r1):.4f} mm, {tol})"))
        a0 = math.atan2(sv - cv, su - cu)
        a1 = math.atan2(ev - cv, eu - cu)
        if math.hypot(eu - su, ev - sv) <= SAME_POINT_MM:
            sweep = 2.0 * math.pi
        else:
            sweep = ((a1 - a0) if s.ccw else (a0 - a1)) % (2.0 * math.pi)
        centre = [0.0, 0.0, 0.0]
        centre[u], centre[v], centre[n] = cu, cv, start[n]
        self._check_spindle(b, MoveCategory.CUT)
        self.got.arcs += 1
        self._add(Move(
            MoveKind.ARC, MoveCategory.CUT, start, end, feed, **self._common(b),
            centre=(centre[0], centre[1], centre[2]), plane=plane, direction=1 if s.ccw else -1,
            sweep_rad=sweep, radius_mm=r0))

    # ------------------------------------------------------------------ result
    def _final_arc_checks(self) -> None:
        """Arcs accepted on the resolution read so far, against the program's resolution; and
        a note if that resolution widens the tolerance."""
        tol = self.arc_tolerance_mm()
        for c in self.got.radius_checks:
            if c.mismatch_mm > tol:
                raise self._err(c.block, c.message(self._tolerance_text(tol)))
        if self.got.arcs and tol > self.opt.arc_tolerance_mm:
            self.notes.items.append(
                f"arc radii checked to {tol:.4g} mm, not path.arc_tolerance_mm "
                f"({self.opt.arc_tolerance_mm:g} mm): the program writes its coordinates to "
                f"{self.got.decimals} decimal(s) ({self.resolution_mm():g} mm), and rounding "
                "each end and the centre by half of that moves a radius by up to 2*sqrt(2) x "
                "as much")

    def program(self) -> Program:
        """The result."""
        self._final_arc_checks()
        scale = self._scale
        headers = [tool_header(text, line, scale) for line, text in self.got.tool_comments]
        moves = tuple(self.moves)
        if self.five_axis:
            moves = tuple(replace(m, axis_start=a0, axis_end=a1)
                          for m, (a0, a1) in zip(moves, self.axes, strict=True))
            self.notes.items.append(
                "five-axis program (G43.5 or TRAORI): every move carries tool vectors; moves "
                "outside G43.5/TRAORI are read with the tool along +Z")
        return Program(moves=moves, units="inch" if self.s.inch else "mm",
                       work_offsets=tuple(self.got.offsets), tools=tuple(self.got.tools),
                       warnings=self.notes.finish(), source=self.source,
                       program_number=self.program_number, stops=tuple(self.got.stops),
                       tool_headers=tuple(h for h in headers if h is not None),
                       resolution_mm=self.resolution_mm())


def parse_gcode(text: str, source: str = "<G-code>", *,
                arc_centre: Literal["incremental", "absolute"] = "incremental",
                arc_tolerance_mm: float = 0.002, block_delete: bool = True,
                start_position: tuple[float, float, float] | None = None,
                dwell_p_units: Literal["s", "ms"] = "s") -> Program:
    """Read a G-code program from text.

    Parameters
    ----------
    text : str
        The program.
    source : str
        Its name in messages.
    arc_centre : {"incremental", "absolute"}
        Meaning of I, J, K until the program says G90.1 (absolute) or G91.1 (incremental, the
        Fanuc default: offsets from the arc start).
    arc_tolerance_mm : float
        Largest accepted difference between the start and the end radius of an arc [mm]; the
        reader accepts up to ``2 sqrt(2)`` units of the program's last written decimal if that
        is more (and says so in the warnings).
    block_delete : bool
        True (the switch on): lines starting with ``/`` are skipped (and listed in the
        warnings); False: they are executed.
    start_position : tuple of 3 float, optional
        Tool position before the program [mm in the work frame]; by default unknown, so moves
        start being listed once a rapid has given X, Y and Z (or a G1 as an approach).
    dwell_p_units : {"s", "ms"}
        Unit of G4's P word: seconds (RS-274/NGC, LinuxCNC; a whole P of 100 or more is noted
        in the warnings) or milliseconds (Fanuc posts: P1000 = 1 s). Fanuc's ``G4 X`` is
        always seconds.

    Returns
    -------
    Program
        Moves in mm (with tool vectors in five-axis programs: G43.5, TRAORI; see the module
        docstring), stops, tool comments (:attr:`Program.tool_headers`, their sizes scaled by
        the program's units), the number resolution and the warnings.

    Raises
    ------
    InputError
        Anything outside the supported subset, or inconsistent; the message names the line, the
        N number if any, and the word.
    """
    if arc_centre not in ("incremental", "absolute"):
        raise ValueError("arc_centre must be 'incremental' or 'absolute'")
    if not arc_tolerance_mm > 0:
        raise ValueError("arc_tolerance_mm must be > 0")
    if dwell_p_units not in ("s", "ms"):
        raise ValueError("dwell_p_units must be 's' or 'ms'")
    options = _Options(arc_absolute=arc_centre == "absolute", arc_tolerance_mm=arc_tolerance_mm,
                       block_delete=block_delete, dwell_p_ms=dwell_p_units == "ms")
    it = _Interpreter(source, options, start_position)
    it.run(text)
    return it.program()


def read_gcode(path: str | Path, **options) -> Program:
    """Read a G-code program file (UTF-8); options as :func:`parse_gcode`.

    Raises
    ------
    InputError
        The file is missing, not UTF-8 text, or not a supported program.
    """
    text = read_user_text(path, "G-code program")
    return parse_gcode(text, source=str(path), **options)

