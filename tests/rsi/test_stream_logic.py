"""The streamer's per-cycle logic without sockets: what the controller holds after a discarded
answer, the stop ramp against a numerical integral of its profile, the handshake checks."""

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.export.rsi import RsiTable
from feedopt.rsi.corrections import CorrectionMode, limit_step, plan_from_table
from feedopt.rsi.protocol import ControllerPacket, CorrectionSpace
from feedopt.rsi.streamer import CorrectionStream, Phase, StreamSettings, StreamStatus

CYCLE = 0.004
START = np.array([1750.0, -300.0, 800.0, -9.7, 0.0, 0.0])


def _line_plan(rows: int, speed_mm_s: float):
    """A straight line along x at constant speed from START."""
    m = np.zeros((rows, 18))
    m[:, 0] = np.arange(rows) * CYCLE
    m[:, 1:7] = START
    m[:, 1] += speed_mm_s * m[:, 0]
    return plan_from_table(RsiTable.from_matrix(m), CYCLE, "line.csv")


def _run(logic, first: int, count: int, delay: int = 0):
    out = []
    for k in range(first, first + count):
        out.append(logic.answer(ControllerPacket(ipoc=4 * k, rist=START.copy(), delay=delay),
                                None))
    return out


@pytest.mark.parametrize("mode", list(CorrectionMode))
def test_a_discarded_answer_is_not_built_on(mode) -> None:
    """The controller's Delay rises by one more than the packets left unanswered: it dropped
    the last answer and still holds the one before. The robot stood still meanwhile, so the
    next answer neither jumps ahead to keep the clock nor catches up: it resumes from the
    held row along the path, its speed rising smoothly to the planned one."""
    v, a = 10.0, 500.0
    plan = _line_plan(400, v)  # 0.04 mm per cycle
    logic = CorrectionStream(plan, StreamSettings(mode=mode, max_step_mm=0.05))
    answers = _run(logic, 0, 50)
    held_before = answers[-2].total  # what the controller holds if answers[-1] is dropped
    # ... the stream then falls behind by 5 packets it never answers
    ans = logic.answer(ControllerPacket(ipoc=4 * 55, rist=START.copy(), delay=6), None, 5)
    np.testing.assert_array_equal(ans.held, held_before)
    assert ans.phase is Phase.RESUME
    assert 0.0 <= ans.total[0] - held_before[0] < 0.01 * v * CYCLE  # barely moving yet
    np.testing.assert_array_equal(ans.total[1:], 0.0)  # on the line
    if mode is CorrectionMode.RELATIVE:  # the increment is taken from what is held
        np.testing.assert_allclose(ans.sent, ans.total - held_before)
    # the controller took that one (Delay unchanged): the next steps from it
    nxt = logic.answer(ControllerPacket(ipoc=4 * 56, rist=START.copy(), delay=6), None)
    np.testing.assert_array_equal(nxt.held, ans.total)
    more = _run(logic, 57, 40, delay=6)
    x = np.array([held_before[0], ans.total[0], nxt.total[0]] + [m.total[0] for m in more])
    speed = np.diff(x) / CYCLE
    assert np.all(np.diff(speed) >= -1e-6) and speed[-1] == pytest.approx(v, rel=1e-9)
    assert np.max(np.diff(speed) / CYCLE) <= a * 1.01  # within the stop acceleration
    assert more[-1].phase is Phase.RUN


def test_a_gap_past_the_late_limit_holds_where_the_robot_stands() -> None:
    """An IPOC gap of 800 cycles near the end (past the end of the trajectory by the clock):
    the logic resumes from the held row, not from the clock's; a stop requested for that gap
    holds at the held row at once (the robot stood still), and it is not 'completed'."""
    plan = _line_plan(300, 10.0)
    logic = CorrectionStream(plan, StreamSettings())
    answers = _run(logic, 0, 255)  # handshake + rows 0..249
    logic.request_stop(StreamStatus.CONTROLLER_GAP)
    ans = logic.answer(ControllerPacket(ipoc=4 * 1055, rist=START.copy()), None, 799)
    assert ans.phase is Phase.HOLD and ans.stop and ans.row == 249.0
    np.testing.assert_array_equal(ans.total, answers[-1].total)
    assert logic.stop_status is StreamStatus.CONTROLLER_GAP and logic.rows_reached == 250


def test_without_delay_the_last_answer_is_assumed_held() -> None:
    # packets without RIst: the start check is off
    logic = CorrectionStream(_line_plan(100, 5.0), StreamSettings(start_check=False))
    answers = [logic.answer(ControllerPacket(ipoc=4 * k), None) for k in range(30)]
    for a, b in zip(answers[:-1], answers[1:], strict=True):
        np.testing.assert_array_equal(b.held, a.total)


def test_stop_ramp_follows_the_smoothstep() -> None:
    """After request_stop the row advances by the integral of r(u) = 1 - 3u^2 + 2u^3 over
    the ramp length L = max(4 cycles, 1.5 v / a, sqrt(6 v / j)) (trapezoid rule here)."""
    v, a, j = 8.0, 500.0, 5000.0
    plan = _line_plan(2000, v)
    logic = CorrectionStream(plan, StreamSettings(stop_accel_mm_s2=a, stop_jerk_mm_s3=j))
    _run(logic, 0, 105)  # handshake (5) + 100 rows
    row0 = logic.answer(ControllerPacket(ipoc=4 * 105), None).row
    logic.request_stop(StreamStatus.INTERRUPTED, 4 * 105)
    length = max(4 * CYCLE, 1.5 * v / a, np.sqrt(6 * v / j))
    steps = int(np.ceil(length / CYCLE)) + 3
    ramp = _run(logic, 106, steps)
    for n, ans in enumerate(ramp, start=1):
        t = min(n * CYCLE, length)
        u = np.linspace(0.0, t / length, 2001)
        r = 1 - 3 * u ** 2 + 2 * u ** 3
        integral = np.sum((r[1:] + r[:-1]) / 2 * np.diff(u)) * length  # [s]
        assert ans.row == pytest.approx(row0 + integral / CYCLE, rel=1e-6)
    assert ramp[-1].phase is Phase.HOLD and ramp[-1].stop
    # on the line, decelerating within the limit
    x = np.array([ans.total[0] for ans in ramp])
    speed = np.diff(np.concatenate([[x[0] - v * CYCLE], x])) / CYCLE
    assert np.all(np.diff(speed) <= 1e-9) and speed[-1] == pytest.approx(0.0, abs=1e-9)
    assert np.max(-np.diff(speed) / CYCLE) <= a * 1.01


