"""G-code out: ``<law>.nc``, the path with a feed word per block from a timing law.

For KUKA.CNC cells and CNC machines that plan their own motion from F words: the law's feed
along the path becomes one F (G94, mm/min) per block. Blocks are G1 moves; an F changes where
the law's feed changes by more than :data:`FEED_TOLERANCE` (relative), so each block's F is
the lowest feed the law commands anywhere in it, at most that much below the highest. For a
law that keeps the deflection limit the F is also capped by the feed bound v_max(s) of every
sample in the block and rounded down, so no block is programmed faster than the bound allows
(the controller may still run slower: its own acceleration and look-ahead).

What is written (Fanuc-style, read back by :mod:`feedopt.gcode`): ``G21 G90 G94 G17 G54``,
an ``M0`` stop for the operator to start the spindle (the export does not know the spindle
speed: see the header), a rapid to :data:`CLEARANCE_MM` above the start along the tool axis,
a G1 plunge to the start, the path (lines as single G1 blocks split only where the F changes,
curves as G1 chords within :data:`CHORD_TOLERANCE_MM`), a G0 retract and ``M30``.

Coordinates are the robot base frame in mm, the frame every feedopt export uses
(:mod:`feedopt.export.frames`): for a KUKA.CNC cell select BASE_DATA = $NULLFRAME with the
G54 offset zero; for another machine set G54 to the robot base frame's origin in it. A G-code
program has a fixed tool axis: the exporter writes only paths whose TCP +z (the tool axis) is
the base +Z everywhere (within :data:`AXIS_TOLERANCE_DEG`); 5-axis output is not written.

The boundary ramps of a law (from rest at the start, to rest at the end) are not written as
F words: a controller ramps by itself. Their samples take the feed the law reaches at the end
of the ramp (capped by the bound for a law that keeps it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.export.frames import APPROACH_MM, frames_header_lines
from feedopt.export.job import Exporter, ExportJob, header_notes, status_line
from feedopt.units import MM, MM_PER_M

#: Largest relative drop of a block's F below the law's feed inside the block.
FEED_TOLERANCE = 0.02
#: Height of the rapid approach and retract above the path ends, along the tool axis [mm]:
#: the robot programs' approach height (:func:`feedopt.export.frames.entry_exit`).
CLEARANCE_MM = APPROACH_MM
#: Feed of the plunge from the clearance height to the start [mm/s] (in air).
PLUNGE_FEED_MM_S = 10.0
#: Largest angle between the tool axis and the base +Z for a 3-axis program [deg].
AXIS_TOLERANCE_DEG = 0.01
#: Largest distance of the path from a written chord on curves [mm]: chords are as long as
#: the sag kappa L^2 / 8 allows (far below a cutting tolerance; 0.32 mm chords on a 12.7 mm
#: radius), not one per planning sample.
CHORD_TOLERANCE_MM = 0.001
#: Decimals of the coordinates [mm] and of F [mm/min] (F is rounded down).
XYZ_DECIMALS = 4
F_DECIMALS = 1


def law_feed_targets(feed: np.ndarray, v_max: np.ndarray, keeps_bound: bool) -> np.ndarray:
    """The feed a controller should aim for at each sample [m/s].

    ``feed`` is the law's feed at the samples; the start ramp (up to its first sample where
    the feed stops rising) and the end ramp (likewise from the end) take the feed at the ramp's
    end. ``keeps_bound``: the law promises ``feed <= v_max``; then the targets are capped by
    ``v_max`` everywhere (the ramps included).
    """
    f = np.asarray(feed, dtype=float).copy()
    n = f.size
    if n >= 2:
        d = np.diff(f)
        i0 = int(np.argmax(d <= 0)) if (d <= 0).any() else n - 1
        f[:i0] = f[i0]
        j0 = int(np.argmax(d[::-1] >= 0)) if (d >= 0).any() else n - 1
        i1 = n - 1 - j0
        f[i1 + 1:] = f[i1]
    if keeps_bound:
        f = np.minimum(f, v_max)
    return _stops_filled(f)


def _stops_filled(f: np.ndarray) -> np.ndarray:
    """``f`` with its zero feeds (interior stops: a reversal, a dwell; the controller stops
    there by itself) replaced by the feed of the nearest sample before them that moves, or
    after them at the start."""
    moving = f > 0.0
    if moving.all() or not moving.any():
        return f
    idx = np.where(moving, np.arange(f.size), -1)
    before = np.maximum.accumulate(idx)
    first = int(np.argmax(moving))
    return np.where(moving, f, f[np.where(before >= 0, before, first)])


def feed_pieces(target: np.ndarray, rel_tol: float = FEED_TOLERANCE,
                breaks: Sequence[int] = ()) -> np.ndarray:
    """Sample indices ``b_0 = 0 < b_1 < ... = n - 1`` cutting the samples into pieces.

    Piece k covers samples ``b_k .. b_(k+1)`` (neighbours share their boundary sample); in
    each, ``max(target) <= (1 + rel_tol) min(target)`` unless the piece is a single interval.
    Every index in ``breaks`` is a boundary (segment ends). Greedy from the start, each piece
    as long as the tolerance allows (windows doubled, so the cost is linear in the samples).
    """
    g = np.asarray(target, dtype=float)
    n = g.size
    if n < 2:
        raise ValueError("feed_pieces needs at least 2 samples")
    forced = sorted({int(b) for b in breaks if 0 < int(b) < n - 1} | {n - 1})
    out = [0]
    a, k = 0, 0
    while a < n - 1:
        while forced[k] <= a:
            k += 1
        stop, width = forced[k], 64
        while True:
            hi = min(a + width, stop)
            seg = g[a:hi + 1]
            bad = np.maximum.accumulate(seg) > (1.0 + rel_tol) * np.minimum.accumulate(seg)
            if bad.any():
                b = a + max(int(np.argmax(bad)) - 1, 1)
                break
            if hi == stop:
                b = stop
                break
            width *= 2
        out.append(b)
        a = b
    return np.asarray(out, dtype=int)


def piece_feeds(target: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Lowest target of each piece (``bounds`` from :func:`feed_pieces`), shape (k,)."""
    g = np.asarray(target, dtype=float)
    return np.array([g[a:b + 1].min() for a, b in zip(bounds[:-1], bounds[1:], strict=True)])


