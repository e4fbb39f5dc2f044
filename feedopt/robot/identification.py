"""Joint-stiffness identification from static load tests (thesis 3.4, Eq. 3.19-3.20).

A test applies a wrench ``W = [f; m]`` at the TCP (base axes) at a pose ``q`` and measures the
TCP displacement ``d`` (and, with a 6-DoF tracker, the rotation ``dtheta``). The six-parameter
model of Eq. 3.19, ``[d; dtheta] = J K^-1 J^T W``, is linear in the joint compliances
``x_i = 1/k_i``::

    [d; dtheta] = J diag(J^T W) x                        (Eq. 3.19, one test)

so stacking the tests gives ``b = A x``, solved by linear least squares (:func:`identify`).

* **CP** (complete pose, Eq. 3.19): all six compliances at once.
* **DPP** (decoupled partial pose, Eq. 3.20): the arm term ``J K_123^-1 J^T`` and the wrist
  term ``J K_456^-1 J^T`` are identified one after the other. The wrist axes 4-6 of a spherical
  wrist meet in the wrist centre, which the wrist joints cannot move: its displacement
  ``d + dtheta x (p_wc - p_tcp)`` (rigid flange) depends on ``x_1..3`` only, and gives them
  first; the wrist compliances then fit what the arm leaves of ``[d; dtheta]``. This needs
  the measured rotations. (The thesis names its reference [41] for the decoupling without
  giving its procedure; this is our reading of Eq. 3.20, stated here so it can be checked.)

Noise: translations and rotations are two groups with their own variance, estimated from the
residuals without bias for the linear estimator used (method of moments on
``E[r r^T] = (I - A M) S (I - A M)^T``); the rows are weighted by them (three passes of feasible
generalised least squares). Standard errors are ``sqrt(diag(M S M^T))`` for the estimator
``x = M b``, propagated to ``k = 1/x`` to first order (``se_k = se_x / x^2``).

Repeats: tests at the same pose and load (within :data:`REPEAT_ANGLE_RAD` and
:data:`REPEAT_LOAD_REL`, :func:`repeat_groups`) are one test measured several times. They are
averaged into one distinct test before the fit, so every distinct test counts once (as the
distinct tests alone would, with their means as values) and the residual degrees of freedom
count distinct tests. The noise behind the standard errors is then estimated from the
residuals of the means, which holds whatever part of the misfit the repeats cannot average
out (setup and model errors); the scatter of the repeats about their means is reported
separately as the repeatability (pooled, after the small differences in pose and load are
taken out with the fitted model). Repeats alone (one distinct test measured 30 times) leave
no residual for the means: no standard error, said so. Values identical to the last digit
are flagged: a real repeat never is, so they are copies.

Identifiability: a joint whose compliance does not change the measurements (e.g. joint 1 under
vertical loads only, joint 6 when every force acts on its axis) makes ``A`` rank deficient;
:class:`UnidentifiableJoints` names it. The condition number is that of ``A`` with its
columns scaled to unit norm (weighted rows), which is close to the smallest over column
scalings (van der Sluis 1969), so it does not depend on units.

:func:`suggest_poses` picks test poses by D-optimality; :func:`fit_compliance_scale` and
:func:`fit_point_offset` fit one parameter to a few measured deflections.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np
from scipy.optimize import minimize_scalar, nnls
from scipy.spatial import cKDTree

from feedopt.errors import InputError
from feedopt.robot.ik import IKOptions
from feedopt.robot.model import (
    RobotModel,
    forward_kinematics,
    jacobian_condition_number,
    tcp_jacobians,
)
from feedopt.robot.stiffness import (
    complementary_ratio,
    complementary_stiffness,
    compliance,
    joint_stiffness,
)

#: Arm joints of Eq. 3.20 (the rest is the wrist).
N_ARM = 3
#: Column-scaled singular value ratio below which a direction of ``x`` is not identified.
RANK_TOL = 1e-9
#: Column norm (relative to the largest) below which a joint never affects the measurements.
UNSEEN_TOL = 1e-9
#: Largest wrist-axis miss distance [m] that still counts as a spherical wrist (DPP).
SPHERICAL_TOL = 1e-6
#: Warn when the compliances' relative error bound (condition number x noise/signal) exceeds it.
ERROR_BOUND_WARN = 0.5
#: Warn when a stiffness's standard error exceeds this fraction of it.
RELATIVE_SE_WARN = 0.25
#: Warn when K_c of a test is this large relative to K: Eq. 3.19 neglects it (Eq. 3.18), which
#: biases the stiffnesses by up to about twice this ratio (KR500-3, Table A.3 poses).
GEOMETRY_RATIO_WARN = 0.01
#: Poses above this Jacobian condition number are near-singular (as ``feedopt run``'s IK).
NEAR_SINGULAR = IKOptions().max_condition
#: Most tests read (each costs a Jacobian and a complementary-stiffness evaluation).
MAX_TESTS = 10_000
#: Largest pose plan and candidate set of :func:`suggest_poses` (a plan of 200 poses from
#: 20000 candidates takes about 3 s here).
MAX_POSES = 200
MAX_CANDIDATES = 20_000
#: Most exchange passes of the D-optimal search.
EXCHANGE_PASSES = 20
#: Starting noise guess of both groups [m], [rad] (equal weights: 1 mm counts as 1 mrad).
_SIGMA0 = 1e-5
#: Largest magnitude of a load-test value: beyond it the row is not a static load test of a
#: robot but a typo, a unit slip or garbage (the linear model of Eq. 3.19 holds far below).
MAX_FORCE_N = 1e5  # 100 kN, ten times the heaviest robot payload
MAX_MOMENT_NM = 1e5  # 100 kN m
MAX_DISPLACEMENT_M = 0.1  # 100 mm
MAX_ROTATION_RAD = 0.1  # 100 mrad (5.7 deg)
#: Below these largest measured values the tests show no deflection (no instrument resolves
#: 0.1 um or 0.1 urad): an infinitely stiff robot, or measurements not filled in.
MIN_DEFLECTION_M = 1e-7
MIN_ROTATION_RAD = 1e-7
#: Two tests are repeats of one when every joint angle agrees within REPEAT_ANGLE_RAD
#: (0.01 deg, the resolution of Table A.3's poses) and their wrenches within REPEAT_LOAD_REL
#: of the larger one (forces [N] and moments [N m] over a lever of WRENCH_LENGTH_M: the same
#: weights, or a load cell's reading of the same set load), and both or neither measure the
#: rotation.
REPEAT_ANGLE_RAD = float(np.deg2rad(0.01))
REPEAT_LOAD_REL = 0.02
WRENCH_LENGTH_M = 1.0


class Method(StrEnum):
    """Identification method (thesis 3.4)."""

    CP = "cp"  # Eq. 3.19: the six compliances together
    DPP = "dpp"  # Eq. 3.20: arm (wrist-centre displacement), then wrist


class WarningKind(StrEnum):
    """What an :class:`IdentificationWarning` is about."""

    ILL_CONDITIONED = "ill_conditioned"  # cond x noise/signal: the result may be meaningless
    POORLY_DETERMINED = "poorly_determined"  # a stiffness with a large standard error
    NON_PHYSICAL = "non_physical"  # a fitted compliance <= 0 (stiffness negative/infinite)
    NO_REDUNDANCY = "no_redundancy"  # as many measurements as unknowns: no standard errors
    NEAR_SINGULAR_POSE = "near_singular_pose"  # K_c not negligible there (thesis 3.4)
    GEOMETRY_CHANGE = "geometry_change"  # load large enough that Eq. 3.18's K_c matters
    EXACT_COPIES = "exact_copies"  # tests identical to an earlier one in every value


@dataclass(frozen=True)
class IdentificationWarning:
    """A caveat on an identification: its kind, the joints / tests concerned and the number.

    ``joints`` and ``tests`` are 0-based indices; ``value`` is the quantity compared with its
    threshold (error bound, relative standard error, condition number, K_c ratio).
    """

    kind: WarningKind
    value: float
    joints: tuple[int, ...] = ()
    tests: tuple[int, ...] = ()

    def text(self, test_names: list[str] | None = None) -> str:
        """One-line explanation (tests named by ``test_names`` when given)."""
        joints = ", ".join(str(j + 1) for j in self.joints)
        names = [test_names[t] if test_names else f"test {t + 1}" for t in self.tests]
        tests = ", ".join(names[:8]) + (f" and {len(names) - 8} more" if len(names) > 8 else "")
        if self.kind is WarningKind.ILL_CONDITIONED:
            return (f"the identification is ill conditioned for this noise: the compliances "
                    f"may be off by up to {self.value:.0%} (condition number x noise/signal); "
                    "add poses (feedopt calibrate-stiffness --suggest) or larger loads")
        if self.kind is WarningKind.POORLY_DETERMINED:
            return (f"joint {joints}: standard error {self.value:.0%} of the stiffness; the "
                    "tests load this joint too little: add poses or loads that do")
        if self.kind is WarningKind.NON_PHYSICAL:
            return (f"joint {joints}: fitted compliance <= 0 (no physical stiffness); the "
                    "tests do not determine this joint against the noise")
        if self.kind is WarningKind.NO_REDUNDANCY:
            return ("the distinct tests give as many measured values as unknowns (repeats of "
                    "a test count once): the fit is exact and no standard error can be "
                    "estimated; add tests at other poses or loads")
        if self.kind is WarningKind.EXACT_COPIES:
            return (f"{tests}: identical to an earlier test in every value; a repeat "
                    "measurement never agrees to the last digit, so these look like copies "
                    "(counted once with the original, as every repeat is): remove them or give "
                    "the real readings")
        if self.kind is WarningKind.NEAR_SINGULAR_POSE:
            return (f"{tests}: near-singular pose (Jacobian condition number up to "
                    f"{self.value:.3g} > {NEAR_SINGULAR:g}), where the neglected K_c of Eq. 3.18 "
                    "is not small (thesis 3.4)")
        return (f"{tests}: the load changes the geometry (K_c of Eq. 3.18 up to "
                f"{self.value:.1%} of K), which Eq. 3.19 neglects: expect a bias of up to about "
                "twice that; use smaller loads")


class UnidentifiableJoints(InputError):
    """The tests cannot identify these joints (0-based ``joints``); the message says why."""

    def __init__(self, message: str, joints: tuple[int, ...]) -> None:
        super().__init__(message)
        self.joints = joints


@dataclass(frozen=True)
class LoadTests:
    """Static load tests in SI units (one row per pose and load).

    Attributes
    ----------
    q : (n, dof) joint angles [rad]
    wrench : (n, 6) ``[f; m]`` applied at the TCP, base axes [N, N m]
    displacement : (n, 3) measured TCP displacement, base axes [m]
    rotation : (n, 3) measured TCP rotation (rotation vector, base axes) [rad], NaN rows where
        not measured; or None
    """

    q: np.ndarray
    wrench: np.ndarray
    displacement: np.ndarray
    rotation: np.ndarray | None = None


@dataclass(frozen=True)
class StiffnessIdentification:
    """Result of :func:`identify` (SI units, joints in configuration order).

    Attributes
    ----------
    method : Method
    stiffness, stiffness_se : (dof,) joint stiffness and standard error [N m/rad]
    compliance : (dof,) fitted ``x = 1/k`` [rad/(N m)]; compliance_cov : (dof, dof)
    residual : (n, 6) measured - predicted ``[d; dtheta]`` [m, rad], NaN where not measured
    sigma : (2,) noise estimate of translations [m] and rotations [rad] (NaN: not measured)
    condition_number : column-scaled condition number (DPP: the larger of the two stages)
    dof_residual : measured values of the distinct tests minus unknowns
    warnings : typed caveats (:class:`IdentificationWarning`); their ``tests`` are rows
    test_group : (n,) index of the distinct test (repeats merged) each row belongs to
    repeatability : (2,) pooled scatter of repeats about their means, translation [m] and
        rotation [rad] (NaN: no repeats)
    repeatability_dof : degrees of freedom of the translation repeatability (0: no repeats)
    """

    method: Method
    stiffness: np.ndarray
    stiffness_se: np.ndarray
    compliance: np.ndarray
    compliance_cov: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    condition_number: float
    dof_residual: int
    warnings: tuple[IdentificationWarning, ...]
    test_group: np.ndarray
    repeatability: np.ndarray
    repeatability_dof: int

    @property
    def n_distinct(self) -> int:
        """Number of distinct tests (repeats merged)."""
        return int(self.test_group.max()) + 1 if self.test_group.size else 0


# --------------------------------------------------------------------------- the model


def identification_matrix(jacobians: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """``A`` (n, 6, dof) with ``[d; dtheta] = A x``, ``x = 1/k`` [rad/(N m)].

    ``J K^-1 J^T W = J diag(J^T W) x`` (Eq. 3.19): column ``i`` is joint ``i``'s Jacobian
    column times the torque ``(J^T W)_i`` the test puts on it.
    """
    tau = np.einsum("nij,ni->nj", jacobians, wrench)
    return jacobians * tau[:, None, :]


def _wrist_centre_offsets(jacobians: np.ndarray) -> np.ndarray:
    """``u = p_wc - p_tcp`` (n, 3) [m]: the point no wrist joint moves (``v_j + w_j x u = 0``).

    InputError when axes 4-6 do not meet (no spherical wrist: DPP does not apply).
    """
    v, w = jacobians[:, :3, N_ARM:], jacobians[:, 3:, N_ARM:]  # (n, 3, 3): columns = joints
    n = jacobians.shape[0]
    # w_j x u = -v_j  ->  [w_j]x u = -v_j, three joints stacked (9 x 3) per pose
    skew = np.zeros((n, 3, 3, 3))
    wj = np.swapaxes(w, 1, 2)  # (n, joint, 3)
    skew[..., 0, 1], skew[..., 0, 2] = -wj[..., 2], wj[..., 1]
    skew[..., 1, 0], skew[..., 1, 2] = wj[..., 2], -wj[..., 0]
    skew[..., 2, 0], skew[..., 2, 1] = -wj[..., 1], wj[..., 0]
    lhs = skew.reshape(n, 9, 3)
    rhs = -np.swapaxes(v, 1, 2).reshape(n, 9)
    u = np.linalg.solve(np.swapaxes(lhs, 1, 2) @ lhs,
                        np.einsum("nki,nk->ni", lhs, rhs)[..., None])[..., 0]
    miss = np.abs(np.einsum("nki,ni->nk", lhs, u) - rhs).max()
    if not miss <= SPHERICAL_TOL:
        raise InputError(
            f"--method dpp needs a spherical wrist (axes 4-6 meeting in one point); this "
            f"robot's wrist axes miss each other by {miss * 1e3:.3g} mm: use --method cp")
    return u


# --------------------------------------------------------------------------- least squares


@dataclass(frozen=True)
class LinearFit:
    """``x = M b`` (``estimator`` M), its covariance, noise per group, residual dof."""

    x: np.ndarray
    cov: np.ndarray
    sigma: np.ndarray  # per group
    dof: int
    estimator: np.ndarray  # M, x = M b


def _noise(a: np.ndarray, m: np.ndarray, b: np.ndarray, groups: np.ndarray,
           n_groups: int) -> np.ndarray:
    """Unbiased noise standard deviation per group for the linear estimator ``x = M b``.

    ``E[sum_{i in g} r_i^2] = sum_h s_h^2 (n_g d_gh - 2 d_gh tr(M_g A_g) + ||A_g M_h||_F^2)``
    for ``r = (I - A M) b``; solved for ``s_h^2 >= 0`` (NaN when no residual is left).
    """
    r = b - a @ (m @ b)
    s = np.zeros((n_groups, n_groups))
    rss = np.zeros(n_groups)
    for g in range(n_groups):
        ig = groups == g
        rss[g] = r[ig] @ r[ig]
        gram = a[ig].T @ a[ig]
        for h in range(n_groups):
            mh = m[:, groups == h]
            s[g, h] = np.trace(gram @ mh @ mh.T)
        s[g, g] += ig.sum() - 2.0 * np.trace(m[:, ig] @ a[ig])
    if a.shape[0] <= a.shape[1] or not np.all(np.diag(s) > 1e-9):
        return np.full(n_groups, np.nan)
    var, _ = nnls(s, rss)
    return np.sqrt(var)


def _fit(a: np.ndarray, b: np.ndarray, groups: np.ndarray, n_groups: int,
         estimator) -> LinearFit:
    """Feasible weighted least squares: ``estimator(weights) -> M``, three reweighting passes."""
    sigma = np.full(n_groups, _SIGMA0)
    for _ in range(3):
        m = estimator(1.0 / sigma[groups])
        est = _noise(a, m, b, groups, n_groups)
        if not np.all(np.isfinite(est)):
            break
        sigma = np.maximum(est, max(1e-12 * est.max(), 1e-15))
    else:
        m = estimator(1.0 / sigma[groups])
    est = _noise(a, m, b, groups, n_groups)
    cov = sum(est[g] ** 2 * m[:, groups == g] @ m[:, groups == g].T for g in range(n_groups))
    return LinearFit(m @ b, np.asarray(cov), est, a.shape[0] - a.shape[1], m)


def _usable_sigma(sigma: np.ndarray) -> np.ndarray:
    """``sigma`` for row weights: NaN (no residual) -> :data:`_SIGMA0`, 0 (an exact fit) -> the
    floor of :func:`_fit`."""
    ok = np.isfinite(sigma) & (sigma > 0)
    if not ok.any():
        return np.full(sigma.shape, _SIGMA0)
    floor = max(1e-12 * float(sigma[ok].max()), 1e-15)
    return np.where(np.isfinite(sigma), np.maximum(sigma, floor), _SIGMA0)


def _weighted_pinv(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``M`` with ``M b = argmin ||w (A x - b)||``."""
    return np.linalg.pinv(a * w[:, None]) * w[None, :]


