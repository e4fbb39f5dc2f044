"""A simulated KUKA RSI controller: packets every cycle on UDP, corrections applied to a plant.

For tests and for users without a robot (``feedopt rsi-sim``). Every cycle (4 ms by
default, on its own clock) the simulator sends a ``<Rob>`` packet (:mod:`feedopt.rsi.protocol`)
with IPOC advancing by the cycle in ms, as a KRC4 does, ``RIst`` = the plant's encoder pose,
``RSol`` = the commanded pose and ``Delay`` = its count of late answers; then waits one
cycle for the answer carrying that IPOC. As the controller's ETHERNET object would:

- an answer that does not arrive within the cycle, carries another IPOC or another
  ``Sen Type`` is late: the command stays where it was (``HOLDON="1"`` in absolute mode;
  a lost increment in relative mode); ``timeout_cycles`` late answers in a row stop RSI
  (the ETHERNET object's ``Timeout``);
- ``RKorr`` is the total correction from the pose at RSI_ON (absolute) or this cycle's
  increment (relative), in the base frame (X, Y, Z mm; A, B, C deg, added per component);
- ``<Stop>1</Stop>`` ends ``RSI_MOVECORR()``: the simulator stops sending.

The plant (:class:`Plant`): the encoder pose follows the commanded pose through a first-order
lag (time constant ``lag_s``, exact discretisation ``alpha = 1 - exp(-cycle / lag)``), and the
true TCP is the encoder pose plus a static offset (``compliance_mm``: a constant process
force times the compliance, which the encoders do not see). ``RIst`` reports the encoder pose,
as a real controller's does; the true pose goes to an optional tracker address
(``tracker_to``) as ``x,y,z,a,b,c`` datagrams, sent just before each packet, so a streamer
closing the loop on the tracker (thesis section 3.6.2) sees the deflection.
"""

from __future__ import annotations

import enum
import gc
import math
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from feedopt.errors import InputError, Terminated
from feedopt.rsi.corrections import CorrectionMode
from feedopt.rsi.protocol import (
    DEFAULT_SEN_TYPE,
    MAX_PACKET_BYTES,
    PacketError,
    build_controller_packet,
    parse_sensor_answer,
)

#: The IPOC of the first packet (any start works; a KRC's is a running millisecond count).
FIRST_IPOC = 1_000_000


@dataclass(frozen=True)
class PlantSettings:
    """``compliance_mm``: (3,) static offset of the true TCP from the encoder pose [mm];
    ``lag_s``: first-order lag of the encoder pose behind the command [s] (0: none)."""

    compliance_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    lag_s: float = 0.0


class Plant:
    """The robot as the simulator sees it: commanded pose -> encoder pose -> true TCP."""

    def __init__(self, start_pose: np.ndarray, settings: PlantSettings, cycle_s: float) -> None:
        self.encoder = np.array(start_pose, dtype=float)
        self.command = self.encoder.copy()
        self.offset = np.concatenate([np.asarray(settings.compliance_mm, dtype=float),
                                      np.zeros(3)])
        self.alpha = 1.0 if settings.lag_s <= 0 else -math.expm1(-cycle_s / settings.lag_s)

    @property
    def true(self) -> np.ndarray:
        """The TCP pose the tool really has: encoder pose plus the static offset."""
        return self.encoder + self.offset

    def step(self) -> None:
        """Advance one cycle towards the current command (first-order lag)."""
        self.encoder = self.encoder + self.alpha * (self.command - self.encoder)


class SimStatus(enum.Enum):
    STOPPED = "stopped by the sensor"  # <Stop>1 ended RSI_MOVECORR
    TIMEOUT = "RSI timeout"  # timeout_cycles late answers in a row
    MAX_TIME = "time limit"  # max_s reached
    INTERRUPTED = "interrupted"


