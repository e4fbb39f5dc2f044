"""Static joint-stiffness model of the robot: TCP compliance and deflection (thesis 3.4).

Each joint is a linear torsional spring (six-parameter model). A wrench ``W = [f; m]`` acting
on the tool at the TCP, in base axes, loads the joints with ``tau = J^T W``; they deflect by
``dq = K^-1 tau`` and the TCP moves by ``dx = J dq``, so ``dx = C W`` with

    C = J K^-1 J^T                                   (Eq. 3.19, CP)
    C = J K_123^-1 J^T + J K_456^-1 J^T              (Eq. 3.20, DPP: arm + wrist terms)
    C = J (K - K_c)^-1 J^T                           (Eq. 3.18, with geometry change)

``J`` is the TCP Jacobian in the base-aligned TCP frame (LOCAL_WORLD_ALIGNED). The arm and
wrist terms of Eq. 3.20 add up to ``J diag(1/k) J^T``; what distinguishes DPP from CP is the
set of calibrated values (thesis Table 3.4), selected by name.
"""

from __future__ import annotations

import numpy as np

from feedopt.errors import InputError
from feedopt.robot.model import RobotModel, tcp_jacobians


def joint_stiffness(robot: RobotModel, stiffness: str | np.ndarray = "dpp") -> np.ndarray:
    """Joint stiffness vector (dof,) [N m/rad] from a set name or explicit values.

    Parameters
    ----------
    robot : RobotModel
    stiffness : str or (dof,) array
        Name of a set of ``robot.yaml`` (``"cp"``, ``"dpp"``: thesis Table 3.4; case does not
        matter) or the diagonal of K itself [N m/rad].

    Raises
    ------
    InputError
        Unknown set name, or values that are not ``dof`` positive finite numbers.
    """
    if isinstance(stiffness, str):
        key = stiffness.lower()
        if key not in robot.stiffness:
            raise InputError(
                f"stiffness set '{stiffness}' is not defined for robot {robot.name}; "
                f"available: {', '.join(sorted(robot.stiffness))}"
            )
        return robot.stiffness[key]
    k = np.asarray(stiffness, dtype=float)
    if k.shape != (robot.dof,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InputError(
            f"joint stiffness must be {robot.dof} positive values [N m/rad], got {stiffness!r}"
        )
    return k


def compliance(
    robot: RobotModel,
    q: np.ndarray,
    stiffness: str | np.ndarray = "dpp",
    k_c: np.ndarray | None = None,
) -> np.ndarray:
    """TCP compliance matrices (n, 6, 6) mapping a base-frame wrench [N, N m] to [m, rad].

    ``C = J K^-1 J^T`` (Eq. 3.19; Eq. 3.20 with the DPP set, arm + wrist terms). With the
    complementary stiffness ``k_c`` (n, dof, dof) from :func:`complementary_stiffness`,
    ``C = J (K - K_c)^-1 J^T`` (Eq. 3.18).

    Parameters
    ----------
    robot : RobotModel
    q : (n, dof) array
        Joint configurations [rad].
    stiffness : str or (dof,) array
        Joint stiffness set name or values (:func:`joint_stiffness`).
    k_c : (n, dof, dof) array or None
        Complementary stiffness [N m/rad]; ``None`` neglects it (Eq. 3.19/3.20).

    Returns
    -------
    (n, 6, 6) array
        ``[dx; dtheta] = C [f; m]``, rows and columns in base axes at the TCP.
    """
    k = joint_stiffness(robot, stiffness)
    jac = tcp_jacobians(robot, q)
    return compliance_from_jacobians(jac, k, k_c)


def compliance_from_jacobians(
    jacobians: np.ndarray, k: np.ndarray, k_c: np.ndarray | None = None
) -> np.ndarray:
    """``J K^-1 J^T`` (Eq. 3.19/3.20) or ``J (K - K_c)^-1 J^T`` (Eq. 3.18).

    Parameters
    ----------
    jacobians : (..., 6, dof) array
        TCP Jacobians in the base-aligned TCP frame (:func:`feedopt.robot.model.tcp_jacobians`).
    k : (dof,) array
        Joint stiffness [N m/rad].
    k_c : (..., dof, dof) array or None
        Complementary stiffness [N m/rad] (:func:`complementary_stiffness`).

    Returns
    -------
    (..., 6, 6) array
        Compliance [m/N, m/(N m), rad/N, rad/(N m)].
    """
    jac = np.asarray(jacobians, dtype=float)
    if k_c is None:
        return np.einsum("...ij,j,...kj->...ik", jac, 1.0 / k, jac)
    kk = np.diag(k) - np.asarray(k_c, dtype=float)
    x = np.linalg.solve(kk, np.swapaxes(jac, -1, -2))  # (K - K_c)^-1 J^T
    return jac @ x


def compliance_split(
    robot: RobotModel, q: np.ndarray, stiffness: str | np.ndarray = "dpp", n_arm: int = 3
) -> tuple[np.ndarray, np.ndarray]:
    """Arm and wrist terms of Eq. 3.20, each (n, 6, 6): ``J K_123^-1 J^T``, ``J K_456^-1 J^T``.

    Their sum is :func:`compliance` of the same set; ``n_arm`` joints count as the arm.
    """
    k = joint_stiffness(robot, stiffness)
    jac = tcp_jacobians(robot, q)
    inv = 1.0 / k
    arm, wrist = inv.copy(), inv.copy()
    arm[n_arm:] = 0.0
    wrist[:n_arm] = 0.0
    return (
        np.einsum("...ij,j,...kj->...ik", jac, arm, jac),
        np.einsum("...ij,j,...kj->...ik", jac, wrist, jac),
    )


def translational_compliance(
    robot: RobotModel, q: np.ndarray, stiffness: str | np.ndarray = "dpp"
) -> np.ndarray:
    """Translational compliance (n, 3, 3) [m/N]: TCP displacement per force at the TCP.

    The upper-left block of :func:`compliance` (Eq. 3.19, DPP: Eq. 3.20) for a pure force on
    the tool at the TCP (no moment), in base axes; the tool is rigid and K_c is neglected.

    Parameters
    ----------
    robot : RobotModel
    q : (n, dof) array
        Joint configurations [rad].
    stiffness : str or (dof,) array
        Joint stiffness set name or values (:func:`joint_stiffness`).
    """
    return compliance(robot, q, stiffness)[..., :3, :3]


def deflection(compliance_3x3: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Deflections ``C F`` (n, ..., m) for compliances (n, m, m) and forces (n, ..., m).

    Vectorised over samples and any extra axes of ``force`` (e.g. cutter angles); m = 3 for
    a force [N] -> displacement [m], m = 6 for a wrench -> [displacement; rotation].
    """
    c = np.asarray(compliance_3x3, dtype=float)
    f = np.asarray(force, dtype=float)
    if c.ndim != 3 or c.shape[1] != c.shape[2]:
        raise InputError(f"compliance must have shape (n, m, m), got {c.shape}")
    if f.ndim < 2 or f.shape[0] != c.shape[0] or f.shape[-1] != c.shape[1]:
        raise InputError(
            f"force must have shape ({c.shape[0]}, ..., {c.shape[1]}) to match the compliance "
            f"{c.shape}, got {f.shape}"
        )
    flat = f.reshape(f.shape[0], -1, f.shape[-1])  # (n, k, m)
    return np.matmul(flat, np.swapaxes(c, 1, 2)).reshape(f.shape)


def complementary_stiffness(
    robot: RobotModel, q: np.ndarray, force_wrench: np.ndarray, step: float = 1e-6
) -> np.ndarray:
    """Complementary stiffness ``K_c = d(J(q)^T W)/dq`` (n, dof, dof) [N m/rad] (Eq. 3.18).

    ``W`` (n, 6) or (n, 3) is the wrench (force) on the tool at the TCP in base axes, held
    constant while the robot deflects. Joint equilibrium ``K dq = J(q0 + dq)^T W`` linearised
    gives ``(K - K_c) dq = J(q0)^T W``. The derivative of pinocchio's analytic Jacobian is
    taken by central differences (relative error ~1e-9).
    """
    qs = np.atleast_2d(np.asarray(q, dtype=float))
    w = np.atleast_2d(np.asarray(force_wrench, dtype=float))
    n, dof = qs.shape
    if w.shape[-1] == 3:
        w = np.concatenate([w, np.zeros(w.shape[:-1] + (3,))], axis=-1)
    if w.shape != (n, 6):
        raise InputError(f"force_wrench must have shape ({n}, 3) or ({n}, 6), got {w.shape}")
    eye = np.eye(dof) * step
    qp = (qs[:, None, :] + eye[None]).reshape(-1, dof)
    qm = (qs[:, None, :] - eye[None]).reshape(-1, dof)
    jp = tcp_jacobians(robot, qp).reshape(n, dof, 6, dof)
    jm = tcp_jacobians(robot, qm).reshape(n, dof, 6, dof)
    # d(J^T W)_a / dq_i = sum_r dJ[r, a]/dq_i W[r]  ->  K_c[n, a, i]
    djw = np.einsum("nira,nr->nai", jp - jm, w) / (2.0 * step)
    return djw


def complementary_ratio(k_c: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Size of K_c relative to K: spectral norm of ``K^-1/2 K_c K^-1/2`` (n,) (dimensionless).

    Eq. 3.19 neglects K_c; the relative change of the joint deflection is about this ratio,
    so values << 1 (far from singularity, thesis 3.4) mean K_c is negligible.
    """
    s = 1.0 / np.sqrt(np.asarray(k, dtype=float))
    scaled = s[:, None] * np.asarray(k_c, dtype=float) * s[None, :]
    return np.linalg.norm(scaled, ord=2, axis=(-2, -1))
