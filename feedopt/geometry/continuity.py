"""Geometric continuity at the junctions of a path (thesis 3.3.1): G0, G1, G2 jumps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedopt.geometry.path import Path
from feedopt.units import MM, MM_PER_M


@dataclass(frozen=True)
class ContinuityReport:
    """Jumps across every junction between consecutive segments.

    s : (m,) arc length of the junction [m]
    kind_before, kind_after : segment kinds on either side
    corner_index : (m,) waypoint index of the blend at the junction (-1 if none)
    g0 : (m,) |p_after - p_before| [m]
    g1 : (m,) |T_after - T_before| (unit tangents; 2 sin(angle/2) for a kink of that angle)
    g2 : (m,) |k_after - k_before| curvature vectors d2p/ds2 [1/m]
    """

    s: np.ndarray
    kind_before: tuple[str, ...]
    kind_after: tuple[str, ...]
    corner_index: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    g2: np.ndarray

    def __len__(self) -> int:
        return len(self.s)

    def max(self) -> tuple[float, float, float]:
        """Largest (G0 [m], G1, G2 [1/m]) jump over all junctions (zeros if none)."""
        if not len(self):
            return 0.0, 0.0, 0.0
        return float(self.g0.max()), float(self.g1.max()), float(self.g2.max())

    def table(self, max_rows: int | None = 40) -> str:
        """Plain-text table in mm (G0 in mm, G2 in 1/mm); long reports keep head and tail."""
        head = (f"{'#':>5} {'s_mm':>12} {'before':>14} {'after':>14} {'corner':>6} "
                f"{'G0_mm':>10} {'G1':>10} {'G2_1_mm':>10}")
        rows = [head]
        # g0 and s are lengths (m -> mm: * MM_PER_M); g2 is a curvature (1/m -> 1/mm: * MM)
        idx = list(range(len(self)))
        cut = max_rows is not None and len(idx) > max_rows
        if cut:
            half = max_rows // 2
            idx = idx[:half] + [-1] + idx[-half:]
        for i in idx:
            if i < 0:
                rows.append(f"{'...':>5} ({len(self) - 2 * (max_rows // 2)} junctions omitted)")
                continue
            corner = str(self.corner_index[i]) if self.corner_index[i] >= 0 else "-"
            rows.append(
                f"{i:>5} {self.s[i] * MM_PER_M:>12.4f} {self.kind_before[i]:>14} "
                f"{self.kind_after[i]:>14} {corner:>6} {self.g0[i] * MM_PER_M:>10.3g} "
                f"{self.g1[i]:>10.3g} {self.g2[i] * MM:>10.3g}")
        g0, g1, g2 = self.max()
        rows.append(f"max over {len(self)} junctions: G0 {g0 * MM_PER_M:.3g} mm, G1 {g1:.3g}, "
                    f"G2 {g2 * MM:.3g} 1/mm")
        return "\n".join(rows)


def continuity_report(path: Path) -> ContinuityReport:
    """Evaluate each segment at its end and the next one at its start and compare."""
    k = len(path.segments)
    before = np.arange(k - 1)
    after = before + 1
    lens = np.array([g.length for g in path.segments[:-1]], dtype=float)
    a = path._eval_segments(before, lens)
    b = path._eval_segments(after, np.zeros(k - 1))
    jumps = [np.linalg.norm(x - y, axis=1) for x, y in zip(a[:3], b[:3], strict=True)]
    corner = np.array([max(path.segments[i].corner_index, path.segments[i + 1].corner_index)
                       for i in before], dtype=int)
    return ContinuityReport(
        s=path.segment_start[1:],
        kind_before=tuple(path.segment_kind[:-1]),
        kind_after=tuple(path.segment_kind[1:]),
        corner_index=corner,
        g0=jumps[0],
        g1=jumps[1],
        g2=jumps[2],
    )
