"""The geometry stage of a scenario run: the scenario's path section -> :class:`Path`.

The section is duck-typed (the attributes of ``feedopt.scenario.PathSection``: generator,
length_mm, height_mm, waves, start_mm, end_mm, file, z_mm, blend, blend_size_mm,
drop_repeated_waypoints), in the scenario's user units (mm); geometry does not import the
scenario module.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path as FilePath
from typing import Any

import numpy as np

from feedopt.errors import InputError
from feedopt.gcode import read_apt, read_gcode, read_heidenhain
from feedopt.geometry.orientation import blend_orientation
from feedopt.geometry.orientation_knots import waypoint_knots
from feedopt.geometry.path import (
    MAX_SAMPLES,
    Path,
    PathPoints,
    build_lipb_path,
    check_sample_count,
)
from feedopt.geometry.program_path import (
    ProgramPath,
    ProgramPathOptions,
    program_path,
    segment_labels,
)
from feedopt.geometry.waves import square_wave, straight_line, triangle_wave
from feedopt.geometry.waypoints import read_tool_vectors_csv, read_waypoints_csv
from feedopt.units import MM

#: what the refusal of repeated waypoints suggests in a scenario
SCENARIO_REPEAT_HINT = "set path.drop_repeated_waypoints: true"
Resolver = Callable[[FilePath, str, str], FilePath]


def resolve_file(base: FilePath, relative: str, what: str) -> FilePath:
    """A file named in a scenario, relative to ``base`` unless absolute; InputError if it
    does not exist (the message of ``feedopt.scenario.resolve``)."""
    p = FilePath(relative)
    p = p if p.is_absolute() else base / p
    if not os.path.lexists(p):  # a dangling link or a loop: its reader says what it is
        raise InputError(f"{what} not found: {relative} (looked for {p})")
    return p


def waypoints_from_section(section: Any, base_dir: FilePath,
                           resolve: Resolver = resolve_file) -> np.ndarray:
    """Waypoints (n, 3) [m] in the workpiece frame: the generated wave (lifted to ``z_mm``),
    the line, or the CSV file ``section.file`` resolved against ``base_dir``."""
    gen = section.generator
    if gen == "triangle_wave":
        w = triangle_wave(section.length_mm * MM, section.height_mm * MM, section.waves)
    elif gen == "square_wave":
        w = square_wave(section.length_mm * MM, section.height_mm * MM, section.waves)
    elif gen == "line":
        w = straight_line(np.asarray(section.start_mm) * MM, np.asarray(section.end_mm) * MM)
    elif gen == "csv":
        w = read_waypoints_csv(resolve(base_dir, section.file, "path.file (waypoint CSV)"))
    else:
        raise InputError(f"path.generator {gen!r} is not one of triangle_wave, square_wave, "
                         "line, csv")
    w = np.array(w, dtype=float)
    if gen in ("triangle_wave", "square_wave"):
        w[:, 2] += section.z_mm * MM
    return w


def program_options(section: Any, stock_top: bool = True) -> ProgramPathOptions:
    """The program-path options of a ``gcode`` path section (mm -> m); ``stock_top`` False:
    ``stock_top_mm`` is not used (a stock model has the material itself): air links are not
    checked against it and plunges count as air moves for the tolerance."""
    return ProgramPathOptions(
        tolerance=section.tolerance_mm * MM, air_tolerance=section.air_tolerance_mm * MM,
        blend=section.blend, blend_size=section.blend_size_mm * MM,
        chain_max_move=section.chain_max_move_mm * MM,
        chain_max_turn=math.radians(section.chain_max_turn_deg),
        stock_top=section.stock_top_mm * MM if stock_top else None,
        orientation_tolerance=math.radians(section.orientation_tolerance_deg))


def check_tools(program, tool_number: int | None) -> None:
    """InputError when the program cuts with several tools, or with another one than
    ``path.tool_number`` (the scenario describes one tool)."""
    cutting = [m for m in program.moves if m.category.value == "cut" and m.tool is not None]
    tools = list(dict.fromkeys(m.tool for m in cutting))
    if len(tools) > 1:
        second = next(m for m in cutting if m.tool == tools[1])
        raise InputError(
            f"{program.source} line {second.line}: the program cuts with tools "
            f"{', '.join(f'T{t}' for t in tools)}; the scenario describes one tool (its tool "
            "file): split the program per tool")
    if tool_number is not None and tools and tools[0] != tool_number:
        first = next(m for m in cutting if m.tool == tools[0])
        raise InputError(
            f"{program.source} line {first.line}: the program cuts with T{tools[0]}, but "
            f"path.tool_number is {tool_number} (the tool the scenario's tool file describes)")


#: program readers besides G-code's: generator -> (reader, what the file is)
_PROGRAM_READERS = {"apt": (read_apt, "APT CL file"),
                    "heidenhain": (read_heidenhain, "HEIDENHAIN Klartext program")}


def program_from_section(section: Any, base_dir: FilePath,
                         resolve: Resolver = resolve_file, stock_top: bool = True
                         ) -> ProgramPath:
    """The smoothed path of the section's G-code program, with its provenance and report."""
    if section.generator == "gcode":
        file = resolve(base_dir, section.file, "path.file (G-code program)")
        program = read_gcode(file, arc_tolerance_mm=section.arc_tolerance_mm,
                             dwell_p_units=section.dwell_p_units)
    else:
        reader, what = _PROGRAM_READERS[section.generator]
        file = resolve(base_dir, section.file, f"path.file ({what})")
        program = reader(file, arc_tolerance_mm=section.arc_tolerance_mm)
    check_tools(program, section.tool_number)
    result = program_path(program, program_options(section, stock_top))
    notes = tuple(f"{file.name}: {w}" for w in (*program.warnings, *result.warnings))
    result.path.notes = notes
    result.path.junctions = result.junctions
    return result


