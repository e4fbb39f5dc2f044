"""The ``programmed`` baseline: a program's own feeds under the robot's limits."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import LawNotApplicable
from feedopt.schedule.checks import check_timing
from feedopt.schedule.programmed import plan_programmed
from feedopt.units import MM
from tests.schedule.conftest import wave_problem


def test_declines_paths_without_a_program():
    with pytest.raises(LawNotApplicable, match="baseline is the constant law"):
        plan_programmed(wave_problem(601))


def test_runs_the_programmed_feeds_ignoring_the_deflection_bound():
    """F 4.23 mm/s on the first half, 2 mm/s on the second; the deflection bound is lower
    (2.2-4 mm/s) and is exceeded where the program asks for more."""
    p0 = wave_problem(1201)
    programmed = np.where(p0.s < 0.18, 4.23 * MM, 2.0 * MM)
    p = wave_problem(1201, programmed_feed=programmed)
    tr = plan_programmed(p)
    assert tr.law == "programmed" and tr.continuity == 2
    capped = wave_problem(1201, v_max=programmed)
    chk = check_timing(tr, capped)
    assert chk.ok and chk.feed_ratio <= 1.0 + 1e-9  # never above the program's F
    m = tr.at(np.linspace(0, tr.duration, 20001))
    assert m.sdot.max() == pytest.approx(4.23 * MM, rel=1e-3)  # reaches the program's F
    assert np.any(m.sdot > np.interp(m.s, p.s, p.v_max) * 1.05)  # above the deflection bound
    # the time it takes is about the programmed time (ramps and the one feed change aside)
    t_prog = np.trapezoid(1.0 / programmed, p.s)
    assert t_prog < tr.duration < 1.03 * t_prog