def _num(x: float, decimals: int = XYZ_DECIMALS) -> str:
    text = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0." if text in ("-0", "0", "") else (text if "." in text else text + ".")


def _nums(x: np.ndarray, decimals: int = XYZ_DECIMALS) -> np.ndarray:
    """:func:`_num` of every value of ``x``, the stripping done on the array of texts."""
    text = np.array([f"{v:.{decimals}f}" for v in np.ravel(x).tolist()])
    text = np.strings.rstrip(np.strings.rstrip(text, "0"), ".")
    zero = (text == "-0") | (text == "0") | (text == "")
    dotted = np.where(np.strings.find(text, ".") >= 0, text, np.strings.add(text, "."))
    return np.where(zero, "0.", dotted).reshape(np.shape(x))


def _f_units(feed_mm_s: np.ndarray) -> np.ndarray:
    """:func:`_f_word`'s whole units of 10^-F_DECIMALS mm/min of every feed."""
    scaled = np.asarray(feed_mm_s, dtype=float) * 60.0 * 10**F_DECIMALS
    units = np.floor(scaled)
    return (units + (scaled - units > 1.0 - 1e-9)).astype(np.int64)


def _g1_blocks(points_mm: np.ndarray, feed_mm_s: np.ndarray) -> list[str]:
    """``G1 X.. Y.. Z..`` per point, with the F word where it changes (the first has one)."""
    if not len(points_mm):
        return []
    xyz = _nums(points_mm)
    lines = np.strings.add(np.strings.add(np.strings.add(np.strings.add(np.strings.add(
        "G1 X", xyz[:, 0]), " Y"), xyz[:, 1]), " Z"), xyz[:, 2])
    units = _f_units(feed_mm_s)
    new = np.concatenate([[True], units[1:] != units[:-1]])
    words = np.zeros(units.size, dtype="<U24")
    words[new] = [f" F{u / 10**F_DECIMALS:.{F_DECIMALS}f}" for u in units[new].tolist()]
    return np.strings.add(lines, words).tolist()


