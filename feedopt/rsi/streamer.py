"""Reference RSI streamer: a UDP server answering every controller packet with RKorr.

``feedopt stream CSV --listen HOST:PORT`` binds a UDP socket (the address the controller's
Ethernet configuration names in ``IP_NUMBER`` / ``PORT``) and, for every ``<Rob>`` packet:
answers at once with the correction of that cycle and the echoed IPOC
(:mod:`feedopt.rsi.protocol`), counts what was late or missing, and writes one log row.

Phases (:class:`Phase`):

- ``handshake``: the first few packets are answered with a zero correction while the stream
  checks that the controller's IPOC advances by the stream's cycle (a controller running
  12 ms against a 4 ms trajectory is refused) and that the robot (RIst) is at the
  trajectory's start pose.
- ``run``: row k of the :class:`~feedopt.rsi.corrections.CorrectionPlan` answers the packet
  whose IPOC is k cycles after the first running one (a missing packet skips its row: the
  trajectory keeps its timing). With a PID (:mod:`feedopt.rsi.pid`, thesis Eq. 3.27) the
  error between the pose the previous answer asked for and the measured pose (RIst, or a
  tracker's datagrams) adds its output.
- ``ramp``: on the late-packet limit, Ctrl-C / SIGTERM or a controller packet gap the stream
  does not freeze the correction: it keeps following the planned path while its speed falls
  to zero along a smoothstep (1 - 3u^2 + 2u^3) whose length keeps the deceleration and jerk
  within ``stop_accel_mm_s2`` / ``stop_jerk_mm_s3``.
- ``hold``: the last correction is held and ``<Stop>1</Stop>`` asks the context's STOP
  object to end ``RSI_MOVECORR()``; the stream ends when the controller goes quiet.

Every answer passes one gate: its step from the correction the controller holds is at most
``max_step_mm`` (translation norm) and ``max_step_deg`` (each angle), whatever the PID or a
catch-up after late packets asks for (:func:`~feedopt.rsi.corrections.limit_step`). What the
controller holds is the last answer it accepted: the controller's ``<Delay D>`` (its running
count of late answers, as ROS-Industrial's kuka_rsi_simulator keeps it) rising by more than
the packets the stream left unanswered means the last answer was discarded, and the
controller still holds the one before. Relative-mode increments are taken from the held
correction too, so a discarded increment is made up for, not lost. Without ``Delay`` in the
packets the last answer is assumed accepted.

Late and missing: a packet is *late* when a newer one was already waiting when it was read
(the stream fell behind: it is skipped, its row never sent) or when its answer left more than
one cycle after it arrived; *missing* when its IPOC never arrived (a gap in the IPOC sequence).
The controller's own count (``<Delay D>``, DEF_Delay) is followed too; the limit trips on
either count reaching ``late_limit``.
"""

from __future__ import annotations

import enum
import gc
import math
import os
import select
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from feedopt.errors import InputError, Terminated
from feedopt.rsi.corrections import (
    CorrectionMode,
    CorrectionPlan,
    limit_step,
    step_sizes,
    wrap_deg,
)
from feedopt.rsi.pid import PidCoefficients, PidGains, PidState, pid_coefficients, pid_step
from feedopt.rsi.protocol import (
    DEFAULT_SEN_TYPE,
    MAX_PACKET_BYTES,
    ControllerPacket,
    PacketError,
    build_sensor_answer,
    parse_controller_packet,
)


class Phase(enum.Enum):
    HANDSHAKE = "handshake"
    RUN = "run"
    RAMP = "ramp"
    HOLD = "hold"


class StreamStatus(enum.Enum):
    """How a stream ended."""

    COMPLETED = "completed"  # the whole trajectory was sent, then held
    LATE_LIMIT = "late-packet limit"  # stopped safely (ramp to hold)
    INTERRUPTED = "interrupted"  # Ctrl-C / SIGTERM / SIGHUP: stopped safely
    CONTROLLER_SILENT = "controller silent"  # packets stopped before the end


