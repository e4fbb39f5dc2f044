"""What building a program's path records: where every move starts on the path
(:class:`MoveTable`), what every programmed junction got and how far the result is from the
program, both ways (:class:`JunctionReport`), and the smoothed chains (:class:`ChainReport`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from feedopt.units import MM, MM_PER_M


class Treatment(Enum):
    """What a programmed junction got."""

    NONE = "none"  #: already G2 (or a G2 jump below G2_TOL)
    BLEND = "blend"  #: a corner blend of the scenario's kind
    TRANSITION = "transition"  #: a quintic G2 transition
    BLEND_TRANSITIONS = "blend+transitions"  #: a G1 blend (circle) and transitions at its ends
    STOP = "stop"  #: the tool stops there: the pieces meet at the programmed point


@dataclass(frozen=True)
class MoveTable:
    """Per programmed move (program order) where it starts on the path and what it is.

    s_start : (m,) arc length where the move starts on the smoothed path [m]
    line, n_number : (m,) source line (1-based) and N number (-1: none)
    category : (m,) "cut" | "plunge" | "rapid" | "retract"
    kind : (m,) "line" | "arc" | "rapid"
    feed : (m,) programmed feed [m/s], NaN for rapids
    spindle_rpm : (m,) last S word [rev/min], NaN before any
    tool : (m,) tool number, -1 before any M6
    program_move : (m,) index into the program's moves, -1 for the legs of an air link
        (which carry the line of the move they lead to); None: one row per program move
    """

    s_start: np.ndarray
    line: np.ndarray
    n_number: np.ndarray
    category: np.ndarray
    kind: np.ndarray
    feed: np.ndarray
    spindle_rpm: np.ndarray
    tool: np.ndarray
    program_move: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.s_start.size)

    def index_at(self, s: np.ndarray) -> np.ndarray:
        """Index of the move each arc length ``s`` [m] belongs to."""
        idx = np.searchsorted(self.s_start, np.asarray(s, dtype=float), side="right") - 1
        return np.clip(idx, 0, len(self) - 1)

    def lowest_cut(self, s: np.ndarray, values: np.ndarray) -> tuple[int, int]:
        """(sample, move) where ``values`` (one per arc length ``s``) is lowest on cut moves
        (on all moves if nothing cuts): "the feed bound is lowest at line 88"."""
        move = self.index_at(s)
        cut = self.category[move] == "cut"
        k = int(np.argmin(np.where(cut, values, np.inf) if cut.any() else values))
        return k, int(move[k])

    def label(self, i: int) -> str:
        """``"line 88 (N880)"`` for move ``i``."""
        n = int(self.n_number[i])
        return f"line {int(self.line[i])}" + (f" (N{n})" if n >= 0 else "")


@dataclass(frozen=True)
class JunctionReport:
    """Per programmed junction (between moves ``before`` and ``before + 1`` that are not
    inside a smoothed chain): what it got and how far the result is from the program.

    before : (k,) index of the move before the junction (in the :class:`MoveTable`)
    s : (k,) arc length of the move boundary on the path [m]
    turn : (k,) programmed turning angle (G1 jump) [rad]
    curvature_jump : (k,) programmed |K_after - K_before| (G2 jump) [1/m]
    treatment : (k,) :class:`Treatment` values
    size : (k,) blend size used [m] (NaN without blend)
    transition_length : (k,) arc length of the transition(s) [m] (NaN without)
    deviation : (k,) two-sided (Hausdorff) distance between the modified stretch and the
        programmed geometry it replaces [m]: the larger of the two below
    tolerance : (k,) the tolerance that applied [m] (a G64 P where the program set one)
    g0, g1, g2 : (k,) largest G0 [m], G1, G2 [1/m] jump of the result over the junction
    labels : (k,) ``"line 12 (N120)->13"``
    path_deviation : (k,) largest distance of a point of the modified stretch from the
        programmed moves near the junction [m] (path -> program)
    program_deviation : (k,) largest distance of a point of the replaced programmed geometry
        from the path [m] (program -> path: how much of the corner is cut short)
    """

    before: np.ndarray
    s: np.ndarray
    turn: np.ndarray
    curvature_jump: np.ndarray
    treatment: tuple[str, ...]
    size: np.ndarray
    transition_length: np.ndarray
    deviation: np.ndarray
    tolerance: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    g2: np.ndarray
    labels: tuple[str, ...] = ()
    path_deviation: np.ndarray | None = None
    program_deviation: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.before.size)

    def worst(self) -> int:
        """Index of the junction whose deviation is the largest fraction of its tolerance
        (-1 without junctions)."""
        if not len(self):
            return -1
        return int(np.argmax(self.deviation / self.tolerance))

    def table(self, max_rows: int | None = 40) -> str:
        """Plain-text table in mm (curvatures in 1/mm); long reports keep head and tail.
        ``path_mm`` and ``prog_mm`` are the two directions of the deviation ``dev_mm``."""
        head = (f"{'junction':>26} {'s_mm':>10} {'turn_deg':>9} {'dK_1_mm':>9} "
                f"{'treatment':>17} {'size_mm':>8} {'trans_mm':>8} {'path_mm':>9} "
                f"{'prog_mm':>9} {'dev_mm':>9} {'tol_mm':>7} {'G0_mm':>8} {'G1':>8} "
                f"{'G2_1_mm':>8}")
        rows = [head]
        idx = list(range(len(self)))
        if max_rows is not None and len(idx) > max_rows:
            half = max_rows // 2
            idx = idx[:half] + [-1] + idx[-half:]
        path_dev = self.deviation if self.path_deviation is None else self.path_deviation
        prog_dev = self.deviation if self.program_deviation is None else self.program_deviation
        for i in idx:
            if i < 0:
                rows.append(f"{'...':>26} ({len(self) - 2 * (max_rows // 2)} junctions omitted)")
                continue
            rows.append(
                f"{self.labels[i]:>26} {self.s[i] * MM_PER_M:>10.3f} "
                f"{math.degrees(self.turn[i]):>9.3f} {self.curvature_jump[i] * MM:>9.4g} "
                f"{self.treatment[i]:>17} {_opt(self.size[i]):>8} "
                f"{_opt(self.transition_length[i]):>8} {path_dev[i] * MM_PER_M:>9.2e} "
                f"{prog_dev[i] * MM_PER_M:>9.2e} {self.deviation[i] * MM_PER_M:>9.2e} "
                f"{self.tolerance[i] * MM_PER_M:>7.3g} {self.g0[i] * MM_PER_M:>8.1e} "
                f"{self.g1[i]:>8.1e} {self.g2[i] * MM:>8.1e}")
        if len(self):
            rows.append(self.summary())
        return "\n".join(rows)

    def summary(self) -> str:
        """One line: the largest deviation relative to its tolerance, with the label, both
        directions and the tolerance of that same junction; the largest in mm too where that
        is another junction (an air junction, whose tolerance is larger); the largest jumps."""
        w = self.worst()
        path_dev = self.deviation if self.path_deviation is None else self.path_deviation
        prog_dev = self.deviation if self.program_deviation is None else self.program_deviation
        text = (f"{len(self)} junctions: largest deviation {self.deviation[w] * MM_PER_M:.3g} mm"
                f" of {self.tolerance[w] * MM_PER_M:.3g} mm at {self.labels[w]} (path -> "
                f"program {path_dev[w] * MM_PER_M:.3g} mm, program -> path "
                f"{prog_dev[w] * MM_PER_M:.3g} mm)")
        big = int(np.argmax(self.deviation))
        if self.deviation[big] > self.deviation[w]:
            text += (f", in mm {self.deviation[big] * MM_PER_M:.3g} mm of "
                     f"{self.tolerance[big] * MM_PER_M:.3g} mm at {self.labels[big]}")
        return (text + f"; largest jumps G0 {self.g0.max() * MM_PER_M:.2g} mm, G1 "
                f"{self.g1.max():.2g}, G2 {self.g2.max() * MM:.2g} 1/mm")


@dataclass(frozen=True)
class ChainReport:
    """A run of short G1 moves smoothed into one spline."""

    first_move: int
    moves: int
    first_line: int
    last_line: int
    length: float  # [m]
    deviation: float  # curve -> program [m]
    coverage: float  # program vertices -> curve [m]
    points: np.ndarray | None = None  # (moves + 1, 3) the programmed vertices [m]


def _opt(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v * MM_PER_M:.3g}"
