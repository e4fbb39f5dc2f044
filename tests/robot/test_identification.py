"""Joint-stiffness identification (thesis 3.4, Eq. 3.19-3.20) against synthetic load tests.

The measurements are made without the identification's own model code: joint torques by
virtual work from finite differences of pinocchio's forward kinematics, joint deflections
``tau / k``, and the TCP motion they cause again from finite differences of the forward
kinematics (no Jacobian, no compliance matrix).
"""

from __future__ import annotations

import shutil

import numpy as np
import pinocchio as pin
import pytest
import yaml
from hypothesis import event, given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.robot.identification import (
    LoadTests,
    Method,
    PlanLoads,
    PoseCandidates,
    UnidentifiableJoints,
    WarningKind,
    fit_compliance_scale,
    fit_point_offset,
    identification_matrix,
    identify,
    linear_fit,
    load_wrenches,
    point_offset_terms,
    repeat_groups,
    suggest_poses,
)
from feedopt.robot.model import forward_kinematics, load_robot, tcp_jacobians
from feedopt.robot.stiffness import compliance
from tests.properties._support import budget
from tests.robot.helpers import KUKA_DIR, TABLE_A3_DEG

#: Thesis Table 3.4 [N m/rad].
CP = np.array([3.93, 3.46, 2.77, 1.57, 0.24, 0.17]) * 1e6
DPP = np.array([2.86, 2.36, 1.67, 0.24, 0.16, 0.14]) * 1e6
H = 1e-5
#: Largest joint step [rad] of the central difference along the joint deflection.
STEP = 1e-4


def fk_motion(robot, q: np.ndarray, wrench: np.ndarray, k: np.ndarray):
    """TCP displacement [m] and rotation vector [rad] (n, 3) of the joint-spring model.

    tau_i = f . dp/dq_i + m . w_i (virtual work, central differences of the FK),
    dq = tau / k, motion = FK(q + h dq) vs FK(q - h dq) / 2h, a joint step of STEP: the
    linear model's motion to about STEP^2 relative.
    """
    n, dof = q.shape
    tau = np.empty((n, dof))
    for i in range(dof):
        e = np.zeros(dof)
        e[i] = H
        tp, tm = forward_kinematics(robot, q + e), forward_kinematics(robot, q - e)
        dp = (tp[:, :3, 3] - tm[:, :3, 3]) / (2 * H)
        w = np.array([pin.log3(a[:3, :3] @ b[:3, :3].T) for a, b in zip(tp, tm, strict=True)])
        tau[:, i] = np.einsum("ni,ni->n", wrench[:, :3], dp) + np.einsum(
            "ni,ni->n", wrench[:, 3:], w / (2 * H))
    dq = tau / k
    h = STEP / np.abs(dq).max(axis=1, keepdims=True)
    tp, tm = forward_kinematics(robot, q + h * dq), forward_kinematics(robot, q - h * dq)
    d = (tp[:, :3, 3] - tm[:, :3, 3]) / (2 * h)
    r = np.array([pin.log3(a[:3, :3] @ b[:3, :3].T) for a, b in zip(tp, tm, strict=True)])
    return d, r / (2 * h)


def table_a3_tests(robot, load: float = 1000.0, lever: float = 0.2):
    """Table A.3 poses, three loads each: (q, wrench) with one row per test."""
    q = np.deg2rad(TABLE_A3_DEG)
    w = load_wrenches(forward_kinematics(robot, q), load, lever)
    return np.repeat(q, w.shape[1], axis=0), w.reshape(-1, 6)


@pytest.fixture(scope="module")
def a3(kuka):
    """Table A.3 tests and their noise-free motion for both Table 3.4 sets."""
    q, w = table_a3_tests(kuka)
    return q, w, {"cp": fk_motion(kuka, q, w, CP), "dpp": fk_motion(kuka, q, w, DPP)}


def test_fk_motion_is_an_independent_check(kuka, a3):
    """The synthetic data agree with the model C W (Eq. 3.19) only to finite-difference accuracy:
    they were not made with it."""
    q, w, motion = a3
    c = compliance(kuka, q, DPP)
    model = np.einsum("nij,nj->ni", c, w)
    d, r = motion["dpp"]
    np.testing.assert_allclose(d, model[:, :3], rtol=0, atol=1e-7 * np.abs(d).max())
    np.testing.assert_allclose(r, model[:, 3:], rtol=0, atol=1e-7 * np.abs(r).max())
    assert not np.array_equal(d, model[:, :3])


