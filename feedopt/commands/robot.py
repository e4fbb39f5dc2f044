"""``feedopt robot``: TCP pose, Cartesian stiffness and deflection of a robot at one pose."""

from __future__ import annotations

import argparse

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.kuka import abc_from_rotation
from feedopt.robot.model import (
    forward_kinematics,
    jacobian_condition_number,
    load_robot,
    tcp_jacobians,
)
from feedopt.robot.stiffness import (
    compliance_from_jacobians,
    deflection,
    joint_stiffness,
)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``robot`` subcommand."""
    p = subparsers.add_parser(
        "robot",
        help="TCP pose, translational stiffness and deflection of a robot at one configuration",
        description=(
            "Print the TCP pose (KUKA X, Y, Z in mm, A, B, C in deg; TCP +z along the tool into "
            "the spindle), the 3x3 translational stiffness at the TCP (force-only loading, "
            "thesis Eq. 3.19/3.20), its principal directions and, with --force-n, the TCP "
            "deflection. Write negative values with '=': --q-deg=-10,-90,90,0,45,0"
        ),
    )
    p.add_argument("robot_dir", metavar="ROBOT_DIR", help="directory with robot.yaml and URDF")
    p.add_argument("--q-deg", required=True, help="joint angles in deg, comma-separated")
    p.add_argument("--force-n", help="force on the tool at the TCP, base frame: fx,fy,fz [N]")
    p.add_argument("--stiffness", default="dpp", help="joint stiffness set (default: dpp)")
    p.set_defaults(func=run)


def _floats(text: str, n: int, option: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError as exc:
        raise InputError(f"{option}: expected {n} comma-separated numbers, got {text!r}") from exc
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise InputError(f"{option}: expected {n} comma-separated numbers, got {text!r}")
    return values


def run(args: argparse.Namespace) -> int:
    """Validate, compute and print; returns 0."""
    robot = load_robot(args.robot_dir)
    q = np.deg2rad(_floats(args.q_deg, robot.dof, "--q-deg"))
    bad = np.flatnonzero((q < robot.q_lower) | (q > robot.q_upper))
    if bad.size:
        j = int(bad[0])
        raise InputError(
            f"--q-deg: joint {j + 1} = {np.rad2deg(q[j]):.3f} deg is outside its limits "
            f"[{np.rad2deg(robot.q_lower[j]):.1f}, {np.rad2deg(robot.q_upper[j]):.1f}] deg"
        )
    force = None if args.force_n is None else _floats(args.force_n, 3, "--force-n")
    k = joint_stiffness(robot, args.stiffness)

    pose = forward_kinematics(robot, q[None])[0]
    jac = tcp_jacobians(robot, q[None])
    c6 = compliance_from_jacobians(jac, k)
    c3 = c6[:, :3, :3]
    k3 = np.linalg.inv(c3[0])
    evals, evecs = np.linalg.eigh(0.5 * (k3 + k3.T))
    abc = abc_from_rotation(pose[:3, :3])
    xyz = pose[:3, 3] * 1e3

    print(f"robot: {robot.name}   stiffness set: {args.stiffness}")
    print("joint stiffness [MNm/rad]: " + " ".join(f"{v / 1e6:.3f}" for v in k))
    print(
        f"TCP pose: X={xyz[0]:.3f} Y={xyz[1]:.3f} Z={xyz[2]:.3f} mm  "
        f"A={abc[0]:.3f} B={abc[1]:.3f} C={abc[2]:.3f} deg"
    )
    print(f"Jacobian condition number (1 m length scale): {jacobian_condition_number(jac)[0]:.2f}")
    print("translational stiffness at the TCP [N/mm] (base axes x, y, z):")
    for row in k3 * 1e-3:
        print("  " + " ".join(f"{v:12.2f}" for v in row))
    print("principal stiffnesses [N/mm] and directions (base frame):")
    for i in np.argsort(evals)[::-1]:
        d = evecs[:, i]
        print(f"  {evals[i] * 1e-3:12.2f}  along [{d[0]:+.4f}, {d[1]:+.4f}, {d[2]:+.4f}]")
    if force is not None:
        dx = deflection(c3, force[None])[0] * 1e3
        print(
            f"force [N]: {force[0]:.2f} {force[1]:.2f} {force[2]:.2f} -> deflection [mm]: "
            f"dx={dx[0]:.5f} dy={dx[1]:.5f} dz={dx[2]:.5f} |d|={np.linalg.norm(dx):.5f}"
        )
    return 0
