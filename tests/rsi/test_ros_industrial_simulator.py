"""feedopt stream against ROS-Industrial's kuka_rsi_simulator: axis corrections, IPOC + 1.

The simulator (tests/data/rsi/ros_industrial, BSD, as published) is the controller side that
ROS-Industrial's kuka_rsi_hw_interface is developed against: it sends ``<Rob>`` packets with
AIPos / ASPos / Delay and an IPOC counting packets, reads ``root.find('AK')`` of each answer
(a Cartesian ``RKorr`` answer crashes it) and moves its axes to the start plus that absolute
correction. It runs here in a subprocess with Python 3's ``except ... as`` and stand-ins for
rospy (recording what it publishes) and std_msgs; the stream answers with the element names
of ROS-Industrial's own Ethernet configuration (``--config ros_rsi_ethernet.xml``).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from feedopt.export.rsi import RsiTable
from feedopt.rsi.corrections import plan_from_table
from feedopt.rsi.protocol import CorrectionSpace, read_ethernet_config
from feedopt.rsi.streamer import Streamer, StreamSettings, StreamStatus

DATA = Path(__file__).resolve().parents[1] / "data" / "rsi" / "ros_industrial"
CYCLE = 0.004
Q0 = np.array([0.0, -90.0, 90.0, 0.0, 90.0, 0.0])  # the simulator's start (act_joint_pos)

_STUBS = textwrap.dedent('''
    import json, sys, time, types
    log = open(sys.argv[3], "w")
    start, cycles = time.monotonic(), int(sys.argv[4])
    count, silent = [0], [0]
    rospy = types.ModuleType("rospy")
    class Publisher:
        def __init__(self, name, kind, queue_size=1):
            self.name = name
        def publish(self, msg):
            text = msg.decode() if isinstance(msg, bytes) else str(msg)
            log.write(json.dumps([self.name, text]) + "\\n")
            log.flush()
            if self.name.endswith("state"):
                count[0] += 1
            elif self.name.endswith("command"):
                silent[0] = 0
    rospy.Publisher = Publisher
    rospy.init_node = lambda name: None
    rospy.loginfo = rospy.logfatal = lambda *a: None
    def logwarn(*a):  # the simulator's "Socket timed out" (1 s without an answer)
        silent[0] += 1
    rospy.logwarn = logwarn
    rospy.on_shutdown = lambda hook: None
    rospy.is_shutdown = lambda: (count[0] >= cycles or silent[0] >= 3  # the stream has ended
                                 or time.monotonic() - start > 60)
    msg = types.ModuleType("std_msgs.msg")
    msg.String = str
    std = types.ModuleType("std_msgs")
    std.msg = msg
    sys.modules.update({"rospy": rospy, "std_msgs": std, "std_msgs.msg": msg})
    sys.argv = [sys.argv[0], sys.argv[1], sys.argv[2]]
''')


def _simulator_source() -> str:
    """The published simulator with Python 2's ``except X, e:`` as ``except X as e:``."""
    text = (DATA / "kuka_rsi_simulator").read_text()
    return re.sub(r"except ([\w.]+), (\w+):", r"except \1 as \2:", text)


def _axis_plan(rows: int):
    m = np.zeros((rows, 18))
    m[:, 0] = np.arange(rows) * CYCLE
    m[:, 1] = 5.0 * m[:, 0]  # the TCP's speed the ramps are sized by
    m[:, 7:13] = Q0
    m[:, 7] += 6.0 * m[:, 0] - 3.0 * m[:, 0] ** 2  # A1 slows to rest at t = 1 s
    m[:, 9] -= 2.0 * m[:, 0] - 1.0 * m[:, 0] ** 2  # A3
    return plan_from_table(RsiTable.from_matrix(m), CYCLE, "axes.csv", CorrectionSpace.AXIS)