class Measurement(enum.Enum):
    """Where the PID's measured pose comes from."""

    RIST = "rist"  # the controller's RIst (encoder-based: blind to deflection)
    TRACKER = "tracker"  # datagrams "x,y,z,a,b,c" [mm, deg] from a tracker bridge


@dataclass(frozen=True)
class StreamSettings:
    """Options of a stream (see ``feedopt stream --help`` for each)."""

    listen: tuple[str, int] = ("127.0.0.1", 49152)
    mode: CorrectionMode = CorrectionMode.ABSOLUTE
    late_limit: int = 20
    max_step_mm: float = 0.1
    max_step_deg: float = 0.1
    wait_s: float = 30.0
    silence_s: float = 0.5
    hold_s: float = 1.0
    sen_type: str = DEFAULT_SEN_TYPE
    pid: PidGains | None = None
    measurement: Measurement = Measurement.RIST
    tracker_listen: tuple[str, int] | None = None
    pid_limit_mm: float = 2.0
    pid_limit_deg: float = 1.0
    start_tolerance_mm: float = 0.5
    start_tolerance_deg: float = 0.5
    handshake_cycles: int = 5
    stop_accel_mm_s2: float = 500.0
    stop_jerk_mm_s3: float = 5000.0
    late_after_s: float | None = None  # an answer later than this is late (None: one cycle)


@dataclass(frozen=True)
class CycleAnswer:
    """What one packet is answered with: ``sent`` is the RKorr (6,), ``total`` the correction
    from the pose at RSI_ON after the gate, ``row`` the trajectory position (rows, may be
    fractional while ramping), ``pid`` its output (or None), ``stop`` the Stop element."""

    phase: Phase
    row: float
    total: np.ndarray
    sent: np.ndarray
    stop: bool
    pid: np.ndarray | None = None
    measured: np.ndarray | None = None
    held: np.ndarray | None = None  # the correction the controller held (the gate's origin)


def _smoothstep_distance(u: float) -> float:
    """Integral of 1 - 3u^2 + 2u^3 from 0 to u (the ramp's distance per unit of its length)."""
    u = min(max(u, 0.0), 1.0)
    return u - u ** 3 + 0.5 * u ** 4


