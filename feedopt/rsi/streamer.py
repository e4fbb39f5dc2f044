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
- ``run``: each answer takes the trajectory one row further from the row of the correction
  the controller holds. With a PID (:mod:`feedopt.rsi.pid`, thesis Eq. 3.27) the error
  between the pose the previous answer asked for and the measured pose (RIst, or a
  tracker's datagrams) adds its output.
- ``resume``: after a stall (an IPOC gap: packets that never arrived or that the stream
  skipped, or an answer the controller discarded) the controller held its correction, so
  the robot stood still on the path: the stream neither jumps ahead to keep the clock nor
  catches up (both would leave the path, or exceed the planned feed); it restarts from the
  held row along the path, its speed rising along a smoothstep (3u^2 - 2u^3) as long as a
  stop ramp. The trajectory is late by the stalled cycles.
- ``ramp``: on the late-packet limit, Ctrl-C / SIGTERM or a restarted controller (its IPOC
  goes back) the stream does not freeze the correction: it keeps following the planned path
  while its speed falls to zero along a smoothstep (1 - 3u^2 + 2u^3) whose length keeps the
  deceleration and jerk within ``stop_accel_mm_s2`` / ``stop_jerk_mm_s3``. A stall during
  the ramp (or the gap that trips the limit) means the robot already stands still: it is
  held where it stands.
- ``hold``: the last correction is held and ``<Stop>1</Stop>`` asks the context's STOP
  object to end ``RSI_MOVECORR()``; the stream ends when the controller goes quiet.

So every answer without a PID is a point of the planned path (``total`` in the log).

The controller is ``controller`` in the settings (``--controller HOST[:PORT]``), else the
sender of the first valid RSI packet; datagrams from other senders and invalid ones are
counted and ignored.

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
The limit trips on ``late_limit`` late or missing answers in a row (or ``late_total`` in
all), counted by the controller (its ``<Delay D>``, DEF_Delay, rising, plus the IPOC gaps)
when its packets carry Delay: that is what the controller acts on, and a loaded PC's answers
that still reach it within its cycle are not late to it. Without Delay, by this stream's
count. A Delay that rises at every handshake packet (whose answers are immediate) is a Type
or element mismatch, refused as such. The IPOC step per packet is the cycle in ms (KRC4) or
1 (RSI 2.x, the ROS-Industrial and FZI simulators), reported; axis corrections (``AK`` /
``AKorr``, :class:`feedopt.rsi.protocol.CorrectionSpace`) are answered like Cartesian ones,
with the start checked on AIPos and the step gate per axis.
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
    wrap_deg,
)
from feedopt.rsi.pid import PidCoefficients, PidGains, PidState, pid_coefficients, pid_step
from feedopt.rsi.protocol import (
    DEFAULT_SEN_TYPE,
    MAX_PACKET_BYTES,
    AnswerFormat,
    ControllerPacket,
    CorrectionSpace,
    PacketError,
    build_sensor_answer,
    parse_controller_packet,
)

#: Quiet before an IPOC that goes back after which the robot is taken to stand still [s].
RESTART_PAUSE_S = 0.1


class Phase(enum.Enum):
    HANDSHAKE = "handshake"
    RUN = "run"
    RESUME = "resume"
    RAMP = "ramp"
    HOLD = "hold"


class StreamStatus(enum.Enum):
    """How a stream ended."""

    COMPLETED = "completed"  # the whole trajectory was sent, then held
    LATE_LIMIT = "late-packet limit"  # stopped safely (ramp or hold)
    CONTROLLER_GAP = "controller gap"  # the IPOC jumped past the late-packet limit: held
    RESTARTED = "controller restarted"  # the IPOC went back: stopped safely
    INTERRUPTED = "interrupted"  # Ctrl-C / SIGTERM / SIGHUP: stopped safely
    CONTROLLER_SILENT = "controller silent"  # packets stopped before the end


class StopKind(enum.Enum):
    """How the motion came to rest."""

    END = "end"  # the last row of the trajectory
    RAMP = "ramp"  # slowed down along the path (smoothstep)
    HOLD = "hold"  # the controller had already held the correction still: kept there


class Measurement(enum.Enum):
    """Where the PID's measured pose comes from."""

    RIST = "rist"  # the controller's RIst (encoder-based: blind to deflection)
    TRACKER = "tracker"  # datagrams "x,y,z,a,b,c" [mm, deg] from a tracker bridge


@dataclass(frozen=True)
class StreamSettings:
    """Options of a stream (see ``feedopt stream --help`` for each). ``controller``: the
    controller's (IP, port or None for any port); None: the first valid RSI packet's sender."""

    listen: tuple[str, int] = ("127.0.0.1", 49152)
    mode: CorrectionMode = CorrectionMode.ABSOLUTE
    late_limit: int = 20  # late or missing answers in a row that stop the stream
    late_total: int | None = None  # and in all (None: no total limit)
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
    controller: tuple[str, int | None] | None = None
    answer_format: AnswerFormat | None = None  # None: feedopt's own for the plan's space
    ipoc_step: int | None = None  # IPOC per packet expected (None: 1 or the cycle in ms)
    start_check: bool = True  # refuse to start unless RIst (AIPos) shows the start pose

    def format_for(self, space: CorrectionSpace) -> AnswerFormat:
        """The answers' document for a plan correcting ``space``."""
        if self.answer_format is not None:
            return self.answer_format
        return AnswerFormat.default(space, self.sen_type)