def linear_fit(a: np.ndarray, b: np.ndarray, groups: np.ndarray | None = None) -> LinearFit:
    """Weighted least squares ``b ~ A x`` with per-group noise (see the module docstring).

    Parameters
    ----------
    a : (m, p) array
    b : (m,) array
    groups : (m,) int array or None
        Noise group of each row (0, 1, ...); None: one group.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    groups = np.zeros(len(b), dtype=int) if groups is None else np.asarray(groups)
    n_groups = int(groups.max()) + 1
    return _fit(a, b, groups, n_groups, lambda w: _weighted_pinv(a, w))


def _column_condition(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column norms and singular values of ``a`` (m, p) with unit-norm columns."""
    norms = np.linalg.norm(a, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    return norms, np.linalg.svd(a / safe, compute_uv=False)


def _check_identifiable(a: np.ndarray, joints: list[int], torque: np.ndarray) -> float:
    """Condition number of ``a`` (weighted rows, columns = ``joints``), or UnidentifiableJoints.

    ``torque`` (n, len(joints)) tells "never loaded" from "loaded but not seen".
    """
    norms, s = _column_condition(a)
    unseen = [j for j, c in zip(joints, norms, strict=True) if not c > UNSEEN_TOL * norms.max()]
    if unseen:
        loaded = np.abs(torque).max(axis=0) > UNSEEN_TOL * np.abs(torque).max()
        never = [j for j in unseen if not loaded[joints.index(j)]]
        names = ", ".join(str(j + 1) for j in unseen)
        if never:
            why = (f"no test puts a torque on joint {', '.join(str(j + 1) for j in never)}: "
                   "every wrench has zero moment about its axis (e.g. only vertical loads for "
                   "joint 1, or forces acting on the axis of joint 6 for a tool coaxial with "
                   "it); add loads with a lever arm about that axis")
        else:
            why = ("where it is loaded, its rotation moves none of the measured quantities "
                   "(a TCP on the joint's axis, e.g. a tool coaxial with joint 6, with "
                   "translations only): add the measured TCP rotations (drx_mrad, dry_mrad, "
                   "drz_mrad)")
        raise UnidentifiableJoints(f"the tests cannot identify joint {names}: {why}",
                                   tuple(unseen))
    if not s[-1] > RANK_TOL * s[0]:
        safe = np.where(norms > 0, norms, 1.0)
        null = np.linalg.svd(a / safe)[2][-1]
        share = np.abs(null) / np.abs(null).max()
        bad = tuple(j for j, f in zip(joints, share, strict=True) if f > 0.2)
        raise UnidentifiableJoints(
            f"the tests cannot identify joints {', '.join(str(j + 1) for j in bad)} "
            "separately: only a combination of their compliances changes the measurements "
            "(rank-deficient identification); add poses where these joints are loaded "
            "differently (feedopt calibrate-stiffness --suggest)", bad)
    return float(s[0] / s[-1])


# --------------------------------------------------------------------------- identification


def _check_magnitudes(wrench: np.ndarray, b: np.ndarray) -> None:
    """InputError naming the first test with an absurd value, or with no deflection at all."""
    limits = [("force", wrench[:, :3], MAX_FORCE_N, "N"),
              ("moment", wrench[:, 3:], MAX_MOMENT_NM, "N m"),
              ("displacement", b[:, :3], MAX_DISPLACEMENT_M, "m"),
              ("rotation", b[:, 3:], MAX_ROTATION_RAD, "rad")]
    for name, arr, limit, unit in limits:
        big = np.argwhere(np.abs(arr) > limit)
        if big.size:
            t, c = map(int, big[0])
            raise InputError(
                f"load tests: test {t + 1}'s {name} component {c + 1} is {arr[t, c]:g} {unit}, "
                f"beyond the {limit:g} {unit} of a static load test (a unit slip?)")
    largest = float(np.abs(b[:, :3]).max())
    if not largest >= MIN_DEFLECTION_M:
        raise InputError(
            f"the measurements show no deflection: the largest measured displacement is "
            f"{largest * 1e3:g} mm (below {MIN_DEFLECTION_M * 1e3:g} mm no instrument resolves "
            "one), which would mean an infinitely stiff robot; fill in the measured TCP "
            "displacements")
    rot = np.abs(b[:, 3:])
    if not np.isnan(rot).all() and not np.nanmax(rot) >= MIN_ROTATION_RAD:
        raise InputError(
            f"every measured rotation is 0 (largest {np.nanmax(rot) * 1e3:g} mrad): a loaded "
            "robot always turns its TCP; if the rotations were not measured, leave them out")


def _check_dpp_applies(dof: int, b: np.ndarray) -> None:
    """InputError unless DPP can run: six joints, the rotation of every test measured."""
    if dof != 2 * N_ARM:
        raise InputError(f"--method dpp splits 6 joints into arm and wrist; this robot "
                         f"has {dof}: use --method cp")
    missing = np.flatnonzero(np.isnan(b[:, 3:]).any(axis=1))
    if missing.size:
        raise InputError(
            f"--method dpp needs the measured TCP rotation of every test (drx_mrad, "
            f"dry_mrad, drz_mrad) to find the wrist-centre displacement; test "
            f"{missing[0] + 1} has none: measure it or use --method cp")


def _validate(robot: RobotModel, tests: LoadTests) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(tests.q, dtype=float)
    n = q.shape[0] if q.ndim == 2 else 0
    if q.shape != (n, robot.dof) or n == 0 or not np.all(np.isfinite(q)):
        raise InputError(f"load tests: q must be n > 0 rows of {robot.dof} finite joint angles, "
                         f"got shape {q.shape}")
    if n > MAX_TESTS:
        raise InputError(f"{n} load tests is more than the {MAX_TESTS} read; a few hundred "
                         "are plenty (feedopt calibrate-stiffness --suggest)")
    for name, arr, m in (("wrench", tests.wrench, 6), ("displacement", tests.displacement, 3)):
        if np.shape(arr) != (n, m) or not np.all(np.isfinite(arr)):
            raise InputError(f"load tests: {name} must be {n} rows of {m} finite numbers")
    b = np.full((n, 6), np.nan)
    b[:, :3] = tests.displacement
    if tests.rotation is not None:
        rot = np.asarray(tests.rotation, dtype=float)
        if (rot.shape != (n, 3) or np.any(np.isinf(rot))
                or np.any(np.isnan(rot).any(axis=1) != np.isnan(rot).all(axis=1))):
            raise InputError(f"load tests: rotation must be {n} rows of 3 numbers (a row of "
                             "NaN: not measured)")
        b[:, 3:] = rot
    _check_magnitudes(np.asarray(tests.wrench, dtype=float), b)
    return q, b


def _wrench_norm(wrench: np.ndarray) -> np.ndarray:
    """``sqrt(|f|^2 + (|m| / WRENCH_LENGTH_M)^2)`` per row [N]."""
    return np.hypot(np.linalg.norm(wrench[..., :3], axis=-1),
                    np.linalg.norm(wrench[..., 3:], axis=-1) / WRENCH_LENGTH_M)


def repeat_groups(q: np.ndarray, wrench: np.ndarray, has_rotation: np.ndarray) -> np.ndarray:
    """Index (n,) of the distinct test each row repeats, numbered in order of appearance.

    A row joins the earliest row (the group's first) whose joint angles all agree within
    :data:`REPEAT_ANGLE_RAD`, whose wrench differs by at most :data:`REPEAT_LOAD_REL` of the
    larger of the two (:func:`_wrench_norm`), and that measures the rotation as it does. A k-d
    tree finds the rows with any such neighbour first, so distinct tests cost no loop.
    """
    n = q.shape[0]
    norm = _wrench_norm(wrench)
    coarse = REPEAT_LOAD_REL * max(float(norm.max()), 1e-300)  # >= every pair's tolerance
    coords = np.hstack([q / REPEAT_ANGLE_RAD, wrench / coarse, 4.0 * has_rotation[:, None]])
    dist = cKDTree(coords).query(coords, k=min(2, n), p=np.inf, distance_upper_bound=1.0)[0]
    leader = np.arange(n)
    left = np.flatnonzero(np.isfinite(dist.reshape(n, -1)[:, -1])) if n > 1 else leader[:0]
    while left.size:  # one pass per group of repeats
        first = left[0]
        same = ((np.abs(q[left] - q[first]).max(axis=1) <= REPEAT_ANGLE_RAD)
                & (_wrench_norm(wrench[left] - wrench[first])
                   <= REPEAT_LOAD_REL * np.maximum(norm[left], norm[first]))
                & (has_rotation[left] == has_rotation[first]))
        leader[left[same]] = first
        left = left[~same]
    return np.unique(leader, return_inverse=True)[1].astype(int)


def _group_means(group: np.ndarray, *arrays: np.ndarray) -> list[np.ndarray]:
    """Mean of each array's rows per group (rows of a group share their NaN pattern)."""
    counts = np.bincount(group).astype(float)
    out = []
    for arr in arrays:
        total = np.zeros((counts.size,) + arr.shape[1:])
        np.add.at(total, group, arr)
        out.append(total / counts.reshape((-1,) + (1,) * (arr.ndim - 1)))
    return out


def identify(robot: RobotModel, tests: LoadTests,
             method: Method | str = Method.CP) -> StiffnessIdentification:
    """Joint stiffness from load tests by linear least squares in the compliances.

    Repeats of a test (same pose and load, :func:`repeat_groups`) are averaged first and count
    once (see the module docstring); the result's residuals and warnings refer to the rows.

    Parameters
    ----------
    robot : RobotModel
        Kinematics and TCP (its stiffness values are not used).
    tests : LoadTests
    method : Method or "cp" / "dpp"
        CP: Eq. 3.19, all six compliances at once (translations, and rotations where given).
        DPP: Eq. 3.20, arm from the wrist-centre displacement, then the wrist (needs the
        rotation of every test and a spherical wrist).

    Raises
    ------
    UnidentifiableJoints
        A joint (or combination) the tests cannot identify, named in the message.
    InputError
        Malformed tests, absurd magnitudes, no deflection at all; DPP without rotations or a
        spherical wrist; a system the least squares cannot solve (never a LinAlgError).
    """
    method = Method(method)
    q, b = _validate(robot, tests)
    if method is Method.DPP:
        _check_dpp_applies(robot.dof, b)
    wrench = np.asarray(tests.wrench, dtype=float)
    group = repeat_groups(q, wrench, ~np.isnan(b[:, 3]))
    q_m, w_m, b_m = _group_means(group, q, wrench, b)
    try:
        core = _identify_distinct(robot, q_m, w_m, b_m, method)
    except np.linalg.LinAlgError as exc:
        raise InputError(f"the load tests give a least-squares system that cannot be solved "
                         f"({exc}); check the values, or add tests at other poses") from None
    return _per_row(robot, core, group, q, wrench, b)


def _per_row(robot: RobotModel, core: StiffnessIdentification, group: np.ndarray,
             q: np.ndarray, wrench: np.ndarray, b: np.ndarray) -> StiffnessIdentification:
    """``core`` (fitted to the distinct tests) with residuals and warnings per row, the
    repeatability of the repeats, and the exact-copy warning."""
    n = group.size
    if core.residual.shape[0] == n:
        residual = core.residual
    else:
        a_rows = identification_matrix(tcp_jacobians(robot, q), wrench)
        residual = b - np.einsum("nij,j->ni", a_rows, core.compliance)
    counts = np.bincount(group)
    spread = residual - _group_means(group, residual)[0][group]  # pure error: repeats only
    extra = counts - 1  # repeats beyond the first, per distinct test
    with_rot = np.zeros(counts.size, dtype=bool)
    with_rot[group] = np.isfinite(b[:, 3])
    dof = (3 * int(extra.sum()), 3 * int(extra[with_rot].sum()))
    rep = np.full(2, np.nan)
    for g, cols in enumerate((slice(0, 3), slice(3, 6))):
        if dof[g] > 0:
            rep[g] = float(np.sqrt(np.nansum(spread[:, cols] ** 2) / dof[g]))
    warnings = [replace(w, tests=tuple(int(r) for r in np.flatnonzero(np.isin(group, w.tests))))
                if w.tests else w for w in core.warnings]
    rows = np.hstack([q, wrench, np.nan_to_num(b, nan=np.inf)])
    first = np.unique(rows, axis=0, return_index=True)[1]
    copies = np.setdiff1d(np.arange(n), first)
    if copies.size:
        warnings.append(IdentificationWarning(WarningKind.EXACT_COPIES, float(copies.size),
                                              tests=tuple(int(r) for r in copies)))
    return replace(core, residual=residual, warnings=tuple(warnings), test_group=group,
                   repeatability=rep, repeatability_dof=dof[0])


def _identify_distinct(robot: RobotModel, q: np.ndarray, wrench: np.ndarray, b: np.ndarray,
                       method: Method) -> StiffnessIdentification:
    """:func:`identify` of distinct tests (SI arrays; NaN rotations where not measured)."""
    n, dof = q.shape
    jac = tcp_jacobians(robot, q)
    tau = np.einsum("nij,ni->nj", jac, wrench)
    a_full = identification_matrix(jac, wrench)  # (n, 6, dof)
    if method is Method.DPP:
        fit, cond = _dpp(jac, tau, a_full, b)
        present = np.ones((n, 6), dtype=bool)
    else:
        present = ~np.isnan(b)
        a = a_full[present]  # (m, dof), rows in test order
        groups = np.tile(np.arange(6) >= 3, (n, 1))[present].astype(int)
        n_groups = int(groups.max()) + 1
        bb = b[present]
        cond = _check_identifiable(a / _SIGMA0, list(range(dof)), tau)
        fit = _fit(a, bb, groups, n_groups, lambda w: _weighted_pinv(a, w))
        w = 1.0 / _usable_sigma(fit.sigma)[groups]
        cond = _check_identifiable(a * w[:, None], list(range(dof)), tau)
    residual = np.full((n, 6), np.nan)
    residual[present] = b[present] - np.einsum("nij,j->ni", a_full, fit.x)[present]
    sigma = np.full(2, np.nan)
    sigma[: len(fit.sigma)] = fit.sigma
    k, se_k = _stiffness_and_se(fit)
    warnings = _warnings(robot, q, wrench, jac, b, present, fit, cond)
    return StiffnessIdentification(method, k, se_k, fit.x, fit.cov, residual, sigma, cond,
                                   fit.dof, warnings, np.arange(n), np.full(2, np.nan), 0)


def _dpp(jac: np.ndarray, tau: np.ndarray, a_full: np.ndarray,
         b: np.ndarray) -> tuple[LinearFit, float]:
    """Eq. 3.20 decoupled: arm compliances from the wrist-centre displacement, then the wrist.

    Both stages are linear in the data, so the estimator ``x = M b`` is one matrix and its
    covariance and noise estimate are exact (not conditional on the first stage).
    """
    n = jac.shape[0]
    u = _wrist_centre_offsets(jac)
    arm = list(range(N_ARM))
    wrist = list(range(N_ARM, 2 * N_ARM))
    # wrist-centre Jacobian of the arm joints: v_j + w_j x u (Eq. 3.20, first term)
    j_wc = jac[:, :3, :N_ARM] + np.cross(np.swapaxes(jac[:, 3:, :N_ARM], 1, 2),
                                         u[:, None, :]).transpose(0, 2, 1)
    a1 = (j_wc * tau[:, None, :N_ARM]).reshape(3 * n, N_ARM)
    # d_wc = d + dtheta x u = d - [u]x dtheta: a (3, 6) map per test
    t_map = np.zeros((n, 3, 6))
    t_map[:, :, :3] = np.eye(3)
    t_map[:, 0, 4], t_map[:, 0, 5] = u[:, 2], -u[:, 1]
    t_map[:, 1, 3], t_map[:, 1, 5] = -u[:, 2], u[:, 0]
    t_map[:, 2, 3], t_map[:, 2, 4] = u[:, 1], -u[:, 0]
    a = a_full.reshape(6 * n, 2 * N_ARM)
    bb = b.reshape(6 * n)
    groups = np.tile(np.arange(6) >= 3, n).astype(int)
    cond1 = _check_identifiable(a1, arm, tau[:, :N_ARM])

    def estimator(w: np.ndarray) -> np.ndarray:
        p1 = np.linalg.pinv(a1).reshape(N_ARM, n, 3)  # stage 1: equal weights (all lengths)
        m1 = np.einsum("ptk,tkc->ptc", p1, t_map).reshape(N_ARM, 6 * n)
        p2 = _weighted_pinv(a[:, N_ARM:], w)  # stage 2: what the arm leaves of [d; dtheta]
        m2 = p2 - (p2 @ a[:, :N_ARM]) @ m1
        return np.vstack([m1, m2])

    fit = _fit(a, bb, groups, 2, estimator)
    w = 1.0 / _usable_sigma(fit.sigma)[groups]
    cond2 = _check_identifiable(a[:, N_ARM:] * w[:, None], wrist, tau[:, N_ARM:])
    return fit, max(cond1, cond2)


def _stiffness_and_se(fit: LinearFit) -> tuple[np.ndarray, np.ndarray]:
    """``k = 1/x`` and its first-order standard error ``se_x / x^2`` (inf/NaN where x = 0)."""
    se_x = np.sqrt(np.clip(np.diag(fit.cov), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return 1.0 / fit.x, se_x / fit.x**2


def _warnings(robot: RobotModel, q: np.ndarray, wrench: np.ndarray, jac: np.ndarray,
              b: np.ndarray, present: np.ndarray, fit: LinearFit,
              cond: float) -> tuple[IdentificationWarning, ...]:
    out: list[IdentificationWarning] = []
    k, se_k = _stiffness_and_se(fit)
    if fit.dof <= 0 or not np.all(np.isfinite(fit.sigma)):
        out.append(IdentificationWarning(WarningKind.NO_REDUNDANCY, float(fit.dof)))
    else:
        groups = np.tile(np.arange(6) >= 3, (len(q), 1)).astype(int)[present]
        sig = _usable_sigma(fit.sigma)[groups]
        snr = np.sqrt(np.mean((b[present] / sig) ** 2))
        bound = cond / snr
        if bound > ERROR_BOUND_WARN:
            out.append(IdentificationWarning(WarningKind.ILL_CONDITIONED, float(bound)))
        rel = se_k / np.abs(k)
        for j in np.flatnonzero(rel > RELATIVE_SE_WARN):
            out.append(IdentificationWarning(WarningKind.POORLY_DETERMINED, float(rel[j]),
                                             joints=(int(j),)))
    bad = np.flatnonzero(~(fit.x > 0))
    if bad.size:
        out.append(IdentificationWarning(WarningKind.NON_PHYSICAL, float(fit.x[bad].min()),
                                         joints=tuple(int(j) for j in bad)))
    jc = jacobian_condition_number(jac, IKOptions().condition_length)
    near = np.flatnonzero(~(jc <= NEAR_SINGULAR))
    if near.size:
        out.append(IdentificationWarning(WarningKind.NEAR_SINGULAR_POSE, float(jc[near].max()),
                                         tests=tuple(int(t) for t in near)))
    if not bad.size:
        ratio = complementary_ratio(complementary_stiffness(robot, q, wrench), k)
        big = np.flatnonzero(ratio > GEOMETRY_RATIO_WARN)
        if big.size:
            out.append(IdentificationWarning(WarningKind.GEOMETRY_CHANGE,
                                             float(ratio[big].max()),
                                             tests=tuple(int(t) for t in big)))
    return tuple(out)


# --------------------------------------------------------------------------- pose suggestion


@dataclass(frozen=True)
class LoadPlan:
    """Suggested load tests: poses, and the loads to apply at each.

    Attributes
    ----------
    q : (n_poses, dof) joint angles [rad]
    wrench : (n_poses, n_loads, 6) wrench at the TCP, base axes [N, N m]
    tcp_position : (n_poses, 3) TCP position in the base frame [m]
    jacobian_condition : (n_poses,) Jacobian condition numbers (1 m length scale)
    log_det : log det(A^T A) of the identification matrix with columns scaled by the nominal
        compliances (relative precision; the D-criterion that was maximised)
    condition_number : column-scaled condition number of the plan's identification matrix
    candidates : feasible random candidates the poses were chosen from
    """

    q: np.ndarray
    wrench: np.ndarray
    tcp_position: np.ndarray
    jacobian_condition: np.ndarray
    log_det: float
    condition_number: float
    candidates: int


def load_wrenches(tcp_poses: np.ndarray, load: float, lever: float) -> np.ndarray:
    """Wrenches (n, 3, 6) at the TCP of forces ``load`` [N] along base +x, +y and -z applied
    ``lever`` [m] from the TCP along the tool frame's x axis (a bracket on the spindle).

    ``m = r x f``: the lever gives the moment about the tool axis that a coaxial tool's
    forces cannot (joint 6 is otherwise unidentifiable).
    """
    forces = load * np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
    r = lever * tcp_poses[:, :3, 0]  # (n, 3)
    moments = np.cross(r[:, None, :], forces[None, :, :])
    return np.concatenate([np.broadcast_to(forces, moments.shape), moments], axis=-1)


@dataclass(frozen=True)
class PlanLoads:
    """The loads of a suggested plan and what is measured under them.

    Attributes
    ----------
    load : float
        Each force [N] (:func:`load_wrenches`).
    lever : float
        Its lever [m] from the TCP along the tool x axis.
    rotations : bool
        Measure the TCP rotation as well as its displacement.
    """

    load: float = 1000.0
    lever: float = 0.2
    rotations: bool = True


@dataclass(frozen=True)
class PoseCandidates:
    """The random configurations a plan is chosen from.

    Attributes
    ----------
    count : int
        Random configurations drawn (``--candidates``).
    seed : int
        Seed of the random generator.
    min_tcp_z : float
        Lowest TCP height above the base [m] of a kept candidate.
    margin : float
        Share of each joint range left out at both ends.
    """

    count: int = 2000
    seed: int = 0
    min_tcp_z: float = 0.0
    margin: float = 0.05


def _check_plan_request(n_poses: int, loads: PlanLoads, candidates: PoseCandidates) -> None:
    """InputError for a plan size, candidate count, load or seed out of range."""
    if not 1 <= n_poses <= MAX_POSES:
        raise InputError(f"--suggest: give 1 to {MAX_POSES} poses, got {n_poses}")
    if not 10 <= candidates.count <= MAX_CANDIDATES:
        raise InputError(f"--candidates: give 10 to {MAX_CANDIDATES}, got {candidates.count}")
    load, lever = loads.load, loads.lever
    if not (np.isfinite(load) and load > 0) or not (np.isfinite(lever) and lever >= 0):
        raise InputError(f"the test load must be > 0 and its lever >= 0, got {load:g} N at "
                         f"{lever * 1e3:g} mm")
    if candidates.seed < 0:
        raise InputError(f"--seed must be >= 0, got {candidates.seed}")


def _feasible_candidates(robot: RobotModel, n_poses: int, candidates: PoseCandidates
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Random configurations within the joint limits less the margin, kept when
    non-singular and with the TCP high enough: their q, Jacobians, TCP poses and Jacobian
    condition numbers. InputError when fewer than ``n_poses`` are kept."""
    rng = np.random.default_rng(candidates.seed)
    span = robot.q_upper - robot.q_lower
    margin = candidates.margin
    q = rng.uniform(robot.q_lower + margin * span, robot.q_upper - margin * span,
                    (candidates.count, robot.dof))
    jac = tcp_jacobians(robot, q)
    poses = forward_kinematics(robot, q)
    jcond = jacobian_condition_number(jac, IKOptions().condition_length)
    ok = (jcond <= NEAR_SINGULAR) & (poses[:, 2, 3] >= candidates.min_tcp_z)
    if ok.sum() < n_poses:
        raise InputError(f"only {int(ok.sum())} of {candidates.count} random poses are "
                         f"non-singular with the TCP above z = {candidates.min_tcp_z * 1e3:g} "
                         "mm: ask for fewer poses or more candidates")
    return q[ok], jac[ok], poses[ok], jcond[ok]


def suggest_poses(
    robot: RobotModel,
    n_poses: int,
    loads: PlanLoads | None = None,
    candidates: PoseCandidates | None = None,
) -> LoadPlan:
    """Pick ``n_poses`` test poses that make the identification well conditioned.

    Criterion: D-optimality, the largest ``log det(A^T A)`` of the identification matrix
    (Eq. 3.19, :func:`identification_matrix`) with its columns scaled by the nominal
    compliances (the robot's first stiffness set), i.e. the smallest volume of the confidence
    ellipsoid of the relative compliances (Borm and Menq 1991's observability index O1 is its
    n-th root; Sun and Hollerbach 2008 compare such indices for robot calibration).
    Search: ``candidates.count`` random configurations, uniform within the joint limits less
    ``candidates.margin`` of each range, kept when non-singular (Jacobian condition number <=
    :data:`NEAR_SINGULAR`) and with the TCP at least ``candidates.min_tcp_z`` above the base;
    greedy forward selection, then Fedorov-style exchange passes (Fedorov 1972; Mitchell's
    DETMAX) until no swap raises the criterion (at most :data:`EXCHANGE_PASSES`).
    Each pose gets the loads of :func:`load_wrenches` (``loads``, default
    :class:`PlanLoads`); the measurements are the TCP displacement (and rotation if
    ``loads.rotations``). Collisions are not checked.

    Raises
    ------
    InputError
        Bad sizes, too few feasible candidates; UnidentifiableJoints when even the best plan
        cannot identify a joint (e.g. ``lever = 0`` with a tool coaxial with joint 6).
    """
    loads = PlanLoads() if loads is None else loads
    candidates = PoseCandidates() if candidates is None else candidates
    _check_plan_request(n_poses, loads, candidates)
    q, jac, poses, jcond = _feasible_candidates(robot, n_poses, candidates)
    wrench = load_wrenches(poses, loads.load, loads.lever)  # (c, L, 6)
    c, n_loads = wrench.shape[:2]
    nominal = 1.0 / joint_stiffness(robot, next(iter(robot.stiffness)))
    rows = slice(0, 6 if loads.rotations else 3)
    a = identification_matrix(np.repeat(jac, n_loads, axis=0), wrench.reshape(-1, 6))
    a = (a[:, rows] * nominal).reshape(c, n_loads * (rows.stop), robot.dof)
    info = np.swapaxes(a, 1, 2) @ a  # (c, dof, dof)
    chosen = _d_optimal(info, n_poses)
    a_plan = a[chosen].reshape(-1, robot.dof)
    tau = np.einsum("nij,nli->nlj", jac[chosen], wrench[chosen]).reshape(-1, robot.dof)
    cond = _check_identifiable(a_plan, list(range(robot.dof)), tau)
    log_det = float(np.linalg.slogdet(a_plan.T @ a_plan)[1])
    return LoadPlan(q[chosen], wrench[chosen], poses[chosen, :3, 3], jcond[chosen], log_det,
                    cond, int(c))


def _d_optimal(info: np.ndarray, n: int) -> np.ndarray:
    """Indices of ``n`` candidates maximising log det of the summed information matrices."""
    dof = info.shape[-1]
    eps = 1e-9 * np.trace(info, axis1=1, axis2=2).mean() / dof * np.eye(dof)
    chosen: list[int] = []
    total = eps.copy()
    for _ in range(n):
        score = np.linalg.slogdet(total + info)[1]
        score[chosen] = -np.inf
        best = int(np.argmax(score))
        chosen.append(best)
        total = total + info[best]
    for _ in range(EXCHANGE_PASSES):
        improved = False
        for pos in range(n):
            base = total - info[chosen[pos]]
            current = np.linalg.slogdet(total)[1]
            score = np.linalg.slogdet(base + info)[1]
            score[chosen] = -np.inf
            best = int(np.argmax(score))
            if score[best] > current + 1e-9:
                chosen[pos] = best
                total = base + info[best]
                improved = True
        if not improved:
            break
    return np.array(chosen)


# --------------------------------------------------------------------------- one-parameter fits


@dataclass(frozen=True)
class ParameterFit:
    """A one-parameter fit to measured deflections.

    Attributes
    ----------
    value, standard_error : the parameter (NaN error with a single measured value)
    residual : measured - fitted, same shape as the measurements
    alternatives : other offsets that fit the measured magnitudes as well, within the search
        range (:func:`fit_point_offset`: a norm can be met on both sides)
    """

    value: float
    standard_error: float
    residual: np.ndarray
    alternatives: tuple[float, ...] = ()


def _finite(name: str, arr: object) -> np.ndarray:
    out = np.asarray(arr, dtype=float)
    if out.size == 0 or not np.all(np.isfinite(out)):
        raise InputError(f"{name}: expected finite numbers, got {arr!r}")
    return out


def fit_compliance_scale(predicted: np.ndarray, measured: np.ndarray) -> ParameterFit:
    """One scale ``s`` of the whole compliance from measured deflections: ``measured ~ s pred``.

    ``d = J K^-1 J^T F`` (Eq. 3.19/3.20) is linear in the compliance, so a uniform scale of
    ``K^-1`` scales every deflection component, norm, and maximum over a revolution or a cut
    by the same ``s``: ``predicted`` and ``measured`` may be any such quantities (same shape),
    e.g. the thesis's maximum constant-feed deflection. The joint stiffness that reproduces the
    measurements is ``k / s``. This is :func:`identify` with one unknown (least squares,
    standard error from the residual when there is more than one value).
    """
    p = _finite("predicted deflections", predicted)
    m = _finite("measured deflections", measured)
    if p.shape != m.shape:
        raise InputError(f"predicted {p.shape} and measured {m.shape} deflections must match")
    if not np.abs(p).max() > 0:
        raise InputError("predicted deflections are all zero: no scale fits them")
    fit = linear_fit(p.reshape(-1, 1), m.ravel())
    s = float(fit.x[0])
    return ParameterFit(s, float(np.sqrt(fit.cov[0, 0])), m - s * p)


def point_offset_terms(robot: RobotModel, q: np.ndarray, force: np.ndarray,
                       stiffness: str | np.ndarray = "dpp") -> tuple[np.ndarray, np.ndarray]:
    """``(d, t)`` (n, ..., 3) so that the point ``L`` [m] up the tool axis from the TCP moves by
    ``d + L t`` under ``force`` (n, ..., 3) [N] acting at the TCP.

    ``[d; dtheta] = C [f; 0]`` (Eq. 3.19/3.20); a rigid tool moves the point ``p = p_tcp + L a``
    (``a``: TCP +z, into the spindle) by ``d + dtheta x (L a)``, so ``t = dtheta x a``.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    f = np.asarray(force, dtype=float)
    c = compliance(robot, q, stiffness)  # (n, 6, 6)
    axis = forward_kinematics(robot, q)[:, :3, 2]
    flat = f.reshape(f.shape[0], -1, 3)
    disp = np.einsum("nij,nkj->nki", c[:, :, :3], flat)  # (n, k, 6)
    t = np.cross(disp[..., 3:], axis[:, None, :])
    return disp[..., :3].reshape(f.shape), t.reshape(f.shape)


def fit_point_offset(d: np.ndarray, t: np.ndarray, measured: np.ndarray,
                     bounds: tuple[float, float] = (-1.0, 1.0)) -> ParameterFit:
    """Offset ``L`` [m] along the tool axis of the point whose deflection was measured.

    A tracker target on the spindle is not the TCP: it moves by ``d + L t``
    (:func:`point_offset_terms`). With measured vectors (n, 3) the fit is linear (least
    squares, exact standard error). With measured magnitudes (n,) of maxima over the samples
    of ``d`` (n, k, 3) (e.g. the largest deflection of a cut), ``max_k |d + L t|`` is fitted by
    a scan of ``bounds`` and a bounded refinement of each local optimum: the best is
    ``value``, the others are ``alternatives`` (a norm can be met on both sides).
    """
    d = _finite("deflections d", d)
    t = _finite("rotation terms t", t)
    m = _finite("measured deflections", measured)
    if d.shape != t.shape or d.shape[-1] != 3:
        raise InputError(f"d {d.shape} and t {t.shape} must match, with 3 components last")
    if m.ndim == 2 and m.shape == d.shape:  # vectors: linear
        fit = linear_fit(t.reshape(-1, 1), (m - d).ravel())
        value = float(fit.x[0])
        return ParameterFit(value, float(np.sqrt(fit.cov[0, 0])), m - d - value * t)
    if m.ndim != 1 or d.shape[0] != m.shape[0]:
        raise InputError(f"measured deflections must be vectors {d.shape} or magnitudes "
                         f"({d.shape[0]},), got {m.shape}")
    lo, hi = bounds
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise InputError(f"offset bounds must be two finite numbers, low < high, got {bounds}")
    d3 = d.reshape(d.shape[0], -1, 3)
    t3 = t.reshape(d3.shape)

    def resid(offset: float) -> np.ndarray:
        return np.linalg.norm(d3 + offset * t3, axis=-1).max(axis=1) - m

    grid = np.linspace(lo, hi, 401)
    cost = np.array([resid(g) @ resid(g) for g in grid])
    minima = [i for i in range(len(grid))
              if cost[i] <= cost[max(i - 1, 0)] and cost[i] <= cost[min(i + 1, len(grid) - 1)]]
    found = []
    for i in minima:
        a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        res = minimize_scalar(lambda x: resid(x) @ resid(x), bounds=(a, b), method="bounded",
                              options={"xatol": 1e-12 * max(1.0, hi - lo)})
        found.append((float(res.fun), float(res.x)))
    found.sort()
    best_cost, best = found[0]
    tie = best_cost + 1e-6 * float(m @ m)
    r = resid(best)
    h = 1e-6 * max(1.0, abs(best))
    slope = (resid(best + h) - resid(best - h)) / (2 * h)
    n = m.size
    se = (float(np.sqrt(r @ r / (n - 1) / (slope @ slope)))
          if n > 1 and slope @ slope > 0 else float("nan"))
    others: list[float] = []
    for cost_i, x in found[1:]:
        if cost_i <= tie and all(abs(x - y) > 1e-6 * (hi - lo) for y in [best, *others]):
            others.append(x)
    return ParameterFit(best, se, r, tuple(others))
