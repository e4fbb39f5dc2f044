"""``feedopt rsi-sim`` against a scripted hostile sensor (issue 26, item 4): corrections beyond
the RSI context's limits, or not numbers, stop RSI with an error naming the cycle and the
value, and are never applied to the plant; refused answers are reported."""

from __future__ import annotations

import re
import socket
import threading

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.rsi.protocol import MAX_PACKET_BYTES, parse_controller_packet
from feedopt.rsi.sim import CorrectionLimits, SimSettings, SimStatus, run_sim


def _sen(ipoc: int, values: tuple[str, ...]) -> bytes:
    attrs = " ".join(f'{a}="{v}"' for a, v in zip("XYZABC", values, strict=True))
    return f'<Sen Type="ImFree"><RKorr {attrs} /><IPOC>{ipoc}</IPOC></Sen>'.encode("ascii")


class HostileSensor:
    """Answers every packet: a correction growing 0.01 mm per cycle in X until cycle
    ``at`` (0-based), which gets ``values``; a garbage datagram before every answer."""

    def __init__(self, at: int, values: tuple[str, ...]) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(5.0)
        self.at, self.values = at, values
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def port(self) -> int:
        return self.sock.getsockname()[1]

    def _serve(self) -> None:
        k = 0
        while True:
            try:
                data, addr = self.sock.recvfrom(MAX_PACKET_BYTES)
            except (TimeoutError, OSError):
                return
            ipoc = parse_controller_packet(data).ipoc
            values = (self.values if k == self.at else
                      (f"{0.01 * k:.6f}", "0", "0", "0", "0", "0"))
            self.sock.sendto(b"not xml", addr)
            self.sock.sendto(_sen(ipoc, values), addr)
            k += 1

    def close(self) -> None:
        self.sock.close()
        self.thread.join(2.0)


@pytest.mark.parametrize("values, what", [
    (("1e308", "0", "0", "0", "0", "0"), "X above PosCorr UpperLimX [mm] 1e+308, limit 5"),
    (("0", "-7.5", "0", "0", "0", "0"), "Y below PosCorr LowerLimY [mm] -7.5, limit -5"),
    (("nan", "0", "0", "0", "0", "0"), "RKorr X is not a number"),
    (("0", "0", "0", "0", "0", "1e309"), "RKorr C is not a number"),
    (("4.5", "4.5", "0", "0", "0", "0"), "translation above PosCorrMon MaxTrans [mm] "
                                         "6.36396, limit 6"),
])
def test_a_correction_beyond_the_limits_stops_rsi(values, what, capsys) -> None:
    """Cycle 50 of the hostile sensor: RSI stops there with an error (exit 3), the plant never
    received it, and the summary counts the garbage answers it refused."""
    sensor = HostileSensor(50, values)
    try:
        code = main(["rsi-sim", "--connect", f"127.0.0.1:{sensor.port}", "--max-s", "10",
                     "--max-speed-mm-s", "1e9"])
    finally:
        sensor.close()
    out, err = capsys.readouterr()
    assert code == 3, (out, err)
    assert "rsi-sim correction limit: 51 cycles" in out
    # On a loaded machine an answer can miss its 4 ms cycle: it then arrives in the next one
    # and is refused for its old IPOC. Every such refusal is a late answer, counted as one.
    late = int(re.search(r"(\d+) late answer", out).group(1))
    stale = int(re.search(r"51 not RSI, (\d+) with another IPOC or Sen Type", out).group(1))
    assert stale <= late, out
    assert "RSI stopped with an error at cycle 51 (IPOC 1000200)" in err
    assert what in err and "the correction was not applied" in err


def test_the_plant_never_moves_by_a_refused_correction() -> None:
    sensor = HostileSensor(30, ("1e308", "0", "0", "0", "0", "0"))
    try:
        report = run_sim(SimSettings(connect=("127.0.0.1", sensor.port), max_s=5.0,
                                     reply_timeout_s=0.5, limits=CorrectionLimits()))
    finally:
        sensor.close()
    assert report.status is SimStatus.LIMIT and report.cycles == 31
    stop = report.limit_stop
    assert (stop.cycle, stop.ipoc, stop.value, stop.limit) == (30, 1000120, 1e308, 5.0)
    cmd = report.record.command
    assert np.all(np.isfinite(cmd)) and np.abs(cmd).max() <= 0.29 + 1e-9
    np.testing.assert_array_equal(cmd[-1], cmd[-2])  # held, not moved


def test_a_jump_faster_than_the_robot_stops_rsi(capsys) -> None:
    """9 mm in one 4 ms cycle (2250 mm/s) within a 50 mm PosCorr limit: the speed limit."""
    sensor = HostileSensor(20, ("9", "0", "0", "0", "0", "0"))
    try:
        code = main(["rsi-sim", "--connect", f"127.0.0.1:{sensor.port}", "--max-s", "10",
                     "--limit-mm", "50", "--max-trans-mm", "60"])
    finally:
        sensor.close()
    out, err = capsys.readouterr()
    assert code == 3, (out, err)
    assert "speed of the correction [mm/s] 2202.5, limit 2000" in err  # (9 - 0.19) / 0.004


@pytest.mark.parametrize("argv, fragment", [
    (["--limit-mm", "0"], "--limit-mm must be > 0"),
    (["--max-trans-mm", "nan"], "--max-trans-mm must be > 0"),
    (["--max-speed-mm-s", "-1"], "--max-speed-mm-s must be > 0"),
])
def test_bad_limits(argv, fragment, capsys) -> None:
    assert main(["rsi-sim", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0]
