"""``feedopt stream``: serve a feedopt RSI trajectory to a KUKA controller over RSI Ethernet."""

from __future__ import annotations

import argparse
import math
import sys

from feedopt.errors import InputError

#: Exit code of a stream that stopped safely before the end of the trajectory.
EXIT_STOPPED_EARLY = 3


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "stream",
        epilog="docs: docs/controllers.md",
        help="stream a trajectory CSV to a KUKA controller as RSI corrections (UDP server)",
        description=(
            "Listen for the controller's RSI Ethernet packets (<Rob> XML, one per 4 ms cycle) "
            "and answer each at once with the RKorr correction of that cycle and the echoed "
            "IPOC: the trajectory's pose minus the pose at RSI_ON (absolute mode) or this "
            "cycle's increment (relative). The first cycles check that the controller runs the "
            "trajectory's cycle and that the robot (RIst) is at its start pose. Late and "
            "missing packets are counted; after a gap (the controller held its correction) the "
            "motion resumes from where the robot stands, along the path; on --late-limit, "
            "Ctrl-C, a restarted controller (its IPOC goes back) or the end of the trajectory "
            "the motion slows to a stop along the path (or, after a gap, is held where it "
            "stands), then <Stop>1</Stop> ends RSI_MOVECORR(). No answer moves the correction "
            "by more than --max-step-mm / "
            "--max-step-deg from the one the controller holds. With --pid the thesis's PID "
            "(Eq. 3.27, Kp 0.05, Ki 0.3 Cartesian, Ki 0.02 angular) adds the error between the "
            "pose asked for and the measured one (RIst, or a tracker with --tracker-listen). "
            "Exit 0: the trajectory was completed; 3: stopped safely before its end; 2: bad "
            "input; 130/143: stopped by a signal (after the ramp)."),
    )
    p.add_argument("csv", metavar="CSV", help="trajectory CSV written by feedopt run (<law>.csv)")
    p.add_argument("--listen", default="127.0.0.1:49152", metavar="HOST:PORT",
                   help="UDP address to answer on: IP_NUMBER / PORT of the controller's "
                   "Ethernet configuration (default 127.0.0.1:49152; port 0: any free port)")
    p.add_argument("--cycle-ms", type=float, default=4.0,
                   help="the controller's RSI cycle: 4 (IPO_FAST, default) or 12 (IPO); the "
                   "CSV's rows must be this far apart")
    p.add_argument("--mode", choices=("absolute", "relative"), default="absolute",
                   help="RSI_ON mode: total correction from the pose at RSI_ON (absolute, "
                   "default; HOLDON=1) or per-cycle increments (relative; HOLDON=0)")
    p.add_argument("--late-limit", type=int, default=20, metavar="N",
                   help="stop (ramp to hold) after N late or missing answers in a row "
                   "(default 20), counted by the controller's Delay when its packets carry "
                   "it (what it acts on), else by this PC's clock and the IPOC gaps")
    p.add_argument("--late-total", type=int, default=None, metavar="M",
                   help="also stop after M late or missing answers in all (default: no total "
                   "limit; KUKA's ETHERNET object stops RSI at its own Timeout, 100 in its "
                   "examples)")
    p.add_argument("--max-step-mm", type=float, default=0.1, metavar="MM",
                   help="largest change of the translation correction between two answers "
                   "(default 0.1 mm = 25 mm/s at 4 ms); a trajectory needing more is refused")
    p.add_argument("--max-step-deg", type=float, default=0.1, metavar="DEG",
                   help="largest change of each angle correction between two answers "
                   "(default 0.1 deg)")
    _add_controller_options(p)
    p.set_defaults(func=run)


