"""``feedopt robot``: TCP pose, Cartesian stiffness and deflection of a robot at one pose."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions
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
from feedopt.units import MM

#: Condition number (1 m length scale) above which a pose is near-singular: the default
#: ``max_condition`` of :class:`feedopt.robot.ik.IKOptions`, so ``feedopt run`` refuses
#: such a pose on a path (KR500-3 wrist: |A5| below about 3 deg).
NEAR_SINGULAR = IKOptions().max_condition
#: robot.yaml and this command give joint stiffness in MN m/rad.
_NM_PER_MNM = 1e6
#: Above this the smallest singular value is rounding noise: the pose is exactly singular.
SINGULAR = 1e12
#: Joints whose share of the null-motion vector exceeds this are named in the warning.
NULL_SHARE = 0.2


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``robot`` subcommand."""
    p = subparsers.add_parser(
        "robot",
        epilog="docs: docs/robot.md",
        help="TCP pose, translational stiffness and deflection of a robot at one configuration",
        description=(
            "Print the TCP pose (KUKA X, Y, Z in mm, A, B, C in deg; TCP +z along the tool into "
            "the spindle), the 3x3 translational stiffness at the TCP (force-only loading, "
            "thesis Eq. 3.19/3.20), its principal directions and, with --force-n, the TCP "
            "deflection. Write negative values with '=': --q-deg=-10,-90,90,0,45,0. "
            f"A warning goes to stderr when the pose is near-singular (Jacobian condition "
            f"number > {NEAR_SINGULAR:g}, the limit above which feedopt run refuses a path "
            f"sample) or singular (> {SINGULAR:g}: rank-deficient to rounding), naming the "
            "joints that can move without moving the TCP."
        ),
    )
    p.add_argument("robot_dir", metavar="ROBOT_DIR", help="directory with robot.yaml and URDF")
    p.add_argument("--q-deg", required=True, help="joint angles in deg, comma-separated")
    p.add_argument("--force-n", help="force on the tool at the TCP, base frame: fx,fy,fz [N]")
    p.add_argument("--stiffness", default="dpp", help="joint stiffness set (default: dpp)")
    p.set_defaults(func=run)


def singularity_warning(jacobian: np.ndarray, condition: float) -> str | None:
    """Warning text for a (near-)singular pose, or None (``jacobian``: (6, dof), 1 m scale).

    The right singular vector of the smallest singular value is the joint motion that moves
    the TCP least; the joints with a large share of it are named (joints 4-6 only: a wrist
    singularity, e.g. A4 and A6 aligned at A5 = 0 on a KUKA).
    """
    if not condition > NEAR_SINGULAR:
        return None
    vt = np.linalg.svd(jacobian, full_matrices=False)[2]  # vt[-1]: smallest sigma
    null = vt[-1] / np.linalg.norm(vt[-1])
    joints = [int(j) + 1 for j in np.flatnonzero(np.abs(null) > NULL_SHARE)]
    kind = "singular" if condition > SINGULAR else "near-singular"
    limit = SINGULAR if kind == "singular" else NEAR_SINGULAR
    dof = jacobian.shape[1]
    wrist = dof == 6 and bool(joints) and min(joints) >= 4
    where = "wrist" if wrist else "arm (shoulder/elbow)"
    motion = " ".join(f"{null[j - 1]:+.3f} q{j}" for j in joints)
    text = (
        f"{kind} pose, {where} singularity: Jacobian condition number {condition:.3g} > "
        f"{limit:g}; joints {', '.join(map(str, joints))} can move together ({motion}) with "
        "almost no TCP motion. "
    )
    if kind == "singular":
        text += "The condition number printed is rounding noise (infinite in exact arithmetic). "
    return text + (
        f"feedopt run refuses path samples whose condition number exceeds {NEAR_SINGULAR:g}."
    )


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
    axes = robot.axis_convention
    given = _floats(args.q_deg, robot.dof, "--q-deg")
    q = axes.from_controller(given)
    bad = np.flatnonzero((q < robot.q_lower) | (q > robot.q_upper))
    if bad.size:
        j = int(bad[0])
        if axes.coupled_axes()[j]:  # its range depends on the joint it adds: say the URDF's
            raise InputError(
                f"--q-deg: joint {robot.joint_names[j]} comes to {q[j] / axes.unit[j]:.3f} "
                f"(URDF), outside its URDF range [{robot.q_lower[j] / axes.unit[j]:.1f}, "
                f"{robot.q_upper[j] / axes.unit[j]:.1f}]; controller axis {j + 1} is coupled "
                f"({axes.describe()})")
        ends = np.sort(axes.to_controller(np.stack([robot.q_lower, robot.q_upper]))[:, j])
        raise InputError(
            f"--q-deg: axis {j + 1} (joint {robot.joint_names[j]}) = {given[j]:.3f} is outside "
            f"its limits [{ends[0]:.1f}, {ends[1]:.1f}] (the controller's axis values, deg"
            + ("" if axes.stated else "; the URDF's angles: robot.yaml states no "
               "controller.axes") + ")"
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
    xyz = pose[:3, 3] / MM

    print(f"robot: {robot.name}   stiffness set: {args.stiffness}")
    print("joint stiffness [MNm/rad]: " + " ".join(f"{v / _NM_PER_MNM:.3f}" for v in k))
    print(
        f"TCP pose: X={xyz[0]:.3f} Y={xyz[1]:.3f} Z={xyz[2]:.3f} mm  "
        f"A={abc[0]:.3f} B={abc[1]:.3f} C={abc[2]:.3f} deg"
    )
    cond = float(jacobian_condition_number(jac)[0])
    print(f"Jacobian condition number (1 m length scale): {cond:.2f}")
    warning = singularity_warning(jac[0], cond)
    if warning:
        print(f"feedopt robot: warning: {warning}", file=sys.stderr)
    print("translational stiffness at the TCP [N/mm] (base axes x, y, z):")
    for row in k3 * MM:  # N/m -> N/mm
        print("  " + " ".join(f"{v:12.2f}" for v in row))
    print("principal stiffnesses [N/mm] and directions (base frame):")
    for i in np.argsort(evals)[::-1]:
        d = evecs[:, i]
        print(f"  {evals[i] * MM:12.2f}  along [{d[0]:+.4f}, {d[1]:+.4f}, {d[2]:+.4f}]")
    if force is not None:
        dx = deflection(c3, force[None])[0] / MM
        print(
            f"force [N]: {force[0]:.2f} {force[1]:.2f} {force[2]:.2f} -> deflection [mm]: "
            f"dx={dx[0]:.5f} dy={dx[1]:.5f} dz={dx[2]:.5f} |d|={np.linalg.norm(dx):.5f}"
        )
    return 0
