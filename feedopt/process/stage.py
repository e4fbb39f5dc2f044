"""The process stage of a run: tool, cutting coefficients and engagement along the path.

:func:`process_along_path` is what the runner calls; it takes the scenario's ``tool``,
``material`` and ``cut`` entries (files resolved against the scenario's folder) and the
sampled path, and says what the run should know (tight path radii, feeds per tooth outside
the calibrated range) as warnings.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.process.coefficients import (
    CoefficientTable,
    CuttingCoefficients,
    feed_per_tooth_warning,
    load_coefficients,
)
from feedopt.process.dexel_material import DexelMaterialAlongPath, engagement_from_dexel
from feedopt.process.engagement import (
    Engagement,
    peripheral_engagement,
    radial_depth_profile,
    slot_engagement,
)
from feedopt.process.general_forces import slice_engagement
from feedopt.process.material import MaterialAlongPath, engagement_from_stock
from feedopt.process.path_radius import check_path_radius
from feedopt.process.plunge import check_plunge_depth
from feedopt.process.program_tool import check_program_tool
from feedopt.process.tool import Tool, load_tool
from feedopt.units import MM


@dataclass(frozen=True, eq=False)
class ProcessAlongPath:
    """Tool, coefficients (all speeds, and at the spindle speed), per-sample engagement.

    ``unmodelled_plunge`` (n,) bool marks the samples of straight plunges into material that
    have no force model because the material file has no plunge coefficients: their
    engagement carries no plunge (no end-edge force), so the deflection bound does not
    limit their feed; the caller caps it. An empty array means none (the default).
    """

    tool: Tool
    table: CoefficientTable
    coefficients: CuttingCoefficients
    engagement: Engagement
    warnings: tuple[str, ...]
    # with a stock: the sweep and the stock (a tri-dexel for a tilted tool)
    material: MaterialAlongPath | DexelMaterialAlongPath | None = None
    unmodelled_plunge: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))


def engagement_of(cut, tool: Tool, s: np.ndarray) -> Engagement:
    """Per-sample engagement from the scenario's ``cut`` section (stated by hand)."""
    depth = cut.axial_depth_mm * MM
    if depth > tool.flute_length:
        raise InputError(
            f"cut.axial_depth_mm = {cut.axial_depth_mm:g} mm exceeds the flute length "
            f"{tool.flute_length / MM:g} mm of tool '{tool.name}'"
        )
    if cut.type == "slot":
        return slot_engagement(s.size, depth)
    try:
        return _peripheral(cut, tool, s, depth)
    except InputError as exc:
        field = ("cut.radial_depth_profile" if cut.radial_depth_profile is not None
                 else "cut.radial_depth_mm")
        raise InputError(f"{field}: {exc}") from None


def _peripheral(cut, tool: Tool, s: np.ndarray, depth: float) -> Engagement:
    if cut.radial_depth_profile is not None:
        prof = cut.radial_depth_profile
        table_s = (np.asarray(prof.s_mm) * MM if prof.s_mm is not None
                   else np.asarray(prof.s_fraction) * s[-1])
        radial = radial_depth_profile(s, table_s, np.asarray(prof.depth_mm) * MM)
    else:
        radial = np.full(s.size, cut.radial_depth_mm * MM)
    return peripheral_engagement(radial, tool.diameter, depth, cut.milling)


def seconds_per_tooth(rpm: float, tool: Tool) -> float:
    """Time between two teeth [s]: feed per tooth = feed * this."""
    return 1.0 / (rpm / 60.0 * tool.teeth)


def feed_range_warnings(table: CoefficientTable, feeds: list[tuple[str, float]], rpm: float,
                        tool: Tool) -> list[str]:
    """Warnings for named feeds [m/s] whose feed per tooth leaves the calibrated range."""
    out = []
    for what, v in feeds:
        text = feed_per_tooth_warning(table, v * seconds_per_tooth(rpm, tool))
        if text:
            out.append(f"{what} ({v / MM:.4g} mm/s): {text}")
    return out


def bound_feed_warnings(process: ProcessAlongPath, v_max: np.ndarray, rpm: float) -> list[str]:
    """A warning when the lowest feed of the bound ``v_max`` [m/s] (the two end samples
    excluded) leaves the calibrated range of feeds per tooth at ``rpm``."""
    lowest = float(np.min(v_max[1:-1] if v_max.size > 2 else v_max))
    return feed_range_warnings(process.table, [("the lowest feed of the bound", lowest)], rpm,
                               process.tool)


