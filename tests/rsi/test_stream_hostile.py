"""``feedopt stream`` against a scripted hostile controller on 127.0.0.1 (issue 26, item 3).

The controller here is a script, not the simulator: it sends packet k with IPOC
``FIRST + 4 k`` unless the script says otherwise (a jump forward: a pause; a jump back: a
restart), waits for the answer carrying that IPOC, applies its RKorr (absolute mode,
HOLDON: a missing answer holds the correction) and counts late answers in ``Delay``, until
an answer carries ``<Stop>1``. Other senders are plain sockets.

Every case checks, from the stream's own log, that each commanded pose (the start pose plus
the logged total correction) lies on the planned path: the distance to the nearest of 200
samples per row of the path (scipy cKDTree, not the streamer's row) is at most
``PATH_TOLERANCE_MM``. The stretch of the default trajectory used turns through its first
corner (93 deg over rows 7058-8321), where a chord between distant path points is mm off.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from feedopt.export.rsi import RsiTable, read_rsi_csv, write_rsi_csv
from feedopt.rsi.protocol import (
    MAX_PACKET_BYTES,
    PacketError,
    build_controller_packet,
    parse_sensor_answer,
)
from tests.rsi.conftest import poses
from tests.rsi.test_stream import _cli_stream, _read_log

FIRST = 1_000_000
CYCLE_MS = 4
#: Largest distance of a commanded pose from the planned path [mm] (the log has 1e-6 mm).
PATH_TOLERANCE_MM = 1e-3
#: ... and of its A, B, C from those of the nearest path point [deg].
ANGLE_TOLERANCE_DEG = 1e-3
#: Rows of the default trajectory streamed: through its first corner.
ROWS = slice(6900, 8500)


@pytest.fixture
def corner(default_table, tmp_path) -> Path:
    m = default_table.as_matrix()[ROWS].copy()
    m[:, 0] -= m[0, 0]
    path = tmp_path / "corner.csv"
    write_rsi_csv(path, RsiTable.from_matrix(m))
    return path


@dataclass
class ControllerRun:
    ipoc: np.ndarray  # (m,) sent
    answered: np.ndarray  # (m,) bool
    command: np.ndarray  # (m, 6) the pose commanded after each packet
    stopped: bool  # an answer carried Stop 1


def drive(sock: socket.socket, port: int, start: np.ndarray, jumps: dict[int, int],
          hook=None, max_packets: int = 4000, window_s: float = 2.0) -> ControllerRun:
    """Be the controller: packet k carries IPOC ``jumps[k]`` where given, else the previous
    plus 4; ``hook(k)`` runs before packet k (other senders)."""
    ipoc = FIRST - CYCLE_MS
    command = start.copy()
    late = run = 0
    rows = []
    stopped = False
    for k in range(max_packets):
        if hook is not None:
            hook(k)
        ipoc = jumps.get(k, ipoc + CYCLE_MS)
        sock.sendto(build_controller_packet(ipoc, rist=command, rsol=command, delay=late),
                    ("127.0.0.1", port))
        answer = _answer(sock, ipoc, window_s)
        if answer is None:
            late += 1
            run += 1
            if run >= 5:  # nobody answers: give up (a failing test, not a hang)
                break
        else:
            run = 0
            command = start + answer.rkorr
        rows.append((ipoc, answer is not None, *command))
        if answer is not None and answer.stop:
            stopped = True
            break
    m = np.array(rows)
    return ControllerRun(ipoc=m[:, 0].astype(np.int64), answered=m[:, 1].astype(bool),
                         command=m[:, 2:], stopped=stopped)


def _answer(sock: socket.socket, ipoc: int, window_s: float):
    sock.settimeout(window_s)
    while True:
        try:
            data = sock.recv(MAX_PACKET_BYTES)
        except TimeoutError:
            return None
        try:
            answer = parse_sensor_answer(data)
        except PacketError:
            continue
        if answer.ipoc == ipoc:
            return answer


def _controller_socket() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    return sock


def _run_case(csv: Path, log: Path, jumps: dict[int, int], extra: list[str] = (),
              hook_factory=None, sock: socket.socket | None = None):
    """Stream ``csv`` against the scripted controller; (exit code, stdout, stderr, run)."""
    want = poses(read_rsi_csv(csv))
    sock = sock or _controller_socket()
    proc, port = _cli_stream([str(csv), "--listen", "127.0.0.1:0", "--log", str(log),
                                *extra])
    try:
        hook = None if hook_factory is None else hook_factory(port)
        run = drive(sock, port, want[0], jumps, hook)
        out, err = proc.communicate(timeout=20)
    finally:
        proc.kill()
        sock.close()
    return proc.returncode, out, err, run


def path_error(log: Path, csv: Path) -> tuple[np.ndarray, np.ndarray, dict]:
    """Per logged answer: distance [mm] of the commanded pose from the densely sampled planned
    path, and the largest A/B/C difference [deg] from the nearest sample."""
    table = read_rsi_csv(csv)
    p = poses(table)
    p[:, 3:] = np.unwrap(p[:, 3:], period=360.0, axis=0)
    f = np.linspace(0.0, 1.0, 200, endpoint=False)
    dense = (p[:-1, None, :] + f[None, :, None] * np.diff(p, axis=0)[:, None, :]).reshape(-1, 6)
    dense = np.vstack([dense, p[-1:]])
    lg = _read_log(log)
    total = np.column_stack([lg[f"total_{a}"] for a in "xyzabc"])
    pose = p[0] + total
    dist, idx = cKDTree(dense[:, :3]).query(pose[:, :3])
    angle = np.max(np.abs(pose[:, 3:] - dense[idx, 3:]), axis=1)
    return dist, angle, lg


def _assert_on_path(log: Path, csv: Path) -> dict:
    dist, angle, lg = path_error(log, csv)
    assert dist.max() <= PATH_TOLERANCE_MM, (dist.max(), int(np.argmax(dist)))
    assert angle.max() <= ANGLE_TOLERANCE_DEG
    return lg


def _assert_controller_on_path(run: ControllerRun, csv: Path) -> None:
    """The poses the controller was commanded, against the same dense path."""
    p = poses(read_rsi_csv(csv))
    f = np.linspace(0.0, 1.0, 200, endpoint=False)
    dense = (p[:-1, None, :3] + f[None, :, None] * np.diff(p[:, :3], axis=0)[:, None, :])
    dist, _ = cKDTree(np.vstack([dense.reshape(-1, 3), p[-1:, :3]])).query(run.command[:, :3])
    assert dist.max() <= PATH_TOLERANCE_MM + 1e-6  # answers carry 6 decimals


def test_a_pause_mid_corner_holds_on_the_path(corner, tmp_path) -> None:
    """The IPOC jumps 832 cycles forward in the corner (the issue's case): the robot held its
    correction during the pause, so the stream holds it there, on the path, and stops: exit 3
    with 'controller gap', not a chord at the step cap."""
    log = tmp_path / "cycles.csv"
    k = 300  # 5 handshake packets, then row 294 (in the corner)
    jumps = {k: FIRST + CYCLE_MS * (k + 832)}
    code, out, err, run = _run_case(corner, log, jumps, ["--late-limit", "500"])
    assert code == 3, (out, err)
    assert "stream controller gap: 295/1600 rows" in out and "missing 832" in out
    assert "IPOC jumped 832 cycles" in err and "it was held there at row 295 of 1600" in err
    lg = _assert_on_path(log, corner)
    assert run.stopped and set(lg["phase"][lg["ipoc"] >= jumps[k]]) == {"hold"}
    after = run.command[run.ipoc >= jumps[k]]
    np.testing.assert_array_equal(after, np.broadcast_to(run.command[k - 1], after.shape))
    _assert_controller_on_path(run, corner)


def test_a_short_pause_resumes_along_the_path(corner, tmp_path) -> None:
    """A 15-cycle pause (under --late-limit): the stream resumes from where the robot stands,
    speeding up along the path, and completes the trajectory late by the pause (exit 0)."""
    log = tmp_path / "cycles.csv"
    jumps = {400: FIRST + CYCLE_MS * (400 + 15)}
    code, out, err, run = _run_case(corner, log, jumps, ["--late-limit", "500"])
    assert code == 0, (out, err)
    assert "stream completed: 1600/1600 rows" in out and "missing 15" in out
    lg = _assert_on_path(log, corner)
    assert "resume" in set(lg["phase"]) and run.stopped
    moving = lg["phase"] != "handshake"
    assert np.all(np.diff(lg["row"][moving]) >= 0) and np.all(np.diff(lg["row"][moving]) <= 1)
    _assert_controller_on_path(run, corner)


def test_a_pause_past_the_end_is_not_completed(corner, tmp_path) -> None:
    """Near the end, the IPOC jumps past the trajectory's last row by the clock: the robot
    held 100 rows short of the end, and the report says so (exit 3, not 'completed')."""
    log = tmp_path / "cycles.csv"
    k = 1505  # row 1499
    jumps = {k: FIRST + CYCLE_MS * (k + 800)}
    code, out, err, run = _run_case(corner, log, jumps, ["--late-limit", "500"])
    assert code == 3, (out, err)
    assert "stream controller gap: 1500/1600 rows" in out and "completed" not in out
    assert "it was held there at row 1500 of 1600" in err
    _assert_on_path(log, corner)
    _assert_controller_on_path(run, corner)


def test_a_restarted_controller_ramps_to_a_stop(corner, tmp_path) -> None:
    """The IPOC goes back mid-corner (a restarted context): the stream slows to a stop along
    the path, answering the new IPOCs, holds and sends Stop 1 (exit 3)."""
    log = tmp_path / "cycles.csv"
    k = 500
    jumps = {k: 5000}
    code, out, err, run = _run_case(corner, log, jumps, ["--late-limit", "1000"])
    assert code == 3, (out, err)
    assert "stream controller restarted:" in out
    want = f"IPOC went back from {FIRST + CYCLE_MS * (k - 1)} to 5000"
    assert want in err and "slowed to a stop along the path and was held at row" in err
    lg = _assert_on_path(log, corner)
    after = lg["ipoc"] < FIRST
    assert {"ramp", "hold"} <= set(lg["phase"][after]) and run.stopped
    assert np.all(run.answered[run.ipoc < FIRST])  # every new IPOC answered
    v = np.linalg.norm(np.diff(run.command[k - 1:, :3], axis=0), axis=1)
    assert v[0] > 0.005 and v[-1] < 1e-6 and np.all(np.diff(v) <= 1e-6)  # slowed down to rest
    _assert_controller_on_path(run, corner)


def test_other_senders_are_counted_and_ignored(corner, tmp_path) -> None:
    """Without --controller: a host sending garbage before the controller is not taken for
    it (the first valid RSI packet is); its later valid RSI packets are never answered; the
    real controller is served to the end (exit 0)."""
    log = tmp_path / "cycles.csv"
    hooks = []
    rob = build_controller_packet(9_999_999)

    def factory(port):
        sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sender.bind(("127.0.0.1", 0))
        hooks.append(sender)
        plan = {0: [b"hello", b"<Rob><IPOC>x</IPOC></Rob>"], 200: [rob, b"\x00" * 10],
                201: [rob]}
        return lambda k: [sender.sendto(d, ("127.0.0.1", port)) for d in plan.get(k, [])]

    code, out, err, run = _run_case(corner, log, {}, ["--late-limit", "1000"], factory)
    sender = hooks[0]
    sender.settimeout(0.2)
    with pytest.raises(TimeoutError):
        sender.recv(MAX_PACKET_BYTES)  # never answered
    name = f"127.0.0.1:{sender.getsockname()[1]}"
    sender.close()
    assert code == 0, (out, err)
    assert "stream completed: 1600/1600 rows" in out
    assert f"not RSI 2, from other senders 3 ({name})" in out
    assert np.all(run.answered)
    _assert_on_path(log, corner)


def test_configured_controller_only(corner, tmp_path) -> None:
    """--controller names the controller: valid RSI packets from another port that come
    first are ignored (counted), and the configured controller is the one answered."""
    log = tmp_path / "cycles.csv"
    sock = _controller_socket()
    me = sock.getsockname()[1]
    hooks = []

    def factory(port):
        sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sender.bind(("127.0.0.1", 0))
        hooks.append(sender)
        rob = build_controller_packet(FIRST + 10_000)
        return lambda k: [sender.sendto(rob, ("127.0.0.1", port)) for _ in range(3) if k == 0]

    code, out, err, run = _run_case(corner, log, {}, ["--late-limit", "1000", "--controller",
                                                      f"127.0.0.1:{me}"], factory, sock)
    hooks[0].close()
    assert code == 0, (out, err)
    assert f"answered from 127.0.0.1:{me}" in out and "from other senders 3" in out
    assert np.all(run.answered)
    _assert_on_path(log, corner)


@pytest.mark.parametrize("value, fragment", [
    ("", "give the controller's HOST or HOST:PORT"),
    ("127.0.0.1:0", "port 0 is no sender's port"),
    ("127.0.0.1:99999", "the port must be 0-65535"),
    ("no-such-host.invalid", "cannot resolve 'no-such-host.invalid'"),
])
def test_bad_controller_option(corner, value, fragment, capsys) -> None:
    from feedopt.cli import main

    assert main(["stream", str(corner), "--listen", "127.0.0.1:0", "--controller", value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("feedopt stream: error: --controller")
    assert fragment in err[0]


ROS_CONFIG = Path(__file__).resolve().parents[1] / "data" / "rsi" / "ros_industrial" / \
    "ros_rsi_ethernet.xml"


@pytest.mark.parametrize("extra, fragment", [
    (["--config", str(ROS_CONFIG), "--correction", "cartesian"],
     "answers with AK (A1, A2, A3, A4, A5, A6): axis corrections"),
    (["--config", str(ROS_CONFIG), "--sen-type", "Other"], "SENTYPE is ImFree"),
    (["--ipoc-step", "0"], "--ipoc-step must be >= 1"),
    (["--config", "/no/such/eth.xml"], "/no/such/eth.xml"),
    (["--correction", "axis", "--pid"], "--pid corrects the measured TCP pose"),
])
def test_bad_correction_options(corner, extra, fragment, capsys) -> None:
    from feedopt.cli import main

    assert main(["stream", str(corner), "--listen", "127.0.0.1:0", "--wait-s", "0.5",
                 *extra]) == 2
    assert fragment in capsys.readouterr().err


def test_the_log_never_overwrites_the_ethernet_configuration(corner, tmp_path, capsys) -> None:
    from feedopt.cli import main

    config = tmp_path / "eth.xml"
    config.write_bytes(ROS_CONFIG.read_bytes())
    before = config.read_bytes()
    assert main(["stream", str(corner), "--listen", "127.0.0.1:0", "--wait-s", "0.5",
                 "--config", str(config), "--correction", "axis", "--log", str(config)]) == 2
    assert "would destroy your input" in capsys.readouterr().err
    assert config.read_bytes() == before
