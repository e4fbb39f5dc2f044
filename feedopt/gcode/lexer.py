"""Splitting G-code text into blocks of words (no machine state here).

One physical line is one block. The lexer removes comments, ``( ... )`` anywhere and ``;`` to
the end of the line; drops every space (RS-274 allows them inside words: ``G 1 X 1 0.5``);
folds letters to upper case; recognises the block-delete slash ``/`` at the start, a line that
is only ``%``, and words ``<letter><number>`` with numbers like ``1``, ``-1.``, ``+.5``. Whatever
else is left (``#1=2``, ``[1+2]``, ``O<sub>``, a stray character) is an
:class:`~feedopt.errors.InputError` naming the line, its N number if any and the text.

Sinumerik five-axis words are read too: the tool-vector components ``A3=0.5``, ``B3=...``,
``C3=...`` (a :class:`Word` with letter ``"A3"``, ``"B3"``, ``"C3"``) and the keywords
``TRAORI``, ``TRAFOOF``, ``ORIWKS``, ``ORIVECT`` (a Word with that letter and value 0; the
``(1)`` of ``TRAORI(1)`` is a comment here, as every parenthesis). They are only tried when a
line is not plain words, so RS-274 lines lex as before.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from feedopt.errors import InputError

_NUMBER = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)"
_WORD = re.compile(rf"([A-Z])({_NUMBER})")
#: A word, a Sinumerik vector word ``A3=0.5`` or a five-axis keyword (tried in this order)
_EXTENDED = re.compile(rf"(TRAORI|TRAFOOF|ORIWKS|ORIVECT)|([ABC]3)=({_NUMBER})|([A-Z])({_NUMBER})")
_LEADING_N = re.compile(r"\s*/?\s*[Nn]\s*([0-9]+)")
_COMMENT_CHARS = frozenset("();")
#: Largest magnitude accepted for a word's number (N aside): beyond it floats lose meaning.
MAX_ABS_VALUE = 1e9
_LINE_END = re.compile(r"\r\n|\r|\n")


@dataclass(frozen=True)
class Word:
    """One word of a block, e.g. ``G01`` or ``X-1.5``.

    Attributes
    ----------
    letter : str
        Upper-case letter (Sinumerik: ``"A3"``, ``"B3"``, ``"C3"`` or a keyword, see above).
    value : float
        The number after it.
    text : str
        The word as written, spaces removed and upper case (``G01``), for messages.
    """

    letter: str
    value: float
    text: str


@dataclass(frozen=True)
class Block:
    """One physical line of the program, lexed.

    Attributes
    ----------
    line : int
        1-based physical line number in the file.
    text : str
        The line as written (without its line ending).
    words : tuple of Word
        The words, in the order written (the N word included).
    n_number : int or None
        The N (sequence) number, if the line has one.
    block_delete : bool
        The line starts with ``/``.
    percent : bool
        The line is the tape marker ``%`` (comments aside).
    comments : tuple of str
        Text of the comments on the line, in order.
    """

    line: int
    text: str
    words: tuple[Word, ...]
    n_number: int | None
    block_delete: bool
    percent: bool
    comments: tuple[str, ...]


def where(source: str, line: int, n_number: int | None) -> str:
    """Location prefix for messages: ``"prog.nc line 12 (N120)"``."""
    n = f" (N{n_number})" if n_number is not None else ""
    return f"{source} line {line}{n}"


def _split_comments(raw: str, loc: str) -> tuple[str, list[str]]:
    """Code part of ``raw`` (comments replaced by a space) and the comment texts."""
    if not _COMMENT_CHARS.intersection(raw):
        return raw, []
    code: list[str] = []
    comments: list[str] = []
    i = 0
    n = len(raw)
    while i < n:
        ch = raw[i]
        if ch == "(":
            j = raw.find(")", i + 1)
            if j < 0:
                raise InputError(f"{loc}: comment '(' is not closed on its line: add ')'")
            inner = raw[i + 1:j]
            if "(" in inner:
                raise InputError(f"{loc}: nested comment '(' inside '( ... )' is not allowed")
            comments.append(inner)
            code.append(" ")
            i = j + 1
        elif ch == ";":
            comments.append(raw[i + 1:])
            break
        elif ch == ")":
            raise InputError(f"{loc}: ')' without an opening '('")
        else:
            code.append(ch)
            i += 1
    return "".join(code), comments


def _explain(code: str, pos: int, loc: str) -> InputError:
    """The error for the first text at ``pos`` of ``code`` that is not a word."""
    rest = code[pos:pos + 12]
    ch = code[pos]
    if ch == "#":
        why = "macro variables (#) are not supported"
    elif ch in "[]":
        why = "expressions in [ ] are not supported"
    elif ch == "=":
        why = "assignments (=) are not supported (macros or parameters)"
    elif ch == "/":
        why = "block delete '/' is only allowed at the start of a line"
    elif ch == "%":
        why = "'%' must be alone on its line"
    elif ch == "O" and pos + 1 < len(code) and code[pos + 1] == "<":
        why = "O-word subroutines and control flow (o<name>) are not supported"
    elif "A" <= ch <= "Z":
        nxt = code[pos + 1] if pos + 1 < len(code) else ""
        if nxt == "#":
            why = "macro variables (#) are not supported"
        elif nxt == "[":
            why = "expressions in [ ] are not supported"
        elif "A" <= nxt <= "Z":
            why = ("keywords (O-word SUB, IF, WHILE, GOTO ...: subprograms, macros and control "
                   "flow) are not supported")
        else:
            why = f"letter {ch} is not followed by a number"
    elif ch.isascii() and ch.isprintable():
        why = f"unexpected character {ch!r}"
    else:
        why = f"unexpected character {ch!r} (U+{ord(ch):04X}) outside a comment"
    return InputError(f"{loc}: cannot read {rest!r}: {why}")


def _extended_words(code: str, loc: str) -> tuple[Word, ...]:
    """The words of a line that is not plain words: Sinumerik vector words and keywords
    among them, or the error for the first text that is neither."""
    words: list[Word] = []
    pos = 0
    while pos < len(code):
        m = _EXTENDED.match(code, pos)
        if m is None:
            raise _explain(code, pos, loc)
        keyword, vec, vec_value, letter, value = m.groups()
        if keyword:
            words.append(Word(keyword, 0.0, keyword))
        elif vec:
            words.append(Word(vec, float(vec_value), m.group(0)))
        else:
            words.append(Word(letter, float(value), letter + value))
        pos = m.end()
    return tuple(words)


def lex_line(raw: str, line: int, source: str = "<G-code>") -> Block:
    """Lex one physical line.

    Parameters
    ----------
    raw : str
        The line, without its line ending.
    line : int
        Its 1-based physical line number (for messages).
    source : str
        Name of the program for messages.

    Returns
    -------
    Block

    Raises
    ------
    InputError
        Unclosed or nested comment, or text that is not a word.
    """
    m = _LEADING_N.match(raw)
    loc = where(source, line, int(m.group(1)) if m else None)
    code, comments = _split_comments(raw, loc)
    code = "".join(code.split())
    if not code.isascii():
        bad = next(c for c in code if not c.isascii())
        raise _explain(code, code.index(bad), loc)
    code = code.upper()
    block_delete = code.startswith("/")
    if block_delete:
        code = code[1:]
    if code == "%":
        return Block(line, raw, (), None, block_delete, True, tuple(comments))
    found = _WORD.findall(code)
    if sum(len(a) + len(b) for a, b in found) != len(code):
        words = _extended_words(code, loc)
    else:
        words = tuple(Word(a, float(b), a + b) for a, b in found)
    for w in words:
        if abs(w.value) >= MAX_ABS_VALUE and w.letter != "N":
            raise InputError(f"{loc}: {w.text[:20]}: number too large (limit {MAX_ABS_VALUE:g})")
    n_number = None
    for w in words:
        if w.letter == "N":
            if n_number is not None:
                raise InputError(f"{loc}: two N words on one line")
            if not w.text[1:].isdigit():
                raise InputError(f"{loc}: N number {w.text} must be a whole number")
            n_number = int(w.text[1:])
    return Block(line, raw, words, n_number, block_delete, False, tuple(comments))


def split_lines(text: str) -> list[str]:
    """Physical lines of ``text`` (``\\n``, ``\\r\\n`` or ``\\r`` endings; no empty last line)."""
    lines = _LINE_END.split(text)
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def lex(text: str, source: str = "<G-code>") -> Iterator[Block]:
    """Lex every physical line of ``text`` (``\\n``, ``\\r\\n`` or ``\\r`` line endings).

    Parameters
    ----------
    text : str
        The whole program.
    source : str
        Name of the program for messages.

    Yields
    ------
    Block
        One per physical line, blank lines included (with no words).
    """
    for i, raw in enumerate(split_lines(text), start=1):
        yield lex_line(raw, i, source)
