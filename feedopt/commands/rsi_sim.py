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
        epilog="docs: docs/controllers.md",
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
            "stop RSI; <Stop>1</Stop> ends the run. Each correction is checked before it is "
            "applied against the RSI context's limits (PosCorr LowerLim/UpperLim and "
            "MaxRotAngle, PosCorrMon MaxTrans and MaxRotAngle, and the robot's speed per "
            "cycle): one beyond them, or not a number, stops RSI with an error as on a KRC, "
            "and the report names the cycle and the value. Exit 0: stopped by the sensor or at "
            "--max-s; 3: RSI stopped on a timeout or a correction limit; 2: bad input."),
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
    p.add_argument("--limit-mm", type=float, metavar="MM",
                   help="PosCorr LowerLim/UpperLim X, Y, Z: the total correction stays within "
                   "+-MM of the pose at RSI_ON (default: with --reference the limits the "
                   "exported host program sets for that trajectory, its range + 5 mm; else "
                   "5 mm, which public notes give as RSI Visual's default; not checked "
                   "against a KUKA manual)")
    p.add_argument("--limit-deg", type=float, metavar="DEG",
                   help="PosCorr MaxRotAngle (default: from --reference as the host program "
                   "sets it, else 5 deg)")
    p.add_argument("--max-trans-mm", type=float, metavar="MM",
                   help="PosCorrMon MaxTrans: largest total translation (default: from "
                   "--reference, else 6 mm)")
    p.add_argument("--max-rot-deg", type=float, metavar="DEG",
                   help="PosCorrMon MaxRotAngle (default: from --reference, else 6 deg)")
    p.add_argument("--max-speed-mm-s", type=float, default=2000.0, metavar="MM_S",
                   help="fastest change of the correction (default 2000 mm/s, the top of the "
                   "$VEL.CP range our KRL export uses)")
    p.add_argument("--max-speed-deg-s", type=float, default=400.0, metavar="DEG_S",
                   help="fastest turn of the correction (default 400 deg/s, our assumption)")
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
    reference = plan = None
    start = np.zeros(6)
    if args.reference is not None:
        plan = plan_from_table(read_rsi_csv(args.reference), cycle_s, args.reference)
        start, reference = plan.start_pose, plan.poses()[:, :3]
    elif args.start_pose is not None:
        start = _floats(args.start_pose, 6, "--start-pose")
    log = None if args.log is None else check_output_file(
        args.log, "--log", example="sim.csv",
        inputs=[args.reference] if args.reference else [])
    limits = _limits(args, plan)
    settings = SimSettings(
        limits=limits, connect=connect, start_pose=tuple(start.tolist()), cycle_s=cycle_s,
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
    _print_report(report)
    if report.status is SimStatus.INTERRUPTED:
        return 130
    return EXIT_TIMEOUT if report.status in (SimStatus.TIMEOUT, SimStatus.LIMIT) else 0


def _limits(args: argparse.Namespace, plan):
    """The correction limits: options, else those the exported host program sets for the
    reference's trajectory, else RSI's defaults (:class:`feedopt.rsi.sim.CorrectionLimits`)."""
    from feedopt.rsi.sim import CorrectionLimits

    base = CorrectionLimits()
    if plan is not None:
        from feedopt.export.rsi_program import (
            POSCORR_OBJECT,
            POSCORRMON_OBJECT,
            correction_limits,
        )

        lim = correction_limits(plan)
        base = CorrectionLimits(
            lower_mm=tuple(lim[(POSCORR_OBJECT, f"LowerLim{a}")] for a in "XYZ"),
            upper_mm=tuple(lim[(POSCORR_OBJECT, f"UpperLim{a}")] for a in "XYZ"),
            max_rot_deg=lim[(POSCORR_OBJECT, "MaxRotAngle")],
            max_trans_mm=lim[(POSCORRMON_OBJECT, "MaxTrans")],
            monitor_rot_deg=lim[(POSCORRMON_OBJECT, "MaxRotAngle")])
    for option, value in (("--limit-mm", args.limit_mm), ("--limit-deg", args.limit_deg),
                          ("--max-trans-mm", args.max_trans_mm),
                          ("--max-rot-deg", args.max_rot_deg),
                          ("--max-speed-mm-s", args.max_speed_mm_s),
                          ("--max-speed-deg-s", args.max_speed_deg_s)):
        if value is not None:
            _check(value, option, strict=True)
    mm = args.limit_mm
    return CorrectionLimits(
        lower_mm=base.lower_mm if mm is None else (-mm,) * 3,
        upper_mm=base.upper_mm if mm is None else (mm,) * 3,
        max_rot_deg=base.max_rot_deg if args.limit_deg is None else args.limit_deg,
        max_trans_mm=base.max_trans_mm if args.max_trans_mm is None else args.max_trans_mm,
        monitor_rot_deg=base.monitor_rot_deg if args.max_rot_deg is None else args.max_rot_deg,
        max_speed_mm_s=args.max_speed_mm_s, max_speed_deg_s=args.max_speed_deg_s)


def _print_report(r) -> None:
    from feedopt.rsi.sim import SimStatus

    end = r.record.true[-1, :3] - r.record.command[-1, :3] if r.cycles else np.zeros(3)
    print(f"rsi-sim {r.status.value}: {r.cycles} cycles, {r.late} late answers (longest run "
          f"{r.longest_late_run}); largest following error {r.max_following_error_mm:.6f} mm"
          + ("" if r.max_path_error_mm is None else
             f"; true TCP from the reference path: max {r.max_path_error_mm:.6f} mm, last "
             f"{float(r.path_error_mm[-1]):.6f} mm")
          + f"; true - commanded at the end: {end[0]:.4f} {end[1]:.4f} {end[2]:.4f} mm"
          + f"; answers refused: {r.not_rsi} not RSI, {r.stale} with another IPOC or Sen Type")
    stop = r.limit_stop
    if r.status is SimStatus.LIMIT and stop is not None:
        values = " ".join(f"{a}={v:.6g}" for a, v in zip("XYZABC", stop.rkorr.tolist(),
                                                         strict=True))
        what = (stop.what if "not a number" in stop.what else
                f"{stop.what} {stop.value:.6g}, limit {stop.limit:.6g}")
        print(f"feedopt rsi-sim: RSI stopped with an error at cycle {stop.cycle + 1} (IPOC "
              f"{stop.ipoc}): RKorr {values}: {what}; the correction was not applied and the "
              "robot was held", file=sys.stderr)