class CorrectionStream:
    """The per-cycle logic of the streamer, without sockets: packet in, answer out.

    :meth:`answer` is called once per answered packet with the pose the PID measures (RIst or
    the tracker's latest; None: none this cycle) and the number of packets left unanswered
    since the previous answer; :meth:`request_stop` starts the ramp to hold.
    """

    def __init__(self, plan: CorrectionPlan, settings: StreamSettings) -> None:
        self.plan = plan
        self.settings = settings
        self.cycle_ms = plan.cycle_s * 1e3
        self.phase = Phase.HANDSHAKE
        self.stop_status: StreamStatus | None = None
        self._handshake_ipocs: list[int] = []
        self._start_ipoc: int | None = None
        self._ramp: tuple[int, float, float] | None = None  # (ipoc, row, length in ms)
        self._total = np.zeros(6)  # the last answer sent
        self._held = np.zeros(6)  # the correction the controller holds
        self._last_delay: int | None = None
        self._desired_prev: np.ndarray | None = None
        self._row = 0.0
        trans, _ = step_sizes(plan.absolute)
        self._speed_mm_s = trans / plan.cycle_s  # (n - 1,) per row
        self._pid: PidCoefficients | None = (
            None if settings.pid is None else pid_coefficients(settings.pid, plan.cycle_s))
        self._pid_state = PidState.zero()
        self._pid_limit = np.array([settings.pid_limit_mm] * 3 + [settings.pid_limit_deg] * 3)

    # -- state ---------------------------------------------------------------------------
    @property
    def last_row(self) -> int:
        return len(self.plan) - 1

    @property
    def rows_reached(self) -> int:
        """Rows of the plan reached so far (0 before the run)."""
        return 0 if self._start_ipoc is None else int(self._row) + 1

    @property
    def stopping(self) -> bool:
        return self.phase in (Phase.RAMP, Phase.HOLD)

    def request_stop(self, status: StreamStatus, ipoc: int | None = None) -> None:
        """Begin the ramp to hold (no effect once stopping; before the run: hold at once)."""
        if self.stopping:
            return
        self.stop_status = status
        if self.phase is Phase.HANDSHAKE or ipoc is None or self._start_ipoc is None:
            self.phase = Phase.HOLD
            return
        k = min(int(self._row), self.last_row - 1) if self.last_row > 0 else 0
        v = float(self._speed_mm_s[k]) if self.last_row > 0 else 0.0
        s = self.settings
        length_s = max(4 * self.plan.cycle_s, 1.5 * v / s.stop_accel_mm_s2,
                       math.sqrt(6.0 * v / s.stop_jerk_mm_s3))
        self._ramp = (ipoc, self._row, length_s * 1e3)
        self.phase = Phase.RAMP

    # -- handshake -----------------------------------------------------------------------
    def _check_handshake(self, packet: ControllerPacket, measured: np.ndarray | None) -> None:
        ipocs = self._handshake_ipocs
        steps = np.diff(ipocs)
        if steps.size and int(steps.min()) != round(self.cycle_ms):
            step = int(steps.min())
            raise InputError(
                f"the controller's IPOC advances by {step} per packet, so it runs a {step} ms "
                f"RSI cycle, but the stream's cycle is {self.cycle_ms:g} ms (the trajectory's "
                f"rows, --cycle-ms): plan for {step} ms (export.rsi_cycle_ms) or start RSI "
                "with the cycle of the trajectory (RSI_ON(..., #IPO_FAST) = 4 ms, #IPO = 12 ms)")
        s = self.settings
        if packet.rist is not None:
            d = packet.rist - self.plan.start_pose
            dist = float(np.linalg.norm(d[:3]))
            ang = float(np.max(np.abs(wrap_deg(d[3:]))))
            if dist > s.start_tolerance_mm or ang > s.start_tolerance_deg:
                pose = ", ".join(f"{v:.3f}" for v in packet.rist)
                start = ", ".join(f"{v:.3f}" for v in self.plan.start_pose)
                raise InputError(
                    f"the robot is at X,Y,Z,A,B,C = {pose} (RIst) but {self.plan.source} starts "
                    f"at {start}: {dist:.3f} mm / {ang:.3f} deg away (tolerance "
                    f"{s.start_tolerance_mm:g} mm / {s.start_tolerance_deg:g} deg): move it to "
                    "the start pose before RSI_ON (the exported host program's LIN does)")
        if self._pid is not None and measured is None:
            where = ("RIst in the controller's packets (DEF_RIst in the Ethernet configuration)"
                     if s.measurement is Measurement.RIST else
                     "a tracker datagram on --tracker-listen")
            raise InputError(f"--pid {s.measurement.value}: no measured pose during the first "
                             f"{len(ipocs)} cycles; it needs {where}")

    # -- one cycle -----------------------------------------------------------------------
    def _nominal(self, row: float) -> np.ndarray:
        row = min(max(row, 0.0), float(self.last_row))
        i = min(int(row), max(self.last_row - 1, 0))
        f = row - i
        a = self.plan.absolute
        return a[i] if self.last_row == 0 else a[i] + f * (a[i + 1] - a[i])

    def _update_row(self, ipoc: int) -> None:
        if self.phase is Phase.RUN:
            self._row = (ipoc - self._start_ipoc) / self.cycle_ms
            if self._row >= self.last_row:
                self._row = float(self.last_row)
                self.stop_status = StreamStatus.COMPLETED
                self.phase = Phase.HOLD
        elif self.phase is Phase.RAMP:
            ipoc0, row0, length_ms = self._ramp
            u = (ipoc - ipoc0) / length_ms
            self._row = min(row0 + length_ms / self.cycle_ms * _smoothstep_distance(u),
                            float(self.last_row))
            if u >= 1.0 or self._row >= self.last_row:
                self.phase = Phase.HOLD

    def _track_held(self, packet: ControllerPacket, unanswered: int) -> None:
        """Update what the controller holds from its late count (module docstring)."""
        if packet.delay is None:
            self._held = self._total
        elif self._last_delay is not None:
            discarded = packet.delay - self._last_delay - unanswered
            if discarded <= 0:
                self._held = self._total
        self._last_delay = packet.delay

    def answer(self, packet: ControllerPacket, measured: np.ndarray | None,
               unanswered: int = 0) -> CycleAnswer:
        """The answer to ``packet``; ``unanswered``: packets since the last answered one that
        the stream did not answer (skipped as stale, or never received). Raises InputError
        during the handshake when the controller runs another cycle, the robot is not at the
        start pose or the PID has no measurement."""
        s = self.settings
        self._track_held(packet, unanswered)
        if self.phase is Phase.HANDSHAKE:
            self._handshake_ipocs.append(packet.ipoc)
            if len(self._handshake_ipocs) >= s.handshake_cycles:
                self._check_handshake(packet, measured)
                self.phase = Phase.RUN
                self._start_ipoc = packet.ipoc + round(self.cycle_ms)
            zero = np.zeros(6)
            return CycleAnswer(Phase.HANDSHAKE, 0.0, zero, zero, False, measured=measured,
                               held=zero)
        self._update_row(packet.ipoc)
        if self._pid is not None and self.phase is Phase.RUN and measured is not None \
                and self._desired_prev is not None:
            e = self._desired_prev - measured
            e[3:] = wrap_deg(e[3:])
            self._pid_state = pid_step(self._pid, self._pid_state, e, self._pid_limit)
        nominal = self._nominal(self._row)
        pid_u = self._pid_state.u if self._pid is not None else None
        desired = nominal + pid_u if pid_u is not None else nominal.copy()
        held = self._held
        self._total = limit_step(held, desired, s.max_step_mm, s.max_step_deg)
        self._desired_prev = self.plan.start_pose + nominal
        sent = self._total if s.mode is CorrectionMode.ABSOLUTE else self._total - held
        stop = self.phase is Phase.HOLD and bool(np.allclose(self._total, desired, rtol=0,
                                                             atol=1e-9))
        return CycleAnswer(self.phase, self._row, self._total.copy(), np.array(sent), stop,
                           pid=None if pid_u is None else pid_u.copy(), measured=measured,
                           held=held.copy())


