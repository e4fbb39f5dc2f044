"""KUKA A, B, C <-> rotation (intrinsic Z-Y'-X'')."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from feedopt.robot.kuka import abc_from_rotation, rotation_from_abc


def test_rotation_is_rz_ry_rx():
    rng = np.random.default_rng(3)
    abc = rng.uniform([-180, -89, -180], [180, 89, 180], size=(50, 3))
    r = rotation_from_abc(abc)
    # pinocchio's rpyToMatrix(r, p, y) = Rz(y) Ry(p) Rx(r): the same as KUKA's Rz(A) Ry(B) Rx(C)
    for a, m in zip(abc, r, strict=True):
        np.testing.assert_allclose(m, pin.rpy.rpyToMatrix(*np.deg2rad(a[::-1])), atol=1e-12)
    np.testing.assert_allclose(abc_from_rotation(r), abc, atol=1e-9)


def test_gimbal_lock_keeps_the_rotation():
    abc = np.array([[30.0, 90.0, 20.0], [-40.0, -90.0, 10.0]])
    back = abc_from_rotation(rotation_from_abc(abc))
    np.testing.assert_allclose(back[:, 2], 0.0)
    np.testing.assert_allclose(rotation_from_abc(back), rotation_from_abc(abc), atol=1e-9)
