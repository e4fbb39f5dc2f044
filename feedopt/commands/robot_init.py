"""``feedopt robot init URDF --out DIR``: a robot directory from a published URDF.

Reads the URDF (:func:`feedopt.robot.init.inspect_urdf`: the serial chain, the flange and
which way it points, limits and speeds), writes DIR with a copy of the URDF and a robot.yaml
whose every guess is labelled a placeholder, checks that DIR loads as a robot, and prints
what the user must still fill in. DIR must be new or empty; it appears whole or not at all.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from feedopt.errors import InputError
from feedopt.outdir import STAGING_MARKER, staging_folder
from feedopt.robot.robot_file import CONTROLLERS


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "robot-init",
        epilog="docs: docs/robot.md",
        help="write a robot directory from a URDF (also: feedopt robot init URDF --out DIR)",
        description="Read URDF (a serial arm), find its flange and which way it points out of "
        "the flange (a CAD offset of the flange frame from the last joint's axis up to 1 mm "
        "is tolerated and reported), and write DIR: a copy of the URDF and a robot.yaml with "
        "the URDF's limits and speeds and labelled placeholders for the stiffness, the "
        "accelerations and the tool. Prints what you must still fill in.",
    )
    p.add_argument("urdf", metavar="URDF", help="the robot's URDF (expanded, not xacro)")
    p.add_argument("--out", required=True, metavar="DIR", help="new (or empty) robot folder")
    p.add_argument("--flange", metavar="FRAME", help="the flange frame (default: 'flange', "
                   "'tool0', 'ee_link' or the last frame on the last joint)")
    p.add_argument("--controller", default="generic", choices=CONTROLLERS,
                   help="controller family (default generic; kuka then needs controller.axes)")
    p.add_argument("--tool-length-mm", type=float, default=200.0,
                   help="placeholder tool length along the flange axis (default 200)")
    p.set_defaults(func=run)


def _target(out: str, urdf: Path) -> Path:
    """``out`` checked: new or empty, not the URDF's own folder or file."""
    from feedopt.outdir import DestinationKind, check_destination

    kind = check_destination(Path(out), [Path.cwd()], overwrite=True, inputs=[urdf])
    if kind not in (DestinationKind.NEW, DestinationKind.EMPTY):
        raise InputError(f"--out {out} already holds files; robot init writes a new robot "
                         "folder: choose a new or empty one (nothing was changed)")
    return Path(out).resolve()


def run(args: argparse.Namespace) -> int:
    from feedopt.robot.init import inspect_urdf, robot_yaml_text, still_to_fill
    from feedopt.robot.model import load_robot
    from feedopt.textio import read_user_bytes

    urdf = Path(args.urdf)
    read_user_bytes(urdf, "URDF")  # missing, a folder, a FIFO, oversized: its message
    if not (args.tool_length_mm > 0 and args.tool_length_mm < 2000):
        raise InputError(f"--tool-length-mm must be > 0 and < 2000 mm, got {args.tool_length_mm}")
    target = _target(args.out, urdf)
    summary = inspect_urdf(urdf, args.flange)
    text = robot_yaml_text(summary, urdf.name, args.tool_length_mm, args.controller)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = staging_folder(target, "robot-init")
    except OSError as exc:
        raise InputError(f"--out {args.out}: cannot write in {target.parent} "
                         f"({exc.strerror or type(exc).__name__}); choose a folder you can "
                         "write to") from None
    try:
        shutil.copyfile(urdf, staging / urdf.name)
        (staging / "robot.yaml").write_text(text, encoding="utf-8")
        try:  # what was written loads as a robot, or nothing is kept
            robot = load_robot(staging)
        except InputError as exc:
            raise InputError(str(exc).replace(str(staging), str(args.out))) from None
        if target.exists():
            target.rmdir()
        (staging / STAGING_MARKER).unlink()  # kept until now: a killed init is cleaned later
        staging.rename(target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    print(f"wrote {args.out}: {robot.name}, {robot.dof} joints "
          f"({', '.join(f'{j} {k}' for j, k in zip(summary.joints, summary.kinds, strict=True))})"
          f", flange '{summary.flange}' (out of the flange: "
          f"{', '.join(f'{v + 0.0:.3f}' for v in summary.outward)} in it; origin "
          f"{summary.off_axis_mm:.3f} mm off the last joint's axis)")
    if summary.locked:
        print(f"joints locked (they do not move the flange): {', '.join(summary.locked)}")
    print("still to fill in robot.yaml:")
    for line in still_to_fill(summary, args.controller):
        print(f"  - {line}")
    print(f"then: feedopt validate --robot {args.out}")
    return 0