@pytest.mark.parametrize("method", ["cp", "dpp"])
@pytest.mark.parametrize("truth", ["cp", "dpp"])
def test_table_a3_poses_with_table_3_4_round_trip(kuka, a3, method, truth):
    q, w, motion = a3
    d, r = motion[truth]
    res = identify(kuka, LoadTests(q, w, d, r), method)
    k = CP if truth == "cp" else DPP
    np.testing.assert_allclose(res.stiffness, k, rtol=1e-6)
    assert res.method is Method(method)
    assert res.dof_residual == 30 * 6 - 6
    assert np.abs(res.residual).max() < 1e-7 * np.abs(d).max()
    assert 1.0 <= res.condition_number < 10.0
    assert not res.warnings


@pytest.mark.parametrize("method", ["cp", "dpp"])
def test_noisy_tests_recover_stiffness_within_stated_standard_errors(kuka, a3, method):
    """Monte Carlo: the errors are covered by the standard errors as a normal law says, and
    the standard errors match the spread of the estimates; the noise estimate is unbiased."""
    q, w, motion = a3
    d, r = motion["dpp"]
    sd_t, sd_r = 0.02e-3, 0.01e-3  # 0.02 mm, 0.01 mrad
    rng = np.random.default_rng(7 if method == "cp" else 8)
    ks, ses, sig = [], [], []
    for _ in range(120):
        res = identify(kuka, LoadTests(q, w, d + rng.normal(0, sd_t, d.shape),
                                       r + rng.normal(0, sd_r, r.shape)), method)
        ks.append(res.stiffness)
        ses.append(res.stiffness_se)
        sig.append(res.sigma)
    ks, ses = np.array(ks), np.array(ses)
    z = (ks - DPP) / ses
    assert np.abs(z).max() < 4.5
    assert 0.88 <= np.mean(np.abs(z) < 2) <= 0.99  # 0.954 for a normal law
    ratio = ks.std(axis=0) / ses.mean(axis=0)
    assert np.all((ratio > 0.75) & (ratio < 1.3)), ratio
    assert 0.9 < ratio.mean() < 1.1, ratio  # each ratio is known to about 7 %
    np.testing.assert_allclose(np.mean(sig, axis=0), [sd_t, sd_r], rtol=0.05)


def test_one_noise_group_is_textbook_least_squares():
    """One group: s^2 = RSS / (m - p) and cov = s^2 (A^T A)^-1; two groups with rows scaled
    1000x: the same x, each group's noise in its own unit."""
    rng = np.random.default_rng(9)
    a = rng.normal(size=(40, 4))
    b = a @ np.array([1.0, -2.0, 0.5, 3.0]) + rng.normal(0, 0.1, 40)
    fit = linear_fit(a, b)
    x, rss = np.linalg.lstsq(a, b, rcond=None)[:2]
    s2 = rss[0] / (40 - 4)
    np.testing.assert_allclose(fit.x, x, rtol=1e-12)
    np.testing.assert_allclose(fit.sigma, [np.sqrt(s2)], rtol=1e-10)
    np.testing.assert_allclose(fit.cov, s2 * np.linalg.inv(a.T @ a), rtol=1e-10)
    assert fit.dof == 36


def test_translations_only_with_moments_and_partial_rotations(kuka, a3):
    """CP uses whatever was measured: a TCP off joint 6's axis (here: the wrench point of the
    lever) is not needed when some tests have rotations; rows without are NaN residuals."""
    q, w, motion = a3
    d, r = motion["dpp"]
    r = r.copy()
    r[::2] = np.nan
    res = identify(kuka, LoadTests(q, w, d, r), "cp")
    np.testing.assert_allclose(res.stiffness, DPP, rtol=1e-6)
    assert np.isnan(res.residual[::2, 3:]).all() and np.isfinite(res.residual[1::2]).all()
    assert res.dof_residual == 30 * 3 + 15 * 3 - 6


