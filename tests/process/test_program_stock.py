"""stock.from_program: the box around what a program cuts."""

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.program_stock import program_stock_box
from feedopt.units import MM


def _pocket():
    # air above, a plunge to -2, a square at -2, a retract: the deepest cut is -2 mm
    pts = np.array([[0, 0, 5], [0, 0, 0], [0, 0, -2], [10, 0, -2], [10, 20, -2],
                    [0, 20, -2], [0, 20, 5]], dtype=float) * MM
    cat = np.array(["rapid", "plunge", "plunge", "cut", "cut", "cut", "retract"])
    return pts, cat


def test_box_spans_the_cut_widened_by_radius_and_spacing():
    pts, cat = _pocket()
    made = program_stock_box(pts, cat, stock_top=0.0, tool_radius=3 * MM, spacing=0.5 * MM)
    # independent: the cut points are x 0..10, y 0..20, z -2; widen by 3.5 mm
    assert made.box_mm == pytest.approx((-3.5, -3.5, -2.0, 13.5, 23.5, 0.0))
    assert "stock.from_program" in made.note and "-2.000..0.000" in made.note


def test_rapids_and_air_do_not_grow_the_box():
    pts, cat = _pocket()
    pts = np.vstack([pts, [[500 * MM, 500 * MM, 10 * MM]]])
    cat = np.append(cat, "rapid")
    made = program_stock_box(pts, cat, 0.0, 3 * MM, 0.5 * MM)
    assert made.box_mm[3] == pytest.approx(13.5)


def test_nothing_below_the_top_is_refused_naming_the_field():
    pts, cat = _pocket()
    with pytest.raises(InputError, match=r"path.stock_top_mm = -5 mm.*Z-2 mm"):
        program_stock_box(pts, cat, stock_top=-5 * MM, tool_radius=3 * MM, spacing=0.5 * MM)