def stock_description(material, section) -> str:
    """``"; stock ..."`` for ``feedopt validate``: the Z-map's cells or the tri-dexel's rays
    and spacing, and the mesh's units; ``""`` without a stock."""
    if material is None:
        return ""
    grid = material.before
    units = f", mesh read in {section.units or 'mm'}" if section.mesh else ""
    if isinstance(material, DexelMaterialAlongPath):
        size = (f"tri-dexel {' + '.join(f'{r:,}' for r in grid.rays)} rays every "
                f"{grid.spacing / MM:g} mm")
    else:
        size = f"{grid.shape[0]} x {grid.shape[1]} cells of {grid.cell / MM:g} mm"
    return f"; stock {size}{units}"


def process_warnings(process: ProcessAlongPath, path, scenario) -> list[str]:
    """The warnings of the process stage: the program's tool comment against the scenario's
    tool file (:func:`~feedopt.process.program_tool.check_program_tool`), then the stage's
    own (:attr:`ProcessAlongPath.warnings`)."""
    return (check_program_tool(path, process.tool, scenario.path.file, scenario.tool)
            + list(process.warnings))


#: Depth below the stock top [m] under which a tool tip counts as in the material (1 nm).
_IN_MATERIAL = 1e-9


def in_program_air(engagement: Engagement, moves, samples, stock_top: float,
                   tool: Tool | None = None, source: str = "the program") -> Engagement:
    """The engagement of a program path without a stock model: none on rapids and retracts
    and above the stock top; on cut moves the stated one, its axial depth limited to the
    material below the tool tip (stock top - z), so ramps and helices enter the cut
    gradually; on plunges (G1 along -Z) below the stock top a full plunge
    (``plunge = 1``, :mod:`feedopt.process.plunge`) and no side engagement.

    With ``tool``, a plunge whose tip goes deeper below the stock top than the tool's flute
    length is refused (InputError naming ``source``, the line and the flute length).
    """
    move = moves.index_at(samples.s)
    category = moves.category[move]
    below = stock_top - samples.position[:, 2]
    depth = np.minimum(engagement.axial_depth, below)
    air = (category != "cut") | (depth <= _IN_MATERIAL)
    depth = np.where(air, engagement.axial_depth, depth)
    plunge = (category == "plunge") & (below > _IN_MATERIAL)
    if tool is not None:
        check_plunge_depth(plunge & (below > tool.flute_length * (1 + 1e-9)), move, moves,
                           tool, source, below)
    return Engagement(entry=np.where(air, 0.0, engagement.entry),
                      exit=np.where(air, 0.0, engagement.exit), axial_depth=depth,
                      plunge=plunge.astype(float))


def unmodelled_plunges(engagement: Engagement, coefficients: CuttingCoefficients, moves,
                       samples, material_name: str, tool: Tool | None = None
                       ) -> tuple[Engagement, np.ndarray, list[str]]:
    """Without plunge coefficients, or with a cutter that is not a flat end mill (the
    end-cutting model is a flat end's, :mod:`feedopt.process.plunge`), the plunging samples
    lose their plunge (no force model): returns the engagement to use, the (n,) mask of those
    samples and a warning naming the program lines. Otherwise the engagement unchanged and an
    all-False mask."""
    mask = engagement.plunging
    shaped = tool is not None and not tool.is_flat
    if (coefficients.plunge is not None and not shaped) or not mask.any():
        return engagement, np.zeros(engagement.n, dtype=bool), []
    move = moves.index_at(samples.s[mask]) if moves is not None else np.zeros(0, dtype=int)
    lines = [moves.label(int(m)) for m in dict.fromkeys(move.tolist())]
    shown = (", ".join(lines[:10]) + (f" and {len(lines) - 10} more" if len(lines) > 10 else "")
             or "the path")
    why = (f"the end-cutting model is a flat end mill's, the tool is a {tool.shape.value} "
           "cutter" if shaped else f"material file {material_name!r} has no plunge "
           "coefficients (a plunge: block per speed; feedopt calibrate --plunge-forces fits "
           "them)")
    warning = (f"the plunges along the tool axis into material at {shown} ({int(mask.sum())} "
               f"samples) have no force model: {why}; the deflection limit does not bound "
               "their feed")
    return engagement.with_plunge(None), mask, [warning]


