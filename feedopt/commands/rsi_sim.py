"""``feedopt rsi-sim``: a simulated KUKA RSI controller to run ``feedopt stream`` against."""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from feedopt.commands.robot import _floats
from feedopt.errors import InputError

#: Exit code when RSI timed out on late answers (the sensor stopped answering).
EXIT_TIMEOUT = 3


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "rsi-sim",
        help="simulated KUKA RSI controller: packets every cycle, corrections applied to a "
        "plant with a static offset and a lag",
        description=(
            "Send the controller's RSI packets (<Rob> XML with RIst, RSol, Delay and an IPOC "
            "advancing by the cycle in ms) to --connect every --cycle-ms, apply each answer's "
            "RKorr to a plant and report how it moved. The plant's encoder pose follows the "
            "command with a first-order lag (--lag-ms); its true TCP adds a static offset "
            "(--compliance-mm: process force times compliance, which RIst does not see; "
            "--tracker-to sends the true pose as a tracker would). An answer later than one "
            "cycle is dropped (the command is held); --timeout-cycles late answers in a row "
            "stop RSI; <Stop>1</Stop> ends the run. Exit 0: stopped by the sensor or at "
            "--max-s; 3: RSI timeout; 2: bad input."),
    )
    p.add_argument("--connect", default="127.0.0.1:49152", metavar="HOST:PORT",
                   help="where feedopt stream listens (default 127.0.0.1:49152)")
    p.add_argument("--reference", metavar="CSV",
                   help="the trajectory CSV being streamed: the robot starts at its first "
                   "pose, and the report gives the true TCP's distance from its path")
    p.add_argument("--start-pose", metavar="X,Y,Z,A,B,C",
                   help="start pose [mm, deg] without --reference (default all zero)")
    p.add_argument("--compliance-mm", default="0,0,0", metavar="DX,DY,DZ",
                   help="static offset of the true TCP from the commanded pose [mm] "
                   "(default 0,0,0)")
    p.add_argument("--lag-ms", type=float, default=0.0,
                   help="first-order lag time constant of the robot's motion (default 0)")
    p.add_argument("--cycle-ms", type=float, default=4.0, help="RSI cycle: 4 (default) or 12")
    p.add_argument("--mode", choices=("absolute", "relative"), default="absolute",
                   help="how RKorr is applied, as RSI_ON's mode (default absolute)")
    p.add_argument("--timeout-cycles", type=int, default=100, metavar="N",
                   help="late answers in a row that stop RSI (ETHERNET Timeout; default 100)")
    p.add_argument("--max-s", type=float, default=3600.0, help="stop after this long")
    p.add_argument("--tracker-to", metavar="HOST:PORT",
                   help="send the true TCP pose here every cycle as 'x,y,z,a,b,c'")
    p.add_argument("--sen-type", default="ImFree", help="expected Sen Type (default ImFree)")
    p.add_argument("--log", metavar="CSV", help="write one row per cycle here")
    p.add_argument("--realtime", action="store_true",
                   help="ask for real-time scheduling (SCHED_FIFO; Linux, needs CAP_SYS_NICE)")
    p.set_defaults(func=run)


def _check(value: float, option: str, low: float = 0.0, strict: bool = False) -> float:
    ok = math.isfinite(value) and (value > low if strict else value >= low)
    if not ok:
        raise InputError(f"{option} must be {'>' if strict else '>='} {low:g}, got {value!r}")
    return value


def run(args: argparse.Namespace) -> int:
    """Parse, simulate, print the report; exit code as in the description."""
    from feedopt.export.rsi import read_rsi_csv
    from feedopt.outfile import check_output_file, write_atomically
    from feedopt.rsi.corrections import CorrectionMode, plan_from_table
    from feedopt.rsi.protocol import check_sen_type, parse_address
    from feedopt.rsi.sim import PlantSettings, SimSettings, SimStatus, run_sim, write_sim_log
    from feedopt.scenario import RSI_CYCLES_MS

    if args.cycle_ms not in RSI_CYCLES_MS:
        raise InputError(f"--cycle-ms {args.cycle_ms:g}: RSI runs 4 or 12 ms cycles")
    cycle_s = args.cycle_ms * 1e-3
    _check(args.lag_ms, "--lag-ms")
    _check(args.max_s, "--max-s", strict=True)
    if args.timeout_cycles < 1:
        raise InputError(f"--timeout-cycles must be >= 1, got {args.timeout_cycles}")
    connect = parse_address(args.connect, "--connect")
    if connect[1] == 0:
        raise InputError(f"--connect {args.connect}: give the port feedopt stream listens on")
    tracker = None if args.tracker_to is None else parse_address(args.tracker_to,
                                                                 "--tracker-to")
    compliance = _floats(args.compliance_mm, 3, "--compliance-mm")
    if args.reference is not None and args.start_pose is not None:
        raise InputError("give --reference or --start-pose, not both (the reference's first "
                         "pose is the start)")
    reference = None
    start = np.zeros(6)
    if args.reference is not None:
        plan = plan_from_table(read_rsi_csv(args.reference), cycle_s, args.reference)
        start, reference = plan.start_pose, plan.poses()[:, :3]
    elif args.start_pose is not None:
        start = _floats(args.start_pose, 6, "--start-pose")
    log = None if args.log is None else check_output_file(
        args.log, "--log", example="sim.csv",
        inputs=[args.reference] if args.reference else [])
    settings = SimSettings(
        connect=connect, start_pose=tuple(start.tolist()), cycle_s=cycle_s,
        mode=CorrectionMode(args.mode),
        plant=PlantSettings(compliance_mm=tuple(compliance.tolist()), lag_s=args.lag_ms * 1e-3),
        timeout_cycles=args.timeout_cycles, max_s=args.max_s, tracker_to=tracker,
        sen_type=check_sen_type(args.sen_type))
    if args.realtime:
        from feedopt.rsi.streamer import request_realtime

        why = request_realtime()
        if why is not None:
            print(f"feedopt rsi-sim: warning: {why}", file=sys.stderr)
    print(f"feedopt rsi-sim: sending RSI packets to {connect[0]}:{connect[1]} every "
          f"{args.cycle_ms:g} ms", flush=True)
    report = run_sim(settings, reference)
    if log is not None:
        write_atomically(log, lambda p: write_sim_log(p, report), "--log")
    r = report
    end = r.record.true[-1, :3] - r.record.command[-1, :3] if r.cycles else np.zeros(3)
    print(f"rsi-sim {r.status.value}: {r.cycles} cycles, {r.late} late answers (longest run "
          f"{r.longest_late_run}); largest following error {r.max_following_error_mm:.6f} mm"
          + ("" if r.max_path_error_mm is None else
             f"; true TCP from the reference path: max {r.max_path_error_mm:.6f} mm, last "
             f"{float(r.path_error_mm[-1]):.6f} mm")
          + f"; true - commanded at the end: {end[0]:.4f} {end[1]:.4f} {end[2]:.4f} mm")
    if r.status is SimStatus.TIMEOUT:
        return EXIT_TIMEOUT
    if r.status is SimStatus.INTERRUPTED:
        return 130
    return 0
