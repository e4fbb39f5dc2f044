"""KUKA orientation convention: A, B, C are intrinsic Z-Y'-X'' Euler angles in degrees.

``R = Rz(A) @ Ry(B) @ Rx(C)``; the inverse picks B in [-90, 90] deg.
"""

from __future__ import annotations

import numpy as np


def rotation_from_abc(abc_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from KUKA A, B, C angles (..., 3) in degrees."""
    a, b, c = np.moveaxis(np.deg2rad(np.asarray(abc_deg, dtype=float)), -1, 0)
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    r = np.empty(a.shape + (3, 3))
    r[..., 0, 0] = ca * cb
    r[..., 0, 1] = ca * sb * sc - sa * cc
    r[..., 0, 2] = ca * sb * cc + sa * sc
    r[..., 1, 0] = sa * cb
    r[..., 1, 1] = sa * sb * sc + ca * cc
    r[..., 1, 2] = sa * sb * cc - ca * sc
    r[..., 2, 0] = -sb
    r[..., 2, 1] = cb * sc
    r[..., 2, 2] = cb * cc
    return r


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