@dataclass(frozen=True)
class CycleAnswer:
    """What one packet is answered with: ``sent`` is the RKorr (6,), ``total`` the correction
    from the pose at RSI_ON after the gate, ``row`` the trajectory position (rows, fractional
    while resuming or ramping), ``pid`` its output (or None), ``stop`` the Stop element."""

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


def _smoothstep_rise(u: float) -> float:
    """Integral of 3u^2 - 2u^3 from 0 to u (the resume's distance per unit of its length)."""
    u = min(max(u, 0.0), 1.0)
    return u ** 3 - 0.5 * u ** 4


@dataclass
class _Profile:
    """A speed profile along the path from ``row0``: ``rate0`` rows per cycle at its start,
    ``cycles`` long, ``n`` cycles done."""

    row0: float
    rate0: float
    cycles: float
    n: int = 0

    @property
    def u(self) -> float:
        return self.n / self.cycles


class CorrectionStream:
    """The per-cycle logic of the streamer, without sockets: packet in, answer out.

    :meth:`answer` is called once per answered packet with the pose the PID measures (RIst or
    the tracker's latest; None: none this cycle) and the number of packets left unanswered
    since the previous answer; :meth:`request_stop` starts the ramp to hold.

    The trajectory position only ever advances from the row the controller holds, by at most
    one row per answer: every answer is a point of the planned path (module docstring).
    """

    def __init__(self, plan: CorrectionPlan, settings: StreamSettings) -> None:
        self.plan = plan
        self.settings = settings
        self.cycle_ms = plan.cycle_s * 1e3
        self.phase = Phase.HANDSHAKE
        self.stop_status: StreamStatus | None = None
        self.stop_kind: StopKind | None = None
        self.stop_row: float | None = None
        self._handshake_ipocs: list[int] = []
        self._handshake_delays: list[int | None] = []
        self._started = False
        self._profile: _Profile | None = None  # of RESUME and RAMP
        self._total = np.zeros(6)  # the last answer sent
        self._held = np.zeros(6)  # the correction the controller holds
        self._row = 0.0  # the row of the last answer
        self._held_row = 0.0  # the row of the correction the controller holds
        self._last_delay: int | None = None
        self._desired_prev: np.ndarray | None = None
        self._speed_mm_s = plan.tcp_steps() / plan.cycle_s  # (n - 1,) per row
        self.format = settings.format_for(plan.space)
        if self.format.space is not plan.space:
            raise InputError(
                f"the Ethernet configuration answers with {self.format.element} "
                f"({', '.join(self.format.names)}): {self.format.space.value} corrections, "
                f"but the stream sends {plan.space.value} corrections (--correction "
                f"{self.format.space.value} for it)")
        if settings.pid is not None and plan.space is CorrectionSpace.AXIS:
            raise InputError("--pid corrects the measured TCP pose (RIst or a tracker): it "
                             "runs with Cartesian corrections only (drop --pid or use "
                             "--correction cartesian)")
        self.ipoc_step: int | None = None  # found in the handshake
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
        return int(self._row) + 1 if self._started else 0

    @property
    def stopping(self) -> bool:
        return self.phase in (Phase.RAMP, Phase.HOLD)

    def _speed_at(self, row: float) -> float:
        """Planned speed [mm/s] at ``row`` (0 for a one-row plan)."""
        if self.last_row == 0:
            return 0.0
        return float(self._speed_mm_s[min(int(row), self.last_row - 1)])

    def _rate(self) -> float:
        """Rows per cycle of the current motion (1 while running)."""
        p = self._profile
        if self.phase is Phase.RUN:
            return 1.0
        if self.phase is Phase.RESUME and p is not None:
            u = min(p.u, 1.0)
            return 3 * u ** 2 - 2 * u ** 3
        if self.phase is Phase.RAMP and p is not None:
            u = min(p.u, 1.0)
            return p.rate0 * (1 - 3 * u ** 2 + 2 * u ** 3)
        return 0.0

    def _profile_cycles(self, speed_mm_s: float) -> float:
        """Cycles of a speed change between 0 and ``speed_mm_s`` within the stop limits."""
        s = self.settings
        length_s = max(4 * self.plan.cycle_s, 1.5 * speed_mm_s / s.stop_accel_mm_s2,
                       math.sqrt(6.0 * speed_mm_s / s.stop_jerk_mm_s3))
        return length_s / self.plan.cycle_s

    def _hold(self, row: float, kind: StopKind) -> None:
        self.phase = Phase.HOLD
        self._row = row
        self.stop_kind = kind
        self.stop_row = row

    def request_stop(self, status: StreamStatus, ipoc: int | None = None) -> None:
        """Begin the ramp to hold from the current row and speed (no effect once stopping;
        before the run: hold at once). ``ipoc`` is accepted for callers of the older API."""
        del ipoc
        if self.stopping:
            return
        self.stop_status = status
        if not self._started:
            self._hold(self._row, StopKind.HOLD)
            return
        rate = self._rate()
        v = rate * self._speed_at(self._row)
        self._profile = _Profile(self._row, rate, self._profile_cycles(v))
        self.phase = Phase.RAMP

    def restart(self) -> None:
        """The controller's IPOC went back: forget its late count (a new context counts
        from 0) and, before the run, start the handshake again."""
        self._last_delay = None
        if self.phase is Phase.HANDSHAKE:
            self._handshake_ipocs.clear()
            self._handshake_delays.clear()

    # -- handshake -----------------------------------------------------------------------
    def _check_ipoc_step(self) -> None:
        """The IPOC step per packet: the controller's cycle in ms (KRC4, RSI 3.x) or 1 (RSI
        2.x on a KRC2, and the ROS-Industrial and FZI simulators), or ``ipoc_step`` as
        stated; another step is another cycle than the trajectory's: refused."""
        steps = np.diff(self._handshake_ipocs)
        if not steps.size:
            return
        step = int(steps.min())
        want = self.settings.ipoc_step
        allowed = (want,) if want is not None else (1, round(self.cycle_ms))
        if step not in allowed:
            if want is not None:
                raise InputError(f"the controller's IPOC advances by {step} per packet, not "
                                 f"by {want} (--ipoc-step): give --ipoc-step {step} if its "
                                 "cycle is the trajectory's, or leave it out (1 or the cycle "
                                 "in ms are accepted)")
            raise InputError(
                f"the controller's IPOC advances by {step} per packet, so it runs a {step} ms "
                f"RSI cycle, but the stream's cycle is {self.cycle_ms:g} ms (the trajectory's "
                f"rows, --cycle-ms): plan for {step} ms (export.rsi_cycle_ms) or start RSI "
                "with the cycle of the trajectory (RSI_ON(..., #IPO_FAST) = 4 ms, #IPO = 12 ms);"
                " a controller whose IPOC counts packets: --ipoc-step 1")
        self.ipoc_step = step

    def _check_answers_taken(self) -> None:
        """The controller's Delay rising at every packet of the handshake means it took
        none of the (immediate, zero) answers: the Type or the elements do not match its
        configuration, not lateness."""
        delays = self._handshake_delays
        if len(delays) < 3 or any(d is None for d in delays):
            return
        if np.all(np.diff(np.asarray(delays)) >= 1):
            fmt = self.format
            raise InputError(
                f"the controller counted every answer of the first {len(delays)} cycles as "
                f"late (its Delay rose from {delays[0]} to {delays[-1]}) although each was sent "
                f"at once: it probably rejects them. Its SENTYPE must be the answers' Type "
                f"({fmt.sen_type}: --sen-type) and its RECEIVE elements these ({fmt.element}."
                f"{'/'.join(fmt.names)}: --config its Ethernet XML)")

    def _check_start(self, packet: ControllerPacket) -> None:
        """The robot at the plan's start: RIst against its pose (Cartesian), AIPos against
        its axis values (axis mode); refused without them unless ``start_check`` is off."""
        s = self.settings
        axis = self.plan.space is CorrectionSpace.AXIS
        actual = packet.aipos if axis else packet.rist
        if actual is None:
            if not s.start_check:
                return
            what = "AIPos (DEF_AIPos)" if axis else "RIst (DEF_RIst)"
            raise InputError(
                f"the controller's packets carry no {what}, so the stream cannot check that "
                "the robot is at the trajectory's start: add it to the <SEND> elements of the "
                "Ethernet configuration, or start without the check (--no-start-check) if "
                "you have made sure yourself")
        if axis:
            d = actual - self.plan.start_q_deg
            worst = int(np.argmax(np.abs(d)))
            if abs(d[worst]) > s.start_tolerance_deg:
                axes = ", ".join(f"{v:.3f}" for v in actual.tolist())
                start = ", ".join(f"{v:.3f}" for v in self.plan.start_q_deg.tolist())
                raise InputError(
                    f"the robot's axes are at A1..A6 = {axes} (AIPos) but {self.plan.source} "
                    f"starts at {start}: A{worst + 1} is {d[worst]:.3f} deg away (tolerance "
                    f"{s.start_tolerance_deg:g} deg): move it to the start before RSI_ON (the "
                    "exported host program's moves do)")
            return
        self._check_start_pose(actual)

    def _check_start_pose(self, rist: np.ndarray) -> None:
        """RIst within the start tolerance of the plan's start pose."""
        s = self.settings
        d = rist - self.plan.start_pose
        dist = float(np.linalg.norm(d[:3]))
        ang = float(np.max(np.abs(wrap_deg(d[3:]))))
        if dist > s.start_tolerance_mm or ang > s.start_tolerance_deg:
            pose = ", ".join(f"{v:.3f}" for v in rist.tolist())
            start = ", ".join(f"{v:.3f}" for v in self.plan.start_pose.tolist())
            raise InputError(
                f"the robot is at X,Y,Z,A,B,C = {pose} (RIst) but {self.plan.source} starts "
                f"at {start}: {dist:.3f} mm / {ang:.3f} deg away (tolerance "
                f"{s.start_tolerance_mm:g} mm / {s.start_tolerance_deg:g} deg): move it to "
                "the start pose before RSI_ON (the exported host program's LIN does)")

    def _check_handshake(self, packet: ControllerPacket, measured: np.ndarray | None) -> None:
        """The IPOC step, the start pose and the PID's measurement, after the handshake's
        packets (InputError: nothing has moved yet)."""
        self._check_ipoc_step()
        self._check_answers_taken()
        self._check_start(packet)
        s = self.settings
        if self._pid is not None and measured is None:
            where = ("RIst in the controller's packets (DEF_RIst in the Ethernet configuration)"
                     if s.measurement is Measurement.RIST else
                     "a tracker datagram on --tracker-listen")
            raise InputError(f"--pid {s.measurement.value}: no measured pose during the first "
                             f"{len(self._handshake_ipocs)} cycles; it needs {where}")

    # -- one cycle -----------------------------------------------------------------------
    def _nominal(self, row: float) -> np.ndarray:
        row = min(max(row, 0.0), float(self.last_row))
        i = min(int(row), max(self.last_row - 1, 0))
        f = row - i
        a = self.plan.absolute
        return a[i] if self.last_row == 0 else a[i] + f * (a[i + 1] - a[i])

    def _advance(self, stalled: bool) -> None:
        """The next row: one more from the held row while running; after a stall (the
        controller held its correction for a cycle or more, so the robot stood still) a
        smooth restart from the held row, or, while stopping, a hold there."""
        if stalled and self.phase in (Phase.RUN, Phase.RESUME):
            row0 = self._held_row
            cycles = math.ceil(self._profile_cycles(self._speed_at(row0)) - 1e-9)
            self._profile = _Profile(row0, 0.0, float(cycles))  # whole cycles: ends at rate 1
            self.phase = Phase.RESUME
        elif stalled and self.phase is Phase.RAMP:
            self._hold(self._held_row, StopKind.HOLD)
            return
        p = self._profile
        if self.phase is Phase.RUN:
            self._row += 1.0
        elif self.phase is Phase.RESUME:
            p.n += 1
            self._row = p.row0 + p.cycles * _smoothstep_rise(p.u)
            if p.u >= 1.0:
                self.phase = Phase.RUN
        elif self.phase is Phase.RAMP:
            p.n += 1
            self._row = p.row0 + p.rate0 * p.cycles * _smoothstep_distance(p.u)
            if p.u >= 1.0:
                self._hold(min(self._row, float(self.last_row)), StopKind.RAMP)
        if self._row >= self.last_row and self.phase is not Phase.HOLD:
            ending = self.phase is not Phase.RAMP
            if ending:
                self.stop_status = StreamStatus.COMPLETED
            self._hold(float(self.last_row), StopKind.END if ending else StopKind.RAMP)

    def _track_held(self, packet: ControllerPacket, unanswered: int) -> bool:
        """Update what the controller holds from its late count (module docstring); True
        when it held its correction for a cycle or more since the last answer (a stall)."""
        accepted = True
        if packet.delay is not None and self._last_delay is not None:
            accepted = packet.delay - self._last_delay - unanswered <= 0
        if packet.delay is not None:
            self._last_delay = packet.delay
        if accepted:
            self._held, self._held_row = self._total, self._row
        return unanswered > 0 or not accepted

    def _handshake(self, packet: ControllerPacket, measured: np.ndarray | None) -> CycleAnswer:
        self._handshake_ipocs.append(packet.ipoc)
        self._handshake_delays.append(packet.delay)
        if len(self._handshake_ipocs) >= self.settings.handshake_cycles:
            self._check_handshake(packet, measured)
            self.phase = Phase.RUN
            self._started = True
            self._row = self._held_row = -1.0  # the next answer is row 0
        zero = np.zeros(6)
        return CycleAnswer(Phase.HANDSHAKE, 0.0, zero, zero, False, measured=measured,
                           held=zero)

    def answer(self, packet: ControllerPacket, measured: np.ndarray | None,
               unanswered: int = 0) -> CycleAnswer:
        """The answer to ``packet``; ``unanswered``: packets since the last answered one that
        the stream did not answer (skipped as stale, or never received). Raises InputError
        during the handshake when the controller runs another cycle, the robot is not at the
        start pose or the PID has no measurement."""
        s = self.settings
        stalled = self._track_held(packet, unanswered)
        if self.phase is Phase.HANDSHAKE:
            return self._handshake(packet, measured)
        if self._row < 0:  # the first running answer: nothing held yet
            self._row = self._held_row = -1.0
            stalled = False
        self._advance(stalled)
        if self._pid is not None and self.phase is Phase.RUN and measured is not None \
                and self._desired_prev is not None:
            e = self._desired_prev - measured
            e[3:] = wrap_deg(e[3:])
            self._pid_state = pid_step(self._pid, self._pid_state, e, self._pid_limit)
        nominal = self._nominal(self._row)
        pid_u = self._pid_state.u if self._pid is not None else None
        desired = nominal + pid_u if pid_u is not None else nominal.copy()
        held = self._held
        self._total = limit_step(held, desired, s.max_step_mm, s.max_step_deg,
                                 self.plan.space)
        self._desired_prev = self.plan.start_pose + nominal
        sent = self._total if s.mode is CorrectionMode.ABSOLUTE else self._total - held
        stop = self.phase is Phase.HOLD and bool(np.allclose(self._total, desired, rtol=0,
                                                             atol=1e-9))
        return CycleAnswer(self.phase, self._row, self._total.copy(), np.array(sent), stop,
                           pid=None if pid_u is None else pid_u.copy(), measured=measured,
                           held=held.copy())