#: a five-axis path whose feed descends along the tool axis by more than this [deg] while
#: cutting gets a note (what the force model assumes or leaves out there)
DESCENT_NOTE_DEG = 5.0


def feed_along_axis(samples, cutting: np.ndarray) -> np.ndarray | None:
    """Per sample the unit feed direction's component along the tool axis ``t . k`` (the
    sine of the lean: a lead or tilt against the path, a ramp) on a five-axis path's cutting
    samples, 0 elsewhere (:attr:`Engagement.feed_axial`); None on a three-axis path (the
    feed taken across the axis, as before)."""
    if samples.axis is None or not cutting.any():
        return None
    along = np.clip(np.einsum("ij,ij->i", samples.tangent, samples.axis), -1.0, 1.0)
    return np.where(cutting, along, 0.0)


def descent_notes(samples, feed_axial: np.ndarray | None, tool, stock: bool = False
                  ) -> list[str]:
    """A note where the feed descends along the tool axis by more than
    :data:`DESCENT_NOTE_DEG` while cutting: a cutter with a flat bottom (flat, bull) cuts a
    chip with its end edges that the force model does not have (a flat end mill's side edges
    then take the whole feed: :func:`~feedopt.process.forces.flat_side_scale`); a rounded
    bottom (ball) cuts behind the tool too, where the ``cut:`` engagement's lateral band is
    taken to have material (:func:`~feedopt.process.general_forces.slice_engagement`).
    With ``stock`` (the engagement found in a tri-dexel, per slice) a rounded bottom's cut
    is found, not assumed (the note says where the model is extrapolated); a flat bottom's
    side edges take the feed's component across the axis."""
    if feed_axial is None:
        return []
    angle = np.degrees(np.arcsin(np.clip(-feed_axial, 0.0, 1.0)))
    k = int(np.argmax(angle))
    if angle[k] <= DESCENT_NOTE_DEG:
        return []
    if stock and tool.profile.r0 <= 0.0:
        what = (f"the {tool.shape.value} cutter's rounded bottom cuts there with the chip of "
                "each slice found in the stock, behind the tool too; near the tip the cutting "
                "speed tends to zero, where the calibrated coefficients are extrapolated")
    elif tool.profile.r0 > 0.0:
        side = (" (the side edges take the whole feed there: an upper bound of their chip)"
                if tool.is_flat and not stock else "")
        what = (f"the end edges of the {tool.shape.value} cutter's flat bottom cut a chip there "
                f"that the force model does not have{side}")
    else:
        what = (f"the {tool.shape.value} cutter's edge behind its bottom cuts too; the stated "
                "engagement's lateral band of material is taken to reach behind the tool there")
    return [f"the feed descends along the tool axis by up to {angle[k]:.3g} deg while cutting "
            f"({int(np.count_nonzero(angle > DESCENT_NOTE_DEG))} sample(s) over "
            f"{DESCENT_NOTE_DEG:g} deg, the most at s = {samples.s[k] / MM:.2f} mm): {what}"]


#: axial slices of the check behind :func:`lifted_notes` (milling_forces' default)
LIFT_NOTE_SLICES = 20


def lifted_notes(samples, engagement: Engagement, tool) -> list[str]:
    """A note where a general cutter's stated engagement cuts nothing because its feed rises
    along the axis so steeply that no edge point is on the front of the tool (a lead of
    lambda takes the edge below kappa = lambda out of the cut): zero force there."""
    if engagement.feed_axial is None or tool.is_flat or engagement.by_slice is not None:
        return []
    cutting = engagement.exit > engagement.entry
    se = slice_engagement(tool, engagement.take(np.flatnonzero(cutting)), LIFT_NOTE_SLICES)
    empty = ~np.any(se.lo < se.hi, axis=(1, 2))
    if not empty.any():
        return []
    rows = np.flatnonzero(cutting)[empty]
    k = int(rows[np.argmax(engagement.feed_axial[rows])])
    return [f"the {tool.shape.value} cutter cuts nothing at {rows.size} sample(s) of the "
            f"stated engagement (the first at s = {samples.s[rows[0]] / MM:.2f} mm): the feed "
            f"rises along the tool axis by up to "
            f"{np.degrees(np.arcsin(engagement.feed_axial[k])):.3g} deg, which takes every "
            "engaged edge point off the front of the tool (zero force, no deflection bound "
            "there)"]


