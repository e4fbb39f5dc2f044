"""The interior corners of a polyline as the blends see them (:class:`Corners`), on its own so
that the blend registry and the blends can both name it without importing each other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Corners"]


@dataclass(frozen=True)
class Corners:
    """Geometry of the interior corners of a polyline (one row per interior waypoint).

    Attributes
    ----------
    point : (m, 3) corner waypoint q_k [m]
    d_in, d_out : (m, 3) unit travel directions of the incoming and outgoing lines
    turn : (m,) turning angle gamma in [0, pi] [rad] (corner angle alpha = pi - gamma)
    normal : (m, 3) unit inward normal in the corner plane (zeros where turn == 0)
    len_in, len_out : (m,) lengths of the incoming and outgoing lines [m]
    """

    point: np.ndarray
    d_in: np.ndarray
    d_out: np.ndarray
    turn: np.ndarray
    normal: np.ndarray
    len_in: np.ndarray
    len_out: np.ndarray
