"""A program's tool comment checked against the scenario's tool file."""

import pytest

from feedopt.errors import InputError
from feedopt.gcode.moves import ToolHeader, ToolShape
from feedopt.process.cutter import CutterShape
from feedopt.process.program_tool import check_tool_header, header_for
from feedopt.process.tool import Tool
from feedopt.units import MM

TOOL = Tool(name="6 mm", diameter=6.0 * MM, teeth=2, helix=0.5, flute_length=20 * MM)


def _header(d=6.0, cr=0.0, shape=ToolShape.FLAT, number=1):
    return ToolHeader(number=number, diameter_mm=d, corner_radius_mm=cr, shape=shape,
                      z_min_mm=-2.0, line=3, text=f"T{number} D={d} CR={cr} - {shape.value}")


def test_matching_flat_header_passes_silently():
    assert check_tool_header(_header(6.004), TOOL, "p.nc", "tool.yaml") == []


def test_diameter_mismatch_names_line_both_diameters_and_field():
    with pytest.raises(InputError) as exc:
        check_tool_header(_header(3.175), TOOL, "p.nc", "tool.yaml")
    text = str(exc.value)
    assert "p.nc line 3" in text and "3.175 mm" in text and "6 mm" in text
    assert "scenario field tool" in text


@pytest.mark.parametrize("shape,cr", [(ToolShape.BALL, 3.0), (ToolShape.BULL, 0.5),
                                      (ToolShape.CHAMFER, 0.0), (ToolShape.FLAT, 0.5)])
def test_a_header_of_another_shape_than_the_tool_file_is_refused(shape, cr):
    with pytest.raises(InputError, match="the program was made for a .*flat cutter"):
        check_tool_header(_header(cr=cr, shape=shape), TOOL, "p.nc", "tool.yaml")


def test_a_drill_is_refused():
    with pytest.raises(InputError, match="drill"):
        check_tool_header(_header(shape=ToolShape.DRILL), TOOL, "p.nc", "tool.yaml")


BALL = Tool(name="6 mm ball", diameter=6.0 * MM, teeth=2, helix=0.5, flute_length=20 * MM,
            shape=CutterShape.BALL, corner_radius=3.0 * MM)
BULL = Tool(name="6 mm bull", diameter=6.0 * MM, teeth=2, helix=0.5, flute_length=20 * MM,
            shape=CutterShape.BULL, corner_radius=0.5 * MM)


def test_matching_ball_and_bull_headers_pass():
    assert check_tool_header(_header(cr=3.0, shape=ToolShape.BALL), BALL, "p", "t") == []
    assert check_tool_header(_header(cr=None, shape=ToolShape.BALL), BALL, "p", "t") == []
    assert check_tool_header(_header(cr=0.5, shape=ToolShape.BULL), BULL, "p", "t") == []
    # Fusion writes a bull nose as "flat end mill" with CR=
    assert check_tool_header(_header(cr=0.5, shape=ToolShape.FLAT), BULL, "p", "t") == []


def test_corner_radius_mismatch_names_both():
    with pytest.raises(InputError, match="corner radius is 1 mm.* 0.5 mm"):
        check_tool_header(_header(cr=1.0, shape=ToolShape.BULL), BULL, "p.nc", "tool.yaml")
    with pytest.raises(InputError, match="ball end mill.*bull cutter"):
        check_tool_header(_header(cr=3.0, shape=ToolShape.BALL), BULL, "p.nc", "tool.yaml")


def test_header_without_diameter_is_a_warning():
    out = check_tool_header(_header(d=None), TOOL, "p.nc", "tool.yaml")
    assert len(out) == 1 and "no diameter" in out[0]


def test_header_for_picks_the_cutting_tool():
    a, b = _header(number=1), _header(d=3.0, number=2)
    assert header_for((a, b), 2) is b
    assert header_for((a, b), 5) is None
    assert header_for((_header(number=None),), 2).number is None
    assert header_for((), 1) is None


def test_a_tapered_ball_nose_is_a_ball_end_mill_but_a_tapered_flat_is_not():
    import math
    tapered_ball = Tool(name="tb", diameter=2.0 * MM, teeth=2, helix=0.5, flute_length=10 * MM,
                        shape=CutterShape.TAPERED, corner_radius=1.0 * MM, taper=math.radians(3))
    header = _header(d=2.0, cr=None, shape=ToolShape.BALL)
    assert check_tool_header(header, tapered_ball, "p", "t") == []
    tapered_flat = Tool(name="tf", diameter=2.0 * MM, teeth=2, helix=0.5, flute_length=10 * MM,
                        shape=CutterShape.TAPERED, taper=math.radians(3))
    with pytest.raises(InputError, match="ball end mill.*tapered cutter"):
        check_tool_header(header, tapered_flat, "p", "t")