def test_vertical_loads_cannot_see_joint_1(kuka):
    """Forces along joint 1's (vertical) axis have no moment about it, whatever the lever:
    tau_1 = z . (r x f) + m_z = 0, so joint 1's compliance never shows."""
    q, w = table_a3_tests(kuka)
    vertical = w[:, 2] != 0  # the -z load of each pose (its lever moment is horizontal)
    q, w = q[vertical], w[vertical]
    assert np.allclose(w[:, [0, 1, 5]], 0.0)
    d, r = fk_motion(kuka, q, w, DPP)
    for method in ("cp", "dpp"):
        with pytest.raises(UnidentifiableJoints, match="joint 1:") as err:
            identify(kuka, LoadTests(q, w, d, r), method)
        assert err.value.joints == (0,)
        assert "vertical" in str(err.value)


def test_coaxial_tool_needs_a_lever_or_rotations(kuka):
    """The KR500-3's TCP is on joint 6's axis: forces at the TCP never load joint 6, and with
    translations only its rotation is never seen."""
    q, w = table_a3_tests(kuka, lever=0.0)
    d, r = fk_motion(kuka, q, w, DPP)
    with pytest.raises(UnidentifiableJoints, match="no test puts a torque on joint 6") as err:
        identify(kuka, LoadTests(q, w, d, r), "cp")
    assert err.value.joints == (5,)
    q, w = table_a3_tests(kuka)
    d, r = fk_motion(kuka, q, w, DPP)
    with pytest.raises(UnidentifiableJoints, match="measured TCP rotations") as err:
        identify(kuka, LoadTests(q, w, d), "cp")
    assert err.value.joints == (5,)


def test_wrist_singular_poses_confound_joints_4_and_6(kuka):
    """At q5 = 0 the axes of joints 4 and 6 coincide: only the sum of their compliances shows."""
    q = np.deg2rad(TABLE_A3_DEG).copy()
    q[:, 4] = 0.0
    w = load_wrenches(forward_kinematics(kuka, q), 1000.0, 0.2)
    q, w = np.repeat(q, 3, axis=0), w.reshape(-1, 6)
    d, r = fk_motion(kuka, q, w, DPP)
    with pytest.raises(UnidentifiableJoints, match="joints 4, 6 separately") as err:
        identify(kuka, LoadTests(q, w, d, r), "cp")
    assert err.value.joints == (3, 5)


def test_dpp_needs_rotations_and_a_spherical_wrist(kuka, ur10, a3):
    q, w, motion = a3
    with pytest.raises(InputError, match="drx_mrad"):
        identify(kuka, LoadTests(q, w, motion["dpp"][0]), "dpp")
    qu = np.random.default_rng(3).uniform(-2, 2, (6, 6))
    wu = load_wrenches(forward_kinematics(ur10, qu), 100.0, 0.1).reshape(-1, 6)
    qu = np.repeat(qu, 3, axis=0)
    k = np.array([5, 5, 3, 1, 1, 1]) * 1e4
    du, ru = fk_motion(ur10, qu, wu, k)
    with pytest.raises(InputError, match="spherical wrist"):
        identify(ur10, LoadTests(qu, wu, du, ru), "dpp")
    np.testing.assert_allclose(identify(ur10, LoadTests(qu, wu, du, ru), "cp").stiffness, k,
                               rtol=1e-6)


def test_warnings_are_typed(kuka, a3):
    q, w, motion = a3
    d, r = motion["dpp"]
    rng = np.random.default_rng(0)
    # noise as large as the signal: the result is meaningless and says so
    noisy = identify(kuka, LoadTests(q, w, d + rng.normal(0, 3e-3, d.shape),
                                     r + rng.normal(0, 3e-3, r.shape)), "cp")
    kinds = {x.kind for x in noisy.warnings}
    assert WarningKind.ILL_CONDITIONED in kinds and WarningKind.POORLY_DETERMINED in kinds
    # one pose, one load, six measured values: exact, no standard error
    one = identify(kuka, LoadTests(q[:1], w[:1], d[:1], r[:1]), "cp")
    np.testing.assert_allclose(one.stiffness, DPP, rtol=1e-6)
    assert [x.kind for x in one.warnings] == [WarningKind.NO_REDUNDANCY]
    assert np.isnan(one.stiffness_se).all()
    # a near-singular pose (A5 at 1 deg) is named; K_c of 10 kN loads is not negligible
    qs = q.copy()
    qs[:3, 4] = np.deg2rad(1.0)
    ds, rs = fk_motion(kuka, qs, w, DPP)
    near = identify(kuka, LoadTests(qs, w, ds, rs), "cp")
    (warn,) = [x for x in near.warnings if x.kind is WarningKind.NEAR_SINGULAR_POSE]
    assert warn.tests == (0, 1, 2) and warn.value > 100
    heavy = identify(kuka, LoadTests(q, w * 10, d * 10, r * 10), "cp")
    assert [x.kind for x in heavy.warnings] == [WarningKind.GEOMETRY_CHANGE]
    # displacements against the load: negative compliances
    wrong = identify(kuka, LoadTests(q, w, -d, -r), "cp")
    (neg,) = [x for x in wrong.warnings if x.kind is WarningKind.NON_PHYSICAL]
    assert neg.joints == (0, 1, 2, 3, 4, 5)
    assert "joint 1" in neg.text()