@dataclass(frozen=True)
class StreamReport:
    """The outcome of a stream (typed; the command turns it into text and an exit code)."""

    status: StreamStatus
    answered: int
    rows_sent: int
    rows_total: int
    late: int
    missing: int
    controller_late: int
    bad_packets: int
    max_response_ms: float
    max_step_mm: float
    max_step_deg: float
    stop_acknowledged: bool
    signal_name: str | None = None
    controller: tuple[str, int] | None = None
    max_pid_mm: float = 0.0
    notes: tuple[str, ...] = field(default=())


LOG_COLUMNS = ("ipoc", "t_s", "phase", "row", "late", "missing", "controller_late",
               "response_ms", *(f"sent_{a}" for a in "xyzabc"),
               *(f"total_{a}" for a in "xyzabc"), *(f"pid_{a}" for a in "xyzabc"),
               *(f"measured_{a}" for a in "xyzabc"))


def request_realtime(priority: int = 10) -> str | None:
    """Real-time scheduling (SCHED_FIFO) for the calling thread, as an RSI sensor PC needs
    (the thesis's ran TwinCAT, section 3.6.2): None when granted, else why not (Linux only;
    needs CAP_SYS_NICE or an rtprio limit). The stream loop blocks between packets, so it
    cannot starve the machine."""
    if not hasattr(os, "sched_setscheduler"):
        return "real-time scheduling is not available on this system"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        return f"real-time scheduling not permitted ({exc.strerror or exc})"
    return None


