"""The largest feed per tooth a deflection limit allows at one angle: the upper root of
|c a + b| <= L (a quadratic in c for the norm, linear for a projected deflection). Shared by
the feed bound (:mod:`feedopt.schedule.bounds`) and the compensation cap
(:mod:`feedopt.schedule.compensation`)."""

from __future__ import annotations

import numpy as np

__all__ = ["upper_roots_norm", "upper_roots_projected", "upper_roots_quadratic"]


def upper_roots_norm(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Per angle, the largest c with |c a + b| <= limit (``inf`` without cutting force)."""
    return upper_roots_quadratic(np.einsum("...i,...i->...", a, a),
                                  np.einsum("...i,...i->...", a, b),
                                  np.einsum("...i,...i->...", b, b), limit)


def upper_roots_quadratic(aa: np.ndarray, ab: np.ndarray, bb: np.ndarray,
                           limit: float) -> np.ndarray:
    """Per angle, the largest c with c^2 aa + 2 c ab + bb <= limit^2, i.e. |c a + b| <= limit
    given aa = |a|^2, ab = a.b, bb = |b|^2 (``inf`` without cutting force, aa = 0)."""
    qc = bb - limit * limit  # <= 0 where feasible at c = 0
    disc = np.sqrt(np.maximum(ab * ab - aa * qc, 0.0))
    # Upper root (-ab + disc) / aa, written without cancellation for ab > 0.
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.where(ab > 0, -qc / (ab + disc), (disc - ab) / aa)
    root = np.where(aa > 0, root, np.inf)
    return np.where(np.isnan(root), 0.0, root)


def upper_roots_projected(a: np.ndarray, b: np.ndarray, limit: float) -> np.ndarray:
    """Per angle, the largest c with |c a + b| <= limit for scalar a, b."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a > 0, (limit - b) / a, np.where(a < 0, (-limit - b) / a, np.inf))
