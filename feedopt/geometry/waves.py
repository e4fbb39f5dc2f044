"""Waypoints of the thesis's test paths (chapter 3 triangle / square wave, chapter 4 line).

All in metres, in the XY plane at z = origin z, travelling in +x. Layouts:

triangle_wave: starts on the base line at the origin, rises to a peak at y = +height half a
    wavelength later and comes back to the base line at the end of each wave:
    (0, 0), (l/2, h), (l, 0), (3l/2, h), ..., (L, 0) with l = L / waves. Each wave has one up
    line (+y) then one down line (-y); the first line starts and the last ends on the base
    line (thesis Fig. 3.4-3.8; base line y = 0, peaks at y = +height, not centred).
square_wave: per wave a quarter wavelength along the base, up to ``height``, half a
    wavelength along the top, down, a quarter along the base; consecutive base runs merge,
    so every interior corner turns 90 deg: (0, 0), (l/4, 0), (l/4, h), (3l/4, h),
    (3l/4, 0), (5l/4, 0), ..., (L, 0) with l = L / waves.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from feedopt.errors import InputError
from feedopt.units import MM


def _check(length: float, height: float, waves: int) -> None:
    if not (np.isfinite(length) and length > 0 and np.isfinite(height) and height > 0):
        raise InputError(
            f"wave length and height must be positive, finite numbers of mm, got "
            f"{length / MM:g} mm and {height / MM:g} mm")
    if int(waves) != waves or waves < 1:
        raise InputError(f"number of waves must be a positive integer, got {waves}")


def triangle_wave(length: float = 0.3048, height: float = 0.0762, waves: int = 3,
                  origin: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Triangle-wave waypoints (2 waves + 1 points), (n, 3) [m]; defaults: thesis ch. 3."""
    _check(length, height, waves)
    x = np.linspace(0.0, length, 2 * int(waves) + 1)
    y = np.where(np.arange(x.size) % 2 == 1, height, 0.0)
    return np.column_stack([x, y, np.zeros_like(x)]) + np.asarray(origin, dtype=float)


def square_wave(length: float = 0.3048, height: float = 0.0762, waves: int = 3,
                origin: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Square-wave waypoints (4 waves + 2 points), (n, 3) [m]."""
    _check(length, height, waves)
    lam = length / int(waves)
    pts = [(0.0, 0.0)]
    for k in range(int(waves)):
        x0 = k * lam
        pts += [(x0 + lam / 4, 0.0), (x0 + lam / 4, height), (x0 + 3 * lam / 4, height),
                (x0 + 3 * lam / 4, 0.0)]
    pts.append((length, 0.0))
    xy = np.array(pts)
    return np.column_stack([xy, np.zeros(len(xy))]) + np.asarray(origin, dtype=float)


def straight_line(start: ArrayLike = (0.0, 0.0, 0.0),
                  end: ArrayLike = (0.2032, 0.009525, 0.0)) -> np.ndarray:
    """Two waypoints (2, 3) [m]; defaults: the chapter-4 peripheral cut, 203.2 mm in x while
    y goes 0 -> 9.525 mm (radial immersion 0 -> half of the 19.05 mm cutter)."""
    pts = np.array([np.asarray(start, dtype=float), np.asarray(end, dtype=float)])
    if pts.shape != (2, 3) or not np.all(np.isfinite(pts)):
        raise InputError(
            f"start and end must be finite (x, y, z) points, got {_mm(start)} and {_mm(end)}")
    return pts


def _mm(p: ArrayLike) -> str:
    """A point given in metres, for messages: ``(x, y, z) mm`` (or its repr if not numeric)."""
    try:
        v = np.asarray(p, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return repr(p)
    return "(" + ", ".join(f"{x / MM:.6g}" for x in v) + ") mm"