@dataclass(frozen=True)
class StreamReport:
    """The outcome of a stream (typed; the command turns it into text and an exit code).
    ``foreign``: datagrams from other senders (up to 3 of them in ``foreign_senders``);
    ``stop_kind`` / ``stop_row``: how and where the motion came to rest; ``largest_gap``:
    the most controller cycles missing at once; ``restart``: (IPOC before, IPOC after) when
    the controller's IPOC went back."""

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
    foreign: int = 0
    foreign_senders: tuple[str, ...] = field(default=())
    stop_kind: StopKind | None = None
    stop_row: float | None = None
    largest_gap: int = 0
    restart: tuple[int, int] | None = None


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


def _address_text(addr: tuple) -> str:
    host, port = addr[0], addr[1]
    return f"[{host}]:{port}" if ":" in str(host) else f"{host}:{port}"


def resolve_controller(host: str, port: int | None) -> tuple[str, int | None]:
    """``--controller HOST[:PORT]`` as (IP, port or None); InputError when HOST does not
    resolve."""
    try:
        infos = socket.getaddrinfo(host, port or 0, type=socket.SOCK_DGRAM)
    except socket.gaierror as exc:
        raise InputError(f"--controller {host}: cannot resolve {host!r} ({exc.strerror}); give "
                         "the controller's IP address (its KLI / RSI network card)") from None
    return str(infos[0][4][0]), port


