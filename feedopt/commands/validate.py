"""``feedopt validate SCENARIO.yaml``: check a scenario without planning it.

``feedopt validate --schema`` prints the field reference (Markdown) instead; ``--out FILE``
writes it to FILE. ``--schema`` takes no scenario: ``--schema x.yaml`` is refused (exit 2)
rather than guessed at, because neither reading (validate it? ignore it?) nor writing
(overwrite the scenario with the reference?) is what every user means.

``feedopt validate --robot DIR`` checks a robot directory (robot.yaml against its schema and
its URDF) and prints what feedopt reads from it; ``--robot-schema`` prints robot.yaml's field
reference.
"""

from __future__ import annotations

import argparse
from pathlib import Path

REFERENCE_SUFFIXES = (".md", ".txt", ".markdown")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "validate",
        epilog="docs: docs/scenario-files.md (robot directories: docs/robot.md)",
        help="check a scenario file (schema, referenced files, path geometry)",
        description="Validate SCENARIO.yaml: schema and units, that every referenced file "
        "exists and loads, and that the path can be built (waypoints, blends that fit). "
        "With --schema (and no SCENARIO), print the reference of every scenario field "
        "instead, as Markdown; add --out FILE.md to write it to a file.",
    )
    p.add_argument("scenario", nargs="?", help="scenario YAML file (not with --schema)")
    p.add_argument("--robot", metavar="DIR", help="check a robot directory (robot.yaml and its "
                   "URDF) instead of a scenario")
    p.add_argument("--robot-schema", action="store_true",
                   help="print robot.yaml's field reference (with --out FILE.md: write it)")
    p.add_argument(
        "--schema",
        action="store_true",
        help="print the field reference instead of validating; takes no SCENARIO",
    )
    p.add_argument(
        "--out",
        metavar="FILE",
        help="with --schema: write the reference to FILE (.md or .txt) instead of printing it",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from feedopt.errors import InputError
    from feedopt.scenario import schema_reference

    chosen = [name for name, on in (("a scenario", bool(args.scenario)), ("--schema", args.schema),
                                     ("--robot", args.robot is not None),
                                     ("--robot-schema", args.robot_schema)) if on]
    if len(chosen) > 1 and not (args.schema and args.scenario):
        raise InputError(f"give one of a scenario, --schema, --robot DIR and --robot-schema; "
                         f"got {' and '.join(chosen)}")
    if args.robot_schema:
        from feedopt.robot.robot_file import robot_reference

        return _reference(args.out, robot_reference())
    if args.robot is not None:
        if args.out is not None:
            raise InputError("--out writes a reference (--schema or --robot-schema); checking "
                             "a robot writes nothing")
        print(robot_summary(args.robot))
        return 0
    if args.schema:
        if args.scenario:
            raise InputError(
                f"--schema prints the field reference and takes no scenario file, got "
                f"{args.scenario!r}; run 'feedopt validate {args.scenario}' to check it, or "
                "'feedopt validate --schema --out reference.md' to write the reference to a "
                "file"
            )
        return _reference(args.out, schema_reference())
    if args.out is not None:
        raise InputError(
            "--out writes the --schema reference; validating a scenario writes nothing (use "
            "--schema --out FILE.md, or drop --out)"
        )
    if not args.scenario:
        raise InputError("give a scenario file (or --schema)")
    from feedopt.runner import validate_scenario

    print(validate_scenario(args.scenario))
    return 0


def _reference(out: str | None, text: str) -> int:
    """Print ``text`` or write it to ``out`` (checked first); exit 0."""
    from feedopt.outfile import write_atomically

    if out is None:
        print(text, end="")
        return 0
    write_atomically(_check_reference_out(out), text)
    print(f"wrote {out}")
    return 0


def robot_summary(directory: str) -> str:
    """What feedopt reads from a robot directory: joints, limits in the controller's axis
    values, controller and its convention, TCP at the zero pose, stiffness sets, warnings."""
    import numpy as np

    from feedopt.robot.model import forward_kinematics, load_robot

    robot = load_robot(directory)
    axes = robot.axis_convention
    limits = np.stack([robot.q_lower, robot.q_upper])
    # a coupled axis's range depends on the other joint: print its joint's URDF range
    coupled = axes.coupled_axes()
    ends = np.sort(np.where(coupled, limits / axes.unit, axes.to_controller(limits)), axis=0)
    units = axes.unit_names()
    lines = [f"{directory}: ok — {robot.name}: {robot.dof} joints, controller "
             f"{robot.controller}; {axes.describe()}"]
    for j, name in enumerate(robot.joint_names):
        note = " (the URDF joint's range: the controller's axis is coupled)" if (
            coupled[j]) else ""
        lines.append(f"  {name}: {ends[0, j]:.2f} .. {ends[1, j]:.2f} {units[j]}{note}, "
                     f"speed {robot.joint_velocity_max[j] / axes.unit[j]:.4g} {units[j]}/s")
    tcp = forward_kinematics(robot, np.clip(np.zeros(robot.dof), robot.q_lower,
                                            robot.q_upper))
    where = ", ".join(f"{v + 0.0:.1f}" for v in np.round(tcp[:3, 3] * 1e3, 1))
    axis = ", ".join(f"{v + 0.0:.3f}" for v in np.round(tcp[:3, 2], 3))
    lines.append(f"  TCP at the URDF's zero (clipped to the limits): ({where}) mm in the base "
                 f"frame, tool axis ({axis})")
    lines.append("  stiffness sets: " + ", ".join(robot.stiffness))
    if robot.controller == "kuka" and not axes.stated:
        lines.append("  note: no KRL or RSI program will be written until robot.yaml states "
                     "controller.axes")
    lines += [f"  warning: {w}" for w in robot.data_warnings]
    return "\n".join(lines)


def _check_reference_out(name: str) -> Path:
    """The checked target of ``--schema --out``: a writable .md/.txt file (before any work)."""
    from feedopt.errors import InputError
    from feedopt.outfile import check_name, check_output_file

    check_name(name, "--out")
    if not Path(name).is_dir() and Path(name).suffix.lower() not in REFERENCE_SUFFIXES:
        raise InputError(
            f"--out {name!r}: the reference is Markdown text, not a scenario; give a file "
            f"ending in {' or '.join(REFERENCE_SUFFIXES[:2])} (e.g. --out reference.md)"
        )
    return check_output_file(name, "--out", REFERENCE_SUFFIXES, example="reference.md")