@dataclass(frozen=True)
class SimSettings:
    """Options of the simulated controller (``feedopt rsi-sim --help``)."""

    connect: tuple[str, int]
    start_pose: tuple[float, ...] = (0.0,) * 6
    cycle_s: float = 0.004
    mode: CorrectionMode = CorrectionMode.ABSOLUTE
    plant: PlantSettings = PlantSettings()
    timeout_cycles: int = 100
    max_s: float = 3600.0
    tracker_to: tuple[str, int] | None = None
    bind: tuple[str, int] = ("127.0.0.1", 0)
    sen_type: str = DEFAULT_SEN_TYPE
    reply_timeout_s: float | None = None  # how long an answer may take (None: one cycle)


@dataclass(frozen=True)
class SimRecord:
    """Per cycle: ``ipoc`` (m,), ``late`` (m,) bool, ``rkorr`` (m, 6) (NaN when late),
    ``command`` / ``encoder`` / ``true`` (m, 6) poses after the cycle [mm, deg]."""

    ipoc: np.ndarray
    late: np.ndarray
    rkorr: np.ndarray
    command: np.ndarray
    encoder: np.ndarray
    true: np.ndarray


@dataclass(frozen=True)
class SimReport:
    """Outcome: status, cycles sent, late answers (total and longest run), the record, the
    largest |encoder - command| (following error) and, with a reference, the largest distance
    of the true TCP from the reference path [mm]."""

    status: SimStatus
    cycles: int
    late: int
    longest_late_run: int
    record: SimRecord
    max_following_error_mm: float
    path_error_mm: np.ndarray | None = None

    @property
    def max_path_error_mm(self) -> float | None:
        return None if self.path_error_mm is None else float(self.path_error_mm.max(initial=0))