@dataclass
class _Tally:
    """Counters of one stream."""

    late: int = 0
    missing: int = 0
    bad: int = 0
    foreign: int = 0
    answered: int = 0
    controller_late: int = 0
    largest_gap: int = 0
    run: int = 0  # late or missing answers in a row, by this stream's clock and IPOCs
    controller_run: int = 0  # rises of the controller's Delay in a row
    gap: int = 0  # packets of the last IPOC gap (missing: the controller held or paused)
    largest_run: int = 0
    max_response_s: float = 0.0
    max_pid_mm: float = 0.0
    max_step: np.ndarray = field(default_factory=lambda: np.zeros(2))
    foreign_senders: list[str] = field(default_factory=list)

    def count_foreign(self, addr: tuple) -> None:
        self.foreign += 1
        text = _address_text(addr)
        if len(self.foreign_senders) < 3 and text not in self.foreign_senders:
            self.foreign_senders.append(text)


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

    def latest_tracker(self, current: np.ndarray | None) -> tuple[np.ndarray | None, int]:
        """The newest tracker pose queued (or ``current``) and the bad datagrams read."""
        bad = 0
        while self._tracker is not None and _readable(self._tracker):
            data = self._tracker.recv(MAX_PACKET_BYTES)
            try:
                current = parse_tracker_datagram(data)
            except PacketError:
                bad += 1
        return current, bad

    def run(self, plan: CorrectionPlan, log_path: str | Path | None = None,
            progress: Callable[[int, int], None] | None = None,
            announce: Callable[[str], None] | None = None) -> StreamReport:
        """Stream ``plan`` to the controller (``settings.controller``, else the sender of the
        first valid RSI packet); see the module docstring. ``announce(text)`` once the
        handshake has passed: what the controller sends and what the stream answers.

        Raises InputError when no valid RSI packet arrives within ``wait_s``, or the
        handshake fails (other cycle, robot not at the start, PID without a measurement);
        otherwise returns a :class:`StreamReport` whatever the ending.
        """
        log = None if log_path is None else open(log_path, "w", encoding="ascii")  # noqa: SIM115
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            if log is not None:
                log.write(",".join(LOG_COLUMNS) + "\n")
            session = _Session(self, plan, log, progress)
            session.announce = announce
            return session.run()
        finally:
            if gc_was_enabled:
                gc.enable()
            if log is not None:
                log.close()