def _f_word(feed_mm_s: float) -> str:
    """F in mm/min, rounded down to :data:`F_DECIMALS` (never above the feed given)."""
    scaled = feed_mm_s * 60.0 * 10**F_DECIMALS
    units = math.floor(scaled)
    if scaled - units > 1.0 - 1e-9:  # 5999.9999999 is 6000 written with rounding noise
        units += 1
    return f"F{units / 10**F_DECIMALS:.{F_DECIMALS}f}"


def _comment(text: str) -> str:
    """A G-code comment: ASCII, no nested parentheses."""
    ascii_text = str(text).encode("ascii", "backslashreplace").decode("ascii")
    return "(" + ascii_text.replace("(", "[").replace(")", "]") + ")"


def gcode_text(positions_mm: np.ndarray, target_m_s: np.ndarray, line_sample: np.ndarray,
               breaks: Sequence[int], comments: Sequence[str] = (), *,
               rel_tol: float = FEED_TOLERANCE, clearance_mm: float = CLEARANCE_MM,
               spindle_rpm: float | None = None) -> str:
    """The program text (see the module docstring).

    positions_mm : (n, 3) path samples in the output frame [mm], tool axis +Z
    target_m_s : (n,) feed to aim for at each sample [m/s] (:func:`law_feed_targets`)
    line_sample : (n,) bool, True where the sample lies inside or at the end of a straight
        segment (no intermediate block needed there)
    breaks : sample indices of segment ends (a block always ends there)
    spindle_rpm : ``S.. M3`` before the approach; None: an ``M0`` stop for the operator to
        start the spindle (the export job does not carry the speed)
    """
    p = np.asarray(positions_mm, dtype=float)
    g = np.asarray(target_m_s, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2 or g.shape != (p.shape[0],):
        raise InputError(f"G-code out needs (n, 3) positions and n feeds with n >= 2, got "
                         f"{p.shape} and {g.shape}")
    if not (np.isfinite(p).all() and np.isfinite(g).all() and (g > 0).all()):
        raise InputError("G-code out: positions and feeds must be finite, feeds positive")
    bounds = feed_pieces(g, rel_tol, breaks)
    feeds = piece_feeds(g, bounds)
    ends = np.zeros(p.shape[0], dtype=bool)
    ends[bounds] = True
    ends[np.asarray(breaks, dtype=int)] = True
    ends |= _curve_chord_ends(p, ~np.asarray(line_sample, dtype=bool))
    ends[-1] = True
    ends[0] = False
    piece_of = np.searchsorted(bounds, np.arange(p.shape[0]), side="left") - 1
    piece_of = np.clip(piece_of, 0, feeds.size - 1)
    out = ["%", *(_comment(c) for c in comments), "G21 G90 G94 G17", "G54"]
    if spindle_rpm is None:
        out += [_comment("start the spindle [speed and direction of your job], then cycle "
                         "start"), "M0"]
    else:
        out.append(f"S{_num(spindle_rpm, 1).rstrip('.')} M3")
    start, end = p[0], p[-1]
    xyz = lambda q: " ".join(f"{a}{_num(v)}" for a, v in zip("XYZ", q, strict=True))  # noqa: E731
    out.append(f"G0 {xyz(start + [0.0, 0.0, clearance_mm])}")
    out.append(f"G1 {xyz(start)} {_f_word(PLUNGE_FEED_MM_S)}")
    out += _g1_blocks(p[ends], feeds[piece_of[ends]] * MM_PER_M)
    out.append(f"G0 {xyz(end + [0.0, 0.0, clearance_mm])}")
    out += ["M30", "%"]
    return "\n".join(out) + "\n"


def _curve_chord_ends(p: np.ndarray, curve: np.ndarray,
                      tol_mm: float = CHORD_TOLERANCE_MM) -> np.ndarray:
    """Samples on curves where a chord ends: the chord count a curve needs for a sag tol is
    the integral of sqrt(kappa / (8 tol)) ds; a chord ends where that count passes a whole
    number (curvature from second differences of the samples)."""
    n = p.shape[0]
    ends = np.zeros(n, dtype=bool)
    if n < 3 or not curve.any():
        return ends
    ds = np.linalg.norm(np.diff(p, axis=0), axis=1)
    h = max(float(np.median(ds)), 1e-12)
    kappa = np.zeros(n)
    kappa[1:-1] = np.linalg.norm(p[2:] - 2.0 * p[1:-1] + p[:-2], axis=1) / h**2
    rate = np.where(curve, np.sqrt(kappa / (8.0 * tol_mm)), 0.0)
    count = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * ds)])
    ends[1:] = np.floor(count[1:]) > np.floor(count[:-1])
    # a curve's first and last sample end a block too (where the line blocks meet it)
    edges = np.flatnonzero(np.diff(curve.astype(np.int8)) != 0)
    ends[edges] = True
    ends[np.minimum(edges + 1, n - 1)] = True
    return ends & (curve | np.roll(curve, 1) | np.roll(curve, -1))


