"""The bundled programs scenarios/gcode/{pocket,profile}.nc: reproducible, readable, and their
geometry checked against the dimensions stated in scenarios/gcode/README.md (computed here,
independently of the generator)."""

import importlib.util
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from feedopt.gcode import MoveCategory, MoveKind, parse_gcode, read_gcode

GCODE = Path(__file__).resolve().parents[2] / "scenarios" / "gcode"
R_TOOL = 19.05 / 2.0
LIMITS = ((-30.0, 150.0), (-30.0, 110.0), (-3.0, 25.0))


@pytest.fixture(scope="module")
def gen():
    spec = importlib.util.spec_from_file_location("write_programs", GCODE / "write_programs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def pocket():
    return read_gcode(GCODE / "pocket.nc")


@pytest.fixture(scope="module")
def profile():
    return read_gcode(GCODE / "profile.nc")


# ----------------------------------------------------------------------------- helpers
def points(move, step_mm: float = 0.1) -> np.ndarray:
    """Points along a move, at most ``step_mm`` apart (ends included), shape (k, 3)."""
    k = max(2, math.ceil(move.length_mm / step_mm))
    return move.point_at(np.linspace(0.0, 1.0, k + 1))


def tangent(move, at_end: bool) -> np.ndarray:
    """Unit XY tangent of a move at its start or end."""
    if move.kind is MoveKind.ARC:
        p = np.array(move.end if at_end else move.start)[:2] - np.array(move.centre)[:2]
        t = move.direction * np.array([-p[1], p[0]])
    else:
        t = np.array(move.end)[:2] - np.array(move.start)[:2]
    return t / np.linalg.norm(t)


def at_z(move, z: float) -> bool:
    return abs(move.start[2] - z) < 1e-9 and abs(move.end[2] - z) < 1e-9


def sdf_rounded_rect(p: np.ndarray, centre, half, r: float) -> np.ndarray:
    """Signed distance of XY points to a rounded rectangle (negative inside)."""
    q = np.abs(p[:, :2] - np.asarray(centre)) - (np.asarray(half) - r)
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(np.max(q, axis=1), 0.0)
    return outside + inside - r


def rounded_rect_boundary(centre, half, r: float, n: int = 800) -> np.ndarray:
    """``n`` points on the boundary of the rounded rectangle (rays from the centre, bisection)."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    d = np.column_stack((np.cos(a), np.sin(a)))
    lo, hi = np.zeros(n), np.full(n, float(sum(half)))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        inside = sdf_rounded_rect(np.asarray(centre) + mid[:, None] * d, centre, half, r) < 0
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return np.asarray(centre) + lo[:, None] * d


def distance_to_polyline(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of XY points ``p`` to the polyline ``poly`` (k, 2)."""
    a = poly[:-1, :2]
    ab = poly[1:, :2] - a
    ab2 = np.einsum("ij,ij->i", ab, ab)
    keep = ab2 > 1e-18  # repeated points: no segment
    a, ab, ab2 = a[keep], ab[keep], ab2[keep]
    out = np.empty(len(p))
    for i in range(0, len(p), 256):
        q = p[i:i + 256, None, :2] - a[None]
        t = np.clip(np.einsum("pij,ij->pi", q, ab) / ab2, 0.0, 1.0)
        d = q - t[..., None] * ab[None]
        out[i:i + 256] = np.sqrt(np.min(np.einsum("pij,pij->pi", d, d), axis=1))
    return out


def strip_comments(line: str) -> str:
    return re.sub(r"\([^)]*\)", " ", line).split(";")[0].strip()


WORD = re.compile(r"([A-Z])([+-]?\d*\.?\d*)")


# ----------------------------------------------------------------------------- (a)
def test_generator_reproduces_the_committed_files(gen, tmp_path):
    for name, make in gen.PROGRAMS.items():
        assert make().encode("ascii") == (GCODE / name).read_bytes(), name
    subprocess.run([sys.executable, str(GCODE / "write_programs.py"), str(tmp_path)],
                   check=True, capture_output=True)
    for name in ("pocket.nc", "profile.nc"):
        assert (tmp_path / name).read_bytes() == (GCODE / name).read_bytes(), name


# ----------------------------------------------------------------------------- (b)
ALLOWED_G = {0, 1, 2, 3, 17, 21, 28, 40, 43, 49, 54, 80, 90, 91, 94}
ALLOWED_M = {3, 5, 6, 8, 9, 30}


@pytest.mark.parametrize(("name", "number"), [("pocket.nc", 1001), ("profile.nc", 1002)])
def test_program_reads_with_supported_words_only(name, number):
    text = (GCODE / name).read_text(encoding="ascii")
    lines = text.splitlines()
    assert lines[0] == "%" and lines[-1] == "%"
    assert re.fullmatch(rf"O{number} \([A-Z]+\)", lines[1])
    n_numbers = []
    s_words = set()
    for line in lines[2:-1]:
        code = strip_comments(line)
        if not code:
            continue
        assert not re.search(r"[^A-Z0-9.\- ]", code), line
        words = WORD.findall(code.replace(" ", ""))
        assert "".join(a + b for a, b in words) == code.replace(" ", ""), line
        assert words[0][0] == "N", f"no N number: {line}"
        n_numbers.append(int(words[0][1]))
        for letter, value in words[1:]:
            assert letter in "GMXYZIJRFSTH", line
            v = float(value)
            if letter == "G":
                assert v in ALLOWED_G, line
            elif letter == "M":
                assert v in ALLOWED_M, line
            elif letter == "S":
                s_words.add(v)
            elif letter in "TH":
                assert v == 1, line
            elif letter == "F":
                assert v in (254.0, 200.0, 300.0), line
            elif letter in "XYZIJR":
                assert re.fullmatch(r"-?\d+\.\d{0,4}", value), f"not post-style: {value}"
    assert n_numbers == list(range(10, 10 * len(n_numbers) + 1, 10))
    assert s_words == {2500.0}

    prog = read_gcode(GCODE / name)
    assert prog.program_number == number and prog.units == "mm"
    assert prog.tools == (1,) and prog.work_offsets == ("G54",)
    feed_moves = [m for m in prog.moves if m.kind is not MoveKind.RAPID]
    assert {m.spindle_rpm for m in prog.moves} == {2500.0}
    assert {m.spindle_direction for m in feed_moves} == {1}
    assert {round(m.feed_mm_s * 60.0, 6) for m in feed_moves} == {254.0, 200.0, 300.0}
    assert {m.tool for m in prog.moves} == {1}
    for m in prog.moves:
        if m.kind is MoveKind.ARC:
            assert abs(m.radius_mm - m.end_radius_mm) <= 0.002, m.text
    # modal continuation, both arc forms
    assert any(re.fullmatch(r"N\d+ [XY]-?[\d.]+( [XY]-?[\d.]+)?", ln) for ln in lines)
    assert any(" R" in ln and " G3 " in f" {ln} " for ln in lines)
    assert sum(" I" in ln for ln in lines) > sum(" R" in ln for ln in lines) > 0


@pytest.mark.parametrize("name", ["pocket.nc", "profile.nc"])
def test_no_plunge_into_material_and_within_reach(name):
    prog = read_gcode(GCODE / name)
    for m in prog.moves:
        if m.category is MoveCategory.PLUNGE:
            assert m.end[2] > 0.0, f"straight plunge below Z0: {m.text}"
        if m.kind is MoveKind.RAPID:
            assert m.end[2] > 0.0, m.text
            if math.hypot(m.end[0] - m.start[0], m.end[1] - m.start[1]) > 0:
                assert min(m.start[2], m.end[2]) >= 5.0, f"rapid across at low Z: {m.text}"
        if min(m.start[2], m.end[2]) < 0.0 and m.end[2] < m.start[2]:
            # going down in material: a helix or a ramp
            assert m.kind is MoveKind.ARC or math.hypot(m.end[0] - m.start[0],
                                                        m.end[1] - m.start[1]) > 1.0, m.text
    pts = np.concatenate([points(m, 1.0) for m in prog.moves])
    for axis, (lo, hi) in enumerate(LIMITS):
        assert lo <= pts[:, axis].min() and pts[:, axis].max() <= hi


# ----------------------------------------------------------------------------- (c) pocket
CENTRE = (60.0, 40.0)
WALL_HALF = (60.0 - R_TOOL, 40.0 - R_TOOL)  # tool-centre limit: 50.475 x 30.475
WALL_R = 15.0 - R_TOOL  # 5.475
STEP = 9.525


def test_pocket_wall_is_followed_and_never_crossed(pocket):
    zs = sorted({m.end[2] for m in pocket.moves if m.end[2] < 0})
    assert {-1.5, -3.0} <= set(zs)
    for z in (-1.5, -3.0):
        cuts = [m for m in pocket.moves if m.kind is not MoveKind.RAPID and at_z(m, z)]
        pts = np.concatenate([points(m, 0.1) for m in cuts])
        d = sdf_rounded_rect(pts, CENTRE, WALL_HALF, WALL_R)
        assert d.max() <= 1e-3  # never beyond the wall offset (would gouge the wall)
        assert d.max() >= -1e-3  # the outermost pass touches it
        # ... all the way round: every point of the offset wall has the tool centre near it
        boundary = rounded_rect_boundary(CENTRE, WALL_HALF, WALL_R)
        gap = distance_to_polyline(boundary, pts[:, :2])
        assert gap.max() < 0.01
        # climb milling with M3: every arc counter-clockwise
        assert {m.direction for m in cuts if m.kind is MoveKind.ARC} == {1}


def test_pocket_passes_are_one_step_over_apart(pocket):
    for z in (-1.5, -3.0):
        lines = [m for m in pocket.moves if m.kind is MoveKind.LINE and at_z(m, z)]
        sides = {"+x": set(), "-x": set(), "+y": set(), "-y": set()}
        for m in lines:
            dx, dy = m.end[0] - m.start[0], m.end[1] - m.start[1]
            if abs(dx) < 1e-9 and abs(dy) > 0.5:  # parallel to Y
                x = round(m.start[0] - CENTRE[0], 4)
                sides["+x" if x > 0 else "-x"].add(abs(x))
            elif abs(dy) < 1e-9 and abs(dx) > 0.5 and abs(m.start[1] - CENTRE[1]) > 1.0:
                y = round(m.start[1] - CENTRE[1], 4)  # parallel to X (not the links at y=40)
                sides["+y" if y > 0 else "-y"].add(abs(y))
        for side, offsets in sides.items():
            ordered = sorted(offsets)
            assert len(ordered) == 4, (side, ordered)
            assert ordered[-1] == pytest.approx(WALL_HALF[0 if "x" in side else 1], abs=1e-3)
            assert np.diff(ordered) == pytest.approx([STEP] * 3, abs=1e-3), (side, ordered)


def test_pocket_enters_each_level_by_a_gentle_helix(pocket):
    moves = pocket.moves
    helices = [m for m in moves if m.kind is MoveKind.ARC and abs(m.end[2] - m.start[2]) > 0]
    assert helices
    for m in helices:
        assert m.end[2] < m.start[2]
        assert (m.start[2] - m.end[2]) / m.turns <= 1.0 + 1e-9, m.text
        assert m.centre[:2] == pytest.approx(CENTRE) and 4.0 <= m.radius_mm <= 6.0
    for z in (-1.5, -3.0):
        # the moves that bring the tool from Z0.5 (in air) down to this level: all helix arcs
        last = next(i for i, m in enumerate(moves) if m.end[2] == pytest.approx(z))
        first = last
        while moves[first - 1].kind is MoveKind.ARC:
            first -= 1
        plunge, chain = moves[first - 1], moves[first:last + 1]
        assert plunge.category is MoveCategory.PLUNGE and plunge.end[2] == pytest.approx(0.5)
        assert chain[0].start[2] == pytest.approx(0.5)
        assert all(m.kind is MoveKind.ARC and m.end[2] < m.start[2] for m in chain)
        assert (0.5 - z) / sum(m.turns for m in chain) <= 1.0


# ----------------------------------------------------------------------------- (d) profile
def part_outline() -> np.ndarray:
    """Dense clockwise polyline of the part outline of README.md (closed)."""

    def arc(cx, cy, r, a0, a1):
        a = np.radians(np.linspace(a0, a1, max(2, int(abs(a1 - a0) * 4) + 1)))
        return np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a)))

    def line(p, q):
        return np.array([p, q], dtype=float)

    x = np.linspace(10.0, 80.0, 7001)
    u = (x - 10.0) / 70.0
    free = np.column_stack((x, 90.0 + 12.0 * np.sin(np.pi * u) ** 2 * np.cos(np.pi * u)))
    parts = [line((0, 10), (0, 80)), arc(10, 80, 10, 180, 90), free, arc(80, 80, 10, 90, 0),
             line((90, 80), (90, 65)), arc(110, 65, 20, 180, 270), line((110, 45), (120, 45)),
             arc(120, 35, 10, 90, 0), line((130, 35), (130, 10)), arc(120, 10, 10, 0, -90),
             line((120, 0), (10, 0)), arc(10, 10, 10, -90, -180)]
    for a, b in zip(parts, parts[1:] + parts[:1], strict=True):  # joined, and closed
        assert np.allclose(a[-1], b[0], atol=1e-9)
    return np.concatenate(parts)