def test_handshake_refuses_another_cycle() -> None:
    logic = CorrectionStream(_line_plan(10, 1.0), StreamSettings())
    with pytest.raises(InputError, match="advances by 12 per packet"):
        for k in range(5):
            logic.answer(ControllerPacket(ipoc=12 * k, rist=START.copy()), None)


def test_handshake_refuses_a_robot_away_from_the_start() -> None:
    logic = CorrectionStream(_line_plan(10, 1.0), StreamSettings(start_tolerance_mm=0.5))
    away = START + np.array([0.0, 0.6, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(InputError, match=r"0\.600 mm / 0\.000 deg away"):
        for k in range(5):
            logic.answer(ControllerPacket(ipoc=4 * k, rist=away), None)


def _axis_line_plan(rows: int, rate_deg_s: float):
    """A plan whose axes move A1 at ``rate_deg_s`` (and A4 backwards at half), from Q0."""
    m = np.zeros((rows, 18))
    m[:, 0] = np.arange(rows) * CYCLE
    m[:, 1:7] = START
    m[:, 1] += 5.0 * m[:, 0]  # the TCP's 5 mm/s: what the ramps are sized by
    m[:, 7:13] = Q0
    m[:, 7] += rate_deg_s * m[:, 0]
    m[:, 10] -= 0.5 * rate_deg_s * m[:, 0]
    return plan_from_table(RsiTable.from_matrix(m), CYCLE, "axes.csv", CorrectionSpace.AXIS)


Q0 = np.array([0.0, -90.0, 90.0, 0.0, 90.0, 0.0])


def test_axis_mode_answers_the_axis_values_less_the_start_and_checks_aipos() -> None:
    plan = _axis_line_plan(200, 2.0)
    logic = CorrectionStream(plan, StreamSettings(max_step_deg=0.1))
    answers = [logic.answer(ControllerPacket(ipoc=k, aipos=Q0.copy()), None)
               for k in range(60)]
    assert logic.ipoc_step == 1  # a controller (or simulator) that counts packets
    run = [a for a in answers if a.phase is Phase.RUN]
    for a in run:  # row r: A1 = 2 deg/s * r * 4 ms, A4 = -half of it, the rest still
        r = a.row
        np.testing.assert_allclose(a.total, [2.0 * CYCLE * r, 0, 0, -1.0 * CYCLE * r, 0, 0],
                                   rtol=0, atol=1e-12)
    away = CorrectionStream(plan, StreamSettings())
    with pytest.raises(InputError, match=r"A2 is 1\.000 deg away"):
        for k in range(5):
            away.answer(ControllerPacket(ipoc=k, aipos=Q0 + [0, 1, 0, 0, 0, 0]), None)
    blind = CorrectionStream(plan, StreamSettings())
    with pytest.raises(InputError, match=r"no AIPos \(DEF_AIPos\).*--no-start-check"):
        for k in range(5):
            blind.answer(ControllerPacket(ipoc=k, rist=START.copy()), None)


def test_the_axis_gate_keeps_the_direction_in_joint_space() -> None:
    held, want = np.zeros(6), np.array([0.4, 0.0, -0.2, 0.0, 0.0, 0.1])
    got = limit_step(held, want, 0.1, 0.1, CorrectionSpace.AXIS)
    np.testing.assert_allclose(got, want / 4.0)  # the largest axis step is 0.1 deg


def test_start_check_needs_rist_or_says_how_to_skip_it() -> None:
    logic = CorrectionStream(_line_plan(10, 1.0), StreamSettings())
    with pytest.raises(InputError, match=r"no RIst \(DEF_RIst\)"):
        for k in range(5):
            logic.answer(ControllerPacket(ipoc=4 * k), None)


@pytest.mark.parametrize(("step", "stated", "ok"), [(1, None, True), (4, None, True),
                                                     (12, None, False), (1, 4, False),
                                                     (4, 4, True)])
def test_the_ipoc_step_is_1_or_the_cycle_or_as_stated(step, stated, ok) -> None:
    logic = CorrectionStream(_line_plan(10, 1.0), StreamSettings(ipoc_step=stated))
    packets = [ControllerPacket(ipoc=100 + step * k, rist=START.copy()) for k in range(5)]
    if ok:
        for p in packets:
            logic.answer(p, None)
        assert logic.ipoc_step == step and logic.phase is Phase.RUN
    else:
        with pytest.raises(InputError, match=f"advances by {step} per packet"):
            for p in packets:
                logic.answer(p, None)


def test_pid_is_refused_in_axis_mode() -> None:
    from feedopt.rsi.pid import PidGains

    with pytest.raises(InputError, match="--pid corrects the measured TCP pose"):
        CorrectionStream(_axis_line_plan(10, 1.0), StreamSettings(pid=PidGains.thesis()))
