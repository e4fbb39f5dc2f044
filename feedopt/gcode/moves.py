"""The reader's result: typed moves in millimetres, and their geometry.

Every :class:`Move` is a frozen dataclass of plain floats and tuples (hashable, comparable);
:class:`Program` adds read-only numpy views over all moves (``starts``, ``ends``, ``feeds_mm_s``,
...) for vectorised use, and :func:`sample_move` gives points along a move (arcs by angle).

Arc convention (RS-274): an arc lies in the plane selected by G17 (XY, normal +Z), G18 (ZX,
normal +Y) or G19 (YZ, normal +X). Its in-plane axes ``(u, v)`` are ordered so that
``u x v = normal`` (G17: X, Y; G18: Z, X; G19: Y, Z); ``direction`` is +1 for G3 (counter-
clockwise seen looking down the normal from its positive end, i.e. a positive rotation about
the normal) and -1 for G2. A helical arc also moves linearly along the normal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from functools import cached_property

import numpy as np

Vec3 = tuple[float, float, float]


class MoveKind(Enum):
    """What the controller does: G0, G1, or G2/G3."""

    RAPID = "rapid"
    LINE = "line"
    ARC = "arc"


class MoveCategory(Enum):
    """A move relative to the tool axis +Z.

    ``RAPID`` every G0; ``PLUNGE`` a feed line along -Z only; ``RETRACT`` a feed line along +Z
    only; ``CUT`` every other feed move (every arc, ramps included).
    """

    CUT = "cut"
    PLUNGE = "plunge"
    RETRACT = "retract"
    RAPID = "rapid"


class Plane(Enum):
    """Arc plane: value is ``(u axis, v axis, normal axis)`` as indices 0=X, 1=Y, 2=Z."""

    XY = (0, 1, 2)  # G17
    ZX = (2, 0, 1)  # G18
    YZ = (1, 2, 0)  # G19

    @property
    def normal(self) -> Vec3:
        """Unit normal (+Z, +Y or +X)."""
        n = [0.0, 0.0, 0.0]
        n[self.value[2]] = 1.0
        return (n[0], n[1], n[2])

    @property
    def gcode(self) -> str:
        """``"G17"``, ``"G18"`` or ``"G19"``."""
        return {Plane.XY: "G17", Plane.ZX: "G18", Plane.YZ: "G19"}[self]


#: Distance under which two points count as the same (mm): float noise, not tolerance.
SAME_POINT_MM = 1e-6


class StopKind(Enum):
    """Why the tool stops (feed, acceleration and jerk zero) at a point of the program.

    The reader records ``EXACT`` (a move ending while G61/G61.1 is active, or with G9),
    ``DWELL`` (G4, held ``hold_s``), ``PROGRAM_STOP`` (M0: the operator presses Start),
    ``OPTIONAL_STOP`` (M1) and ``TOOL_CHANGE`` (M6); the path adds ``REVERSAL`` (a move that
    turns back) and ``CORNER`` (a corner the tolerance cannot blend).
    """

    EXACT = "exact stop"
    DWELL = "dwell"
    PROGRAM_STOP = "program stop"
    OPTIONAL_STOP = "optional stop"
    TOOL_CHANGE = "tool change"
    REVERSAL = "reversal"
    CORNER = "corner"


@dataclass(frozen=True)
class Stop:
    """A stop of the program between two moves.

    after_move : index in :attr:`Program.moves` of the move the stop follows (-1: before the
        first move)
    kind : why (:class:`StopKind`)
    hold_s : how long the tool is held there [s] (G4's P; 0 for the others)
    line, n_number, text : the block that asked for it (for an exact stop: the move's block)
    """

    after_move: int
    kind: StopKind
    hold_s: float
    line: int
    n_number: int | None
    text: str


class ToolShape(Enum):
    """Cutter shape named in a program's tool comment."""

    FLAT = "flat end mill"
    BALL = "ball end mill"
    BULL = "bull nose end mill"
    CHAMFER = "chamfer mill"
    DRILL = "drill"
    OTHER = "other"


@dataclass(frozen=True)
class ToolHeader:
    """A tool described in a program comment (Fusion/HSM ``(T1 D=3.175 CR=0. - ZMIN=-5. -
    flat end mill)``, Mastercam, CAMotics styles).

    number : the T number (None if the comment gives none)
    diameter_mm, corner_radius_mm : as written, in mm (None where not given)
    shape : :class:`ToolShape`
    z_min_mm : the post's ZMIN (deepest point of the tool's operations) in mm, None if absent
    line, text : where and what was written
    """

    number: int | None
    diameter_mm: float | None
    corner_radius_mm: float | None
    shape: ToolShape
    z_min_mm: float | None
    line: int
    text: str


@dataclass(frozen=True)
class Move:
    """One motion of the program, in millimetres in the work-offset frame.

    Attributes
    ----------
    kind : MoveKind
        RAPID (G0), LINE (G1) or ARC (G2/G3).
    category : MoveCategory
        CUT, PLUNGE, RETRACT or RAPID relative to the tool axis +Z.
    start, end : tuple of 3 float
        Tool-tip position at the start and end [mm].
    feed_mm_s : float or None
        Programmed feed [mm/s] (F in program units per minute / 60, scaled); None for rapids.
    spindle_rpm : float or None
        Last S word [rev/min], None if none was given yet.
    spindle_direction : int
        +1 after M3 (clockwise), -1 after M4, 0 stopped (M5 or nothing yet).
    tool : int or None
        Tool in the spindle (the T of the last M6), None before any M6.
    work_offset : str or None
        Active work offset (``"G54"`` .. ``"G59"``), None if the program set none.
    length_offset : int or None
        H number of the active G43, None without G43 or after G49. No geometric effect.
    line : int
        1-based physical line of the block in the file.
    n_number : int or None
        N number of the block.
    text : str
        The block as written.
    centre : tuple of 3 float or None
        Arc centre [mm]; its normal coordinate is the start's. None for lines.
    plane : Plane or None
        Arc plane; None for lines.
    direction : int
        Arcs: +1 counter-clockwise (G3) / -1 clockwise (G2) about the plane normal; 0 for lines.
    sweep_rad : float
        Arcs: swept angle, > 0 (2 pi for a full circle); 0 for lines.
    radius_mm : float
        Arcs: radius at the start [mm]; 0 for lines.
    """

    kind: MoveKind
    category: MoveCategory
    start: Vec3
    end: Vec3
    feed_mm_s: float | None
    spindle_rpm: float | None
    spindle_direction: int
    tool: int | None
    work_offset: str | None
    length_offset: int | None
    line: int
    n_number: int | None
    text: str
    centre: Vec3 | None = None
    plane: Plane | None = None
    direction: int = 0
    sweep_rad: float = 0.0
    radius_mm: float = 0.0
    #: path tolerance of G64 P active for this move [mm]; None: the scenario's
    blend_tolerance_mm: float | None = None
    #: the start was not known (program start, after M6/G28/G53): its unknown coordinates
    #: were taken from the end; the path plans an approach through the air to it
    approach: bool = False
    #: five-axis programs: the unit tool vector (from the tool tip into the spindle, in the
    #: program's frame) at the start and at the end of the move; the controller turns it
    #: along the great circle between them, in proportion to the distance travelled
    #: (G43.5 / TCPM, APT ``GOTO/x,y,z,i,j,k``). None for three-axis programs (+Z throughout)
    axis_start: Vec3 | None = None
    axis_end: Vec3 | None = None

    @property
    def normal(self) -> Vec3 | None:
        """Unit normal of the arc plane; None for lines."""
        return self.plane.normal if self.plane is not None else None

    @property
    def turns(self) -> float:
        """Arcs: swept angle in turns (1.0 for a full circle); 0 for lines."""
        return self.sweep_rad / (2.0 * math.pi)

    @property
    def end_radius_mm(self) -> float:
        """Arcs: distance of the end from the centre in the plane [mm]; 0 for lines."""
        if self.plane is None or self.centre is None:
            return 0.0
        u, v, _ = self.plane.value
        return math.hypot(self.end[u] - self.centre[u], self.end[v] - self.centre[v])

    @property
    def length_mm(self) -> float:
        """Path length [mm] (a helix: from its mean radius and its rise)."""
        if self.kind is not MoveKind.ARC:
            return math.dist(self.start, self.end)
        assert self.plane is not None
        n = self.plane.value[2]
        r = 0.5 * (self.radius_mm + self.end_radius_mm)
        return math.hypot(r * self.sweep_rad, self.end[n] - self.start[n])

    def point_at(self, t: np.ndarray | float) -> np.ndarray:
        """Points at parameters ``t`` in [0, 1] (linear in angle for arcs), shape ``(len(t), 3)``.

        Arcs interpolate the radius linearly from the start to the end radius (they may differ
        by up to the reader's tolerance), so ``t=1`` is exactly the end point.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        s = np.asarray(self.start)
        e = np.asarray(self.end)
        if self.kind is not MoveKind.ARC:
            return s + np.outer(t, e - s)
        assert self.plane is not None and self.centre is not None
        u, v, n = self.plane.value
        c = self.centre
        a0 = math.atan2(s[v] - c[v], s[u] - c[u])
        ang = a0 + self.direction * self.sweep_rad * t
        r = self.radius_mm + (self.end_radius_mm - self.radius_mm) * t
        out = np.empty((t.size, 3))
        out[:, u] = c[u] + r * np.cos(ang)
        out[:, v] = c[v] + r * np.sin(ang)
        out[:, n] = s[n] + (e[n] - s[n]) * t
        out[t == 1.0] = e
        out[t == 0.0] = s
        return out


def sample_move(move: Move, max_angle_deg: float = 5.0) -> np.ndarray:
    """Points along ``move`` from start to end inclusive, shape ``(k, 3)`` [mm].

    Lines give their two end points; arcs are sampled at equal angles no larger than
    ``max_angle_deg`` (at least 2 intervals).
    """
    if max_angle_deg <= 0:
        raise ValueError("max_angle_deg must be > 0")
    if move.kind is not MoveKind.ARC:
        return move.point_at(np.array([0.0, 1.0]))
    k = max(2, math.ceil(math.degrees(move.sweep_rad) / max_angle_deg))
    return move.point_at(np.linspace(0.0, 1.0, k + 1))


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Program:
    """A G-code program read into moves.

    Attributes
    ----------
    moves : tuple of Move
        Every motion whose start and end are known, in program order. Rapids from a position
        the reader does not know (program start, after M6, G28, G53) and zero-length moves are
        not in it; ``warnings`` says which lines.
    units : str
        ``"mm"`` (G21) or ``"inch"`` (G20) as programmed; the moves are in mm regardless.
    work_offsets : tuple of str
        Work offsets active during moves, in order of first use (``("G54",)``).
    tools : tuple of int
        Tools used by moves, in order of first use.
    warnings : tuple of str
        Everything the reader recorded but does not model (G43, M0, ignored lines, ...).
    source : str
        Name of the program (file path or the ``source`` given to the parser).
    program_number : int or None
        The O number, if any.
    stops : tuple of Stop
        Stops the program asks for (G61/G9 exact stops, G4 dwells, M0, M1, M6), in order.
    tool_headers : tuple of ToolHeader
        Tools described in the program's comments, in order.
    resolution_mm : float or None
        The program's number resolution [mm]: one unit of the last decimal its coordinates
        are written with (4 decimals in inch: 0.00254 mm); None if no coordinate was read.
    """

    moves: tuple[Move, ...]
    units: str
    work_offsets: tuple[str, ...]
    tools: tuple[int, ...]
    warnings: tuple[str, ...]
    source: str
    program_number: int | None = None
    stops: tuple[Stop, ...] = ()
    tool_headers: tuple[ToolHeader, ...] = ()
    resolution_mm: float | None = None

    def __len__(self) -> int:
        return len(self.moves)

    def sample_move(self, index: int, max_angle_deg: float = 5.0) -> np.ndarray:
        """Points along ``moves[index]``; see :func:`sample_move`."""
        return sample_move(self.moves[index], max_angle_deg)

    @property
    def five_axis(self) -> bool:
        """True when the moves carry tool vectors (:attr:`Move.axis_start`)."""
        return any(m.axis_start is not None for m in self.moves)

    @cached_property
    def axes_start(self) -> np.ndarray:
        """Tool vectors at the move starts, shape ``(n, 3)`` (+Z where a move has none)."""
        return _readonly(np.array([m.axis_start or (0.0, 0.0, 1.0) for m in self.moves],
                                  dtype=float).reshape(-1, 3))

    @cached_property
    def axes_end(self) -> np.ndarray:
        """Tool vectors at the move ends, shape ``(n, 3)`` (+Z where a move has none)."""
        return _readonly(np.array([m.axis_end or (0.0, 0.0, 1.0) for m in self.moves],
                                  dtype=float).reshape(-1, 3))

    @cached_property
    def starts(self) -> np.ndarray:
        """Start points, shape ``(n, 3)`` [mm] (read-only)."""
        return _readonly(np.array([m.start for m in self.moves], dtype=float).reshape(-1, 3))

    @cached_property
    def ends(self) -> np.ndarray:
        """End points, shape ``(n, 3)`` [mm] (read-only)."""
        return _readonly(np.array([m.end for m in self.moves], dtype=float).reshape(-1, 3))

    @cached_property
    def feeds_mm_s(self) -> np.ndarray:
        """Feeds [mm/s], NaN for rapids, shape ``(n,)`` (read-only)."""
        return _readonly(np.array(
            [math.nan if m.feed_mm_s is None else m.feed_mm_s for m in self.moves], dtype=float))

    @cached_property
    def kinds(self) -> np.ndarray:
        """Move kinds as strings (``"rapid"``, ``"line"``, ``"arc"``), shape ``(n,)``."""
        return _readonly(np.array([m.kind.value for m in self.moves], dtype="<U5"))

    @cached_property
    def categories(self) -> np.ndarray:
        """Categories as strings (``"cut"``, ``"plunge"``, ...), shape ``(n,)``."""
        return _readonly(np.array([m.category.value for m in self.moves], dtype="<U7"))

    @cached_property
    def lines(self) -> np.ndarray:
        """1-based source line of each move, shape ``(n,)`` (read-only)."""
        return _readonly(np.array([m.line for m in self.moves], dtype=np.int64))
