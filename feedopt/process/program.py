"""What a G-code program says about the process: spindle speed, tool, nominal feed per move.

A program's S word is the spindle speed and its F words the nominal feed of every move
(:mod:`feedopt.geometry.program_path` keeps them per move). :func:`apply_program` fills the
scenario's ``cut.spindle_rpm`` and ``feed.nominal_mm_s`` from them, so every later stage reads
one set of settings, and refuses a program that needs what the force model does not have
(several spindle speeds while cutting; the tools are checked when the program is read,
:func:`feedopt.geometry.stage.check_tools`).
"""

from __future__ import annotations

import numpy as np

from feedopt.errors import InputError
from feedopt.units import MM


def _cutting(moves) -> np.ndarray:
    return moves.category == "cut"


def apply_program(scenario, moves, source: str):
    """The scenario with ``cut.spindle_rpm`` and ``feed.nominal_mm_s`` from the program.

    ``moves`` is the path's :class:`~feedopt.geometry.program_path.MoveTable`. The nominal
    feed recorded is the programmed cutting feed that covers the longest stretch of the path
    (summary and report; the laws get the feed of every move). Returns ``(scenario,
    warnings)``.
    """
    cut = _cutting(moves)
    rpm = moves.spindle_rpm[cut]
    known = rpm[np.isfinite(rpm)]
    speeds = np.unique(known)
    if speeds.size > 1:
        first = int(np.flatnonzero(cut & np.isfinite(moves.spindle_rpm)
                                   & (moves.spindle_rpm != speeds[0]))[0])
        raise InputError(
            f"{source} {moves.label(first)}: the program cuts at {speeds.size} spindle speeds "
            f"({', '.join(f'S{v:g}' for v in speeds)}); feedopt plans one speed per program "
            "(one set of cutting coefficients): split the program at the speed change")
    given = scenario.cut.spindle_rpm
    if speeds.size and known.size < rpm.size:
        first = int(np.flatnonzero(cut & ~np.isfinite(moves.spindle_rpm))[0])
        raise InputError(f"{source} {moves.label(first)}: cutting before any S word; give "
                         "the spindle speed (S) before the first cut")
    if speeds.size and given is not None and not np.isclose(given, speeds[0], rtol=1e-9):
        raise InputError(
            f"cut.spindle_rpm = {given:g} disagrees with the program's S{speeds[0]:g}: the "
            "program sets the spindle speed; remove cut.spindle_rpm or fix the program")
    if not speeds.size and given is None:
        raise InputError(f"{source}: the program has no S word; give cut.spindle_rpm")
    rpm_used = float(speeds[0]) if speeds.size else float(given)
    feed = moves.feed[cut]
    length = np.diff(np.append(moves.s_start, np.inf))[cut]
    values, inverse = np.unique(feed, return_inverse=True)
    share = np.bincount(inverse.ravel(), weights=np.where(np.isfinite(length), length, 0.0))
    nominal = float(values[int(np.argmax(share))]) / MM
    updated = scenario.model_copy(update={
        "cut": scenario.cut.model_copy(update={"spindle_rpm": rpm_used}),
        "feed": scenario.feed.model_copy(update={"nominal_mm_s": nominal}),
    })
    warnings = []
    if values.size > 1:
        warnings.append(
            f"the program cuts at {values.size} feeds ({', '.join(f'{v / MM:.4g}' for v in values)}"
            f" mm/s); each move's F is its nominal feed, {nominal:.4g} mm/s (the longest "
            "stretch) is reported as the nominal")
    return updated, warnings


def settings_from_program(scenario, path):
    """:func:`apply_program` on a program path (``path.moves``, read from
    ``scenario.path.file``): ``(scenario, warnings)``; a path without moves: the scenario
    unchanged, no warnings."""
    if path.moves is None:
        return scenario, []
    return apply_program(scenario, path.moves, scenario.path.file)


def unmodelled_plunge_moves(moves, s: np.ndarray, plunge: np.ndarray | None) -> list[int]:
    """Indices of the program moves holding samples ``s`` that plunge into material without
    a plunge model (``plunge``: per sample, from the process stage), in program order."""
    if plunge is None or not np.any(plunge):
        return []
    return np.unique(moves.index_at(s[np.asarray(plunge, dtype=bool)])).tolist()


def unmodelled_plunge_note(moves, indices: list[int], cap_mm_s: float | None) -> str | None:
    """The sentence every output carries about plunges planned without a plunge model."""
    if not indices:
        return None
    shown = ", ".join(moves.label(i) for i in indices[:10])
    more = f" and {len(indices) - 10} more" if len(indices) > 10 else ""
    cap = ("the program's F" if cap_mm_s is None
           else f"the program's F, at most feed.plunge_max_mm_s = {cap_mm_s:g} mm/s")
    return (f"not deflection-limited: no plunge coefficients in the material file: "
            f"{len(indices)} straight plunge(s) into material run at {cap} ({shown}{more}); "
            "add a plunge: block (feedopt calibrate) to bound them")