def test_the_ros_industrial_simulator_follows_an_axis_stream(tmp_path):
    fmt = read_ethernet_config(DATA / "ros_rsi_ethernet.xml")
    assert (fmt.element, fmt.space, fmt.stop, fmt.sen_type) == ("AK", CorrectionSpace.AXIS,
                                                                None, "ImFree")
    plan = _axis_plan(251)
    runner = tmp_path / "run_simulator.py"
    runner.write_text(_STUBS + "\n" + _simulator_source())
    log = tmp_path / "published.jsonl"
    settings = StreamSettings(listen=("127.0.0.1", 0), answer_format=fmt, max_step_deg=0.1,
                              wait_s=20.0, hold_s=0.2, late_limit=10_000,
                              late_after_s=1.0)  # a loaded test machine: judge the path
    with Streamer(settings) as streamer:
        host, port = streamer.address
        sim = subprocess.Popen([sys.executable, str(runner), host, str(port), str(log),
                                "400"], stderr=subprocess.PIPE, text=True)
        said = []
        try:
            report = streamer.run(plan, announce=said.append)
        finally:
            sim.wait(timeout=90)  # it ends itself within 61 s of its start
    assert len(said) == 1 and "IPOC +1 per 4 ms packet (it counts packets)" in said[0]
    assert "the robot at the start by AIPos" in said[0] and "answering AK (A1," in said[0]
    assert sim.returncode == 0, sim.stderr.read()
    assert report.status is StreamStatus.COMPLETED, report
    assert report.rows_sent == len(plan)
    assert any("advanced by 1 per 4 ms packet" in n for n in report.notes)
    records = [json.loads(line) for line in log.read_text().splitlines()]
    commands = [ET.fromstring(text) for name, text in records if name.endswith("command")]
    states = [ET.fromstring(text) for name, text in records if name.endswith("state")]
    ak = np.array([[float(c.find("AK").get(f"A{i}")) for i in range(1, 7)] for c in commands])
    # every answer it read is a point of the planned joint path (rows advance one by one)
    a = plan.absolute
    for row in ak:
        r = np.argmin(np.abs(a[:, 0] - row[0]))
        assert np.abs(a[r] - row).max() < 2e-6
    np.testing.assert_allclose(ak[-1], a[-1], rtol=0, atol=1e-6)
    # where the simulator's axes ended: its start plus the last correction it applied
    aipos = np.array([float(states[-1].find("AIPos").get(f"A{i}")) for i in range(1, 7)])
    np.testing.assert_allclose(aipos, Q0 + a[-1], rtol=0, atol=1e-6)
    ipocs = [int(c.findtext("IPOC")) for c in commands]
    assert ipocs == sorted(ipocs) and np.all(np.diff(ipocs) == 1)  # echoed, one per packet


def test_a_cartesian_answer_is_what_crashes_it():
    """The issue's finding, kept as a fact about the simulator: it reads AK only."""
    from feedopt.rsi.protocol import build_sensor_answer

    root = ET.fromstring(build_sensor_answer(7, np.zeros(6)))
    assert root.find("AK") is None and root.find("RKorr") is not None
    axis = read_ethernet_config(DATA / "ros_rsi_ethernet.xml")
    root = ET.fromstring(build_sensor_answer(7, np.arange(6.0), fmt=axis))
    assert [root.find("AK").get(f"A{i}") for i in range(1, 7)] == [
        f"{v:.6f}" for v in range(6)]
    assert root.find("Stop") is None  # its configuration has no Stop element


@pytest.mark.parametrize(("body", "message"), [
    ("<ROOT><CONFIG><SENTYPE>ImFree</SENTYPE></CONFIG><RECEIVE><ELEMENTS>"
     '<ELEMENT TAG="AK.A1" /></ELEMENTS></RECEIVE></ROOT>', "must hold one correction"),
    ("<ROOT><CONFIG></CONFIG></ROOT>", "no <CONFIG><SENTYPE>"),
    ("<ROOT", "not XML"),
])
def test_a_configuration_without_one_correction_is_refused(tmp_path, body, message):
    from feedopt.errors import InputError

    p = tmp_path / "eth.xml"
    p.write_text(body)
    with pytest.raises(InputError, match=message):
        read_ethernet_config(p)


def test_a_killed_simulator_ends_the_stream_as_controller_silent(tmp_path):
    """SIGKILL the simulator mid-trajectory: the stream says the controller went silent
    before the end (not completed), having sent only rows of the planned path."""
    import threading

    fmt = read_ethernet_config(DATA / "ros_rsi_ethernet.xml")
    plan = _axis_plan(1001)  # 4 s
    runner = tmp_path / "run_simulator.py"
    runner.write_text(_STUBS + "\n" + _simulator_source())
    log = tmp_path / "published.jsonl"
    settings = StreamSettings(listen=("127.0.0.1", 0), answer_format=fmt, max_step_deg=0.1,
                              wait_s=20.0, silence_s=0.5, late_limit=10_000,
                              late_after_s=1.0)
    with Streamer(settings) as streamer:
        host, port = streamer.address
        sim = subprocess.Popen([sys.executable, str(runner), host, str(port), str(log),
                                "100000"], stderr=subprocess.PIPE, text=True)
        timer = threading.Timer(1.5, sim.kill)
        timer.start()
        try:
            report = streamer.run(plan)
        finally:
            timer.cancel()
            sim.kill()
            sim.wait(timeout=30)
    assert report.status is StreamStatus.CONTROLLER_SILENT, report
    assert 0 < report.rows_sent < len(plan)
    assert any("sent nothing for 0.5 s" in n for n in report.notes)
