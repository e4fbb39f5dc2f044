"""The feed-bound constraint registry: the bound is the minimum of every registered
constraint, and a toy constraint registered here shapes a whole run."""

from dataclasses import dataclass

import numpy as np
import pytest

from feedopt.runner import run_scenario
from feedopt.schedule.bounds import CONSTRAINTS, BoundInputs, register_constraint

quiet = lambda _m: None  # noqa: E731


def test_builtin_constraints_in_record_order() -> None:
    assert list(CONSTRAINTS) == ["deflection", "max_feed", "spindle_torque", "spindle_power",
                                 "joint_velocity", "compensation_cap", "wall_error",
                                 "floor_error", "orientation"]
    for name, factory in CONSTRAINTS.items():
        assert factory().name == name
    with pytest.raises(ValueError, match="already registered"):
        register_constraint("deflection", CONSTRAINTS["deflection"])


@dataclass(frozen=True)
class ChipCap:
    """Toy chip-thickness rule: feed per tooth at most 0.03 mm."""

    name: str = "chip_cap"

    def v_max(self, inputs: BoundInputs) -> np.ndarray:
        return np.full(inputs.n, 0.03e-3 * inputs.model.feed_per_unit_c)


@pytest.fixture
def chip_cap():
    register_constraint("chip_cap", ChipCap)
    yield
    del CONSTRAINTS["chip_cap"]


def test_toy_constraint_bounds_the_whole_run(chip_cap, quick_scenario, tmp_path) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["constant", "jerk", "convex"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
    bound = result.prepared.bound
    cap = 0.03e-3 * 2 * 2500 / 60  # 2 teeth at 2500 rpm: 2.5 mm/s
    np.testing.assert_allclose(bound.parts["chip_cap"], cap)
    expected = np.min(np.stack([bound.parts[n] for n in CONSTRAINTS]), axis=0)
    np.testing.assert_array_equal(bound.v_max, expected)
    assert bound.v_max.max() <= cap
    share = result.summary["scenario"]["active_constraints"]
    assert share["chip_cap"] > 0.5
    for law in ("jerk", "convex"):
        assert result.summary["laws"][law]["max_feed_mm_s"] <= cap * 1e3 * (1 + 1e-6)
        assert result.summary["laws"][law]["verified"]