def _bind(address: tuple[str, int], option: str) -> socket.socket:
    host, port = address
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except socket.gaierror as exc:
        raise InputError(f"{option} {host}:{port}: cannot resolve {host!r} ({exc.strerror}); "
                         "give an IP address of this machine (e.g. 127.0.0.1)") from None
    family, _, _, _, sockaddr = infos[0]
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.bind(sockaddr)
    except OSError as exc:
        sock.close()
        import errno
        if exc.errno == errno.EADDRINUSE:
            raise InputError(f"{option} {host}:{port}: the port is in use (another feedopt "
                             "stream or RSI server?): stop it or choose another port") from None
        if exc.errno == errno.EADDRNOTAVAIL:
            raise InputError(f"{option} {host}:{port}: {host} is not an address of this "
                             "machine; give one of its IP addresses (the IP_NUMBER of the "
                             "controller's Ethernet configuration)") from None
        if exc.errno == errno.EACCES:
            raise InputError(f"{option} {host}:{port}: not allowed to bind that port (ports "
                             "below 1024 need privileges); RSI uses e.g. 49152") from None
        raise InputError(f"{option} {host}:{port}: cannot listen there "
                         f"({exc.strerror or exc})") from None
    return sock


def _readable(sock: socket.socket) -> bool:
    return bool(select.select([sock], [], [], 0.0)[0])


def parse_tracker_datagram(data: bytes) -> np.ndarray:
    """A tracker datagram ``x,y,z,a,b,c`` (ASCII, mm and deg, TCP in the robot base frame)."""
    try:
        values = np.array([float(v) for v in data.decode("ascii").strip().split(",")])
    except (UnicodeDecodeError, ValueError):
        raise PacketError("tracker datagram is not 'x,y,z,a,b,c' numbers") from None
    if values.shape != (6,) or not np.isfinite(values).all():
        raise PacketError(f"tracker datagram has {values.size} values, expected 6 finite ones")
    return values