def _add_controller_options(p) -> None:
    """The options that describe the controller's side (its address, configuration, IPOC,
    packets) and the closed loop."""
    p.add_argument("--controller", metavar="HOST[:PORT]",
                   help="the controller's address (its RSI network card); packets from any "
                   "other sender are counted and ignored (default: the sender of the first "
                   "valid RSI packet)")
    p.add_argument("--log", metavar="CSV", help="write one row per controller cycle here")
    p.add_argument("--pid", action="store_true",
                   help="close the loop with the thesis's PID (Eq. 3.26-3.27) on the measured "
                   "pose (RIst, or --tracker-listen)")
    p.add_argument("--tracker-listen", metavar="HOST:PORT",
                   help="with --pid: read the measured TCP pose from UDP datagrams "
                   "'x,y,z,a,b,c' (mm, deg, robot base frame) here instead of RIst")
    p.add_argument("--pid-limit-mm", type=float, default=2.0, metavar="MM",
                   help="largest PID correction per axis (default 2 mm)")
    p.add_argument("--pid-limit-deg", type=float, default=1.0, metavar="DEG",
                   help="largest PID correction per angle (default 1 deg)")
    p.add_argument("--wait-s", type=float, default=30.0, metavar="S",
                   help="how long to wait for the controller's first packet (default 30 s)")
    p.add_argument("--sen-type", default="ImFree",
                   help="Sen Type of the answers: the configuration's SENTYPE (default ImFree)")
    p.add_argument("--correction", choices=("cartesian", "axis"), default=None,
                   help="what the answers correct: the TCP pose (RKorr X..C, default) or the "
                   "axes (AK A1..A6 [deg] from the CSV's q columns, the controller's axis "
                   "values: ROS-Industrial's, kroshu's and FZI's RSI setups); default: "
                   "--config's, else cartesian")
    p.add_argument("--config", metavar="XML",
                   help="the controller's RSI Ethernet configuration: answer with the element "
                   "names, the Stop element and the SENTYPE it lists (e.g. AK.A1..A6, ImFree)")
    p.add_argument("--ipoc-step", type=int, default=None, metavar="N",
                   help="IPOC increase per packet the controller sends (default: 1 or the "
                   "cycle in ms are accepted; which one is reported)")
    p.add_argument("--no-start-check", action="store_true",
                   help="start even when the packets carry no RIst (no AIPos in axis mode), "
                   "so the robot's start pose cannot be checked: only if you made sure")
    p.add_argument("--realtime", action="store_true",
                   help="ask for real-time scheduling (SCHED_FIFO; Linux, needs CAP_SYS_NICE): "
                   "what keeps answers within the cycle on a loaded machine")


