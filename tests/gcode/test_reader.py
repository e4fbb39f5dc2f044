"""G-code reader against hand-computed cases: arcs in every form and plane, modal state, units."""

import math

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.gcode import MoveCategory, MoveKind, Plane, parse_gcode, read_gcode, sample_move

HEAD = "G90 G94 G17 G21\nT1 M6\nS8000 M3\nG54\n"


def run(body: str, head: str = HEAD + "G0 X0 Y0 Z0\n", **kw):
    """Parse ``head + body + M30``; the moves of ``body`` only (the head's rapids dropped)."""
    prog = parse_gcode(head + "F600\n" + body + "\nM30\n", source="t.nc", **kw)
    first = head.count("\n") + 2
    return prog, [m for m in prog.moves if m.line >= first]


def test_ijk_quarter_cw_g17():
    _, (m,) = run("G2 X10 Y10 I10 J0")
    assert m.kind is MoveKind.ARC and m.category is MoveCategory.CUT
    assert m.centre == pytest.approx((10, 0, 0))
    assert m.direction == -1 and m.plane is Plane.XY and m.normal == (0, 0, 1)
    assert m.sweep_rad == pytest.approx(math.pi / 2)
    assert m.radius_mm == pytest.approx(10)
    mid = m.point_at(0.5)[0]
    assert mid == pytest.approx((10 - 10 / math.sqrt(2), 10 / math.sqrt(2), 0))
    assert m.feed_mm_s == pytest.approx(10.0)


def test_ijk_missing_offset_is_zero_incremental():
    _, (m,) = run("G3 X20 I10")  # J omitted = 0: semicircle ccw through (10, -10)
    assert m.centre == pytest.approx((10, 0, 0))
    assert m.sweep_rad == pytest.approx(math.pi)
    assert m.point_at(0.5)[0] == pytest.approx((10, -10, 0))


@pytest.mark.parametrize(("r", "centre", "sweep"), [
    ("R10", (10, 0, 0), math.pi / 2), ("R-10", (0, 10, 0), 1.5 * math.pi)])
def test_r_form_both_signs_cw(r, centre, sweep):
    _, (m,) = run(f"G2 X10 Y10 {r}")
    assert m.centre == pytest.approx(centre, abs=1e-12)
    assert m.sweep_rad == pytest.approx(sweep)
    assert m.radius_mm == pytest.approx(10)


@pytest.mark.parametrize(("r", "centre", "sweep"), [
    ("R10", (0, 10, 0), math.pi / 2), ("R-10", (10, 0, 0), 1.5 * math.pi)])
def test_r_form_both_signs_ccw(r, centre, sweep):
    _, (m,) = run(f"G3 X10 Y10 {r}")
    assert m.centre == pytest.approx(centre, abs=1e-12)
    assert m.sweep_rad == pytest.approx(sweep)
    assert m.direction == 1


def test_r_semicircle_with_rounded_radius_within_tolerance():
    _, (m,) = run("G2 X20 R9.999")  # chord 20 > 2R by 0.002 mm: accepted as a semicircle
    assert m.sweep_rad == pytest.approx(math.pi, abs=1e-3)
    assert m.centre == pytest.approx((10, 0, 0))


def test_helical_half_turn():
    _, (m,) = run("G3 X-10 Y0 Z-5 I-10 J0", head=HEAD + "G0 X10 Y0 Z0\n")
    assert m.centre == pytest.approx((0, 0, 0))
    assert m.sweep_rad == pytest.approx(math.pi)
    assert m.point_at(0.5)[0] == pytest.approx((0, 10, -2.5), abs=1e-12)
    assert m.length_mm == pytest.approx(math.hypot(10 * math.pi, 5))
    assert m.category is MoveCategory.CUT


def test_full_circle_ijk_and_helical_full_turn():
    _, (a, b) = run("G2 I5\nG2 I5 Z-1")
    assert a.sweep_rad == pytest.approx(2 * math.pi) and a.turns == pytest.approx(1)
    assert a.start == a.end
    assert b.turns == pytest.approx(1) and b.end == pytest.approx((0, 0, -1))
    pts = sample_move(a, max_angle_deg=90)
    assert pts[2] == pytest.approx((10, 0, 0), abs=1e-12)  # half way round a circle at (5, 0)


