"""KUKA orientation convention: A, B, C are intrinsic Z-Y'-X'' Euler angles in degrees.

``R = Rz(A) @ Ry(B) @ Rx(C)``; the inverse picks B in [-90, 90] deg.
"""

from __future__ import annotations

import numpy as np

from feedopt.robot.frames import rotation_from_rpy


def rotation_from_abc(abc_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from KUKA A, B, C angles (..., 3) in degrees.

    ``Rz(A) Ry(B) Rx(C)`` is the roll-pitch-yaw rotation with roll = C, pitch = B, yaw = A
    (:func:`feedopt.robot.frames.rotation_from_rpy`).
    """
    return rotation_from_rpy(np.asarray(abc_deg, dtype=float)[..., ::-1])


def abc_from_rotation(rotation: np.ndarray) -> np.ndarray:
    """KUKA A, B, C angles (..., 3) in degrees from rotation matrices (..., 3, 3).

    At gimbal lock (B = +-90 deg) C is set to 0 and A carries the whole rotation about z.
    """
    r = np.asarray(rotation, dtype=float)
    b = np.arcsin(np.clip(-r[..., 2, 0], -1.0, 1.0))
    cb = np.cos(b)
    locked = cb < 1e-9
    a = np.where(
        locked, np.arctan2(-r[..., 0, 1], r[..., 1, 1]), np.arctan2(r[..., 1, 0], r[..., 0, 0])
    )
    c = np.where(locked, 0.0, np.arctan2(r[..., 2, 1], r[..., 2, 2]))
    return np.rad2deg(np.stack([a, b, c], axis=-1))