def test_identification_matrix_is_the_compliance_model(kuka, a3):
    """A x = C W column by column: x = e_i gives joint i's contribution J_i (J^T W)_i."""
    q, w, _ = a3
    a = identification_matrix(tcp_jacobians(kuka, q), w)
    x = 1.0 / DPP
    np.testing.assert_allclose(np.einsum("nij,j->ni", a, x),
                               np.einsum("nij,nj->ni", compliance(kuka, q, DPP), w),
                               rtol=1e-12, atol=1e-18)


def test_suggested_poses_beat_random_designs_and_identify(kuka):
    plan = suggest_poses(kuka, 6, candidates=PoseCandidates(count=400, seed=11))
    assert plan.q.shape == (6, 6) and plan.wrench.shape == (6, 3, 6)
    assert np.all((plan.q >= kuka.q_lower) & (plan.q <= kuka.q_upper))
    assert np.all(plan.jacobian_condition <= 100) and np.all(plan.tcp_position[:, 2] >= 0)
    assert len(np.unique(plan.q, axis=0)) == 6
    again = suggest_poses(kuka, 6, candidates=PoseCandidates(count=400, seed=11))
    np.testing.assert_array_equal(plan.q, again.q)

    def log_det(q: np.ndarray) -> float:
        w = load_wrenches(forward_kinematics(kuka, q), 1000.0, 0.2)
        a = identification_matrix(tcp_jacobians(kuka, np.repeat(q, 3, axis=0)),
                                  w.reshape(-1, 6)) / kuka.stiffness["cp"]
        a = a.reshape(-1, 6)
        return np.linalg.slogdet(a.T @ a)[1]

    assert log_det(plan.q) == pytest.approx(plan.log_det, abs=1e-6)
    rng = np.random.default_rng(0)
    span = kuka.q_upper - kuka.q_lower
    random_designs = [log_det(rng.uniform(kuka.q_lower + 0.05 * span,
                                          kuka.q_upper - 0.05 * span, (6, 6)))
                      for _ in range(50)]
    assert plan.log_det > max(random_designs)
    # the plan, measured, identifies the stiffness
    q = np.repeat(plan.q, 3, axis=0)
    w = plan.wrench.reshape(-1, 6)
    d, r = fk_motion(kuka, q, w, DPP)
    np.testing.assert_allclose(identify(kuka, LoadTests(q, w, d, r), "dpp").stiffness, DPP,
                               rtol=1e-6)


def test_suggestion_refuses_plans_that_cannot_identify(kuka):
    with pytest.raises(UnidentifiableJoints, match="joint 6") as err:
        suggest_poses(kuka, 5, PlanLoads(lever=0.0), PoseCandidates(count=200))
    assert err.value.joints == (5,)
    with pytest.raises(UnidentifiableJoints, match="rotations"):
        suggest_poses(kuka, 5, PlanLoads(rotations=False), PoseCandidates(count=200))
    with pytest.raises(InputError, match="1 to 200"):
        suggest_poses(kuka, 0)


