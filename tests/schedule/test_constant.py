"""The ``constant`` law: nominal feed, C2 ramps inside the limits, violation reported."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from feedopt.errors import InputError
from feedopt.schedule.checks import check_timing
from feedopt.schedule.constant import ConstantOptions, plan_constant
from feedopt.units import MM
from tests.schedule.conftest import ramp_problem, wave_problem


@pytest.mark.parametrize("ramp", ["quintic", "jerk"])
def test_nominal_feed_c2_and_violation_reported(ramp):
    p = wave_problem()
    tr = plan_constant(p, ConstantOptions(ramp=ramp))
    chk = check_timing(tr, p)
    # everything holds except the feed bound, which the law ignores by design
    assert len(chk.problems) == 1 and "exceeds its bound" in chk.problems[0]
    assert chk.c2 and chk.max_accel <= p.accel_max and chk.max_jerk <= p.jerk_max * (1 + 1e-9)
    assert abs(tr.length - p.length) < 1e-12
    # cruise at the nominal feed away from the ramps
    inner = (p.s > 0.01) & (p.s < p.length - 0.01)
    np.testing.assert_allclose(tr.feed_at(p.s[inner]), p.nominal_feed, rtol=1e-12)
    # the measured violation, stated in notes, equals nominal / min bound (independent)
    want = float(np.max(p.nominal_feed / p.v_max[inner]))
    assert abs(tr.stats.max_feed_ratio - want) < 1e-9 and tr.stats.exceeds_bound
    assert any(f"{want:.4f}" in n for n in tr.notes)
    # cycle time: cruise time plus what the ramps lose (ramp length / 2 each at rest ends)
    h_up, h_dn = (x * MM for x in tr.stats.ramp_lengths_mm)
    assert abs(tr.duration - (p.length + h_up + h_dn) / p.nominal_feed) < 1e-9


def test_jerk_ramp_is_time_optimal_s_curve():
    p = ramp_problem()
    q = plan_constant(p, ConstantOptions(ramp="quintic"))
    j = plan_constant(p, ConstantOptions(ramp="jerk"))
    # the bang-zero-bang jerk ramp needs 2 sqrt(v/J) (no acceleration-limited phase here)
    v = p.nominal_feed
    assert abs(j.stats.ramp_lengths_mm[0] * MM - v * np.sqrt(v / p.jerk_max)) < 1e-12
    assert j.duration < q.duration
    assert check_timing(j, p).max_jerk == pytest.approx(p.jerk_max, rel=1e-9)


def test_short_path_lowers_cruise_and_boundary_feeds():
    s = np.linspace(0, 2e-4, 101)
    p = wave_problem(101, s=s, v_max=np.full(101, 1e-2), q=np.zeros((101, 6)),
                     dq_ds=np.zeros((101, 6)), d2q_ds2=np.zeros((101, 6)),
                     segment_start=None, segment_kind=())
    tr = plan_constant(p)
    chk = check_timing(tr, p)
    assert chk.ok, chk.problems
    assert tr.stats.cruise_feed_mm_s < 4.23 and tr.stats.cruise_lowered
    assert "lowered" in tr.notes[0]
    p2 = wave_problem(v_start=1e-3, v_end=2e-3)
    chk2 = check_timing(plan_constant(p2, ConstantOptions(ramp="jerk")), p2)
    assert abs(chk2.start_feed - 1e-3) < 1e-9 and abs(chk2.end_feed - 2e-3) < 1e-9 and chk2.c2


def test_bad_input():
    with pytest.raises(ValidationError, match="ramp"):
        ConstantOptions(ramp="linear")
    with pytest.raises(InputError, match="jerk"):
        plan_constant(wave_problem(jerk_max=np.inf), ConstantOptions(ramp="jerk"))


def test_handles_1e5_samples():
    p = wave_problem(100_001)
    tr = plan_constant(p)
    assert check_timing(tr, p).c2
