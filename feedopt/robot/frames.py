"""Frames from roll-pitch-yaw angles: the one place feedopt builds a rotation from them.

Roll, pitch and yaw are URDF-style fixed-axis angles (extrinsic X-Y-Z): the frame is turned by
roll about the parent's x, then by pitch about the parent's y, then by yaw about the parent's
z, i.e. ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (the same as intrinsic Z-Y'-X'', KUKA's A, B, C
with A = yaw, B = pitch, C = roll). The rotation is pinocchio's ``pin.rpy.rpyToMatrix``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from feedopt.errors import InputError
from feedopt.units import MM


def _three(values: object, what: str) -> np.ndarray:
    """``values`` as 3 finite floats, or InputError naming ``what``."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what}: expected 3 numbers, got {values!r}") from exc
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{what}: expected 3 finite numbers, got {values!r}")
    return arr


def rotation_from_rpy(rpy_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices ``Rz(yaw) Ry(pitch) Rx(roll)`` (..., 3, 3) from angles (..., 3).

    Parameters
    ----------
    rpy_deg : (..., 3) array
        Roll, pitch, yaw [deg] (extrinsic X-Y-Z: about the parent's fixed axes).

    Returns
    -------
    (..., 3, 3) array
        Rotation of the child frame in the parent frame (columns: child axes in parent axes).
    """
    rpy = np.deg2rad(np.asarray(rpy_deg, dtype=float))
    if rpy.shape[-1:] != (3,):
        raise InputError(f"roll-pitch-yaw angles must have shape (..., 3), got {rpy.shape}")
    flat = rpy.reshape(-1, 3)
    out = np.empty((flat.shape[0], 3, 3))
    for i, (roll, pitch, yaw) in enumerate(flat):
        out[i] = pin.rpy.rpyToMatrix(roll, pitch, yaw)
    return out.reshape(rpy.shape[:-1] + (3, 3))


def transform_from_xyz_rpy(xyz_m: np.ndarray, rpy_deg: np.ndarray) -> np.ndarray:
    """Homogeneous transform (4, 4) of a frame at ``xyz_m`` [m] turned by ``rpy_deg`` [deg].

    Parameters
    ----------
    xyz_m : (3,) array
        Origin of the child frame in the parent frame [m].
    rpy_deg : (3,) array
        Roll, pitch, yaw of the child frame [deg] (see :func:`rotation_from_rpy`).
    """
    xyz = _three(xyz_m, "frame origin xyz")
    roll, pitch, yaw = np.deg2rad(_three(rpy_deg, "frame roll-pitch-yaw"))
    t = np.eye(4)
    t[:3, :3] = pin.rpy.rpyToMatrix(roll, pitch, yaw)
    t[:3, 3] = xyz
    return t


def workpiece_transform(position_mm: np.ndarray, rpy_deg: np.ndarray) -> np.ndarray:
    """Homogeneous transform (4, 4) [m] of the workpiece frame W in the robot base frame B.

    ``p_B = T[:3, :3] @ p_W + T[:3, 3]``.

    Parameters
    ----------
    position_mm : (3,) array
        Origin of W in B [mm] (scenario ``workpiece.position_mm``).
    rpy_deg : (3,) array
        Roll, pitch, yaw of W in B [deg] (scenario ``workpiece.rpy_deg``): extrinsic X-Y-Z,
        ``R = Rz(yaw) Ry(pitch) Rx(roll)``.

    Raises
    ------
    InputError
        When either argument is not 3 finite numbers.
    """
    xyz = _three(position_mm, "workpiece.position_mm") * MM
    return transform_from_xyz_rpy(xyz, _three(rpy_deg, "workpiece.rpy_deg"))