def test_compliance_scale_from_measured_deflections(kuka):
    """Measurements made with every stiffness divided by 1.7 give the scale 1.7, for vectors and
    for maxima of norms alike (deflection is homogeneous of degree 1 in the compliance)."""
    q = np.deg2rad(TABLE_A3_DEG[:4])
    f = np.random.default_rng(2).normal(size=(4, 36, 3)) * 300.0  # e.g. forces over a revolution
    pred = np.einsum("nij,nkj->nki", compliance(kuka, q, DPP)[:, :3, :3], f)
    meas = np.einsum("nij,nkj->nki", compliance(kuka, q, DPP / 1.7)[:, :3, :3], f)
    fit = fit_compliance_scale(pred, meas)
    assert fit.value == pytest.approx(1.7, rel=1e-12)
    peak = fit_compliance_scale(np.linalg.norm(pred, axis=-1).max(axis=1)[:1],
                                np.linalg.norm(meas, axis=-1).max(axis=1)[:1])
    assert peak.value == pytest.approx(1.7, rel=1e-12) and np.isnan(peak.standard_error)
    rng = np.random.default_rng(4)
    zs = []
    for _ in range(200):
        noisy = meas + rng.normal(0, 2e-5, meas.shape)
        fit = fit_compliance_scale(pred, noisy)
        zs.append((fit.value - 1.7) / fit.standard_error)
    assert np.abs(zs).max() < 4.5 and 0.85 < np.std(zs) < 1.15
    with pytest.raises(InputError, match="must match"):
        fit_compliance_scale(pred, meas[:2])


def test_point_offset_from_a_second_tcp(kuka, tmp_path):
    """The deflection of a point 120 mm up the tool axis, computed with a robot whose TCP is
    there (its own Jacobian), gives the offset back from vectors and from magnitudes."""
    shutil.copytree(KUKA_DIR, tmp_path / "r")
    doc = yaml.safe_load((tmp_path / "r" / "robot.yaml").read_text())
    doc["tool"]["tcp_xyz_mm"] = [400.0 - 120.0, 0.0, 0.0]  # TCP +z = -flange x
    (tmp_path / "r" / "robot.yaml").write_text(yaml.safe_dump(doc))
    up = load_robot(tmp_path / "r")
    q = np.deg2rad(TABLE_A3_DEG[:5])
    f = np.random.default_rng(5).normal(size=(5, 3)) * 500.0
    w = np.hstack([f, np.zeros((5, 3))])
    j_tcp, j_up = tcp_jacobians(kuka, q), tcp_jacobians(up, q)
    dq = np.einsum("nij,ni->nj", j_tcp, w) / DPP
    measured = np.einsum("nij,nj->ni", j_up, dq)[:, :3]
    d, t = point_offset_terms(kuka, q, f, DPP)
    vec = fit_point_offset(d, t, measured)
    assert vec.value == pytest.approx(0.12, abs=1e-9)
    mag = fit_point_offset(d[:, None, :], t[:, None, :], np.linalg.norm(measured, axis=1))
    assert mag.value == pytest.approx(0.12, abs=1e-7)
    # one magnitude is met on both sides of the vertex of |d + L t|^2 (a parabola in L):
    # L = 0.12 and its mirror image, both given
    mirror = -2.0 * (d[0] @ t[0]) / (t[0] @ t[0]) - 0.12
    span = abs(mirror) + 0.5
    one = fit_point_offset(d[:1, None, :], t[:1, None, :],
                           np.linalg.norm(measured[:1], axis=1), bounds=(-span, span))
    found = sorted([one.value, *one.alternatives])
    np.testing.assert_allclose(found, sorted([0.12, mirror]), atol=1e-7)


# --------------------------------------------------------------------------- repeats (issue 26)


def _means(groups: np.ndarray, *arrays: np.ndarray) -> list[np.ndarray]:
    """Per-group means, by a plain loop (independent of the library's np.add.at)."""
    return [np.array([a[groups == g].mean(axis=0) for g in range(groups.max() + 1)])
            for a in arrays]


