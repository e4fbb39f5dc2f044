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

import pinocchio as pin

from feedopt.errors import InputError


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
        if model.joints[j].nq != model.joints[j].nv:
            raise InputError(f"{urdf}: joint '{name}' is continuous (unbounded); give it a "
                             "revolute type with a finite <limit lower upper>")
    lock = [j for j in range(1, model.njoints) if j not in chain]
    if not lock:
        return model, ()
    reduced = pin.buildReducedModel(model, lock, pin.neutral(model))
    return reduced, tuple(model.names[j] for j in lock)
