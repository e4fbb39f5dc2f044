"""Executing lexed G-code blocks with modal state into :class:`~feedopt.gcode.moves.Move` s.

Within a block the words take effect in the RS-274/NGC order: F, S, T, M6, M3/M4/M5, M7-M9,
plane, units, G40, G43/G49, work offset, G90/G91, G90.1/G91.1, then motion (G28 or G0-G3,
G53 modifying G0), then M0/M1/M2/M30. Everything outside the supported subset is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from feedopt.errors import InputError
from feedopt.gcode.lexer import Block, Word, lex_line, split_lines, where
from feedopt.gcode.moves import SAME_POINT_MM, Move, MoveCategory, MoveKind, Plane, Program
from feedopt.textio import read_user_text

MM_PER_INCH = 25.4
_NAN3 = (math.nan, math.nan, math.nan)
_AXES = "XYZ"
_OFFSETS = "IJK"

# G codes as round(10 * value): G1 -> 10, G90.1 -> 901.
_MOTION = {0: MoveKind.RAPID, 10: MoveKind.LINE, 20: MoveKind.ARC, 30: MoveKind.ARC}
_PLANES = {170: Plane.XY, 180: Plane.ZX, 190: Plane.YZ}
_GROUPS: dict[int, str] = {
    **{c: "motion" for c in (0, 10, 20, 30, 800)},
    170: "plane", 180: "plane", 190: "plane",
    200: "units", 210: "units",
    900: "distance", 910: "distance",
    901: "arc distance", 911: "arc distance",
    940: "feed mode", 970: "spindle mode", 400: "cutter compensation",
    430: "tool length", 490: "tool length",
    **{c: "work offset" for c in range(540, 600, 10)},
    280: "non-modal", 530: "machine coordinates",
}
_REFUSED_G: dict[int, str] = {
    **{c: "cutter radius compensation (G41/G42) is not supported: post-process with "
          "compensation in the computer (tool-centre path)" for c in (410, 420)},
    **{c: "canned cycles (G73-G89) are not supported: post-process drilling cycles as "
          "G0/G1 moves" for c in (730, 740, 760, *range(810, 900, 10))},
    930: "inverse-time feed (G93) is not supported: post-process with feed per minute (G94)",
    950: "feed per revolution (G95) is not supported: post-process with feed per minute (G94)",
    40: "dwell (G4) is not supported",
    100: "G10 (setting offsets from the program) is not supported",
    920: "G92 (coordinate system offset) is not supported",
    300: "G30 (return to second home) is not supported",
    960: "constant surface speed (G96) is not supported",
    680: "coordinate rotation (G68) is not supported",
    510: "scaling (G51) is not supported",
    160: "polar coordinates (G16) is not supported",
}
_SPINDLE_M = {3: 1, 4: -1, 5: 0}
_KNOWN_M = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 30}
_REFUSED_LETTERS = {
    **{c: "rotary and extra axes (A B C U V W) are not supported: the reader is for 3-axis "
          "programs" for c in "ABCUVW"},
    "D": "D words (cutter compensation register) are not supported",
    "P": "P words (dwell, canned cycles, subprograms, arc turns) are not supported",
    "Q": "Q words (canned cycles) are not supported",
    "L": "L words (repeats, subprograms) are not supported",
    "E": "E words are not supported",
}
_HANDLED_LETTERS = set("GMXYZIJKRFSTHNO")


def _gcode_key(word: Word) -> int | None:
    ten = word.value * 10.0
    key = round(ten)
    return key if abs(ten - key) < 1e-6 else None


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
    next_tool: int | None = None
    tool: int | None = None
    work_offset: str | None = None
    length_offset: int | None = None
    position: tuple[float, float, float] = _NAN3
    unknown_why: str = "the program start (no G0 to X, Y and Z yet)"
    moved: bool = False
    units_set_at: int | None = None


@dataclass
class _Notes:
    """Warnings collected while reading, some grouped by kind."""

    items: list[str] = field(default_factory=list)
    omitted: list[int] = field(default_factory=list)
    zero_length: list[int] = field(default_factory=list)
    spindle_off: list[int] = field(default_factory=list)
    deleted: list[int] = field(default_factory=list)

    @staticmethod
    def _lines(lines: list[int]) -> str:
        shown = ", ".join(str(n) for n in lines[:10])
        return shown + (f" and {len(lines) - 10} more" if len(lines) > 10 else "")

    def finish(self) -> tuple[str, ...]:
        out = list(self.items)
        if self.deleted:
            out.append(f"block delete: {len(self.deleted)} line(s) starting with '/' skipped "
                       f"(lines {self._lines(self.deleted)})")
        if self.omitted:
            out.append(f"{len(self.omitted)} rapid(s) from a position the reader does not know "
                       f"are not in the move list (lines {self._lines(self.omitted)})")
        if self.zero_length:
            out.append(f"{len(self.zero_length)} zero-length move(s) dropped "
                       f"(lines {self._lines(self.zero_length)})")
        if self.spindle_off:
            out.append(f"{len(self.spindle_off)} feed move(s) with the spindle stopped "
                       f"(no M3/M4, or after M5) (lines {self._lines(self.spindle_off)})")
        return tuple(out)


class _Interpreter:
    """Runs blocks through the modal state; collects moves and warnings."""

    def __init__(self, source: str, arc_centre: str, arc_tolerance_mm: float,
                 block_delete: bool, start_position: tuple[float, float, float] | None) -> None:
        self.source = source
        self.tol = arc_tolerance_mm
        self.block_delete = block_delete
        self.s = _State(arc_absolute=arc_centre == "absolute")
        if start_position is not None:
            self.s.position = (float(start_position[0]), float(start_position[1]),
                               float(start_position[2]))
        self.notes = _Notes()
        self.moves: list[Move] = []
        self.offsets: list[str] = []
        self.tools: list[int] = []
        self.program_number: int | None = None
        self.ended_at: int | None = None

    # ----------------------------------------------------------------- helpers
    def _err(self, b: Block, msg: str) -> InputError:
        return InputError(f"{where(self.source, b.line, b.n_number)}: {msg}")

    @property
    def _scale(self) -> float:
        return MM_PER_INCH if self.s.inch else 1.0

    # ------------------------------------------------------------------ blocks
    def run(self, text: str) -> None:
        """Execute every block of ``text``."""
        first_code = True
        percent_open = False
        lines = split_lines(text)
        for i, raw in enumerate(lines, start=1):
            b = lex_line(raw, i, self.source)
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
            if b.block_delete and self.block_delete:
                self.notes.deleted.append(b.line)
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
        s = self.s
        gs: dict[str, tuple[int, Word]] = {}
        ms: list[tuple[int, Word]] = []
        vals: dict[str, Word] = {}
        for w in b.words:
            if w.letter == "G":
                key = _gcode_key(w)
                if key in _REFUSED_G:
                    raise self._err(b, f"{w.text}: {_REFUSED_G[key]}")
                if key is None or key not in _GROUPS:
                    raise self._err(b, f"{w.text}: G code not supported by the reader")
                group = _GROUPS[key]
                if group in gs:
                    raise self._err(b, f"{gs[group][1].text} and {w.text}: two G codes of the "
                                       f"same modal group ({group}) in one block")
                gs[group] = (key, w)
            elif w.letter == "M":
                key = _gcode_key(w)
                if key in (980, 990):
                    raise self._err(b, f"{w.text}: subprograms (M98/M99) are not supported")
                if key is None or key % 10 or key // 10 not in _KNOWN_M:
                    raise self._err(b, f"{w.text}: M code not supported by the reader")
                ms.append((key // 10, w))
            elif w.letter in _REFUSED_LETTERS:
                raise self._err(b, f"{w.text}: {_REFUSED_LETTERS[w.letter]}")
            elif w.letter not in _HANDLED_LETTERS:
                raise self._err(b, f"{w.text}: word {w.letter} is not supported by the reader")
            elif w.letter == "N":
                continue
            else:
                if w.letter in vals:
                    raise self._err(b, f"{vals[w.letter].text} and {w.text}: two {w.letter} "
                                       "words in one block")
                vals[w.letter] = w
        mcodes = [m for m, _ in ms]
        for group, members in (("spindle", (3, 4, 5)), ("stop", (0, 1, 2, 30)),
                               ("coolant", (7, 8, 9)), ("tool change", (6,))):
            inside = [w.text for m, w in ms if m in members]
            if len(inside) > 1:
                raise self._err(b, f"{' and '.join(inside)}: two M codes of the same group "
                                   f"({group}) in one block")

        if "O" in vals:
            w = vals["O"]
            if self.moves or s.moved or len(b.words) != 1 + (b.n_number is not None):
                raise self._err(b, f"{w.text}: an O word is only read as the program number "
                                   "alone on a line before the first move (subprograms are not "
                                   "supported)")
            if not w.text[1:].isdigit():
                raise self._err(b, f"{w.text}: program number must be a whole number")
            self.program_number = int(w.text[1:])
            return
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
        if 6 in mcodes:
            if s.next_tool is None:
                raise self._err(b, "M6 without a tool selected (no T word before or on the line)")
            s.tool = s.next_tool
            s.position = _NAN3
            s.unknown_why = f"the tool change at line {b.line} (M6 position is machine-specific)"
        for m in mcodes:
            if m in _SPINDLE_M:
                s.spindle_direction = _SPINDLE_M[m]
        if "plane" in gs:
            s.plane = _PLANES[gs["plane"][0]]
        if "units" in gs:
            key, w = gs["units"]
            inch = key == 200
            if inch != s.inch and s.moved:
                raise self._err(b, f"{w.text}: switching units after the first move is not "
                                   f"supported (the program was {'inch' if s.inch else 'mm'} "
                                   "until here)")
            s.inch = inch
        if "tool length" in gs:
            key, w = gs["tool length"]
            if key == 430:
                if "H" not in vals:
                    raise self._err(b, "G43 without an H word (tool length offset number)")
                h = vals["H"]
                if not h.text[1:].isdigit():
                    raise self._err(b, f"{h.text}: H must be a whole number >= 0")
                s.length_offset = int(h.text[1:])
                self.notes.items.append(
                    f"line {b.line}: G43 H{s.length_offset} tool length offset recorded, no "
                    "geometric effect (moves are the programmed tool-tip positions)")
            else:
                s.length_offset = None
        if "H" in vals and gs.get("tool length", (0,))[0] != 430:
            raise self._err(b, f"{vals['H'].text}: H is only read with G43")
        if "work offset" in gs:
            s.work_offset = f"G{gs['work offset'][0] // 10}"
        if "distance" in gs:
            s.absolute = gs["distance"][0] == 900
        if "arc distance" in gs:
            s.arc_absolute = gs["arc distance"][0] == 901

        self._motion(b, gs, vals)

        for m, w in ms:
            if m in (0, 1):
                self.notes.items.append(
                    f"line {b.line}: {'optional ' if m == 1 else ''}program stop {w.text} "
                    "(not modelled: the moves continue)")
            elif m in (2, 30):
                self.ended_at = b.line

    # ------------------------------------------------------------------ motion
    def _motion(self, b: Block, gs: dict[str, tuple[int, Word]], vals: dict[str, Word]) -> None:
        s = self.s
        axes = {a: vals[a] for a in _AXES if a in vals}
        axis_text = ", ".join(x.text for x in axes.values())
        offsets = {a: vals[a] for a in _OFFSETS if a in vals}
        radius = vals.get("R")
        if "motion" in gs:
            key, w = gs["motion"]
            if key == 800:
                # G80 cancels canned cycles, which the reader refuses anyway. Fanuc and Haas
                # keep G0/G1/G2/G3 modal across it (their posts write G80 in the safety line
                # and continue with bare coordinates); RS-274/NGC would cancel the motion.
                if axes:
                    raise self._err(b, f"G80 with axis words ({axis_text}): give G0 or G1")
            else:
                s.motion = _MOTION[key]
                s.ccw = key == 30
        if "non-modal" in gs:  # G28
            if "motion" in gs or "machine coordinates" in gs:
                raise self._err(b, "G28 with a motion code or G53 in the same block")
            self._g28(b, axes)
            if offsets or radius:
                raise self._err(b, "I, J, K or R with G28")
            return
        kind = s.motion
        is_arc = kind is MoveKind.ARC
        if (offsets or radius is not None) and not is_arc:
            word = (radius or next(iter(offsets.values()))).text
            raise self._err(b, f"{word}: I, J, K and R are only read with G2/G3")
        if not axes and not (is_arc and (offsets or radius is not None)):
            if "machine coordinates" in gs:
                raise self._err(b, "G53 without axis words")
            return
        if kind is None:
            raise self._err(b, f"axis words ({axis_text}) without "
                               "an active motion mode (G0, G1, G2, G3): "
                               + "give one")
        sc = self._scale
        start = s.position
        if "machine coordinates" in gs:
            if kind is not MoveKind.RAPID:
                raise self._err(b, "G53 (machine coordinates) is only read with G0")
            if not s.absolute:
                raise self._err(b, "G53 in incremental mode (G91)")
            end = list(start)
            for a in axes:
                end[_AXES.index(a)] = math.nan
            s.position = (end[0], end[1], end[2])
            s.unknown_why = f"the G53 machine-coordinate move at line {b.line}"
            self.notes.items.append(
                f"line {b.line}: G53 rapid to machine coordinates, which the reader does not know:"
                " not in the move list")
            s.moved = True
            return
        target = list(start)
        for a, w in axes.items():
            i = _AXES.index(a)
            target[i] = w.value * sc if s.absolute else start[i] + w.value * sc
        end = (target[0], target[1], target[2])
        s.moved = True
        known = not any(math.isnan(c) for c in start + end)
        if not known:
            if kind is MoveKind.RAPID:
                s.position = end
                self.notes.omitted.append(b.line)
                return
            missing = ", ".join(_AXES[i] for i in range(3)
                                if math.isnan(start[i]) or math.isnan(end[i]))
            raise self._err(b, f"{'G1' if kind is MoveKind.LINE else ('G3' if s.ccw else 'G2')}"
                               f" from a position the reader does not know ({missing} unknown "
                               f"since {s.unknown_why}): position the tool with G0 X Y Z first")
        if kind is MoveKind.RAPID:
            self._line(b, start, end, None)
        else:
            if s.feed_raw is None:
                raise self._err(b, "feed move without a feed rate: no F word before or on this "
                                   "line")
            feed = s.feed_raw * sc / 60.0
            if kind is MoveKind.LINE:
                self._line(b, start, end, feed)
            else:
                self._arc(b, start, end, feed, offsets, radius)
        s.position = end

    def _g28(self, b: Block, axes: dict[str, Word]) -> None:
        """G28: rapid to the intermediate point, then the named axes go to machine home."""
        s = self.s
        if not axes:
            raise self._err(b, "G28 without axis words: which axes go home is machine-specific; "
                               "name them (e.g. G28 G91 Z0)")
        sc = self._scale
        start = s.position
        mid = list(start)
        for a, w in axes.items():
            i = _AXES.index(a)
            mid[i] = w.value * sc if s.absolute else start[i] + w.value * sc
        mid3 = (mid[0], mid[1], mid[2])
        s.moved = True
        if any(math.isnan(c) for c in start + mid3):
            self.notes.omitted.append(b.line)
        else:  # G28 G91 Z0 (the usual home return) has no intermediate move: no note
            self._line(b, start, mid3, None, quiet_if_zero=True)
        for a in axes:
            mid[_AXES.index(a)] = math.nan
        s.position = (mid[0], mid[1], mid[2])
        s.unknown_why = f"the G28 return to machine home at line {b.line}"
        self.notes.items.append(
            f"line {b.line}: G28 returns {''.join(axes)} to machine home, which the reader does "
            "not know: that part of the move is not in the move list")

    def _common(self, b: Block) -> dict:
        s = self.s
        if s.work_offset is not None and s.work_offset not in self.offsets:
            self.offsets.append(s.work_offset)
        if s.tool is not None and s.tool not in self.tools:
            self.tools.append(s.tool)
        return dict(spindle_rpm=s.spindle_rpm, spindle_direction=s.spindle_direction,
                    tool=s.tool, work_offset=s.work_offset, length_offset=s.length_offset,
                    line=b.line, n_number=b.n_number, text=b.text)

    def _line(self, b: Block, start: tuple[float, float, float],
              end: tuple[float, float, float], feed: float | None,
              quiet_if_zero: bool = False) -> None:
        dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
        if math.sqrt(dx * dx + dy * dy + dz * dz) <= SAME_POINT_MM:
            if not quiet_if_zero:
                self.notes.zero_length.append(b.line)
            return
        if feed is None:
            kind, cat = MoveKind.RAPID, MoveCategory.RAPID
        else:
            kind = MoveKind.LINE
            if math.hypot(dx, dy) <= SAME_POINT_MM:
                cat = MoveCategory.PLUNGE if dz < 0 else MoveCategory.RETRACT
            else:
                cat = MoveCategory.CUT
            if self.s.spindle_direction == 0:
                self.notes.spindle_off.append(b.line)
        self.moves.append(Move(kind, cat, start, end, feed, **self._common(b)))

    def _arc(self, b: Block, start: tuple[float, float, float], end: tuple[float, float, float],
             feed: float, offsets: dict[str, Word], radius: Word | None) -> None:
        s = self.s
        plane = s.plane
        u, v, n = plane.value
        sc = self._scale
        code = "G3" if s.ccw else "G2"
        direction = 1 if s.ccw else -1
        su, sv, eu, ev = start[u], start[v], end[u], end[v]
        chord = math.hypot(eu - su, ev - sv)
        full = chord <= SAME_POINT_MM
        if radius is not None:
            if offsets:
                raise self._err(b, f"{code} with both R and I/J/K: give one")
            r = radius.value * sc
            if r == 0:
                raise self._err(b, f"{code} {radius.text}: radius must not be 0")
            if full:
                raise self._err(b, f"{code} {radius.text}: start and end are the same point in "
                                   f"the {plane.gcode} plane; a full circle needs I/J/K, not R")
            half = chord / 2.0
            rr = abs(r)
            if half > rr:
                if half - rr > self.tol:
                    raise self._err(b, f"{code} {radius.text}: radius {rr:.4f} mm is too small "
                                       f"for the chord {chord:.4f} mm (end not reachable)")
                h = 0.0
            else:
                h = math.sqrt(rr * rr - half * half)
            side = direction * (1 if r > 0 else -1)
            mu, mv = (su + eu) / 2.0, (sv + ev) / 2.0
            lu, lv = -(ev - sv) / chord, (eu - su) / chord
            cu, cv = mu + side * h * lu, mv + side * h * lv
        else:
            if not offsets:
                raise self._err(b, f"{code} without a centre (I, J, K) or a radius (R)")
            normal_letter = _OFFSETS[n]
            if normal_letter in offsets and offsets[normal_letter].value != 0:
                raise self._err(b, f"{offsets[normal_letter].text}: {normal_letter} is not a "
                                   f"centre offset in the {plane.gcode} plane")
            cc = [0.0, 0.0, 0.0]
            for i in (u, v):
                letter = _OFFSETS[i]
                if s.arc_absolute:
                    if letter not in offsets:
                        raise self._err(b, f"{code} with absolute arc centres (G90.1) needs "
                                           f"{_OFFSETS[u]} and {_OFFSETS[v]}: {letter} missing")
                    cc[i] = offsets[letter].value * sc
                else:
                    cc[i] = start[i] + (offsets[letter].value * sc if letter in offsets else 0.0)
            cu, cv = cc[u], cc[v]
        r0 = math.hypot(su - cu, sv - cv)
        r1 = math.hypot(eu - cu, ev - cv)
        if r0 <= SAME_POINT_MM:
            raise self._err(b, f"{code}: the centre is at the start point (radius 0)")
        if abs(r0 - r1) > self.tol:
            raise self._err(b, f"{code}: start and end are not on one circle: start radius "
                               f"{r0:.4f} mm, end radius {r1:.4f} mm (differ by "
                               f"{abs(r0 - r1):.4f} mm, tolerance {self.tol:g} mm)")
        a0 = math.atan2(sv - cv, su - cu)
        a1 = math.atan2(ev - cv, eu - cu)
        if full:
            sweep = 2.0 * math.pi
        else:
            sweep = ((a1 - a0) if s.ccw else (a0 - a1)) % (2.0 * math.pi)
        centre = [0.0, 0.0, 0.0]
        centre[u], centre[v], centre[n] = cu, cv, start[n]
        if s.spindle_direction == 0:
            self.notes.spindle_off.append(b.line)
        self.moves.append(Move(
            MoveKind.ARC, MoveCategory.CUT, start, end, feed, **self._common(b),
            centre=(centre[0], centre[1], centre[2]), plane=plane, direction=direction,
            sweep_rad=sweep, radius_mm=r0))

    def program(self) -> Program:
        """The result."""
        return Program(moves=tuple(self.moves), units="inch" if self.s.inch else "mm",
                       work_offsets=tuple(self.offsets), tools=tuple(self.tools),
                       warnings=self.notes.finish(), source=self.source,
                       program_number=self.program_number)


def parse_gcode(text: str, source: str = "<G-code>", *,
                arc_centre: Literal["incremental", "absolute"] = "incremental",
                arc_tolerance_mm: float = 0.002, block_delete: bool = True,
                start_position: tuple[float, float, float] | None = None) -> Program:
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
        Largest accepted difference between the start and the end radius of an arc [mm].
    block_delete : bool
        True (the switch on): lines starting with ``/`` are skipped (and listed in the
        warnings); False: they are executed.
    start_position : tuple of 3 float, optional
        Tool position before the program [mm in the work frame]; by default unknown, so moves
        start being listed once a rapid has given X, Y and Z.

    Returns
    -------
    Program

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
    it = _Interpreter(source, arc_centre, arc_tolerance_mm, block_delete, start_position)
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
