"""verify_trajectory: verdicts and what the user reads (problems, warnings, export blockers)
are in mm-based units with the unit written, limits included."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from scipy.interpolate import PPoly

from feedopt.schedule.constant import plan_constant
from feedopt.schedule.trajectory import Trajectory
from feedopt.verify import verify_trajectory
from tests.schedule.conftest import wave_problem

LIMIT = 0.29e-3


def _deflection(problem, worst: int, peak: float) -> np.ndarray:
    """A made-up replay: 0.2 mm everywhere, ``peak`` [m] at sample ``worst``."""
    d = np.full(problem.n, 0.2e-3)
    d[worst] = peak
    return d


def _all_text(ver) -> list[str]:
    return [*ver.problems, *ver.warnings, *ver.export_blockers]


def _no_si(texts: list[str]) -> None:
    for t in texts:
        # no bare metres: every speed, acceleration, jerk and length is in mm-based units
        assert not re.search(r"\d m(/s|\b)", t), t


def test_baseline_over_the_limit_is_a_warning_in_mm() -> None:
    p = wave_problem()
    tr = plan_constant(p)
    ver = verify_trajectory(tr, p, None, LIMIT, deflection=_deflection(p, 1234, 0.4e-3))
    assert ver.verified and not ver.exportable and not ver.meets_limit
    s_mm = p.s[1234] * 1e3
    want = (f"predicted deflection 0.4000 mm exceeds the limit 0.2900 mm (ratio "
            f"{0.4 / 0.29:.4f}) at sample 1234, s = {s_mm:.2f} mm")
    assert any(w.startswith(want) and "expected" in w for w in ver.warnings)
    assert ver.export_blockers == (f"deflection reaches 0.4000 mm, {0.4 / 0.29:.4f} x the "
                                   "limit 0.29 mm",)
    _no_si(_all_text(ver))


def test_a_law_over_its_limits_is_told_in_user_units() -> None:
    # The constant trajectory relabelled as a law that promises the bound and a tight jerk.
    p = wave_problem(jerk_max=0.5, accel_max=0.05)
    tr = replace(plan_constant(wave_problem()), law="jerk")
    ver = verify_trajectory(tr, p, None, LIMIT, deflection=_deflection(p, 10, 0.35e-3))
    assert not ver.verified
    chk = ver.timing
    text = "\n".join(ver.problems)
    assert f"tangential jerk {chk.max_jerk * 1e3:.6g} mm/s^3 exceeds its limit 500 mm/s^3" in text
    assert (f"tangential acceleration {chk.max_accel * 1e3:.6g} mm/s^2 exceeds its limit "
            "50 mm/s^2") in text
    assert "mm/s exceeds its bound" in text and "predicted deflection 0.3500 mm" in text
    assert f"jerk {chk.max_jerk * 1e3:.4g} mm/s^3 exceeds the limit 500 mm/s^3" in (
        ver.export_blockers)
    _no_si(_all_text(ver))


def test_a_c1_law_is_blocked_with_its_jump_in_mm_s2() -> None:
    p = wave_problem()
    v, a = 2e-3, 0.02
    t1 = v / a
    s1 = v * t1 / 2
    t2 = t1 + (p.length - 2 * s1) / v
    # constant acceleration to v, cruise, constant deceleration: the acceleration jumps by a
    pp = PPoly(np.array([[a / 2, 0.0, -a / 2], [0.0, v, v], [0.0, s1, p.length - s1]]),
               np.array([0.0, t1, t2, t2 + t1]))
    tr = Trajectory("topp", pp, continuity=1)
    ver = verify_trajectory(tr, p, None, LIMIT, deflection=np.full(p.n, 0.1e-3))
    assert ver.timing.accel_jump == pytest.approx(a, rel=1e-9)
    assert ver.export_blockers == ("not C2: the acceleration jumps by up to 20 mm/s^2, so the "
                                   "jerk is unbounded",)
    _no_si(_all_text(ver))