def path_distance(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance [same unit] of each of ``points`` (m, 3) from the polyline ``path`` (n, 3):
    the nearest vertex (scipy cKDTree), then the two segments around it."""
    path = np.asarray(path, dtype=float)
    points = np.asarray(points, dtype=float)
    _, idx = cKDTree(path).query(points)
    best = np.linalg.norm(points - path[idx], axis=1)
    for lo in (idx - 1, idx):
        lo = np.clip(lo, 0, path.shape[0] - 2) if path.shape[0] > 1 else np.zeros_like(lo)
        hi = np.minimum(lo + 1, path.shape[0] - 1)
        a, b = path[lo], path[hi]
        ab = b - a
        den = np.einsum("ij,ij->i", ab, ab)
        t = np.where(den > 0, np.einsum("ij,ij->i", points - a, ab) / np.where(den > 0, den, 1),
                     0.0)
        proj = a + np.clip(t, 0.0, 1.0)[:, None] * ab
        best = np.minimum(best, np.linalg.norm(points - proj, axis=1))
    return best


def _socket(settings: SimSettings) -> socket.socket:
    host, port = settings.bind
    try:
        family = socket.getaddrinfo(settings.connect[0], settings.connect[1],
                                    type=socket.SOCK_DGRAM)[0][0]
    except socket.gaierror as exc:
        raise InputError(f"--connect {settings.connect[0]}:{settings.connect[1]}: cannot "
                         f"resolve the host ({exc.strerror})") from None
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise InputError(f"--bind {host}:{port}: cannot bind ({exc.strerror or exc})") from None
    return sock


def _wait_answer(sock: socket.socket, ipoc: int, deadline: float, sen_type: str):
    """The answer carrying ``ipoc`` if it arrives before ``deadline``; stale ones are dropped."""
    while True:
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            return None
        sock.settimeout(remaining)
        try:
            data = sock.recv(MAX_PACKET_BYTES)
        except TimeoutError:
            return None
        except ConnectionRefusedError:  # nobody listens yet (ICMP port unreachable)
            continue
        try:
            answer = parse_sensor_answer(data)
        except PacketError:
            continue
        if answer.ipoc == ipoc and answer.sen_type == sen_type:
            return answer


def run_sim(settings: SimSettings, reference: np.ndarray | None = None,
            stop_event: threading.Event | None = None) -> SimReport:
    """Run the simulated controller until the sensor sends Stop, RSI times out, ``max_s``
    passes, ``stop_event`` is set or Ctrl-C. ``reference``: (n, 3) path positions [mm] for
    the path error (the trajectory's x, y, z)."""
    cycle = settings.cycle_s
    cycle_ms = round(cycle * 1e3)
    window = cycle if settings.reply_timeout_s is None else settings.reply_timeout_s
    plant = Plant(np.asarray(settings.start_pose, dtype=float), settings.plant, cycle)
    sock = _socket(settings)
    tracker = None if settings.tracker_to is None else socket.socket(
        socket.getaddrinfo(*settings.tracker_to, type=socket.SOCK_DGRAM)[0][0],
        socket.SOCK_DGRAM)
    rows: list[np.ndarray] = []
    ipoc = FIRST_IPOC
    late = run = longest = 0
    status = SimStatus.MAX_TIME
    max_cycles = int(settings.max_s / cycle)
    start = plant.encoder.copy()
    gc_was_enabled = gc.isenabled()
    gc.disable()  # no collector pauses inside the cycle loop
    t_next = time.perf_counter()
    try:
        for _ in range(max_cycles):
            if stop_event is not None and stop_event.is_set():
                status = SimStatus.INTERRUPTED
                break
            delay = t_next - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            if tracker is not None:
                tracker.sendto(",".join(f"{v:.6f}" for v in plant.true).encode("ascii"),
                               settings.tracker_to)
            sock.sendto(build_controller_packet(ipoc, rist=plant.encoder, rsol=plant.command,
                                                delay=late), settings.connect)
            t_sent = time.perf_counter()
            answer = _wait_answer(sock, ipoc, t_sent + window, settings.sen_type)
            rkorr = np.full(6, np.nan)
            if answer is None:
                late += 1
                run += 1
                longest = max(longest, run)
            else:
                run = 0
                rkorr = answer.rkorr
                if settings.mode is CorrectionMode.ABSOLUTE:
                    plant.command = start + rkorr
                else:
                    plant.command = plant.command + rkorr
            plant.step()
            rows.append(np.concatenate([[ipoc, answer is None], rkorr, plant.command,
                                        plant.encoder, plant.true]))
            ipoc += cycle_ms
            t_next = max(t_next + cycle, time.perf_counter())
            if answer is not None and answer.stop:
                status = SimStatus.STOPPED
                break
            if run >= settings.timeout_cycles:
                status = SimStatus.TIMEOUT
                break
    except (KeyboardInterrupt, Terminated):
        status = SimStatus.INTERRUPTED
    finally:
        if gc_was_enabled:
            gc.enable()
        sock.close()
        if tracker is not None:
            tracker.close()
    m = np.array(rows).reshape(-1, 26)
    record = SimRecord(ipoc=m[:, 0].astype(np.int64), late=m[:, 1].astype(bool),
                       rkorr=m[:, 2:8], command=m[:, 8:14], encoder=m[:, 14:20],
                       true=m[:, 20:26])
    following = (np.linalg.norm(record.encoder[:, :3] - record.command[:, :3], axis=1)
                 if m.shape[0] else np.zeros(0))
    path_error = None
    if reference is not None and m.shape[0]:
        path_error = path_distance(record.true[:, :3], reference)
    return SimReport(status=status, cycles=m.shape[0], late=late, longest_late_run=longest,
                     record=record, max_following_error_mm=float(following.max(initial=0.0)),
                     path_error_mm=path_error)


SIM_LOG_COLUMNS = ("ipoc", "late", *(f"rkorr_{a}" for a in "xyzabc"),
                   *(f"command_{a}" for a in "xyzabc"), *(f"encoder_{a}" for a in "xyzabc"),
                   *(f"true_{a}" for a in "xyzabc"))


def write_sim_log(path: str | Path, report: SimReport) -> None:
    """One row per simulated cycle (``SIM_LOG_COLUMNS``; poses in mm / deg)."""
    r = report.record
    m = np.column_stack([r.ipoc, r.late.astype(int), r.rkorr, r.command, r.encoder, r.true])
    np.savetxt(path, m, delimiter=",", header=",".join(SIM_LOG_COLUMNS), comments="",
               fmt=["%d", "%d"] + ["%.6f"] * 24)
