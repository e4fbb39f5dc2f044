"""Property: random programs of lines and arcs (tangent or kinked, any turn) become a path
that is G2 at every junction but its stops (reversals, corners no transition fits) and stays
within the tolerance of every programmed move, measured here by brute force against densely
sampled programmed moves."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

from feedopt.gcode import parse_gcode
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.program_path import ProgramPathOptions, program_path
from feedopt.units import MM

HEAD = "G21 G17 G90 G94\nS2500 M3\nG0 X0 Y0 Z5.\nG1 Z0.5 F300.\nG1 X2. Z-1. F200.\n"

move = st.tuples(
    st.sampled_from(["line", "G2", "G3"]),
    st.floats(1.0, 25.0),  # length of a line / radius of an arc [mm]
    st.floats(-180.0, 180.0),  # heading change before the move [deg] (kinks, reversals)
    st.floats(20.0, 200.0),  # swept angle of an arc [deg]
)


def _program(moves: list[tuple[str, float, float, float]]) -> str:
    x, y, heading = 2.0, 0.0, 0.0
    out = []
    for kind, size, turn, sweep in moves:
        heading += math.radians(turn if abs(turn) > 20 else 0.0)  # tangent or a real kink
        if kind == "line":
            x, y = x + size * math.cos(heading), y + size * math.sin(heading)
            out.append(f"G1 X{x:.4f} Y{y:.4f} F254.")
            continue
        side = 1.0 if kind == "G3" else -1.0  # centre to the left for G3
        cx = x - side * size * math.sin(heading)
        cy = y + side * size * math.cos(heading)
        a0 = math.atan2(y - cy, x - cx)
        a1 = a0 + side * math.radians(sweep)
        ex, ey = cx + size * math.cos(a1), cy + size * math.sin(a1)
        out.append(f"{kind} X{ex:.4f} Y{ey:.4f} I{cx - x:.4f} J{cy - y:.4f} F254.")
        x, y = ex, ey
        heading += side * math.radians(sweep)
    return HEAD + "\n".join(out) + "\nG0 Z5.\nM30\n"


def _distance_to_program(pts_mm: np.ndarray, program) -> np.ndarray:
    polys = [program.moves[i].point_at(np.linspace(0.0, 1.0, 2001))
             for i in range(len(program.moves))]
    best = np.full(len(pts_mm), np.inf)
    for poly in polys:
        a, b = poly[:-1], poly[1:]
        ab = b - a
        den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        for lo in range(0, len(pts_mm), 512):
            p = pts_mm[lo:lo + 512]
            t = np.clip(np.einsum("qij,ij->qi", p[:, None] - a[None], ab) / den, 0, 1)
            d = np.linalg.norm(p[:, None] - (a[None] + t[..., None] * ab[None]), axis=2)
            best[lo:lo + 512] = np.minimum(best[lo:lo + 512], d.min(axis=1))
    return best


# Near-reversals whose G2 transition would be a hairpin of a fraction of a micrometre (its end
# curvatures 0.01-0.04 1/m off in floating point) become corner stops: a 179 deg kink between
# arcs at a 4 um tolerance (a 0.1 um transition).
@example(moves=[("line", 1.0, 0.0, 20.0), ("line", 4.5, 0.0, 40.0), ("G3", 19.0, 0.0, 20.0),
                ("G2", 1.0, 179.0, 20.0)], tol_um=4.0)
# a 174 deg kink into an arc: a 0.51 um transition 0.0135 1/m off G2 (a length threshold of
# 0.5 um did not catch it; the G2 check of the built transitions does)
@example(moves=[("G2", 23.84113409966886, -163.06869473579513, 108.77197998460379),
                ("G2", 18.685551668835004, 0.0, 31.82676060865014),
                ("line", 20.903667963152433, 0.0, 151.0096157350354),
                ("G2", 7.489251358225616, 174.28839589449856, 154.1367312865893)],
         tol_um=4.026222627346993)
@given(moves=st.lists(move, min_size=1, max_size=6), tol_um=st.floats(2.0, 50.0))
def test_random_programs_are_g2_and_within_tolerance(moves, tol_um):
    program = parse_gcode(_program(moves), "fuzz.nc")
    opts = ProgramPathOptions(tolerance=tol_um * 1e-3 * MM, stock_top=None)
    result = program_path(program, opts)  # reversals and unroundable corners become stops
    rep = continuity_report(result.path)
    at_stop = np.isin(rep.s, result.stops.s)  # the tool stops there: a G1 corner is allowed
    assert rep.g0.max() < 1e-9
    assert rep.g1[~at_stop].max(initial=0) < 1e-6 and rep.g2[~at_stop].max(initial=0) * MM < 1e-5
    assert set(result.stops.kind) <= {"tool change", "reversal", "corner"}
    pts = result.path.sample(min(0.05 * MM, result.path.length / 4000)).position / MM
    cut = pts[:, 2] < 0.5 - 1e-6  # the cut level; air moves have the air tolerance
    dist = _distance_to_program(pts[cut], program)
    sag = 1e-3 * tol_um * 1e-3  # programmed arcs as 2001-point polylines: within this
    assert dist.max() <= tol_um * 1e-3 * (1 + 1e-6) + sag + 1e-7
