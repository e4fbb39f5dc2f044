"""How far a controller's own orientation interpolation between a program's points is from the
planned tool axis (five-axis paths).

KRL's SPLINE/SLIN, RAPID's MoveL and FANUC's L moves turn the tool between two programmed
poses by the controller's orientation interpolation, not along the planned one. Modelled as
an even turn in proportion to the arc length along the great circle between the points' tool
axes (the quaternion slerp of both controllers for the axis, KUKA's "standard" orientation
control), the largest angle to the planned axis at the path samples is what a program's
header and the summary state (the RSI trajectory follows the planned axis itself).
"""

from __future__ import annotations

import numpy as np

__all__ = ["gap_notes", "orientation_gap_deg"]


def orientation_gap_deg(job, s_points: np.ndarray) -> float | None:
    """Five-axis paths: the largest angle [deg] between the planned tool axis at the path
    samples and the axis turned at an even rate (great circle, in proportion to s) between
    the axes at the program's points ``s_points`` (increasing arc lengths [m]); None when
    the tool axis does not turn."""
    axes = job.sample_tool_axes
    if np.ptp(axes, axis=0).max() <= 1e-12:
        return None
    s = job.problem.s
    s_keys = np.asarray(s_points, dtype=float)
    at_keys = np.column_stack([np.interp(s_keys, s, axes[:, k]) for k in range(3)])
    at_keys /= np.linalg.norm(at_keys, axis=1, keepdims=True)
    k = np.clip(np.searchsorted(s_keys, s, side="right") - 1, 0, s_keys.size - 2)
    a, b = at_keys[k], at_keys[k + 1]
    omega = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    t = np.clip((s - s_keys[k]) / np.maximum(s_keys[k + 1] - s_keys[k], 1e-300), 0.0, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(omega > 1e-12, np.sin((1 - t) * omega) / np.sin(omega), 1 - t)
        w1 = np.where(omega > 1e-12, np.sin(t * omega) / np.sin(omega), t)
    even = w0[:, None] * a + w1[:, None] * b
    cross = np.linalg.norm(np.cross(even, axes), axis=1)
    return float(np.degrees(np.max(np.arctan2(cross, np.einsum("ij,ij->i", even, axes)))))


def gap_notes(gap: float | None, points: str) -> list[str]:
    """The program header's note for a gap from :func:`orientation_gap_deg` (none without)."""
    if gap is None:
        return []
    return [f"five-axis path: the controller turns the tool between the {points} by its own "
            f"orientation interpolation; turned at an even rate between their tool axes it is "
            f"up to {gap:.3g} deg from the planned tool axis (the RSI trajectory follows it)"]