class Streamer:
    """The UDP server. Binding happens here (a port in use is an InputError before anything
    else); :meth:`run` streams one plan; :meth:`close` releases the sockets."""

    def __init__(self, settings: StreamSettings) -> None:
        self.settings = settings
        self._sock = _bind(settings.listen, "--listen")
        self._tracker: socket.socket | None = None
        if settings.tracker_listen is not None:
            try:
                self._tracker = _bind(settings.tracker_listen, "--tracker-listen")
            except InputError:
                self._sock.close()
                raise

    @property
    def address(self) -> tuple[str, int]:
        """(host, port) actually bound (port 0 in the settings: the one the system chose)."""
        return self._sock.getsockname()[:2]

    @property
    def tracker_address(self) -> tuple[str, int] | None:
        return None if self._tracker is None else self._tracker.getsockname()[:2]

    def close(self) -> None:
        self._sock.close()
        if self._tracker is not None:
            self._tracker.close()

    def __enter__(self) -> Streamer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _latest_tracker(self, current: np.ndarray | None) -> tuple[np.ndarray | None, int]:
        bad = 0
        while self._tracker is not None and _readable(self._tracker):
            data = self._tracker.recv(MAX_PACKET_BYTES)
            try:
                current = parse_tracker_datagram(data)
            except PacketError:
                bad += 1
        return current, bad

    def run(self, plan: CorrectionPlan, log_path: str | Path | None = None,
            progress: Callable[[int, int], None] | None = None) -> StreamReport:
        """Stream ``plan`` to the first controller that sends; see the module docstring.

        Raises InputError when no packet arrives within ``wait_s``, the packets are not RSI,
        or the handshake fails (other cycle, robot not at the start, PID without a
        measurement); otherwise returns a :class:`StreamReport` whatever the ending.
        """
        log = None if log_path is None else open(log_path, "w", encoding="ascii")  # noqa: SIM115
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            if log is not None:
                log.write(",".join(LOG_COLUMNS) + "\n")
            return self._run(plan, log, progress)
        finally:
            if gc_was_enabled:
                gc.enable()
            if log is not None:
                log.close()

    def _first_packet(self) -> tuple[bytes, tuple, float]:
        s = self.settings
        self._sock.settimeout(s.wait_s)
        host, port = self.address
        try:
            data, addr = self._sock.recvfrom(MAX_PACKET_BYTES)
        except TimeoutError:
            raise InputError(
                f"no RSI packet from the controller within {s.wait_s:g} s on {host}:{port} "
                "(--wait-s): is the RSI program at RSI_ON / RSI_MOVECORR, and do IP_NUMBER / "
                "PORT of the controller's Ethernet configuration name this address?") from None
        return data, addr, time.perf_counter()

    def _run(self, plan, log, progress) -> StreamReport:  # noqa: C901 - one protocol loop
        s = self.settings
        logic = CorrectionStream(plan, s)
        cycle_s = plan.cycle_s
        late_after = cycle_s if s.late_after_s is None else s.late_after_s
        cycle_ms = round(plan.cycle_s * 1e3)
        data, controller, t_recv = self._first_packet()
        t0 = t_recv
        self._sock.settimeout(s.silence_s)
        late = missing = bad = answered = 0
        controller_late = 0
        delay0: int | None = None
        last_ipoc: int | None = None
        max_response = 0.0
        max_step = np.zeros(2)
        skipped = 0  # packets received since the last answer but not answered (stale, bad)
        behind = 0  # consecutive packets older than the last answered one
        max_pid = 0.0
        measured_tracker: np.ndarray | None = None
        signal_name: str | None = None
        stop_sent_at: float | None = None
        stop_acknowledged = False
        notes: list[str] = []
        host, port = self.address
        while True:
            try:
                if data is None:
                    try:
                        data, addr = self._sock.recvfrom(MAX_PACKET_BYTES)
                    except TimeoutError:
                        if stop_sent_at is not None:  # the controller ended RSI_MOVECORR
                            stop_acknowledged = True
                            break
                        notes.append(f"the controller sent nothing for {s.silence_s:g} s "
                                     f"after IPOC {last_ipoc}")
                        if logic.stop_status is None:
                            logic.stop_status = StreamStatus.CONTROLLER_SILENT
                        break
                    t_recv = time.perf_counter()
                    if addr != controller:
                        data = None
                        continue
                # read what else is queued: only the newest packet is worth answering
                while _readable(self._sock):
                    newer, addr2 = self._sock.recvfrom(MAX_PACKET_BYTES)
                    if addr2 != controller:
                        continue
                    late += 1
                    skipped += 1
                    data, t_recv = newer, time.perf_counter()
                try:
                    packet = parse_controller_packet(data)
                except PacketError as exc:
                    bad += 1
                    skipped += 1
                    data = None
                    if answered == 0 and bad >= max(s.late_limit, 1):
                        raise InputError(
                            f"{bad} datagrams on {host}:{port} are not KUKA RSI packets "
                            f"(<Rob> with <IPOC>): {exc}") from None
                    continue
                data = None
                if last_ipoc is not None and packet.ipoc <= last_ipoc:
                    # out of order or repeated: its answer would be discarded anyway
                    bad += 1
                    behind += 1
                    if behind >= max(s.late_limit, 1):
                        raise InputError(
                            f"the controller's IPOC went back ({packet.ipoc} after {last_ipoc}) "
                            f"for {behind} packets: a restarted RSI context? start the stream "
                            "again")
                    continue
                behind = 0
                unanswered = 0  # packets since the last answered one, not answered
                if last_ipoc is not None:
                    unanswered = max(int((packet.ipoc - last_ipoc) // cycle_ms) - 1, 0)
                    if logic.phase is not Phase.HANDSHAKE:
                        missing += max(unanswered - skipped, 0)
                last_ipoc = packet.ipoc
                if packet.delay is not None:
                    delay0 = packet.delay if delay0 is None else delay0
                    controller_late = packet.delay - delay0
                if s.measurement is Measurement.TRACKER:
                    measured_tracker, bad_tracker = self._latest_tracker(measured_tracker)
                    bad += bad_tracker
                    measured = measured_tracker
                else:
                    measured = packet.rist
                try:
                    ans = logic.answer(packet, measured, unanswered)
                    skipped = 0
                except InputError:
                    # nothing has moved yet: hold and ask the controller to stop, then refuse
                    self._sock.sendto(build_sensor_answer(packet.ipoc, np.zeros(6), True,
                                                          s.sen_type), controller)
                    raise
                self._sock.sendto(build_sensor_answer(packet.ipoc, ans.sent, ans.stop,
                                                      s.sen_type), controller)
                t_send = time.perf_counter()
                answered += 1
                response = t_send - t_recv
                max_response = max(max_response, response)
                if response > late_after and ans.phase is not Phase.HANDSHAKE:
                    late += 1
                if ans.stop and stop_sent_at is None:
                    stop_sent_at = t_send
                    # the controller ends RSI_MOVECORR on Stop: a short quiet is the end
                    self._sock.settimeout(min(s.silence_s, 25 * cycle_s))
                step = ans.total - ans.held
                max_step = np.maximum(max_step, [np.linalg.norm(step[:3]),
                                                 np.max(np.abs(step[3:]))])
                if ans.pid is not None:
                    max_pid = max(max_pid, float(np.linalg.norm(ans.pid[:3])))
                if log is not None:
                    _log_row(log, packet.ipoc, t_recv - t0, ans, late, missing, controller_late,
                             response)
                if progress is not None and ans.phase is Phase.RUN:
                    progress(int(ans.row), logic.last_row)
                if not logic.stopping and logic.phase is Phase.RUN and (
                        late + missing >= s.late_limit or controller_late >= s.late_limit):
                    logic.request_stop(StreamStatus.LATE_LIMIT, packet.ipoc)
                if stop_sent_at is not None and t_send - stop_sent_at > s.hold_s:
                    notes.append(f"the controller kept sending {s.hold_s:g} s after <Stop>1: "
                                 "is the Stop element of the Ethernet configuration wired to a "
                                 "STOP object in the RSI context?")
                    break
            except (KeyboardInterrupt, Terminated) as exc:
                data = None
                if signal_name is None:
                    signal_name = (exc.signal_name if isinstance(exc, Terminated) else "SIGINT")
                    if logic.phase is Phase.HANDSHAKE and answered == 0:
                        raise
                    logic.request_stop(StreamStatus.INTERRUPTED, last_ipoc)
        status = logic.stop_status or StreamStatus.CONTROLLER_SILENT
        if signal_name is not None and status is not StreamStatus.COMPLETED:
            status = StreamStatus.INTERRUPTED
        return StreamReport(
            status=status, answered=answered, rows_sent=logic.rows_reached,
            rows_total=len(plan), late=late, missing=missing, controller_late=controller_late,
            bad_packets=bad, max_response_ms=max_response * 1e3, max_step_mm=float(max_step[0]),
            max_step_deg=float(max_step[1]), stop_acknowledged=stop_acknowledged,
            signal_name=signal_name, controller=controller[:2], max_pid_mm=max_pid,
            notes=tuple(notes))


def _fmt(values: np.ndarray | None) -> str:
    if values is None:
        return ",".join(["nan"] * 6)
    return ",".join(f"{v:.6f}" for v in values.tolist())


def _log_row(log, ipoc: int, t: float, ans: CycleAnswer, late: int, missing: int,
             controller_late: int, response: float) -> None:
    log.write(f"{ipoc},{t:.6f},{ans.phase.value},{ans.row:.4f},{late},{missing},"
              f"{controller_late},{response * 1e3:.4f},{_fmt(ans.sent)},{_fmt(ans.total)},"
              f"{_fmt(ans.pid)},{_fmt(ans.measured)}\n")
