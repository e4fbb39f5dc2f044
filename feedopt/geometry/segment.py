"""One piece of a tool path (:class:`Segment`), on its own so that the blend kinds that build
segments and the path that strings them together both name it without importing each
other."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["Segment"]


@dataclass(frozen=True, eq=False)
class Segment:
    """One piece of a path.

    kind : "line" or the name of a registered blend kind ("circle", "bezier4", "bezier5",
        "varying_radius", ...)
    s_start, length : where it starts on the path and its arc length [m]
    corner_index : waypoint index (in the caller's array) of the corner a blend rounds; -1
        for lines
    params : geometry, by kind (arrays in m); a blend's are one row of what its kind's
        ``build`` returned:
        line: ``origin`` (3,), ``direction`` (3,) unit
        circle: ``centre``, ``e1``, ``e2`` (3,), ``radius``, ``angle`` (scalars);
            p(phi) = centre + radius (cos phi e1 + sin phi e2), phi = (s - s_start)/radius
        bezier4/5: ``control`` (d+1, 3) control points, ``alpha`` (Eq. 3.3/3.7)
        varying_radius: ``centre``, ``e1``, ``e2``, ``radius`` (r0), ``angle`` (theta_f);
            p(theta) = centre + r(theta) (cos theta e1 + sin theta e2), r of Eq. 3.17
        parametric kinds also carry their arc-length table: ``s_nodes``, ``sigma_nodes``.
    offset : where this segment starts on the curve its ``params`` describe [m]: a segment
        trimmed at its start (by a G2 transition) keeps the curve's parameters and evaluates
        it from ``offset`` to ``offset + length``.
    """

    kind: str
    s_start: float
    length: float
    corner_index: int = -1
    params: dict[str, Any] = field(default_factory=dict)
    offset: float = 0.0

    @property
    def s_end(self) -> float:
        return self.s_start + self.length
