"""Joint-stiffness deflection model (thesis Eq. 3.18-3.20) against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.robot.model import forward_kinematics, tcp_jacobians
from feedopt.robot.stiffness import (
    complementary_ratio,
    complementary_stiffness,
    compliance,
    compliance_split,
    deflection,
    joint_stiffness,
    translational_compliance,
)
from tests.robot.helpers import Q_START_DEG, TABLE_A3_DEG


def _configs():
    return np.deg2rad(np.vstack([TABLE_A3_DEG, Q_START_DEG]))


@pytest.mark.parametrize("name", ["kuka", "ur10"])
def test_compliance_symmetric_positive_semidefinite(name, request):
    robot = request.getfixturevalue(name)
    q = _configs() if name == "kuka" else np.random.default_rng(0).uniform(-2, 2, (8, 6))
    for key in ("cp", "dpp"):
        c = compliance(robot, q, key)
        assert c.shape == (q.shape[0], 6, 6)
        np.testing.assert_allclose(c, np.swapaxes(c, 1, 2), rtol=0, atol=1e-15)
        ev = np.linalg.eigvalsh(c)
        assert ev.min() >= -1e-12 * ev.max()


def test_equal_stiffness_scaling_is_inverse(kuka):
    q = _configs()
    f = np.random.default_rng(1).normal(size=(q.shape[0], 7, 3)) * 100.0
    d1 = deflection(translational_compliance(kuka, q, np.full(6, 1e6)), f)
    d3 = deflection(translational_compliance(kuka, q, np.full(6, 3e6)), f)
    np.testing.assert_allclose(d3, d1 / 3.0, rtol=1e-12)


def test_deflection_equals_joint_spring_solution_from_fk_only(kuka):
    """tau = J^T F, dq = K^-1 tau, dx = J dq, with J^T F and J dq both from finite-difference FK."""
    q = _configs()
    k = joint_stiffness(kuka, "dpp")
    force = np.array([300.0, -200.0, 500.0])
    dx_model = deflection(translational_compliance(kuka, q, "dpp"), np.tile(force, (len(q), 1)))
    h = 1e-6
    for qi, dxi in zip(q, dx_model, strict=True):
        # virtual work: tau_i = F . dp/dq_i (force only, no moment)
        tau = np.empty(6)
        for i in range(6):
            e = np.zeros(6)
            e[i] = h
            tau[i] = force @ (forward_kinematics(kuka, qi + e)[:3, 3]
                              - forward_kinematics(kuka, qi - e)[:3, 3]) / (2 * h)
        dq = tau / k
        eps = 1e-3
        dx = (forward_kinematics(kuka, qi + eps * dq)[:3, 3]
              - forward_kinematics(kuka, qi - eps * dq)[:3, 3]) / (2 * eps)
        np.testing.assert_allclose(dxi, dx, rtol=1e-6, atol=1e-12)


def test_dpp_split_and_cp_vs_dpp(kuka):
    q = _configs()
    arm, wrist = compliance_split(kuka, q, "dpp")
    np.testing.assert_allclose(arm + wrist, compliance(kuka, q, "dpp"), atol=1e-18)
    f = np.tile([0.0, 200.0, -100.0], (len(q), 1))
    d_cp = deflection(translational_compliance(kuka, q, "cp"), f)
    d_dpp = deflection(translational_compliance(kuka, q, "dpp"), f)
    ratio = np.linalg.norm(d_dpp, axis=1) / np.linalg.norm(d_cp, axis=1)
    assert np.all(ratio > 1.05)  # DPP joints are all softer than CP
    # default is DPP (thesis uses Eq. 3.20)
    np.testing.assert_array_equal(translational_compliance(kuka, q), translational_compliance(
        kuka, q, "dpp"))


def test_deflection_vectorised_over_samples_and_angles(kuka):
    q = _configs()
    c = translational_compliance(kuka, q)
    f = np.random.default_rng(2).normal(size=(len(q), 90, 3))
    d = deflection(c, f)
    assert d.shape == f.shape
    for i in (0, 5, 10):
        np.testing.assert_allclose(d[i, 17], c[i] @ f[i, 17])
    wrench = np.concatenate([f, np.ones_like(f)], axis=2)
    d6 = deflection(compliance(kuka, q), wrench)
    assert d6.shape == (len(q), 90, 6)
    with pytest.raises(InputError, match="force must have shape"):
        deflection(c, f[:3])


def test_stiffness_selection_errors(kuka):
    with pytest.raises(InputError, match="available: cp, dpp"):
        joint_stiffness(kuka, "xyz")
    with pytest.raises(InputError, match="6 positive values"):
        joint_stiffness(kuka, np.ones(5))


def _equilibrium(robot, q0, wrench, k):
    """Solve K dq = J(q0 + dq)^T W by fixed-point iteration (large-displacement statics)."""
    dq = np.zeros(6)
    for _ in range(200):
        new = tcp_jacobians(robot, q0 + dq).T @ wrench / k
        if np.abs(new - dq).max() < 1e-16:
            break
        dq = new
    return dq


def test_complementary_stiffness_captures_geometry_change(kuka):
    """Eq. 3.18 matches the nonlinear joint deflection to second order, Eq. 3.19 to first."""
    q0 = np.deg2rad(Q_START_DEG)
    k = joint_stiffness(kuka, "dpp")
    errors = []
    for scale in (0.5, 1.0):  # 1.9 and 3.9 kN: joint deflections of 0.3 and 0.6 deg
        w = scale * np.array([2000.0, -1500.0, 3000.0, 0.0, 0.0, 0.0])
        dq_true = _equilibrium(kuka, q0, w, k)
        jac = tcp_jacobians(kuka, q0)
        dq_lin = jac.T @ w / k
        kc = complementary_stiffness(kuka, q0[None], w[None])[0]
        np.testing.assert_allclose(kc, kc.T, atol=1e-6 * np.abs(kc).max())  # pure force
        dq_kc = np.linalg.solve(np.diag(k) - kc, jac.T @ w)
        errors.append((np.linalg.norm(dq_lin - dq_true), np.linalg.norm(dq_kc - dq_true)))
        assert errors[-1][1] < 0.01 * errors[-1][0]
        ratio = complementary_ratio(kc[None], k)[0]
        assert 0.005 < ratio < 0.05  # K_c is ~1 % of K here: negligible, as the thesis says
    # doubling the load: Eq. 3.19 error grows ~4x (second order), Eq. 3.18 error ~8x (third)
    assert 3.0 < errors[1][0] / errors[0][0] < 5.0
    assert 6.0 < errors[1][1] / errors[0][1] < 10.0
    # compliance with K_c (Eq. 3.18) maps the wrench consistently
    c = compliance(kuka, q0[None], k, k_c=kc[None])[0]
    np.testing.assert_allclose(c @ w, jac @ dq_kc, rtol=1e-10)
