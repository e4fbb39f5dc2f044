"""feedopt stream against RSIPI's echo server, a second independent RSI controller model.

RSIPI 0.3.0's ``EchoServer`` (tests/data/rsi/rsipi, Apache-2.0, as published) reads an RSI
Ethernet configuration, sends ``<Rob>`` packets to its IP_NUMBER / PORT with an IPOC it
advances by the cycle in ms, checks the IPOC echo and the Type of every answer, and applies
``RKorr`` to RIst and ``AKorr`` to AIPos (absolute mode: start plus correction). It runs in
a thread here, on feedopt's exported Ethernet configurations: as written for Cartesian
corrections, and for axis corrections with the element renamed ``AKorr`` (KUKA's name, which
RSIPI knows), which ``feedopt stream --config`` must follow.
"""

from __future__ import annotations

import importlib.util
import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from feedopt.export.rsi import RsiTable
from feedopt.export.rsi_program import ethernet_config_xml
from feedopt.rsi.corrections import plan_from_table
from feedopt.rsi.protocol import CorrectionSpace, read_ethernet_config
from feedopt.rsi.streamer import Streamer, StreamSettings, StreamStatus

DATA = Path(__file__).resolve().parents[1] / "data" / "rsi" / "rsipi"
CYCLE = 0.004


def _echo_server_module():
    """RSIPI's rsi_echo_server as a module of a package of its own (module docstring)."""
    name = "rsipi_vendored"
    if f"{name}.rsi_echo_server" in sys.modules:
        return sys.modules[f"{name}.rsi_echo_server"]
    pkg = types.ModuleType(name)
    pkg.__path__ = [str(DATA)]
    sys.modules[name] = pkg
    spec = importlib.util.spec_from_file_location(f"{name}.rsi_echo_server",
                                                  DATA / "rsi_echo_server.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _plan(space: CorrectionSpace, rows: int = 251):
    """From the echo server's start (RIst and AIPos all zero): the TCP along x and y, the
    axes A1 and A5, each slowing to rest at t = 1 s."""
    m = np.zeros((rows, 18))
    t = np.arange(rows) * CYCLE
    m[:, 0] = t
    m[:, 1] = 8.0 * t - 4.0 * t ** 2
    m[:, 2] = -2.0 * t + 1.0 * t ** 2
    m[:, 7] = 6.0 * t - 3.0 * t ** 2
    m[:, 11] = -4.0 * t + 2.0 * t ** 2
    return plan_from_table(RsiTable.from_matrix(m), CYCLE, "echo.csv", space)


def _free_port() -> int:
    with Streamer(StreamSettings(listen=("127.0.0.1", 0))) as probe:
        return probe.address[1]


def _stream_to_echo(tmp_path, config: Path, settings: StreamSettings, plan):
    """Run ``plan`` through the stream to RSIPI's echo server on ``config`` (absolute mode):
    (the stream's report or the InputError it raised, the server)."""
    from feedopt.errors import InputError

    echo = _echo_server_module()
    with Streamer(settings) as streamer:
        try:
            server = echo.EchoServer(str(config), delay_ms=4, mode="absolute",
                                     timeout_packets=10_000)
        except OSError as exc:  # its own fixed port 50000 is taken on this machine
            pytest.skip(f"RSIPI's echo server cannot bind its port 50000: {exc}")
        server.start()
        try:
            return streamer.run(plan), server
        except InputError as exc:
            return exc, server
        finally:
            server.stop()


@pytest.mark.parametrize("space", list(CorrectionSpace))
def test_rsipi_echo_server_follows_the_stream(tmp_path, monkeypatch, space):
    monkeypatch.chdir(tmp_path)  # the echo server logs to ./logs
    port = _free_port()
    xml = ethernet_config_xml(ip="127.0.0.1", port=port, space=space)
    if space is CorrectionSpace.AXIS:
        xml = xml.replace('TAG="AK.', 'TAG="AKorr.')
    config = tmp_path / "eth.xml"
    config.write_text(xml)
    fmt = read_ethernet_config(config)
    assert fmt.element == ("RKorr" if space is CorrectionSpace.CARTESIAN else "AKorr")
    plan = _plan(space)
    report, server = _stream_to_echo(tmp_path, config, StreamSettings(
        listen=("127.0.0.1", port), answer_format=fmt, wait_s=20.0, hold_s=0.2,
        late_limit=10_000, late_after_s=1.0, max_step_deg=0.1, max_step_mm=0.1), plan)
    assert report.status is StreamStatus.COMPLETED, report
    assert any("advanced by 4 per 4 ms packet" in n for n in report.notes)
    assert server.faulty_packets == 0  # every answer had the right IPOC and Type
    last = plan.absolute[-1]
    if space is CorrectionSpace.AXIS:
        got = [server.state["AIPos"][f"A{i}"] for i in range(1, 7)]
    else:
        got = [server.state["RIst"][k] for k in "XYZABC"]
    np.testing.assert_allclose(got, last, rtol=0, atol=1e-6)


def test_answers_the_controller_rejects_are_named_as_a_type_mismatch(tmp_path, monkeypatch):
    """RSIPI rejects an answer whose Type is not its SENTYPE and counts it in Delay, as a
    KRC does: every handshake answer rejected is a configuration mismatch, not lateness."""
    from feedopt.errors import InputError

    monkeypatch.chdir(tmp_path)
    port = _free_port()
    config = tmp_path / "eth.xml"
    config.write_text(ethernet_config_xml(ip="127.0.0.1", port=port))  # SENTYPE ImFree
    error, server = _stream_to_echo(tmp_path, config, StreamSettings(
        listen=("127.0.0.1", port), sen_type="NotImFree", wait_s=20.0),
        _plan(CorrectionSpace.CARTESIAN))
    assert isinstance(error, InputError)
    assert re.search(r"probably rejects them.*SENTYPE.*NotImFree", str(error))
    assert server.faulty_packets >= 3


def test_the_controller_s_count_decides_not_this_pc_s_clock(tmp_path, monkeypatch):
    """Every answer later than 1 ns by this stream's clock (a loaded PC), none by the
    controller's count (RSIPI's Delay stays 0): the stream completes; the report keeps both
    counts. With a count of its own only it would have stopped at 5 in a row."""
    monkeypatch.chdir(tmp_path)
    port = _free_port()
    config = tmp_path / "eth.xml"
    config.write_text(ethernet_config_xml(ip="127.0.0.1", port=port))
    report, _ = _stream_to_echo(tmp_path, config, StreamSettings(
        listen=("127.0.0.1", port), wait_s=20.0, hold_s=0.2, late_limit=5,
        late_after_s=1e-9), _plan(CorrectionSpace.CARTESIAN, rows=101))
    assert report.status is StreamStatus.COMPLETED, report
    assert report.late >= 100 and report.controller_late == 0
