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
- ``<Stop>1</Stop>`` ends ``RSI_MOVECORR()``: the simulator stops sending;
- the correction is checked against the context's limits (:class:`CorrectionLimits`) before
  it is applied, as RSI's correction objects do: a total beyond PosCorr's ``LowerLim`` /
  ``UpperLim`` / ``MaxRotAngle`` or PosCorrMon's ``MaxTrans`` / ``MaxRotAngle``, a change in
  one cycle faster than the robot may move, or a value that is not a number, stops RSI with
  an error (the KRC's "POSCORR out of range, RSI is stopped"): the command stays where it
  was, no further packet is sent, and the report names the cycle and the value.

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
    LIMIT = "correction limit"  # a correction beyond the context's limits stopped RSI
    MAX_TIME = "time limit"  # max_s reached
    INTERRUPTED = "interrupted"


@dataclass(frozen=True)
class CorrectionLimits:
    """The limits of the RSI context's correction objects, on the total correction from the
    pose at RSI_ON and on its change per cycle.

    Defaults: RSI Visual's defaults for new objects, PosCorr ``LowerLimX..Z`` -5 mm,
    ``UpperLimX..Z`` 5 mm, ``MaxRotAngle`` 5 deg; PosCorrMon ``MaxTrans`` 6 mm,
    ``MaxRotAngle`` 6 deg (the "default 5 mm / 5 deg" and "6 mm" of public RSI 3.2-4.0
    troubleshooting notes; KUKA's manual was not at hand). The exported host program raises
    them for its trajectory (:func:`feedopt.export.rsi_program.correction_limits`). Per
    cycle: ``max_speed_mm_s`` 2000 (2 m/s, the top of KSS's ``$VEL.CP`` range,
    :data:`feedopt.export.krl.VEL_CP_MAX`) and ``max_speed_deg_s`` 400 (an assumed
    ``$VEL_MA.ORI1``; no source at hand). Rotation limits apply to the rotation vector's
    length ``sqrt(A^2 + B^2 + C^2)`` (small corrections), PosCorr's per axis to X, Y, Z.
    """

    lower_mm: tuple[float, float, float] = (-5.0, -5.0, -5.0)
    upper_mm: tuple[float, float, float] = (5.0, 5.0, 5.0)
    max_rot_deg: float = 5.0
    max_trans_mm: float = 6.0
    monitor_rot_deg: float = 6.0
    max_speed_mm_s: float = 2000.0
    max_speed_deg_s: float = 400.0

    def violation(self, total: np.ndarray, previous: np.ndarray,
                  cycle_s: float) -> tuple[str, float, float] | None:
        """(what, value, limit) of the first limit ``total`` (6,) breaks, or None."""
        for i, axis in enumerate("XYZ"):
            if not math.isfinite(total[i]):
                return (f"RKorr {axis} is not a number", float(total[i]), 0.0)
            if total[i] < self.lower_mm[i]:
                return (f"{axis} below PosCorr LowerLim{axis} [mm]", float(total[i]),
                        self.lower_mm[i])
            if total[i] > self.upper_mm[i]:
                return (f"{axis} above PosCorr UpperLim{axis} [mm]", float(total[i]),
                        self.upper_mm[i])
        for i, axis in enumerate("ABC", start=3):
            if not math.isfinite(total[i]):
                return (f"RKorr {axis} is not a number", float(total[i]), 0.0)
        rot = float(np.linalg.norm(total[3:]))
        trans = float(np.linalg.norm(total[:3]))
        step = total - previous
        for what, value, limit in (
                ("rotation above PosCorr MaxRotAngle [deg]", rot, self.max_rot_deg),
                ("translation above PosCorrMon MaxTrans [mm]", trans, self.max_trans_mm),
                ("rotation above PosCorrMon MaxRotAngle [deg]", rot, self.monitor_rot_deg),
                ("speed of the correction [mm/s]", float(np.linalg.norm(step[:3])) / cycle_s,
                 self.max_speed_mm_s),
                ("turn rate of the correction [deg/s]",
                 float(np.linalg.norm(step[3:])) / cycle_s, self.max_speed_deg_s)):
            if value > limit:
                return what, value, limit
        return None


#: No limits but finiteness (the library's default; ``feedopt rsi-sim`` always sets limits).
NO_LIMITS = CorrectionLimits(lower_mm=(-math.inf,) * 3, upper_mm=(math.inf,) * 3,
                             max_rot_deg=math.inf, max_trans_mm=math.inf,
                             monitor_rot_deg=math.inf, max_speed_mm_s=math.inf,
                             max_speed_deg_s=math.inf)


@dataclass(frozen=True)
class LimitStop:
    """Where RSI stopped on a limit: the cycle (0-based), its IPOC, the RKorr received,
    what was exceeded, the value and the limit."""

    cycle: int
    ipoc: int
    rkorr: np.ndarray
    what: str
    value: float
    limit: float


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
    limits: CorrectionLimits | None = None  # None: only non-finite corrections are refused


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
    limit_stop: LimitStop | None = None
    not_rsi: int = 0  # answers that were not RSI documents (refused)
    stale: int = 0  # answers with another IPOC or Sen Type (discarded as late)

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


@dataclass
class _Refused:
    """Answers the controller did not take: not RSI, or another IPOC / Sen Type."""

    not_rsi: int = 0
    stale: int = 0


def _wait_answer(sock: socket.socket, ipoc: int, deadline: float, sen_type: str,
                 refused: _Refused):
    """The answer carrying ``ipoc`` if it arrives before ``deadline``; others are counted
    in ``refused`` and dropped. RKorr values are read as numbers, finite or not (the limit
    check refuses them)."""
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
            answer = parse_sensor_answer(data, finite=False)
        except PacketError:
            refused.not_rsi += 1
            continue
        if answer.ipoc == ipoc and answer.sen_type == sen_type:
            return answer
        refused.stale += 1


class _Controller:
    """The simulated controller's state between cycles."""

    def __init__(self, settings: SimSettings) -> None:
        self.settings = settings
        self.plant = Plant(np.asarray(settings.start_pose, dtype=float), settings.plant,
                           settings.cycle_s)
        self.start = self.plant.encoder.copy()
        self.rows: list[np.ndarray] = []
        self.late = self.run = self.longest = 0
        self.refused = _Refused()
        self.limit_stop: LimitStop | None = None

    def apply(self, ipoc: int, rkorr: np.ndarray) -> bool:
        """Apply an accepted RKorr; False (nothing applied) when it breaks a limit."""
        s, plant = self.settings, self.plant
        previous = plant.command - self.start
        total = rkorr if s.mode is CorrectionMode.ABSOLUTE else previous + rkorr
        found = (s.limits or NO_LIMITS).violation(total, previous, s.cycle_s)
        if found is not None:
            self.limit_stop = LimitStop(len(self.rows), ipoc, np.array(rkorr), *found)
            return False
        plant.command = self.start + total
        return True

    def cycle(self, sock: socket.socket, tracker, ipoc: int, window_s: float) -> SimStatus | None:
        """One cycle: send, wait, apply, step, record; the status when RSI ends here."""
        s, plant = self.settings, self.plant
        if tracker is not None:
            tracker.sendto(",".join(f"{v:.6f}" for v in plant.true.tolist()).encode("ascii"),
                           s.tracker_to)
        sock.sendto(build_controller_packet(ipoc, rist=plant.encoder, rsol=plant.command,
                                            delay=self.late), s.connect)
        answer = _wait_answer(sock, ipoc, time.perf_counter() + window_s, s.sen_type,
                              self.refused)
        rkorr = np.full(6, np.nan)
        if answer is None:
            self.late += 1
            self.run += 1
            self.longest = max(self.longest, self.run)
        else:
            self.run = 0
            rkorr = answer.rkorr
            if not self.apply(ipoc, rkorr):
                self.rows.append(np.concatenate([[ipoc, False], rkorr, plant.command,
                                                 plant.encoder, plant.true]))
                return SimStatus.LIMIT
        plant.step()
        self.rows.append(np.concatenate([[ipoc, answer is None], rkorr, plant.command,
                                         plant.encoder, plant.true]))
        if answer is not None and answer.stop:
            return SimStatus.STOPPED
        if self.run >= s.timeout_cycles:
            return SimStatus.TIMEOUT
        return None


def run_sim(settings: SimSettings, reference: np.ndarray | None = None,
            stop_event: threading.Event | None = None) -> SimReport:
    """Run the simulated controller until the sensor sends Stop, RSI times out or stops on a
    correction limit, ``max_s`` passes, ``stop_event`` is set or Ctrl-C. ``reference``:
    (n, 3) path positions [mm] for the path error (the trajectory's x, y, z)."""
    cycle = settings.cycle_s
    cycle_ms = round(cycle * 1e3)
    window = cycle if settings.reply_timeout_s is None else settings.reply_timeout_s
    ctl = _Controller(settings)
    sock = _socket(settings)
    tracker = None if settings.tracker_to is None else socket.socket(
        socket.getaddrinfo(*settings.tracker_to, type=socket.SOCK_DGRAM)[0][0],
        socket.SOCK_DGRAM)
    ipoc = FIRST_IPOC
    status = SimStatus.MAX_TIME
    gc_was_enabled = gc.isenabled()
    gc.disable()  # no collector pauses inside the cycle loop
    t_next = time.perf_counter()
    try:
        for _ in range(int(settings.max_s / cycle)):
            if stop_event is not None and stop_event.is_set():
                status = SimStatus.INTERRUPTED
                break
            delay = t_next - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            ended = ctl.cycle(sock, tracker, ipoc, window)
            ipoc += cycle_ms
            t_next = max(t_next + cycle, time.perf_counter())
            if ended is not None:
                status = ended
                break
    except (KeyboardInterrupt, Terminated):
        status = SimStatus.INTERRUPTED
    finally:
        if gc_was_enabled:
            gc.enable()
        sock.close()
        if tracker is not None:
            tracker.close()
    return _report(ctl, status, reference)


def _report(ctl: _Controller, status: SimStatus, reference: np.ndarray | None) -> SimReport:
    m = np.array(ctl.rows).reshape(-1, 26)
    record = SimRecord(ipoc=m[:, 0].astype(np.int64), late=m[:, 1].astype(bool),
                       rkorr=m[:, 2:8], command=m[:, 8:14], encoder=m[:, 14:20],
                       true=m[:, 20:26])
    following = (np.linalg.norm(record.encoder[:, :3] - record.command[:, :3], axis=1)
                 if m.shape[0] else np.zeros(0))
    path_error = None
    if reference is not None and m.shape[0]:
        path_error = path_distance(record.true[:, :3], reference)
    return SimReport(status=status, cycles=m.shape[0], late=ctl.late,
                     longest_late_run=ctl.longest, record=record,
                     max_following_error_mm=float(following.max(initial=0.0)),
                     path_error_mm=path_error, limit_stop=ctl.limit_stop,
                     not_rsi=ctl.refused.not_rsi, stale=ctl.refused.stale)


SIM_LOG_COLUMNS = ("ipoc", "late", *(f"rkorr_{a}" for a in "xyzabc"),
                   *(f"command_{a}" for a in "xyzabc"), *(f"encoder_{a}" for a in "xyzabc"),
                   *(f"true_{a}" for a in "xyzabc"))


def write_sim_log(path: str | Path, report: SimReport) -> None:
    """One row per simulated cycle (``SIM_LOG_COLUMNS``; poses in mm / deg)."""
    r = report.record
    m = np.column_stack([r.ipoc, r.late.astype(int), r.rkorr, r.command, r.encoder, r.true])
    np.savetxt(path, m, delimiter=",", header=",".join(SIM_LOG_COLUMNS), comments="",
               fmt=["%d", "%d"] + ["%.6f"] * 24)