def test_repeats_are_averaged_into_the_distinct_tests(kuka, a3):
    """Four noisy repeats of each Table A.3 test (load cell readings within 0.3 %, poses within
    0.002 deg) give exactly the fit of the 30 averaged tests: same stiffness, standard errors,
    noise and residual degrees of freedom (30 x 6 - 6, not 120 x 6 - 6); the scatter of the
    repeats is the repeat noise."""
    q, w, motion = a3
    d, r = motion["dpp"]
    rng = np.random.default_rng(21)
    reps = 4
    qr = np.repeat(q, reps, axis=0) + rng.uniform(-1, 1, (120, 6)) * np.deg2rad(0.002)
    wr = np.repeat(w, reps, axis=0) * (1 + rng.uniform(-0.003, 0.003, (120, 1)))
    dr, rr = fk_motion(kuka, qr, wr, DPP)
    sd_t, sd_r = 0.01e-3, 0.005e-3
    dr, rr = dr + rng.normal(0, sd_t, dr.shape), rr + rng.normal(0, sd_r, rr.shape)
    order = rng.permutation(120)  # repeats need not be next to each other
    tests = LoadTests(qr[order], wr[order], dr[order], rr[order])
    groups = np.repeat(np.arange(30), reps)[order]
    for method in ("cp", "dpp"):
        res = identify(kuka, tests, method)
        first = np.unique(groups, return_index=True)[1]  # numbered by first appearance
        relabel = np.argsort(np.argsort(first))
        np.testing.assert_array_equal(res.test_group, relabel[groups])
        assert res.n_distinct == 30 and res.dof_residual == 30 * 6 - 6
        alone = identify(kuka, LoadTests(*_means(groups, qr[order], wr[order], dr[order],
                                                 rr[order])), method)
        np.testing.assert_allclose(res.stiffness, alone.stiffness, rtol=1e-9)
        np.testing.assert_allclose(res.stiffness_se, alone.stiffness_se, rtol=1e-6)
        np.testing.assert_allclose(res.sigma, alone.sigma, rtol=1e-6)
        np.testing.assert_allclose(res.stiffness, DPP, rtol=0, atol=5 * res.stiffness_se.max())
        assert res.repeatability_dof == 3 * 30 * (reps - 1)
        np.testing.assert_allclose(res.repeatability, [sd_t, sd_r], rtol=0.15)
        assert res.residual.shape == (120, 6) and np.all(np.isfinite(res.residual))
        assert not [x for x in res.warnings if x.kind is WarningKind.EXACT_COPIES]


def test_exact_copies_count_once_and_are_named(kuka, a3):
    """Copies of tests change nothing but the warning: the stiffness and standard errors of
    the distinct tests alone; 30 copies of one test leave no residual, so no standard error
    (not 1e-15) and no noise estimate."""
    q, w, motion = a3
    d, r = motion["dpp"]
    noisy = d + np.random.default_rng(3).normal(0, 1e-5, d.shape)
    alone = identify(kuka, LoadTests(q, w, noisy, r), "cp")
    idx = np.r_[np.arange(30), 4, 4, 17]
    res = identify(kuka, LoadTests(q[idx], w[idx], noisy[idx], r[idx]), "cp")
    np.testing.assert_allclose(res.stiffness, alone.stiffness, rtol=1e-12)
    np.testing.assert_allclose(res.stiffness_se, alone.stiffness_se, rtol=1e-6)
    assert res.dof_residual == alone.dof_residual == 174
    (copies,) = [x for x in res.warnings if x.kind is WarningKind.EXACT_COPIES]
    assert copies.tests == (30, 31, 32) and "look like copies" in copies.text()
    assert np.array_equal(res.repeatability, [0.0, 0.0])
    one = identify(kuka, LoadTests(*(np.repeat(a[:1], 30, axis=0) for a in (q, w, noisy, r))),
                   "cp")
    assert one.n_distinct == 1 and one.dof_residual == 0
    assert np.isnan(one.stiffness_se).all() and np.isnan(one.sigma).all()
    kinds = [x.kind for x in one.warnings]
    assert WarningKind.NO_REDUNDANCY in kinds and WarningKind.EXACT_COPIES in kinds
    assert "repeats of a test count once" in one.warnings[0].text()