def test_g18_direction_seen_from_plus_y():
    # G18 is the ZX plane, normal +Y: G3 (ccw about +Y) takes +X towards -Z.
    head = HEAD + "G0 X10 Y0 Z0\n"
    _, (m,) = run("G18 G3 X0 Z-10 I-10 K0", head=head)
    assert m.plane is Plane.ZX and m.normal == (0, 1, 0)
    assert m.sweep_rad == pytest.approx(math.pi / 2)
    s = 10 / math.sqrt(2)
    assert m.point_at(0.5)[0] == pytest.approx((s, 0, -s))
    _, (m,) = run("G18 G2 X0 Z-10 I-10", head=head)
    assert m.sweep_rad == pytest.approx(1.5 * math.pi)
    assert m.point_at(0.5)[0] == pytest.approx((-s, 0, s))


def test_g19_direction_seen_from_plus_x():
    # G19 is the YZ plane, normal +X: G3 takes +Y towards +Z.
    _, (m,) = run("G19 G3 Y0 Z10 J-10", head=HEAD + "G0 X0 Y10 Z0\n")
    assert m.plane is Plane.YZ and m.normal == (1, 0, 0)
    assert m.sweep_rad == pytest.approx(math.pi / 2)
    s = 10 / math.sqrt(2)
    assert m.point_at(0.5)[0] == pytest.approx((0, s, s))


def test_g18_helical_moves_along_y():
    _, (m,) = run("G18 G2 X0 Z10 Y4 R10", head=HEAD + "G0 X10 Y0 Z0\n")
    # G2 = cw about +Y: +X towards +Z, short arc centre at the origin
    assert m.centre == pytest.approx((0, 0, 0), abs=1e-12)
    assert m.sweep_rad == pytest.approx(math.pi / 2)
    assert m.point_at(0.5)[0][1] == pytest.approx(2)


def test_absolute_arc_centres_g90_1_and_option():
    _, (a,) = run("G90.1 G2 X10 Y10 I10 J0", head=HEAD + "G0 X0 Y0 Z0\n")
    _, (b,) = run("G2 X30 Y10 I30 J0", head=HEAD + "G0 X20 Y0 Z0\n", arc_centre="absolute")
    assert a.centre == pytest.approx((10, 0, 0))
    assert b.centre == pytest.approx((30, 0, 0))
    _, (c,) = run("G91.1 G2 X30 Y10 I10 J0", head=HEAD + "G0 X20 Y0 Z0\n",
                  arc_centre="absolute")
    assert c.centre == pytest.approx((30, 0, 0))
    with pytest.raises(InputError, match=r"line 7: .*G90\.1.*J missing"):
        run("G90.1 G2 X10 Y10 I10")


def test_modal_motion_continues():
    _, ms = run("G1 X1\nX2\nY3 ; comment\nG2 X5 Y5 R2\nX7 Y3 R2\nG0 Z5")
    assert [m.kind for m in ms] == [MoveKind.LINE] * 3 + [MoveKind.ARC] * 2 + [MoveKind.RAPID]
    assert ms[2].end == (2, 3, 0)
    assert ms[4].end == (7, 3, 0)
    assert all(m.feed_mm_s == pytest.approx(10) for m in ms[:5]) and ms[5].feed_mm_s is None


def test_comments_in_every_position_and_spacing():
    text = ("(start)\n;whole line\nN10 (a) G90 (b) G21 ; end\n(x)G0(y)X0(z)Y0 Z0(w)\n"
            "/(deleted anyway) G1 X99\n"
            "n20 g01 x 1 0 . 5 (spaces inside words) f 6 0 0\n"
            "N30 G1(mid)Y2;tail (not closed is fine after ;\nM30 (end)\n")
    prog = parse_gcode(text)
    (a, b) = prog.moves
    assert a.end == (10.5, 0, 0) and a.n_number == 20 and a.line == 6
    assert b.end == (10.5, 2, 0) and b.n_number == 30
    assert any("block delete" in w and "5" in w for w in prog.warnings)


def test_block_delete_switch_off_executes_the_line():
    prog = parse_gcode("G0 X0 Y0 Z0\n/G0 X5\nM30\n", block_delete=False)
    assert prog.moves[-1].end == (5, 0, 0)


def test_categories_relative_to_z():
    _, ms = run("G1 Z-2\nX5\nX8 Z-3\nZ1\nG0 Z10")
    assert [m.category for m in ms] == [MoveCategory.PLUNGE, MoveCategory.CUT, MoveCategory.CUT,
                                        MoveCategory.RETRACT, MoveCategory.RAPID]