def contour(prog):
    """Moves of the contour proper: between the lead-in arc and the lead-out arc."""
    at_depth = [i for i, m in enumerate(prog.moves)
                if m.kind is not MoveKind.RAPID and at_z(m, -1.5)]
    assert at_depth == list(range(at_depth[0], at_depth[-1] + 1))
    lead_in, lead_out = prog.moves[at_depth[0]], prog.moves[at_depth[-1]]
    assert lead_in.kind is MoveKind.ARC and lead_out.kind is MoveKind.ARC
    return lead_in, [prog.moves[i] for i in at_depth[1:-1]], lead_out


def test_profile_tool_centre_is_one_tool_radius_outside_the_part(profile):
    outline = part_outline()
    _, moves, _ = contour(profile)
    pts = np.concatenate([points(m, 0.1) for m in moves])
    d = distance_to_polyline(pts, outline)
    assert np.abs(d - R_TOOL).max() <= 0.01
    assert pts[0] == pytest.approx(pts[-1], abs=1e-9)  # closed: ends where it started


def signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_profile_is_climb_milled_clockwise_and_tangent(profile):
    lead_in, moves, lead_out = contour(profile)
    pts = np.concatenate([points(m, 0.5) for m in moves])[:, :2]
    outline = part_outline()
    assert signed_area(pts) < 0 and signed_area(outline) < 0
    assert abs(signed_area(pts)) > abs(signed_area(outline))  # the tool runs outside
    # tangent continuous: lead-in -> contour -> lead-out, every joint within 3 degrees
    chain = [lead_in, *moves, lead_out]
    for a, b in zip(chain, chain[1:], strict=False):
        cos = float(np.dot(tangent(a, True), tangent(b, False)))
        assert cos > math.cos(math.radians(3.0)), (a.text, b.text)
    # convex corners clockwise about the outline's corner centres, the concave arc ccw
    arcs = [m for m in moves if m.kind is MoveKind.ARC]
    assert [m.direction for m in arcs] == [-1, -1, 1, -1, -1, -1]
    assert [round(m.radius_mm, 4) for m in arcs] == [19.525, 19.525, 10.475, 19.525, 19.525,
                                                     19.525]