class _Session:
    """One stream: the receive loop, the IPOC bookkeeping, answers and the log."""

    def __init__(self, streamer: Streamer, plan: CorrectionPlan, log, progress) -> None:
        self.streamer = streamer
        self.sock = streamer._sock
        self.s = streamer.settings
        self.plan = plan
        self.log = log
        self.progress = progress
        self.logic = CorrectionStream(plan, self.s)
        self.cycle_ms = round(plan.cycle_s * 1e3)
        self.late_after = plan.cycle_s if self.s.late_after_s is None else self.s.late_after_s
        self.n = _Tally()
        self.controller: tuple | None = None
        self.t0 = 0.0
        self.last_ipoc: int | None = None
        self.t_last = 0.0  # when the last packet taken (answered or ignored) arrived
        self.delay0: int | None = None
        self.skipped = 0  # packets received since the last answer but not answered
        self.measured_tracker: np.ndarray | None = None
        self.stop_sent_at: float | None = None
        self.stop_acknowledged = False
        self.restart: tuple[int, int] | None = None
        self.notes: list[str] = []
        self.controller_counts = False  # its packets carry Delay: its count decides
        self.announce: Callable[[str], None] | None = None

    # -- receiving -----------------------------------------------------------------------
    def _from_controller(self, addr: tuple) -> bool:
        if self.controller is not None:
            return tuple(addr[:2]) == tuple(self.controller[:2])
        want = self.s.controller
        return want is None or (addr[0] == want[0] and want[1] in (None, addr[1]))

    def _first_packet(self) -> tuple[ControllerPacket, float]:
        """The first valid RSI packet from the controller (others counted and ignored)."""
        s = self.s
        deadline = time.monotonic() + s.wait_s
        last_error = ""
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise InputError(self._no_packet_message(last_error))
            self.sock.settimeout(remaining)
            try:
                data, addr = self.sock.recvfrom(MAX_PACKET_BYTES)
            except TimeoutError:
                continue
            t_recv = time.perf_counter()
            if not self._from_controller(addr):
                self.n.count_foreign(addr)
                continue
            try:
                packet = parse_controller_packet(data)
            except PacketError as exc:
                self.n.bad += 1
                last_error = f"{exc} (from {_address_text(addr)})"
                if s.controller is not None and self.n.bad >= max(s.late_limit, 1):
                    raise InputError(
                        f"{self.n.bad} datagrams from the controller {_address_text(addr)} are "
                        f"not KUKA RSI packets (<Rob> with <IPOC>): {exc}") from None
                continue
            self.controller = tuple(addr[:2])
            return packet, t_recv

    def _no_packet_message(self, last_error: str) -> str:
        s = self.s
        host, port = self.streamer.address
        who = ("" if s.controller is None else
               f" (--controller {s.controller[0]}"
               + ("" if s.controller[1] is None else f":{s.controller[1]}") + ")")
        extra = []
        if self.n.bad:
            extra.append(f"{self.n.bad} datagrams were not RSI packets (last: {last_error})")
        if self.n.foreign:
            extra.append(f"{self.n.foreign} came from other senders "
                         f"({', '.join(self.n.foreign_senders)})")
        return (f"no RSI packet from the controller{who} within {s.wait_s:g} s on "
                f"{host}:{port} (--wait-s)"
                + (f"; {'; '.join(extra)}" if extra else "")
                + ": is the RSI program at RSI_ON / RSI_MOVECORR, and do IP_NUMBER / PORT of "
                "the controller's Ethernet configuration name this address?")

    def _receive(self) -> tuple[bytes, float] | None:
        """The newest datagram queued from the controller (older ones are late and skipped;
        other senders' are counted), or None when the controller went quiet."""
        data = None
        while data is None:
            try:
                data, addr = self.sock.recvfrom(MAX_PACKET_BYTES)
            except TimeoutError:
                return None
            if not self._from_controller(addr):
                self.n.count_foreign(addr)
                data = None
        t_recv = time.perf_counter()
        while _readable(self.sock):
            newer, addr = self.sock.recvfrom(MAX_PACKET_BYTES)
            if not self._from_controller(addr):
                self.n.count_foreign(addr)
                continue
            self.n.late += 1
            self.skipped += 1
            data, t_recv = newer, time.perf_counter()
        return data, t_recv

    # -- IPOC bookkeeping ----------------------------------------------------------------
    def _unanswered(self, packet: ControllerPacket, t_recv: float) -> int | None:
        """Packets between the last answered one and ``packet`` that were not answered;
        None when ``packet`` is to be ignored (a repeated IPOC). An IPOC that goes back is a
        restarted controller: stop (ramp along the path, hold, Stop)."""
        if self.last_ipoc is not None and packet.ipoc == self.last_ipoc:
            self.n.bad += 1  # a repeat: its answer was already sent
            return None
        if self.last_ipoc is not None and packet.ipoc < self.last_ipoc:
            if self.restart is None:
                self.restart = (self.last_ipoc, packet.ipoc)
                self.notes.append(
                    f"the controller's IPOC went back from {self.last_ipoc} to {packet.ipoc} "
                    "(a restarted RSI context or controller)")
            self.logic.restart()
            self.delay0 = None
            if self.logic.phase is not Phase.HANDSHAKE:
                self.logic.request_stop(StreamStatus.RESTARTED)
            self.last_ipoc = packet.ipoc
            quiet_s = t_recv - self.t_last
            self.t_last = t_recv
            # a pause before the restart: the controller held its correction, so the robot
            # stands still (a stall: hold there); else slow down from the current speed
            return 1 if quiet_s > RESTART_PAUSE_S else 0
        unanswered = 0
        if self.last_ipoc is not None:
            step = self.logic.ipoc_step or self.cycle_ms  # known after the handshake
            unanswered = max(int((packet.ipoc - self.last_ipoc) // step) - 1, 0)
            if self.logic.phase is not Phase.HANDSHAKE:
                gap = max(unanswered - self.skipped, 0)
                self.n.missing += gap
                self.n.gap = gap
                self.n.largest_gap = max(self.n.largest_gap, gap)
        self.last_ipoc = packet.ipoc
        self.t_last = t_recv
        if packet.delay is not None:
            self.delay0 = packet.delay if self.delay0 is None else self.delay0
            late_now = packet.delay - self.delay0 - self.n.controller_late
            self.n.controller_late = max(self.n.controller_late, packet.delay - self.delay0)
            self.n.controller_run = self.n.controller_run + late_now if late_now > 0 else 0
            self.controller_counts = True
        if unanswered:
            self._late_run(unanswered)
        return unanswered

    def _handshake_text(self, packet: ControllerPacket) -> str:
        """What the handshake found, stated once when the motion starts."""
        fmt, logic = self.logic.format, self.logic
        axis = self.plan.space is CorrectionSpace.AXIS
        seen = "AIPos" if axis else "RIst"
        checked = (f"the robot at the start by {seen}" if (packet.aipos if axis else packet.rist)
                   is not None else f"no start check (no {seen}: --no-start-check)")
        step = logic.ipoc_step
        return (f"controller {self.controller[0]}:{self.controller[1]}: IPOC +{step} per "
                f"{self.cycle_ms} ms packet"
                + (" (it counts packets)" if step == 1 and self.cycle_ms != 1 else "")
                + f", {checked}, late answers counted by "
                + ("its Delay" if packet.delay is not None else "this PC's clock")
                + f"; answering {fmt.element} ({', '.join(fmt.names)}), Type {fmt.sen_type}")

    def _late_run(self, late: int) -> None:
        """``late`` more late or missing answers in a row (0: one on time ends the run)."""
        n = self.n
        n.run = n.run + late if late else 0
        n.largest_run = max(n.largest_run, n.run, n.controller_run)

    def _limit_reached(self) -> bool:
        """The late-packet limit: ``late_limit`` in a row or ``late_total`` in all, by the
        controller's own count (its Delay) when its packets carry one, else by this
        stream's (its clock and the IPOC gaps). The controller's count decides because it
        is what the controller acts on: a loaded PC's slow answers that still arrive within
        the controller's cycle are not late to it."""
        s, n = self.s, self.n
        if self.controller_counts:  # and the IPOC gaps: the controller paused or held
            run, total = max(n.controller_run, n.gap), n.controller_late + n.missing
        else:
            run, total = n.run, n.late + n.missing
        return run >= s.late_limit or (s.late_total is not None and total >= s.late_total)

    def _check_limit(self, unanswered: int) -> None:
        """Stop on the late-packet limit (a gap of missing packets: the controller held its
        correction meanwhile, so the stop is a hold where it stands)."""
        s, logic = self.s, self.logic
        if logic.phase not in (Phase.RUN, Phase.RESUME):
            return
        if self._limit_reached():
            gap = unanswered > self.skipped and unanswered - self.skipped >= s.late_limit
            logic.request_stop(StreamStatus.CONTROLLER_GAP if gap else StreamStatus.LATE_LIMIT)

    # -- one packet ----------------------------------------------------------------------
    def _handle(self, packet: ControllerPacket, t_recv: float) -> bool:
        """Answer one packet; False when the stream is to end."""
        s, n = self.s, self.n
        unanswered = self._unanswered(packet, t_recv)
        if unanswered is None:
            return True
        self._check_limit(unanswered)
        if s.measurement is Measurement.TRACKER:
            self.measured_tracker, bad_tracker = self.streamer.latest_tracker(
                self.measured_tracker)
            n.bad += bad_tracker
            measured = self.measured_tracker
        else:
            measured = packet.rist
        was_handshake = self.logic.phase is Phase.HANDSHAKE
        try:
            ans = self.logic.answer(packet, measured, unanswered)
        except InputError:
            # nothing has moved yet: hold and ask the controller to stop, then refuse
            self.sock.sendto(build_sensor_answer(packet.ipoc, np.zeros(6), True,
                                                 fmt=self.logic.format), self.controller)
            raise
        self.skipped = 0
        if was_handshake and self.logic.phase is not Phase.HANDSHAKE and self.announce:
            self.announce(self._handshake_text(packet))
        self.sock.sendto(build_sensor_answer(packet.ipoc, ans.sent, ans.stop,
                                             fmt=self.logic.format), self.controller)
        t_send = time.perf_counter()
        self._account(packet, ans, t_recv, t_send)
        if ans.stop and self.stop_sent_at is None:
            self.stop_sent_at = t_send
            # the controller ends RSI_MOVECORR on Stop: a short quiet is the end
            self.sock.settimeout(min(s.silence_s, 25 * self.plan.cycle_s))
        if self.stop_sent_at is not None and t_send - self.stop_sent_at > s.hold_s:
            self.notes.append(f"the controller kept sending {s.hold_s:g} s after <Stop>1: is "
                              "the Stop element of the Ethernet configuration wired to a STOP "
                              "object in the RSI context?")
            return False
        return True

    def _account(self, packet: ControllerPacket, ans: CycleAnswer, t_recv: float,
                 t_send: float) -> None:
        n = self.n
        n.answered += 1
        response = t_send - t_recv
        n.max_response_s = max(n.max_response_s, response)
        if ans.phase is not Phase.HANDSHAKE:
            late = response > self.late_after
            n.late += late
            self._late_run(int(late))  # an answer on time ends a run
        step = ans.total - ans.held
        if self.plan.space is CorrectionSpace.AXIS:  # every axis in deg
            n.max_step = np.maximum(n.max_step, [0.0, np.max(np.abs(step))])
        else:
            n.max_step = np.maximum(n.max_step, [np.linalg.norm(step[:3]),
                                                 np.max(np.abs(step[3:]))])
        if ans.pid is not None:
            n.max_pid_mm = max(n.max_pid_mm, float(np.linalg.norm(ans.pid[:3])))
        if self.log is not None:
            _log_row(self.log, packet.ipoc, t_recv - self.t0, ans, n.late, n.missing,
                     n.controller_late, response)
        if self.progress is not None and ans.phase is Phase.RUN:
            self.progress(int(ans.row), self.logic.last_row)
        if self.logic.phase in (Phase.RUN, Phase.RESUME) and self._limit_reached():
            self.logic.request_stop(StreamStatus.LATE_LIMIT)

    # -- the loop ------------------------------------------------------------------------
    def run(self) -> StreamReport:
        pending: tuple[ControllerPacket, float] | None = self._first_packet()
        self.t0 = pending[1]
        self.sock.settimeout(self.s.silence_s)
        signal_name: str | None = None
        while True:
            try:
                if pending is None:
                    received = self._receive()
                    if received is None:
                        self._silence()
                        break
                    try:
                        pending = (parse_controller_packet(received[0]), received[1])
                    except PacketError:
                        self.n.bad += 1
                        self.skipped += 1
                        continue
                packet, t_recv = pending
                pending = None
                if not self._handle(packet, t_recv):
                    break
            except (KeyboardInterrupt, Terminated) as exc:
                pending = None
                if signal_name is None:
                    signal_name = (exc.signal_name if isinstance(exc, Terminated) else "SIGINT")
                    if self.logic.phase is Phase.HANDSHAKE and self.n.answered == 0:
                        raise
                    self.logic.request_stop(StreamStatus.INTERRUPTED)
        return self._report(signal_name)

    def _silence(self) -> None:
        if self.stop_sent_at is not None:  # the controller ended RSI_MOVECORR
            self.stop_acknowledged = True
            return
        self.notes.append(f"the controller sent nothing for {self.s.silence_s:g} s after IPOC "
                          f"{self.last_ipoc}")
        if self.logic.stop_status is None:
            self.logic.stop_status = StreamStatus.CONTROLLER_SILENT

    def _report(self, signal_name: str | None) -> StreamReport:
        logic, n = self.logic, self.n
        if logic.ipoc_step is not None:
            self.notes.insert(0, f"the controller's IPOC advanced by {logic.ipoc_step} per "
                              f"{self.cycle_ms} ms packet"
                              + (" (it counts packets: RSI 2.x, or a simulator)"
                                 if logic.ipoc_step == 1 and self.cycle_ms != 1 else ""))
        status = logic.stop_status or StreamStatus.CONTROLLER_SILENT
        if signal_name is not None and status is not StreamStatus.COMPLETED:
            status = StreamStatus.INTERRUPTED
        return StreamReport(
            status=status, answered=n.answered, rows_sent=logic.rows_reached,
            rows_total=len(self.plan), late=n.late, missing=n.missing,
            controller_late=n.controller_late, bad_packets=n.bad,
            max_response_ms=n.max_response_s * 1e3, max_step_mm=float(n.max_step[0]),
            max_step_deg=float(n.max_step[1]), stop_acknowledged=self.stop_acknowledged,
            signal_name=signal_name, controller=self.controller, max_pid_mm=n.max_pid_mm,
            notes=tuple(self.notes), foreign=n.foreign,
            foreign_senders=tuple(n.foreign_senders), stop_kind=logic.stop_kind,
            stop_row=logic.stop_row, largest_gap=n.largest_gap, restart=self.restart)


def _fmt(values: np.ndarray | None) -> str:
    if values is None:
        return ",".join(["nan"] * 6)
    return ",".join(f"{v:.6f}" for v in values.tolist())


def _log_row(log, ipoc: int, t: float, ans: CycleAnswer, late: int, missing: int,
             controller_late: int, response: float) -> None:
    log.write(f"{ipoc},{t:.6f},{ans.phase.value},{ans.row:.4f},{late},{missing},"
              f"{controller_late},{response * 1e3:.4f},{_fmt(ans.sent)},{_fmt(ans.total)},"
              f"{_fmt(ans.pid)},{_fmt(ans.measured)}\n")