def _chord_sag_mm(p: np.ndarray, kept: np.ndarray) -> float:
    """Largest distance of the samples from the chords between the ``kept`` samples."""
    idx = np.flatnonzero(kept)
    if idx.size < 2:
        return 0.0
    k = np.clip(np.searchsorted(idx, np.arange(p.shape[0]), side="right") - 1, 0, idx.size - 2)
    a, b = p[idx[k]], p[idx[k + 1]]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                             1e-300), 0.0, 1.0)
    return float(np.max(np.linalg.norm(p - a - t[:, None] * ab, axis=1)))


def export_gcode(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>.nc`` (the generated path in the base frame), or say why not."""
    problem = job.problem
    z_axes = job.sample_tool_axes
    tilt = float(np.degrees(np.arccos(np.clip(z_axes[:, 2].min(), -1.0, 1.0))))
    if tilt > AXIS_TOLERANCE_DEG:
        return {"gcode_program": None,
                "gcode_not_written": f"no G-code program: the tool axis leaves the base +Z by "
                f"up to {tilt:.3g} deg (a 3-axis program needs it within "
                f"{AXIS_TOLERANCE_DEG} deg)"}
    p = job.path_in_base(problem.s) / MM
    keeps = job.verification.exportable
    target = law_feed_targets(job.verification.feed, problem.v_max, keeps)
    segments = problem.segments()
    starts = np.array([a for a, _, _ in segments])
    ends = np.array([b for _, b, _ in segments])
    is_line = np.array([kind == "line" for *_, kind in segments])
    seg_ends = np.minimum(np.searchsorted(problem.s, ends, side="left"), problem.n - 1)
    # a sample on a line, or at the end of one (its block ends there anyway)
    seg = np.clip(np.searchsorted(starts, problem.s, side="right") - 1, 0, len(segments) - 1)
    line_sample = is_line[seg]
    kept = _curve_chord_ends(p, ~line_sample)
    kept[seg_ends] = True
    kept[0] = kept[-1] = True
    text = gcode_text(p, target, line_sample, seg_ends.tolist(), comments=[
        status_line(job),
        *frames_header_lines(job.robot),
        *header_notes(job),
        "G-code frame: the robot base frame [mm]; tool axis = +Z. KUKA.CNC: BASE_DATA = "
        "$NULLFRAME, G54 = 0.",
        f"F per block [mm/min]: the law's feed, at most {FEED_TOLERANCE:.0%} below it within a "
        "block" + (", never above the deflection feed bound v_max" if keeps else
                   "; this law does NOT keep the deflection bound"),
        "start/end ramps of the law not written: the controller ramps by itself",
        f"curves as G1 chords within {CHORD_TOLERANCE_MM} mm of the path [largest sag "
        f"{_chord_sag_mm(p, kept):.2g} mm]",
    ])
    name = f"{job.law}.nc"
    (out_dir / name).write_text(text, encoding="ascii")
    return {"gcode_program": name}


EXPORTER = Exporter(
    name="gcode", file_pattern="{law}.nc", export=export_gcode,
    description="G-code (G1 blocks, F per block from the law within a 2 % feed tolerance, "
                "base frame) for KUKA.CNC cells and CNC machines",
)