def test_profile_entry_is_a_ramp_outside_the_part_then_a_lead_in_arc(profile):
    lead_in, _, _ = contour(profile)
    i = profile.moves.index(lead_in)
    ramp, plunge = profile.moves[i - 1], profile.moves[i - 2]
    assert plunge.category is MoveCategory.PLUNGE and plunge.end[2] == pytest.approx(0.5)
    assert ramp.kind is MoveKind.LINE and ramp.category is MoveCategory.CUT
    assert ramp.start[2] == pytest.approx(0.5) and ramp.end[2] == pytest.approx(-1.5)
    assert distance_to_polyline(points(ramp, 0.1), part_outline()).min() > R_TOOL
    assert float(np.dot(tangent(ramp, True), tangent(lead_in, False))) == pytest.approx(1.0)


def test_profile_free_form_stretch_is_many_short_lines(profile):
    _, moves, _ = contour(profile)
    free = [m for m in moves if m.kind is MoveKind.LINE and m.start[1] > 90.0 + R_TOOL - 6
            and 10.0 - 1e-9 <= min(m.start[0], m.end[0])
            and max(m.start[0], m.end[0]) <= 80.0 + 1e-9]
    assert len(free) >= 100
    lengths = [m.length_mm for m in free]
    assert 0.05 <= min(lengths) and max(lengths) <= 1.0
    # together they span the whole stretch, consecutively
    assert free[0].start[0] == pytest.approx(10.0) and free[-1].end[0] == pytest.approx(80.0)
    assert all(a.end == b.start for a, b in zip(free, free[1:], strict=False))


# ----------------------------------------------------------------------------- (e) benchmark
def test_freeform_chain_program_reads_into_20000_moves(gen):
    text = gen.freeform_chain_program(20000)
    assert text == gen.freeform_chain_program(20000, seed=0)
    prog = parse_gcode(text, source="chain.nc")
    assert len(prog.moves) >= 20000
    chain = [m for m in prog.moves if m.kind is MoveKind.LINE and at_z(m, -1.5)]
    assert len(chain) == 20000
    lengths = np.array([m.length_mm for m in chain])
    assert lengths.min() >= 0.05 and lengths.max() <= 1.0
    d = np.array([tangent(m, False) for m in chain])
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", d[1:], d[:-1]), -1.0, 1.0)))
    assert turn.max() < 10.0  # tangent continuous: small turns between short moves
    assert not any(m.category is MoveCategory.PLUNGE and m.end[2] < 0 for m in prog.moves)
    for axis, (lo, hi) in enumerate(LIMITS):
        assert lo <= prog.starts[:, axis].min() and prog.ends[:, axis].max() <= hi
