"""Where a five-axis program's tool vectors sit on its smoothed path (the knots of
:mod:`feedopt.geometry.orientation`).

Every programmed move (not the air-link legs the path adds) puts its start vector where it
starts on the path (``MoveTable.s_start``) and its end vector where the next one starts (the
path's end for the last). Neighbouring moves share their knot when the vectors agree. A move
whose start vector differs from the previous move's end vector (the program turned the tool
without moving it) is turned during that move instead when it is an air move (rapid, plunge,
retract: a note says so); before a cutting move it is refused, since the tool turns only while
it travels along the path. Knots at the stops of the path are marked: they get no blend.
"""

from __future__ import annotations

import math

import numpy as np

from feedopt.errors import InputError
from feedopt.gcode.moves import Program
from feedopt.geometry.orientation import OrientationKnots
from feedopt.geometry.path import Path

#: vectors closer than this [rad] are the same programmed orientation
SAME_AXIS = 1e-9


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def program_knots(program: Program, s_start: np.ndarray, program_move: np.ndarray,
                  stop_s: np.ndarray, length: float, merge: float = 0.0
                  ) -> tuple[OrientationKnots, list[str], float]:
    """The knots of ``program`` (the linked program the path was built from), the notes on
    tool turns moved into air moves and merged vectors, and the largest merged turn [rad].

    s_start : (m,) where each of its moves starts on the path [m]; program_move : (m,) the
    index of the programmed move (-1 for air-link legs); stop_s : arc lengths of the path's
    stops [m]; length : the path's length [m]; merge : vectors at one arc length (moves the
    smoothing shortened to nothing) that differ by at most this [rad] are merged into the
    first of them (the caller blends within its tolerance less the largest merged turn).
    """
    rows = np.flatnonzero(np.asarray(program_move) >= 0)
    ends = np.append(s_start[1:], length)
    s = np.column_stack([s_start[rows], ends[rows]]).ravel()
    u = np.stack([program.axes_start[rows], program.axes_end[rows]], axis=1).reshape(-1, 3)
    lines = np.repeat(program.lines[rows], 2)
    air = np.repeat(program.categories[rows] != "cut", 2)
    is_start = np.tile([True, False], rows.size)
    keep = np.ones(s.size, dtype=bool)
    same_s = np.diff(s) <= 1e-12 * max(length, 1e-12)
    turn = _angles(u[:-1], u[1:])
    keep[1:][same_s & (turn <= SAME_AXIS)] = False  # shared knots
    merged = same_s & (turn > SAME_AXIS) & (turn <= merge)
    keep[1:][merged] = False
    moved = same_s & (turn > max(SAME_AXIS, merge)) & is_start[1:]
    notes = []
    if merged.any():
        notes.append(f"{int(merged.sum())} tool vector(s) of moves the smoothing shortened to "
                     f"nothing merged with their neighbour (largest difference "
                     f"{math.degrees(turn[merged].max()):.3g} deg; first at line "
                     f"{lines[int(np.flatnonzero(merged)[0]) + 1]})")
    if np.any(moved & ~air[1:]):
        j = int(np.flatnonzero(moved & ~air[1:])[0]) + 1
        raise InputError(
            f"{program.source} line {lines[j]}: the tool vector turns "
            f"{math.degrees(turn[j - 1]):.3g} deg before this cutting move without the tool "
            "moving (or over a stretch the smoothing shortened to nothing); feedopt turns the "
            "tool only while it travels along the path: turn it during the move before, or "
            "through the air")
    if moved.any():
        keep[1:][moved] = False
        first = lines[int(np.flatnonzero(moved)[0]) + 1]
        notes.append(f"{int(moved.sum())} turn(s) of the tool vector without motion (first "
                     f"before line {first}) are made during the air move that follows")
    merged_turn = float(turn[merged].max()) if merged.any() else 0.0
    return _finish(s[keep], u[keep], lines[keep], stop_s, length,
                   f"{program.source} line"), notes, merged_turn


def _finish(s: np.ndarray, u: np.ndarray, lines: np.ndarray, stop_s: np.ndarray,
            length: float, where: str) -> OrientationKnots:
    """Knots covering [0, length], strictly increasing, stops marked, labelled ``where``
    and the number in ``lines``; InputError where two different vectors still share one arc
    length."""
    if s[0] > 0.0:
        s, u, lines = np.r_[0.0, s], np.r_[u[:1], u], np.r_[lines[:1], lines]
    if s[-1] < length:
        s, u, lines = np.r_[s, length], np.r_[u, u[-1:]], np.r_[lines, lines[-1:]]
    bad = np.flatnonzero(np.diff(s) <= 0.0)
    if bad.size:
        j = int(bad[0]) + 1
        raise InputError(f"{where} {lines[j]}: two tool vectors at one point of the path "
                         f"(s = {s[j] * 1e3:.4f} mm: the smoothing shortened the moves between "
                         "them to nothing, or the tool turns in place); feedopt turns the tool "
                         "only while it travels along the path")
    tol = 1e-9 * max(length, 1e-12)
    stop = np.zeros(s.size, dtype=bool)
    if np.asarray(stop_s).size:
        k = np.clip(np.searchsorted(s, stop_s), 0, s.size - 1)
        near = np.abs(s[k] - stop_s) <= tol
        stop[k[near]] = True
    return OrientationKnots(s=s, u=u, stop=stop,
                           label=tuple(f"{where} {int(x)}" for x in lines))


def waypoint_arc_lengths(path: Path, waypoints: np.ndarray) -> np.ndarray:
    """Where an LIPB path (:func:`~feedopt.geometry.path.build_lipb_path`) passes each of its
    kept ``waypoints`` (k, 3) [m]: the middle of the blend rounding it, the junction of its
    two lines where it has none, the ends for the first and last."""
    corner = np.array([g.corner_index for g in path.segments])
    mid = np.array([g.s_start + 0.5 * g.length for g in path.segments])
    kept = np.setdiff1d(np.arange(len(waypoints) + len(path.dropped_waypoints)),
                        path.dropped_waypoints)
    lines = [g for g in path.segments if g.kind == "line"]
    ends = np.array([[*g.params["origin"], g.s_start] for g in lines]
                    + [[*(g.params["origin"] + g.length * g.params["direction"]), g.s_end]
                       for g in lines])
    gap = np.linalg.norm(waypoints[:, None, :] - ends[None, :, :3], axis=2)
    s = ends[np.argmin(gap, axis=1), 3]
    blended = np.isin(kept, corner)
    where = {int(c): k for k, c in enumerate(corner) if c >= 0}
    s[blended] = mid[[where[int(c)] for c in kept[blended]]]
    s[0], s[-1] = 0.0, path.length
    return s


def waypoint_knots(path: Path, waypoints: np.ndarray, u: np.ndarray, source: str
                   ) -> OrientationKnots:
    """The knots of a five-axis waypoint list: the vector ``u`` (k, 3) unit of each kept
    waypoint where the path passes it (:func:`waypoint_arc_lengths`), labelled by rows."""
    s = waypoint_arc_lengths(path, waypoints)
    return _finish(s, u, np.arange(1, len(s) + 1), np.zeros(0), path.length,
                   f"{source} waypoint")
