"""Setpoint table -> RKorr corrections, checked against the table's own columns."""

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.export.rsi import RsiTable
from feedopt.rsi.corrections import (
    COLUMNS,
    CorrectionMode,
    check_steps,
    limit_step,
    plan_from_table,
    write_corrections_csv,
)
from tests.rsi.conftest import poses

CYCLE = 0.004


def test_absolute_and_relative_from_the_table(default_table) -> None:
    plan = plan_from_table(default_table, CYCLE, "jerk.csv")
    p = poses(default_table)
    np.testing.assert_array_equal(plan.start_pose, p[0])
    np.testing.assert_allclose(plan.absolute, p - p[0], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(plan.absolute[0], np.zeros(6))
    # the controller adds the increments up: their running sum is the absolute correction
    np.testing.assert_allclose(np.cumsum(plan.relative, axis=0), plan.absolute, atol=1e-8)
    np.testing.assert_allclose(plan.poses(), p, atol=1e-9)
    np.testing.assert_array_equal(plan.start_q_deg, default_table.q_deg[0])


def test_angles_are_unwrapped() -> None:
    n = 5
    a = np.array([178.0, 179.0, -180.0, -179.0, -178.0])  # +1 deg per row through +-180
    m = np.zeros((n, 18))
    m[:, 0] = np.arange(n) * CYCLE
    m[:, 4] = a
    plan = plan_from_table(RsiTable.from_matrix(m), CYCLE)
    np.testing.assert_allclose(plan.absolute[:, 3], [0, 1, 2, 3, 4])


def test_other_cycle_is_refused(default_table) -> None:
    m = default_table.as_matrix()[:300:3]  # every 3rd row: 12 ms apart
    table = RsiTable.from_matrix(m)
    with pytest.raises(InputError, match=r"12 ms apart, but the stream's cycle is 4 ms"):
        plan_from_table(table, CYCLE, "x.csv")
    assert len(plan_from_table(table, 0.012)) == 100


def test_uneven_rows_are_refused(default_table) -> None:
    m = default_table.as_matrix()[:50].copy()
    m[17, 0] += 0.001
    with pytest.raises(InputError, match=r"data row 17 .* 5 ms after the previous row"):
        plan_from_table(RsiTable.from_matrix(m), CYCLE, "x.csv")


def test_step_limit_names_the_first_row_over_it(default_table) -> None:
    plan = plan_from_table(default_table, CYCLE, "jerk.csv")
    steps = np.linalg.norm(np.diff(poses(default_table)[:, :3], axis=0), axis=1)
    limit = 0.5 * steps.max()
    first = int(np.argmax(steps > limit)) + 1
    with pytest.raises(InputError, match=rf"data row {first} .* --max-step-mm"):
        check_steps(plan, limit, 1.0)
    check_steps(plan, steps.max() * 1.0001, 1.0)


def test_limit_step_keeps_direction_and_bound() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        prev = rng.normal(size=6)
        want = prev + rng.normal(scale=0.3, size=6)
        got = limit_step(prev, want, 0.1, 0.05)
        d, w = got - prev, want - prev
        assert np.linalg.norm(d[:3]) <= 0.1 + 1e-12
        assert np.abs(d[3:]).max() <= 0.05 + 1e-12
        # same direction, never longer than asked
        assert np.dot(d[:3], w[:3]) == pytest.approx(np.linalg.norm(d[:3]) * np.linalg.norm(
            w[:3]))
        assert np.linalg.norm(d[:3]) <= np.linalg.norm(w[:3]) + 1e-12
    small = np.array([0.01, 0, 0, 0.001, 0, 0])
    np.testing.assert_array_equal(limit_step(np.zeros(6), small, 0.1, 0.05), small)


@pytest.mark.parametrize("mode", list(CorrectionMode))
def test_corrections_csv(default_table, tmp_path, mode) -> None:
    plan = plan_from_table(default_table, CYCLE, "jerk.csv")
    path = write_corrections_csv(tmp_path / "jerk_rsi.csv", plan, mode, comments=["law jerk"])
    text = path.read_text()
    assert f"# mode: {mode.value} (RSI_ON(#{mode.name}" in text
    lines = [line for line in text.splitlines() if not line.startswith("#")]
    assert lines[0] == ",".join(COLUMNS)
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    np.testing.assert_array_equal(data[:, 0], default_table.t_s)
    rows = data[:, 1:] if mode is CorrectionMode.ABSOLUTE else np.cumsum(data[:, 1:], axis=0)
    np.testing.assert_allclose(rows + poses(default_table)[0], poses(default_table), atol=1e-8)


def test_a_non_finite_correction_is_refused_by_name_before_writing(default_table,
                                                                   tmp_path) -> None:
    import dataclasses

    plan = plan_from_table(default_table, CYCLE, "jerk.csv")
    absolute = plan.absolute.copy()
    absolute[7, 4] = np.nan
    bad = dataclasses.replace(plan, absolute=absolute)
    target = tmp_path / "jerk_rsi.csv"
    with pytest.raises(ValueError, match=r"'rkorr_b_deg', row 7; refusing to write"):
        write_corrections_csv(target, bad, CorrectionMode.ABSOLUTE)
    assert not target.exists()