def _positive(value: float, option: str, example: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{option} must be a positive number, got {value!r} (e.g. "
                         f"{option} {example})")
    return value


def _settings(args: argparse.Namespace, cycle_s: float):
    from feedopt.rsi.corrections import CorrectionMode
    from feedopt.rsi.pid import PidGains
    from feedopt.rsi.protocol import check_sen_type, parse_address
    from feedopt.rsi.streamer import Measurement, StreamSettings

    if args.late_limit < 1:
        raise InputError(f"--late-limit must be >= 1, got {args.late_limit}")
    if args.late_total is not None and args.late_total < 1:
        raise InputError(f"--late-total must be >= 1, got {args.late_total}")
    for option, value, example in (("--max-step-mm", args.max_step_mm, "0.1"),
                                   ("--max-step-deg", args.max_step_deg, "0.1"),
                                   ("--pid-limit-mm", args.pid_limit_mm, "2"),
                                   ("--pid-limit-deg", args.pid_limit_deg, "1"),
                                   ("--wait-s", args.wait_s, "30")):
        _positive(value, option, example)
    if args.tracker_listen is not None and not args.pid:
        raise InputError("--tracker-listen feeds the PID: add --pid (or drop --tracker-listen)")
    tracker = (None if args.tracker_listen is None
               else parse_address(args.tracker_listen, "--tracker-listen"))
    return StreamSettings(
        controller=_controller(args.controller),
        listen=parse_address(args.listen, "--listen"), mode=CorrectionMode(args.mode),
        late_limit=args.late_limit, late_total=args.late_total, max_step_mm=args.max_step_mm,
        max_step_deg=args.max_step_deg, wait_s=args.wait_s,
        silence_s=max(0.25, 50 * cycle_s), sen_type=check_sen_type(args.sen_type),
        pid=PidGains.thesis() if args.pid else None,
        measurement=Measurement.TRACKER if tracker else Measurement.RIST,
        tracker_listen=tracker, pid_limit_mm=args.pid_limit_mm,
        pid_limit_deg=args.pid_limit_deg, answer_format=_answer_format(args),
        ipoc_step=_ipoc_step(args.ipoc_step), start_check=not args.no_start_check)


def _answer_format(args: argparse.Namespace):
    """The answers' document: --config's, else feedopt's own for --correction (None: the
    default, Cartesian); a --correction that contradicts --config is refused."""
    from feedopt.rsi.protocol import AnswerFormat, CorrectionSpace, read_ethernet_config

    space = None if args.correction is None else CorrectionSpace(args.correction)
    if args.config is None:
        return None if space is None else AnswerFormat.default(space, args.sen_type)
    fmt = read_ethernet_config(args.config)
    if space is not None and space is not fmt.space:
        raise InputError(f"--correction {space.value}, but {args.config} answers with "
                         f"{fmt.element} ({', '.join(fmt.names)}): {fmt.space.value} "
                         "corrections (leave --correction out to follow the configuration)")
    if args.sen_type != "ImFree" and args.sen_type != fmt.sen_type:
        raise InputError(f"--sen-type {args.sen_type}, but {args.config}'s SENTYPE is "
                         f"{fmt.sen_type} (leave --sen-type out to follow the configuration)")
    return fmt


def _ipoc_step(step: int | None) -> int | None:
    if step is not None and step < 1:
        raise InputError(f"--ipoc-step must be >= 1 (1: the controller counts packets; 4: "
                         f"milliseconds at 4 ms), got {step}")
    return step


def _controller(text: str | None) -> tuple[str, int | None] | None:
    """``--controller HOST[:PORT]`` as (IP, port or None)."""
    from feedopt.rsi.protocol import parse_address
    from feedopt.rsi.streamer import resolve_controller

    if text is None:
        return None
    text = text.strip()
    host, sep, port_text = text.rpartition(":")
    if sep and host and (host.endswith("]") or ":" not in host):
        host, port = parse_address(text, "--controller")
        if port == 0:
            raise InputError(f"--controller {text}: port 0 is no sender's port; give the "
                             "controller's port or leave it out (any port of that host)")
        return resolve_controller(host, port)
    if not text:
        raise InputError("--controller: give the controller's HOST or HOST:PORT")
    return resolve_controller(text.strip("[]"), None)


def run(args: argparse.Namespace) -> int:
    """Check everything, bind, stream; print the outcome; exit code (module docstring)."""
    from feedopt.export.rsi import read_rsi_csv
    from feedopt.outfile import check_output_file, write_atomically
    from feedopt.rsi.corrections import check_steps, plan_from_table
    from feedopt.rsi.protocol import CorrectionSpace
    from feedopt.rsi.streamer import Streamer, StreamStatus
    from feedopt.scenario import RSI_CYCLES_MS

    if args.cycle_ms not in RSI_CYCLES_MS:
        raise InputError(f"--cycle-ms {args.cycle_ms:g}: RSI runs 4 ms (IPO_FAST) or 12 ms "
                         "(IPO) cycles")
    cycle_s = args.cycle_ms * 1e-3
    settings = _settings(args, cycle_s)
    table = _read_trajectory(args.csv, read_rsi_csv)
    space = (settings.answer_format.space if settings.answer_format is not None
             else CorrectionSpace.CARTESIAN)
    plan = plan_from_table(table, cycle_s, args.csv, space)
    check_steps(plan, settings.max_step_mm, settings.max_step_deg)
    inputs = [args.csv] + ([args.config] if args.config else [])
    log = None if args.log is None else check_output_file(args.log, "--log", example="cycles.csv",
                                                          inputs=inputs)
    with Streamer(settings) as streamer:
        host, port = streamer.address
        if args.realtime:
            from feedopt.rsi.streamer import request_realtime

            why = request_realtime()
            if why is not None:
                print(f"feedopt stream: warning: {why}; answers may be late on a busy machine",
                      file=sys.stderr)
        print(f"feedopt stream: listening on {host}:{port} (UDP) for the controller; "
              f"{len(plan)} rows of {args.cycle_ms:g} ms ({plan.t_s[-1]:.3f} s), "
              f"{settings.mode.value} mode, {plan.space.value} corrections"
              + (", PID on" if settings.pid else ""), flush=True)
        if not settings.start_check:
            print("feedopt stream: warning: --no-start-check: if the packets carry no RIst "
                  "(AIPos), the robot's start pose is not checked: the first correction is "
                  "applied wherever the robot stands", file=sys.stderr, flush=True)
        if settings.mode.value == "relative":
            print("feedopt stream: relative mode: the Ethernet configuration's RKorr elements "
                  "need HOLDON=\"0\"", flush=True)
        report_box = []
        bar = _progress_bar(len(plan))

        def progress(row: int, _last_row: int) -> None:
            if row > bar.n:
                bar.update(row - bar.n)

        def stream(log_path=None):
            report_box.append(streamer.run(
                plan, log_path, progress=progress,
                announce=lambda text: print(f"feedopt stream: {text}", flush=True)))

        try:
            if log is None:
                stream()
            else:
                write_atomically(log, stream, "--log")
        finally:
            bar.close()
        report = report_box[0]
    _print_report(report, args)
    if report.status is StreamStatus.COMPLETED:
        return 0
    if report.status is StreamStatus.INTERRUPTED:
        import signal
        return 128 + int(getattr(signal, report.signal_name or "SIGINT", signal.SIGINT))
    return EXIT_STOPPED_EARLY


def _read_trajectory(path: str, read_rsi_csv):
    """The trajectory table; a corrections table (``<law>_rsi.csv``) gets its own message."""
    from feedopt.rsi.corrections import COLUMNS

    try:
        return read_rsi_csv(path)
    except InputError as exc:
        if "header" in str(exc) and repr(COLUMNS[1]) in str(exc):
            raise InputError(f"{path} is an RSI corrections table (<law>_rsi.csv, written for "
                             "your own sensor program); feedopt stream takes the trajectory "
                             "<law>.csv written beside it") from None
        raise


def _progress_bar(rows: int):
    """Rows sent so far on stderr (tqdm; off when stderr is not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=rows, unit="row", file=sys.stderr, disable=None, mininterval=0.5,
                desc="stream", leave=False)


def _print_report(report, args) -> None:
    from feedopt.rsi.streamer import StreamStatus

    r = report
    foreign = (f", from other senders {r.foreign} ({', '.join(r.foreign_senders)})"
               if r.foreign else "")
    print(f"stream {r.status.value}: {r.rows_sent}/{r.rows_total} rows, {r.answered} packets "
          f"answered from {r.controller[0]}:{r.controller[1]}; late {r.late}, missing "
          f"{r.missing}, late by the controller's count {r.controller_late}, not RSI "
          f"{r.bad_packets}{foreign}; slowest answer {r.max_response_ms:.3f} ms; largest step "
          f"{r.max_step_mm:.6f} mm / {r.max_step_deg:.6f} deg"
          + (f"; largest PID correction {r.max_pid_mm:.4f} mm" if args.pid else ""))
    for note in r.notes:
        print(f"note: {note}")
    if r.status is StreamStatus.COMPLETED:
        return
    why = {
        StreamStatus.LATE_LIMIT: (f"stopped at the late-packet limit ({args.late_limit} in a "
                                  "row" + (f", {args.late_total} in all" if args.late_total
                                           else "") + ")"),
        StreamStatus.CONTROLLER_GAP: (
            f"the controller's IPOC jumped {r.largest_gap} cycles (a pause or lost packets; "
            f"--late-limit {args.late_limit})"),
        StreamStatus.RESTARTED: (
            "the controller's IPOC went back"
            + ("" if r.restart is None else f" from {r.restart[0]} to {r.restart[1]}")
            + " (its RSI context or the controller restarted)"),
        StreamStatus.INTERRUPTED: f"interrupted ({r.signal_name})",
        StreamStatus.CONTROLLER_SILENT: (
            "the controller stopped sending before the end of the trajectory (RSI stopped "
            "on its side: see its message window)"),
    }[r.status]
    print(f"feedopt stream: {why}{_how_stopped(r)}"
          + (f"; log written to {args.log}" if args.log else ""), file=sys.stderr)


def _how_stopped(r) -> str:
    """How the motion came to rest, as the report says it did."""
    from feedopt.rsi.streamer import StopKind

    row = "" if r.stop_row is None else f" at row {int(r.stop_row) + 1} of {r.rows_total}"
    if r.stop_kind is StopKind.RAMP:
        return f"; the motion slowed to a stop along the path and was held{row}"
    if r.stop_kind is StopKind.HOLD:
        return (f"; the controller had held its correction meanwhile, so the robot stood still "
                f"on the path: it was held there{row}")
    return ""
