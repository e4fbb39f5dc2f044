"""The thesis's PID (Eq. 3.26-3.27): the difference equation against the transfer function,
and the closed loop on a plant with a static offset against its characteristic roots."""

import numpy as np
import pytest
from scipy.signal import lfilter

from feedopt.export.rsi import RsiTable
from feedopt.rsi.corrections import plan_from_table
from feedopt.rsi.pid import PidGains, PidState, pid_coefficients, pid_step
from feedopt.rsi.protocol import ControllerPacket
from feedopt.rsi.sim import Plant, PlantSettings
from feedopt.rsi.streamer import CorrectionStream, StreamSettings

TS = 0.004


def test_thesis_gains() -> None:
    g = PidGains.thesis()  # section 3.6.2: Kp 0.05 / Ki 0.3 Cartesian, Ki 0.02 angular, Kd 0
    np.testing.assert_array_equal(g.kp, [0.05] * 3 + [0.0] * 3)
    np.testing.assert_array_equal(g.ki, [0.3] * 3 + [0.02] * 3)
    np.testing.assert_array_equal(g.kd, np.zeros(6))


def test_difference_equation_is_the_transfer_function() -> None:
    """Eq. 3.27 step by step == Eq. 3.26 as a rational function of z^-1 (scipy lfilter)."""
    kp, ki, kd = 0.7, 3.0, 0.002
    gains = PidGains(kp=kp, ki=ki, kd=kd)
    # Eq. 3.26 over the common denominator (1 - z^-1), polynomials in z^-1:
    # Kp (1 - z^-1) + Ki Ts/2 (1 + z^-1) + Kd/Ts (1 - z^-1)^2
    num = np.polyadd(np.polyadd(kp * np.array([-1.0, 1.0]), ki * TS / 2 * np.array([1.0, 1.0])),
                     kd / TS * np.polymul([-1.0, 1.0], [-1.0, 1.0]))[::-1]
    den = [1.0, -1.0]
    e = np.random.default_rng(0).normal(size=(400, 6))
    want = lfilter(num, den, e, axis=0)
    coeffs, state, got = pid_coefficients(gains, TS), PidState.zero(), []
    for ek in e:
        state = pid_step(coeffs, state, ek)
        got.append(state.u)
    np.testing.assert_allclose(np.array(got), want, rtol=1e-12, atol=1e-12)


def test_output_limit_does_not_wind_up() -> None:
    coeffs = pid_coefficients(PidGains(kp=0.0, ki=10.0, kd=0.0), TS)
    limit, state = np.full(6, 0.5), PidState.zero()
    for _ in range(1000):  # a long positive error: saturates at the limit
        state = pid_step(coeffs, state, np.ones(6), limit)
    np.testing.assert_array_equal(state.u, limit)
    for _ in range(2):  # the trapezoid averages two errors: off the limit on the second step
        state = pid_step(coeffs, state, -np.ones(6), limit)
    np.testing.assert_allclose(state.u, limit - 10.0 * TS)


def _stationary_plan(start: np.ndarray, rows: int):
    m = np.zeros((rows, 18))
    m[:, 0] = np.arange(rows) * TS
    m[:, 1:7] = start
    return plan_from_table(RsiTable.from_matrix(m), TS, "hold.csv")


def _closed_loop(plan, plant: Plant, cycles: int, measure_true: bool) -> np.ndarray:
    """The streamer's per-cycle logic against the plant, one packet per cycle, no sockets;
    the true TCP's offset from the start pose after every cycle."""
    settings = StreamSettings(pid=PidGains.thesis(), pid_limit_mm=5.0, pid_limit_deg=5.0)
    logic = CorrectionStream(plan, settings)
    out = np.empty((cycles, 6))
    for k in range(cycles):
        packet = ControllerPacket(ipoc=4 * k, rist=plant.encoder.copy())
        measured = plant.true.copy() if measure_true else plant.encoder.copy()
        ans = logic.answer(packet, measured)
        plant.command = plan.start_pose + ans.total
        plant.step()
        out[k] = plant.true - plan.start_pose
    return out


def _roots_solution(x: np.ndarray, a: float, b: float) -> np.ndarray:
    """x[k] = (1 - a) x[k-1] - b x[k-2] from its first two values, by its characteristic
    roots: the closed loop of Eq. 3.27 on a unit plant with a one-cycle measurement delay."""
    z1, z2 = np.roots([1.0, -(1.0 - a), b])
    c1, c2 = np.linalg.solve([[1.0, 1.0], [z1, z2]], x[:2])
    k = np.arange(x.shape[0])
    return (c1 * z1 ** k + c2 * z2 ** k).real


@pytest.mark.parametrize("channel, offset, kp, ki", [(0, 0.3, 0.05, 0.3), (1, -0.2, 0.05, 0.3),
                                                     (3, 0.05, 0.0, 0.02)])
def test_pid_removes_a_static_offset(default_table, channel, offset, kp, ki) -> None:
    """Thesis gains, a plant whose true TCP is off by a constant (deflection), measured by a
    tracker: the offset decays exactly as the characteristic roots of the loop say."""
    start = np.array([default_table.x_mm[0], default_table.y_mm[0], default_table.z_mm[0],
                      default_table.a_deg[0], default_table.b_deg[0], default_table.c_deg[0]])
    cycles = 5000  # 20 s
    plan = _stationary_plan(start, cycles + 10)
    plant = Plant(start, PlantSettings(), TS)
    plant.offset[channel] = offset
    x = _closed_loop(plan, plant, cycles, measure_true=True)[:, channel]
    j0 = int(np.argmax(np.abs(x - offset) > 1e-9))  # the first cycle the PID acts on
    a, b = kp + ki * TS / 2, -kp + ki * TS / 2  # Eq. 3.27 with Kd = 0, computed here
    assert x[j0] == pytest.approx((1 - a) * offset, rel=1e-12)
    want = _roots_solution(x[j0 - 1:], a, b)
    np.testing.assert_allclose(x[j0 - 1:], want, rtol=0, atol=1e-9)
    # continuous-time loop: the proportional kick leaves d / (1 + Kp), which then decays with
    # the time constant (1 + Kp) / Ki
    tau = (1 + kp) / ki
    remaining = offset / (1 + kp) * np.exp(-(cycles - j0) * TS / tau)
    assert abs(x[-1]) == pytest.approx(abs(remaining), rel=0.02)
    if channel < 3:
        assert abs(x[-1]) < 0.005 * abs(offset)  # 20 s: removed to 0.5 %


def test_rist_does_not_see_the_deflection(default_table) -> None:
    """RIst comes from the encoders: a PID on it leaves a static deflection in place (why the
    thesis measured with a laser tracker)."""
    start = np.array([default_table.x_mm[0], default_table.y_mm[0], default_table.z_mm[0],
                      0.0, 0.0, 0.0])
    plant = Plant(start, PlantSettings(compliance_mm=(0.3, 0.0, 0.0)), TS)
    x = _closed_loop(_stationary_plan(start, 1010), plant, 1000, measure_true=False)
    np.testing.assert_allclose(x[:, 0], 0.3, atol=1e-12)