def test_standard_errors_hold_when_repeats_cannot_average_the_error_out(kuka, a3):
    """Monte Carlo: each distinct test carries a systematic error (setup, model) that its
    repeats share, plus repeat noise. The stated standard errors (from the residuals of the
    means) match the spread of the estimates; counting the 4 repeats as independent tests
    (the fit of all rows, as before issue 26) understates them by about half."""
    q, w, motion = a3
    d, r = motion["dpp"]
    reps, sys_t, sys_r, rep_t, rep_r = 4, 0.01e-3, 0.005e-3, 0.004e-3, 0.002e-3
    rng = np.random.default_rng(5)
    a = identification_matrix(tcp_jacobians(kuka, np.repeat(q, reps, axis=0)),
                              np.repeat(w, reps, axis=0)).reshape(-1, 6)
    groups = np.tile(np.arange(6) >= 3, 30 * reps).astype(int)
    ks, ses, naive = [], [], []
    for _ in range(100):
        dt = np.repeat(d + rng.normal(0, sys_t, d.shape), reps, axis=0)
        rt = np.repeat(r + rng.normal(0, sys_r, r.shape), reps, axis=0)
        dt, rt = dt + rng.normal(0, rep_t, dt.shape), rt + rng.normal(0, rep_r, rt.shape)
        res = identify(kuka, LoadTests(np.repeat(q, reps, axis=0), np.repeat(w, reps, axis=0),
                                       dt, rt), "cp")
        ks.append(res.stiffness)
        ses.append(res.stiffness_se)
        fit = linear_fit(a, np.hstack([dt, rt]).ravel(), groups)
        naive.append(np.sqrt(np.diag(fit.cov)) * res.stiffness**2)
    ks, ses, naive = np.array(ks), np.array(ses), np.array(naive)
    ratio = ks.std(axis=0) / ses.mean(axis=0)
    assert np.all((ratio > 0.7) & (ratio < 1.35)), ratio
    assert 0.85 < ratio.mean() < 1.15, ratio
    assert np.all(ks.std(axis=0) / naive.mean(axis=0) > 1.5)  # rows as independent: too small


def test_repeat_groups_tolerances():
    """Same pose within 0.01 deg and load within 2 % of the larger: one test; beyond, or one
    measuring rotations and the other not: two."""
    q = np.zeros((7, 6))
    q[1, 2] = np.deg2rad(0.009)
    q[2, 2] = np.deg2rad(0.011)
    w = np.tile([1000.0, 0, 0, 0, 200.0, 0], (7, 1))
    w[3, 0] = 1015.0  # 1.5 % of the load: a repeat
    w[4, 0] = 1030.0  # 3 %: another load
    w[5, 4] = 230.0  # moment 30 N m (at 1 m) of a 1020 N m-scale wrench: 2.9 %: another test
    rot = np.array([True] * 6 + [False])
    np.testing.assert_array_equal(repeat_groups(q, w, rot), [0, 0, 1, 0, 2, 3, 4])


@budget(40)
@given(data=st.data(), method=st.sampled_from(["cp", "dpp"]))
def test_odd_measurements_never_raise_linalg_errors(kuka, a3, data, method):
    """Zeros, subnormals, 1e308, repeats of few tests, sign flips: identify returns or refuses
    with an InputError; never a LinAlgError or another exception."""
    q, w, motion = a3
    n = data.draw(st.integers(1, 6))
    rows = np.array(data.draw(st.lists(st.integers(0, 29), min_size=n, max_size=n)))
    value = st.sampled_from([0.0, -0.0, 5e-324, 1e-300, 1e-9, 1e-3, -1e-3, 0.05, 0.2, 1e308])
    scale = np.array(data.draw(st.lists(value, min_size=6, max_size=6)))
    d, r = motion["dpp"]
    reps = data.draw(st.integers(1, 30))
    idx = np.repeat(rows, reps)
    tests = LoadTests(q[idx], w[idx], d[idx] / np.abs(d[idx]).max() * scale[:3],
                      r[idx] / np.abs(r[idx]).max() * scale[3:])
    try:
        res = identify(kuka, tests, method)
    except InputError as exc:
        assert str(exc).strip()
        event("refused")
        return
    event("identified")
    assert np.all(np.isfinite(res.compliance))
    assert np.all(np.isnan(res.stiffness_se) | (res.stiffness_se >= 0))


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d, r: (d * 0, r), "the measurements show no deflection"),
    (lambda d, r: (d * 0 + 1e-300, r), "show no deflection"),
    (lambda d, r: (d, r * 0), "every measured rotation is 0"),
    (lambda d, r: (d * 1e308 / np.abs(d).max(), r), "beyond the 0.1 m"),
    (lambda d, r: (d, r * 1e5), "beyond the 0.1 rad"),
])
def test_no_deflection_and_absurd_values_are_refused(kuka, a3, edit, message):
    q, w, motion = a3
    d, r = edit(*motion["dpp"])
    with pytest.raises(InputError, match=message):
        identify(kuka, LoadTests(q, w, d, r), "cp")
    with pytest.raises(InputError, match="beyond the 100000 N"):
        identify(kuka, LoadTests(q, w * 1e3, *motion["dpp"]), "cp")
