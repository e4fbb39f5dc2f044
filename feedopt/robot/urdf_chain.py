"""The serial arm inside a URDF: the joints between the base and the flange, nothing else.

Published URDFs carry joints that do not move the tool: an ABB IRB 6640's balancer cylinder
and piston (continuous joints that mimic joint 2 on a side branch), grippers' fingers, a
second arm. :func:`chain_model` locks every joint that is not an ancestor of the flange frame
(pinocchio's ``buildReducedModel`` at the neutral configuration: exact for the TCP, which
they do not move) and names them. A joint on the arm's own chain that mimics another (a
parallelogram written as a mimic) or turns without limits is refused by name: feedopt plans
one independent, bounded value per joint.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError

#: Joints a planned arm may have: 6 (the 5-DoF milling task and the rotation about the tool
#: axis) to 12 (an arm on a track and a turntable).
MIN_JOINTS, MAX_JOINTS = 6, 12
#: Largest range a revolute joint's <limit> may span [rad] (four turns: an IRB 2400's axis 6
#: spans 800 deg; a range written in degrees, e.g. -185 .. 185, is far beyond it) and a
#: prismatic one [m].
MAX_REVOLUTE_RANGE, MAX_PRISMATIC_RANGE = 8.0 * 3.141592653589793, 100.0


def is_prismatic(model: pin.Model, joint: int) -> bool:
    """Whether pinocchio joint ``joint`` (1-based) slides (PX, PY, PZ, PrismaticUnaligned)."""
    return model.joints[joint].shortname().startswith("JointModelP")


def zero_axes(urdf_bytes: bytes) -> list[str]:
    """Joints whose ``<axis xyz>`` is the zero vector (pinocchio builds no rotation of it)."""
    try:
        root = ET.fromstring(urdf_bytes)
    except ET.ParseError:
        return []
    out = []
    for j in root.iter("joint"):
        axis = j.find("axis")
        if axis is None or j.get("type") in ("fixed", "floating", "planar"):
            continue
        try:
            values = [float(v) for v in axis.get("xyz", "1 0 0").split()]
        except ValueError:
            continue
        if not any(values):
            out.append(j.get("name", "?"))
    return out


def check_arm(model: pin.Model, frame: str, urdf: Path, locked: tuple[str, ...],
              raw: bytes) -> None:
    """InputError unless the chain to ``frame`` is an arm feedopt plans: 6-12 joints, each
    with a non-zero axis and a plausible range (naming the joint or the frame)."""
    zero = [name for name in zero_axes(raw) if model.existJointName(name)]
    if zero:
        raise InputError(f"{urdf}: joint(s) {', '.join(zero)} have <axis xyz=\"0 0 0\">: give "
                         "each the unit vector it turns or slides about")
    dof = model.njoints - 1
    if not MIN_JOINTS <= dof <= MAX_JOINTS:
        names = ", ".join(model.names[j] for j in range(1, model.njoints))
        where = (f"; frame '{frame}' is not at the end of the arm (joints after it: "
                 f"{', '.join(locked)})" if locked and dof < MIN_JOINTS else "")
        raise InputError(f"{urdf}: the chain to '{frame}' has {dof} joint(s) ({names}); feedopt "
                         f"plans arms of {MIN_JOINTS} to {MAX_JOINTS} joints{where}")
    lower, upper = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
    for j in range(1, model.njoints):
        prismatic = is_prismatic(model, j)
        span = float(upper[j - 1] - lower[j - 1])
        most = MAX_PRISMATIC_RANGE if prismatic else MAX_REVOLUTE_RANGE
        if np.isfinite(span) and span > most:
            unit = "m" if prismatic else "rad"
            raise InputError(
                f"{urdf}: joint '{model.names[j]}' spans {lower[j - 1]:g} .. {upper[j - 1]:g} "
                f"{unit}, more than {most:g} {unit}: URDF limits are in rad and m (degrees or "
                "mm written there?)")


def mimic_joints(urdf_bytes: bytes) -> dict[str, str]:
    """``{joint: the joint it mimics}`` of a URDF's ``<mimic joint=...>`` tags."""
    try:
        root = ET.fromstring(urdf_bytes)
    except ET.ParseError:  # pinocchio has read it; leave odd XML to its message
        return {}
    return {j.get("name", ""): m.get("joint", "") for j in root.iter("joint")
            for m in j.findall("mimic")}


def chain_model(model: pin.Model, frame: str, urdf: Path,
                mimics: dict[str, str]) -> tuple[pin.Model, tuple[str, ...]]:
    """``model`` reduced to the joints that move ``frame`` (which must exist), and the names
    of the joints locked. InputError naming a mimic or continuous joint on the chain."""
    fid = int(model.getFrameId(frame))
    chain, j = set(), model.frames[fid].parentJoint
    while j > 0:
        chain.add(j)
        j = model.parents[j]
    for j in sorted(chain):
        name = model.names[j]
        if name in mimics:
            raise InputError(
                f"{urdf}: joint '{name}' mimics '{mimics[name]}' on the arm's own chain to "
                f"'{frame}' (a parallelogram drive written as a mimic); feedopt plans one "
                "independent value per joint: model the parallelogram as its equivalent serial "
                "joint in the URDF (the controller's axis), without the mimic")
        joint = model.joints[j]
        if joint.nq != 1 or joint.nv != 1:
            kind = ("continuous (unbounded)" if joint.nq == 2 and joint.nv == 1 else
                    f"a {joint.shortname()} joint of {joint.nv} degrees of freedom "
                    "(floating or planar)")
            raise InputError(f"{urdf}: joint '{name}' is {kind}; feedopt plans revolute and "
                             "prismatic joints with a finite <limit lower upper>: give it one "
                             "of those types")
    lock = [j for j in range(1, model.njoints) if j not in chain]
    if not lock:
        return model, ()
    reduced = pin.buildReducedModel(model, lock, pin.neutral(model))
    return reduced, tuple(model.names[j] for j in lock)