def test_inch_scaled_exactly_and_feed_converted():
    prog = parse_gcode("G20 G90\nG0 X0 Y0 Z0\nG1 X1 Y0.5 F10\nG2 X2 Y-0.5 R1\nM30")
    line, arc = prog.moves
    assert prog.units == "inch"
    assert line.end == (25.4, 12.7, 0)
    assert line.feed_mm_s == pytest.approx(10 * 25.4 / 60)
    assert arc.radius_mm == pytest.approx(25.4)


def test_tools_spindle_offsets_recorded_per_move():
    text = ("G21 G90 G55\nT3 M6\nS1200 M3\nG0 X0 Y0 Z5\nG43 Z5 H3\nG1 Z0 F100\nM5\nT7\nM6\n"
            "G0 X1 Y1 Z5\nM4 S900\nG1 Z0\nG49\nG0 Z9\nM30\n")
    prog = parse_gcode(text)
    assert prog.tools == (3, 7) and prog.work_offsets == ("G55",)
    plunge1, plunge2, up = prog.moves  # rapids after each M6 start from an unknown position
    assert (plunge1.tool, plunge1.spindle_rpm, plunge1.spindle_direction) == (3, 1200, 1)
    assert plunge1.length_offset == 3 and up.length_offset is None
    assert (plunge2.tool, plunge2.spindle_rpm, plunge2.spindle_direction) == (7, 900, -1)
    assert any("G43 H3" in w for w in prog.warnings)
    assert any("not in the move list" in w for w in prog.warnings)


def test_g28_honest_through_intermediate_point():
    text = "G0 X0 Y0 Z5\nG28 G91 Z10\nG90\nG0 X1 Y1\nG0 Z3\nG1 Z0 F100\nM30\n"
    prog = parse_gcode(text)
    up, plunge = prog.moves  # line 1 from the unknown start; 4, 5 with Z unknown after G28
    assert up.kind is MoveKind.RAPID and up.start == (0, 0, 5) and up.end == (0, 0, 15)
    assert up.line == 2 and plunge.line == 6 and plunge.start == (1, 1, 3)
    assert any("G28 returns Z to machine home" in w for w in prog.warnings)
    assert any("lines 1, 4, 5" in w for w in prog.warnings)
    with pytest.raises(InputError, match=r"line 3: G1 from a position .*Z unknown .*G28"):
        parse_gcode("G0 X0 Y0 Z5\nG28 G91 Z0\nG90 G1 X1 F100\n")


def test_program_arrays_and_sampling():
    prog, _ = run("G0 X1\nG1 X10\nG3 X0 Y10 R-10")
    assert prog.starts.shape == (len(prog), 3) and not prog.ends.flags.writeable
    assert np.isnan(prog.feeds_mm_s[0]) and prog.feeds_mm_s[1] == pytest.approx(10)
    assert list(prog.kinds[-2:]) == ["line", "arc"]
    pts = prog.sample_move(len(prog) - 1, max_angle_deg=1)
    assert len(pts) == 271
    centre = np.array(prog.moves[-1].centre)
    assert np.allclose(np.linalg.norm(pts - centre, axis=1), 10)
    assert pts[-1] == pytest.approx((0, 10, 0))


def test_percent_o_number_and_text_after_end():
    prog = parse_gcode("%\nO0123 (PART)\nG0 X0 Y0 Z0\nM30\nG0 X9\n%\nanything at all\n")
    assert prog.program_number == 123
    assert any("after the program end" in w for w in prog.warnings)
    prog = parse_gcode("%\nG0 X0 Y0 Z0\n%\n(after)\nG0 X1\n")
    assert len(prog) == 0 and any("line 5" in w for w in prog.warnings)


def test_read_gcode_file(tmp_path):
    p = tmp_path / "part.nc"
    p.write_text("G21\r\nG0 X0 Y0 Z0\r\nG1 X1 F60\r\nM30\r\n")
    prog = read_gcode(p)
    assert prog.moves[0].line == 3 and prog.moves[0].feed_mm_s == pytest.approx(1)
    assert prog.source == str(p)


def test_garbage_bytes_file(tmp_path):
    p = tmp_path / "garbage.nc"
    p.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputError, match="not UTF-8"):
        read_gcode(p)
    p.write_bytes(b"G0 X0 Y0 Z0\n\x00\x01binary\n")
    with pytest.raises(InputError, match=r"line 2: .*unexpected character"):
        read_gcode(p)
    with pytest.raises(InputError, match="does not exist"):
        read_gcode(tmp_path / "missing.nc")