def path_from_section(section: Any, base_dir: FilePath, *,
                      resolve: Resolver = resolve_file, stock_top: bool = True) -> Path:
    """The scenario's path (:func:`~feedopt.geometry.path.build_lipb_path` of its waypoints
    with its blend); every geometry error is prefixed with the section, e.g.
    ``path (csv, blend circle 12.7 mm): ...``, and the repeated-waypoint refusal points at
    ``path.drop_repeated_waypoints``. The path's ``dropped_waypoints`` lists the waypoints it
    dropped. A ``gcode`` section gives the program's path (:func:`program_from_section`),
    whose ``moves`` say where every programmed move lies and ``notes`` what the reader and
    the smoothing recorded."""
    if section.generator in _PROGRAM_READERS or section.generator == "gcode":
        return program_from_section(section, base_dir, resolve, stock_top).path
    vectors, name = None, ""
    try:
        if section.generator == "csv":  # resolved once: its tool vectors are read from it too
            file = resolve(base_dir, section.file, "path.file (waypoint CSV)")
            waypoints, vectors, name = read_waypoints_csv(file), read_tool_vectors_csv(file), \
                file.name
        else:
            waypoints = waypoints_from_section(section, base_dir, resolve)
        path = build_lipb_path(waypoints, section.blend, section.blend_size_mm * MM,
                               drop_repeated=section.drop_repeated_waypoints,
                               repeat_hint=SCENARIO_REPEAT_HINT)
    except InputError as exc:
        raise InputError(f"path ({section.generator}, blend {section.blend} "
                         f"{section.blend_size_mm:g} mm): {exc}") from None
    if vectors is not None:
        orient_waypoints(path, waypoints, vectors, name,
                          math.radians(section.orientation_tolerance_deg))
    return path


def orient_waypoints(path: Path, waypoints: np.ndarray, vectors: np.ndarray, name: str,
                      tolerance: float) -> None:
    """Give a five-axis waypoint path its G2 orientation within ``tolerance`` [rad]."""
    dropped = np.asarray(path.dropped_waypoints, dtype=int)
    if dropped.size:  # a repeated point that turns the tool would be a turn in place
        a, b = vectors[dropped], vectors[dropped - 1]
        turn = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1),
                                     np.einsum("ij,ij->i", a, b)))
        if np.any(turn > 1e-7):
            k = int(np.argmax(turn))
            raise InputError(f"{name}: waypoint {int(dropped[k]) + 1} repeats the one before "
                             f"with a tool vector {turn[k]:.3g} deg away (a turn in place; "
                             "feedopt turns the tool only while it travels along the path): "
                             "remove it or give it the same vector")
    kept = np.delete(np.arange(len(waypoints)), dropped)
    knots = waypoint_knots(path, waypoints[kept], vectors[kept], name)
    path.orientation = blend_orientation(knots, tolerance)
    dev = path.orientation.deviation().max(initial=0.0)
    path.notes = (*path.notes, f"{name}: tool vectors at {kept.size} waypoints, their great "
                  f"circles blended G2 within {math.degrees(tolerance):g} deg (largest "
                  f"{math.degrees(dev):.3g} deg)")


def sample_path(path: Path, spacing: float) -> PathPoints:
    """The path sampled every ``spacing`` [m] of arc length (more finely where a five-axis
    path's tool vector turns fast), after refusing a sample count past the cap (named as
    ``path.spacing_mm``)."""
    check_sample_count(path.length, spacing, "path.spacing_mm")
    samples = path.sample(spacing)
    if samples.s.size > MAX_SAMPLES:
        raise InputError(f"path.spacing_mm = {spacing / MM:g} mm: the tool vector turns so fast "
                         f"that sampling it finely enough gives {samples.s.size:.3g} samples; at"
                         f" most {MAX_SAMPLES:.0e} are planned (a coarser spacing or a path "
                         "whose tool turns less)")
    return samples


def segment_names(path: Path) -> list[str]:
    """Readable name of each path segment for messages ("line 3", "circle blend of corner 2",
    "arc at line 88 (N880)" on a program)."""
    if path.moves is not None:
        return segment_labels(path)
    return [f"line {i}" if seg.kind == "line" else
            f"{seg.kind} blend of corner {seg.corner_index}" for i, seg in enumerate(path.segments)]


def path_warnings(path: Path) -> list[str]:
    """What the run should say about the path: the notes of a program's reader and smoothing,
    and the repeated waypoints dropped (``path.drop_repeated_waypoints``)."""
    warnings = list(path.notes)
    if path.dropped_waypoints:
        shown = ", ".join(str(i) for i in path.dropped_waypoints[:10])
        more = len(path.dropped_waypoints) - 10
        warnings.append(f"path: dropped {len(path.dropped_waypoints)} repeated waypoint(s) "
                        f"(indices {shown}{f' and {more} more' if more > 0 else ''}), as "
                        "path.drop_repeated_waypoints asks")
    return warnings


def air_samples(path: Path, s: np.ndarray) -> np.ndarray | None:
    """(n,) bool: the samples at ``s`` [m] on a program's moves that do not cut (rapids,
    links, plunges); None on a path without moves (every sample cuts)."""
    if path.moves is None:
        return None
    return path.moves.category[path.moves.index_at(s)] != "cut"