def process_along_path(scenario, resolve: Callable[[str, str], Path], samples,
                       segment_names: list[str], moves=None) -> ProcessAlongPath:
    """Load the tool and material of ``scenario`` and state the engagement of every sample.

    ``resolve(relative, what)`` finds a file named in the scenario. ``samples`` is the
    sampled path (:class:`feedopt.geometry.path.PathPoints`); ``moves`` the path's program
    provenance (:class:`feedopt.geometry.program_path.MoveTable`) when it comes from a
    G-code program: then only cut moves in the material cut (:func:`in_program_air`).
    """
    cut, feed = scenario.cut, scenario.feed
    tool = load_tool(resolve(scenario.tool, "tool file"))
    if scenario.deflection.mode == "surface" and not tool.is_flat:
        raise InputError(f"deflection.mode surface: the wall and floor error model is a flat "
                         f"end mill's; tool {scenario.tool} is a {tool.shape.value} cutter "
                         "(use mode norm, normal or direction)")
    if scenario.deflection.mode == "surface" and samples.axis is not None:
        raise InputError("deflection.mode surface: the wall and floor error model follows a "
                         "tool along the workpiece's z; this path tilts the tool (its tool "
                         "vectors): use mode norm, normal or direction")
    table = load_coefficients(resolve(scenario.material, "material file"))
    coefficients = table.at(cut.spindle_rpm, extrapolate=cut.extrapolate_coefficients)
    material = None
    source = str(getattr(scenario.path, "file", None) or "the program")
    if scenario.stock is not None and samples.axis is not None:  # a tilted tool: tri-dexel
        material = engagement_from_dexel(scenario.stock, resolve, tool, samples, moves,
                                         source=source, slices=scenario.schedule.axial_slices)
        engagement = material.found.engagement
    elif scenario.stock is not None:
        material = engagement_from_stock(scenario.stock, resolve, tool, samples, moves,
                                         source=source)
        engagement = material.found.engagement
    else:
        engagement = engagement_of(cut, tool, samples.s)
        if moves is not None:
            engagement = in_program_air(engagement, moves, samples,
                                        scenario.path.stock_top_mm * MM, tool, source)
    engagement, unmodelled, plunge_notes = unmodelled_plunges(
        engagement, coefficients, moves, samples, scenario.material, tool)
    if engagement.by_slice is None:  # a tilted tool's stock engagement has its lean
        engagement = engagement.with_feed_axial(feed_along_axis(samples, engagement.cutting))
    warnings = check_path_radius(samples, segment_names, 0.5 * tool.diameter,
                                 cutting=engagement.cutting,
                                 tool_axis=np.asarray(scenario.workpiece.tool_axis)
                                 if samples.axis is None else samples.axis,
                                 refuse=moves is None)
    feeds = [("feed.nominal_mm_s", feed.nominal_mm_s * MM)]
    if feed.max_mm_s is not None:
        feeds.append(("feed.max_mm_s", feed.max_mm_s * MM))
    warnings += feed_range_warnings(table, feeds, cut.spindle_rpm, tool)
    if material is not None:
        warnings += material.warnings
    warnings += plunge_notes
    warnings += descent_notes(samples, engagement.feed_axial, tool,
                              stock=engagement.by_slice is not None)
    warnings += lifted_notes(samples, engagement, tool)
    if material is not None and material.found.beyond_flutes.any():
        i = int(np.argmax(material.found.beyond_flutes))
        warnings.append(f"the stock reaches above the flutes of the tool at "
                        f"{int(material.found.beyond_flutes.sum())} sample(s) (first at s = "
                        f"{samples.s[i] / MM:.2f} mm): the shank would rub; the axial depth is "
                        "clipped to the flute length")
    return ProcessAlongPath(tool=tool, table=table, coefficients=coefficients,
                            engagement=engagement, warnings=tuple(warnings), material=material,
                            unmodelled_plunge=unmodelled)
