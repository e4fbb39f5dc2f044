"""The G and M codes the reader knows, and sorting one block's words by what they do.

G codes are keyed by ``round(10 * value)``: G1 -> 10, G90.1 -> 901, G61.1 -> 611. Every code
belongs to a group (RS-274/NGC's modal groups, with the non-modal G4/G28 and G9/G53 apart);
two codes of one group in a block are refused, except G80 with a motion code (the Fanuc and
Haas safety line ``G00 G17 G21 G40 G49 G80 G90``: G80 cancels canned cycles, the motion code
wins).

Five-axis words: G43.5 (tool length group) switches tool-vector programming on, Sinumerik's
``TRAORI``/``TRAFOOF`` keywords too (``ORIWKS``, ``ORIVECT`` are read and have no effect);
``A3=``, ``B3=``, ``C3=`` are Sinumerik's tool-vector words (the lexer names them ``A3``, ``B3``,
``C3``). Rotary axis words A, B, C stay refused: their positions need the machine's kinematics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from feedopt.errors import InputError
from feedopt.gcode.lexer import Block, Word
from feedopt.gcode.moves import MoveKind, Plane

MOTION = {0: MoveKind.RAPID, 10: MoveKind.LINE, 20: MoveKind.ARC, 30: MoveKind.ARC}
PLANES = {170: Plane.XY, 180: Plane.ZX, 190: Plane.YZ}
G80 = 800
G4, G9, G28, G64 = 40, 90, 280, 640
#: G43 and G43.5 (tool centre point control type 2: tool vectors I J K)
G43, G43_5 = 430, 435
GROUPS: dict[int, str] = {
    **{c: "motion" for c in (0, 10, 20, 30, G80)},
    170: "plane", 180: "plane", 190: "plane",
    200: "units", 210: "units",
    900: "distance", 910: "distance",
    901: "arc distance", 911: "arc distance",
    940: "feed mode", 970: "spindle mode", 400: "cutter compensation",
    430: "tool length", 435: "tool length", 490: "tool length",
    **{c: "work offset" for c in range(540, 600, 10)},
    610: "path control", 611: "path control", G64: "path control",
    980: "canned return", 990: "canned return",
    G4: "non-modal", G28: "non-modal", 921: "non-modal", 922: "non-modal",
    G9: "exact stop", 530: "machine coordinates",
}
_SPLINE = ("splines and NURBS ({}) are not supported: post-process with lines and arcs "
           "(G1/G2/G3)")
REFUSED_G: dict[int, str] = {
    **{c: "cutter radius compensation (G41/G42) is not supported: post-process with "
          "compensation in the computer (tool-centre path)" for c in (410, 420, 411, 421)},
    **{c: "canned cycles (G73-G89) are not supported: post-process drilling cycles as "
          "G0/G1 moves" for c in (730, 740, 760, *range(810, 900, 10))},
    **{c: _SPLINE.format(f"G{c / 10:g}") for c in (50, 51, 52, 53, 62)},
    930: "inverse-time feed (G93) is not supported: post-process with feed per minute (G94)",
    950: "feed per revolution (G95) is not supported: post-process with feed per minute (G94)",
    100: "G10 (setting offsets from the program) is not supported",
    920: "G92 (coordinate system offset) is not supported",
    923: "G92.3 (restoring G92 offsets) is not supported",
    300: "G30 (return to second home) is not supported",
    960: "constant surface speed (G96) is not supported",
    680: "coordinate rotation (G68) is not supported",
    510: "scaling (G51) is not supported",
    160: "polar coordinates (G16) is not supported",
    434: "tool centre point control type 1 (G43.4) programs rotary axis positions (A B C), which "
         "need the machine's kinematics: feedopt does not model them; post the program with tool "
         "vectors (G43.5 with I J K, or an APT CL file with GOTO/x,y,z,i,j,k)",
}
SPINDLE_M = {3: 1, 4: -1, 5: 0}
KNOWN_M = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 30}
M_GROUPS = (("spindle", (3, 4, 5)), ("stop", (0, 1, 2, 30)), ("coolant", (7, 8, 9)),
            ("tool change", (6,)))
_ROTARY = ("rotary and extra axes (A B C U V W) are not supported: rotary axis positions need "
           "the machine's kinematics, which feedopt does not model; post the program with tool "
           "vectors instead (G43.5 with I J K, Sinumerik TRAORI with A3= B3= C3=, or an APT CL "
           "file with GOTO/x,y,z,i,j,k)")
REFUSED_LETTERS = {
    **{c: _ROTARY for c in "ABC"},
    **{c: "rotary and extra axes (A B C U V W) are not supported: U, V and W (extra linear "
          "axes) are not read" for c in "UVW"},
    "D": "D words (cutter compensation register) are not supported",
    "L": "L words (repeats, subprograms) are not supported",
    "E": "E words are not supported",
}
#: Sinumerik's tool-vector words and the five-axis keywords the lexer passes as words
VECTOR_WORDS = ("A3", "B3", "C3")
KEYWORDS = ("TRAORI", "TRAFOOF", "ORIWKS", "ORIVECT")
HANDLED_LETTERS = {*"GMXYZIJKRFSTHNOPQ", *VECTOR_WORDS, *KEYWORDS}


def gcode_key(word: Word) -> int | None:
    """``round(10 * value)`` of a G or M word, None if it has more than one decimal."""
    ten = word.value * 10.0
    key = round(ten)
    return key if abs(ten - key) < 1e-6 else None


@dataclass(frozen=True)
class Sorted:
    """One block's words by role.

    gs : group name -> (key, word) of its G code
    ms : (M number, word) in the order written
    vals : letter -> word for every other letter (N aside)
    """

    gs: dict[str, tuple[int, Word]]
    ms: list[tuple[int, Word]]
    vals: dict[str, Word]


def _add_g(gs: dict[str, tuple[int, Word]], w: Word, err: Callable[[str], InputError]) -> None:
    key = gcode_key(w)
    if key in REFUSED_G:
        raise err(f"{w.text}: {REFUSED_G[key]}")
    if key is None or key not in GROUPS:
        raise err(f"{w.text}: G code not supported by the reader")
    group = GROUPS[key]
    if group in gs:
        other = gs[group]
        if group == "motion" and G80 in (key, other[0]) and key != other[0]:
            if key == G80:  # G80 with a motion code: a no-op cancel, the motion code wins
                return
        else:
            raise err(f"{other[1].text} and {w.text}: two G codes of the same modal group "
                      f"({group}) in one block")
    gs[group] = (key, w)


def sort_words(b: Block, err: Callable[[str], InputError]) -> Sorted:
    """Sort the words of ``b``; ``err(message)`` makes the error for a refused word."""
    gs: dict[str, tuple[int, Word]] = {}
    ms: list[tuple[int, Word]] = []
    vals: dict[str, Word] = {}
    for w in b.words:
        if w.letter == "G":
            _add_g(gs, w, err)
        elif w.letter == "M":
            key = gcode_key(w)
            if key in (980, 990):
                raise err(f"{w.text}: subprograms (M98/M99) are not supported")
            if key is None or key % 10 or key // 10 not in KNOWN_M:
                raise err(f"{w.text}: M code not supported by the reader")
            ms.append((key // 10, w))
        elif w.letter in REFUSED_LETTERS:
            raise err(f"{w.text}: {REFUSED_LETTERS[w.letter]}")
        elif w.letter not in HANDLED_LETTERS:
            raise err(f"{w.text}: word {w.letter} is not supported by the reader")
        elif w.letter != "N":
            if w.letter in vals:
                raise err(f"{vals[w.letter].text} and {w.text}: two {w.letter} words in one "
                          "block")
            vals[w.letter] = w
    for group, members in M_GROUPS:
        inside = [w.text for m, w in ms if m in members]
        if len(inside) > 1:
            raise err(f"{' and '.join(inside)}: two M codes of the same group ({group}) in one "
                      "block")
    _check_p_q(gs, vals, err)
    return Sorted(gs, ms, vals)


def _check_p_q(gs: dict[str, tuple[int, Word]], vals: dict[str, Word],
               err: Callable[[str], InputError]) -> None:
    """P is read with G4 (dwell) and G64 (path tolerance) only, Q with G64 only."""
    dwell = gs.get("non-modal", (0,))[0] == G4
    blend = gs.get("path control", (0,))[0] == G64
    if "P" in vals:
        if dwell and blend:
            raise err(f"{vals['P'].text} with both G4 and G64: give them on separate lines")
        if not (dwell or blend):
            raise err(f"{vals['P'].text}: P words are only read with G4 (dwell) and G64 (path "
                      "tolerance); canned cycles, subprograms and arc turns are not supported")
    if "Q" in vals and not blend and gs.get("tool length", (0,))[0] == G43_5:
        raise err(f"{vals['Q'].text} with G43.5: the tool inclination angle (Q) is not "
                  "supported: post the tool vectors with the inclination in them")
    if "Q" in vals and not blend:
        raise err(f"{vals['Q'].text}: Q words are only read with G64 (canned cycles are not "
                  "supported)")
