"""Deflection over one cutter revolution at every path sample, as an affine function of feed.

With the force split F(phi) = c Fc(phi) + Fe(phi) of the process stage (force-model frame),
the rotation R from that frame to the robot base (columns: feed direction, in-plane normal,
tool axis) and the translational compliance C(q) of the robot stage (Eq. 3.19/3.20),
the deflection is d(phi) = c a(phi) + b(phi) with a = C R Fc and b = C R Fe (design.md).

Forces are computed per *distinct* engagement (a slot has one) and in chunks of samples, so
memory stays bounded at 1e5 samples x 360 angles.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from feedopt.process.forces import CuttingCoefficients, Engagement, ForceSplit, Tool, milling_forces

LIMIT_MODES = ("norm", "normal", "direction")

# Samples per chunk: 4096 samples x 360 angles x 3 x 8 B = 35 MB per array.
_CHUNK = 4096


@dataclass(frozen=True)
class DeflectionModel:
    """Everything needed to evaluate d(phi) = c a(phi) + b(phi) along the path.

    Attributes
    ----------
    tool, coefficients : process-stage cutter and cutting coefficients.
    engagement : per-sample entry/exit angles and axial depth (n,).
    angles : (m,) cutter rotation angles [rad] over which the maximum is taken.
    frames : (n, 3, 3) rotation from the force-model frame to the base frame.
    compliance : (n, 3, 3) translational compliance at the TCP [m/N].
    rpm : spindle speed [rev/min]; feed v = c N rpm / 60.
    mode : ``"norm"`` (|d|, thesis), ``"normal"`` (component along the in-plane surface
        normal, the force-model y axis) or ``"direction"`` (component along ``direction``).
    direction : (3,) unit vector in the base frame for ``mode == "direction"``.
    axial_slices : number of axial slices of the force model.
    """

    tool: Tool
    coefficients: CuttingCoefficients
    engagement: Engagement
    angles: np.ndarray
    frames: np.ndarray
    compliance: np.ndarray
    rpm: float
    mode: str = "norm"
    direction: np.ndarray | None = None
    axial_slices: int = 20

    @property
    def n(self) -> int:
        return int(self.frames.shape[0])

    @property
    def feed_per_unit_c(self) -> float:
        """Path feed [m/s] per metre of feed per tooth: v = c N n / 60."""
        return self.tool.teeth * self.rpm / 60.0

    def forces(self, index: np.ndarray) -> tuple[ForceSplit, np.ndarray]:
        """Force split on the distinct engagements of samples ``index``.

        Returns the split over the distinct rows and, per sample, the row it uses.
        """
        e = self.engagement
        rows = np.stack([e.entry[index], e.exit[index], e.axial_depth[index]], axis=1)
        unique, inverse = np.unique(rows, axis=0, return_inverse=True)
        split = milling_forces(
            self.tool,
            self.coefficients,
            Engagement(entry=unique[:, 0], exit=unique[:, 1], axial_depth=unique[:, 2]),
            self.angles,
            axial_slices=self.axial_slices,
        )
        return split, inverse.ravel()

    def chunks(self) -> Iterator[tuple[slice, np.ndarray, np.ndarray]]:
        """Yield ``(samples, a, b)``: deflection per unit feed per tooth and at zero feed.

        ``a`` and ``b`` have shape (k, m, 3) in the base frame [m/m and m], or (k, m) when the
        mode projects on a direction.
        """
        for start in range(0, self.n, _CHUNK):
            sl = slice(start, min(start + _CHUNK, self.n))
            idx = np.arange(sl.start, sl.stop)
            split, row = self.forces(idx)
            cr = self.compliance[sl] @ self.frames[sl]  # (k, 3, 3): force-model frame -> d
            a = np.einsum("kij,kmj->kmi", cr, split.cutting[row], optimize=True)
            b = np.einsum("kij,kmj->kmi", cr, split.edge[row], optimize=True)
            if self.mode == "norm":
                yield sl, a, b
            else:
                u = self._directions(sl)
                yield sl, np.einsum("kmi,ki->km", a, u), np.einsum("kmi,ki->km", b, u)

    def _directions(self, sl: slice) -> np.ndarray:
        if self.mode == "normal":
            return self.frames[sl, :, 1]
        if self.mode == "direction":
            d = np.asarray(self.direction, dtype=float)
            return np.broadcast_to(d / np.linalg.norm(d), (sl.stop - sl.start, 3))
        raise ValueError(f"unknown limit mode {self.mode!r}; expected one of {LIMIT_MODES}")

    def deflection(self, feed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Max over the revolution of the limited deflection [m] at path feeds ``feed`` [m/s].

        This is the forward replay used by verification: F = c Fc + Fe at the commanded
        feed per tooth, rotated to the base frame and multiplied by the compliance.
        Returns the per-sample maximum and the index of the angle where it occurs.
        """
        c = np.asarray(feed, dtype=float) / self.feed_per_unit_c
        out = np.empty(self.n)
        arg = np.empty(self.n, dtype=int)
        for sl, a, b in self.chunks():
            d = c[sl, None, None] * a + b if a.ndim == 3 else c[sl, None] * a + b
            mag = np.linalg.norm(d, axis=-1) if d.ndim == 3 else np.abs(d)
            arg[sl] = np.argmax(mag, axis=1)
            out[sl] = np.take_along_axis(mag, arg[sl, None], axis=1)[:, 0]
        return out, arg


def feed_frames(tangent: np.ndarray, tool_axis: np.ndarray) -> np.ndarray:
    """Rotation (n, 3, 3) from the force-model frame to the base frame.

    Columns: x = feed direction (path tangent projected normal to the tool axis), z = tool
    axis (pointing into the spindle), y = z x x (Altintas' frame, design.md).
    """
    z = tool_axis / np.linalg.norm(tool_axis, axis=1, keepdims=True)
    x = tangent - np.sum(tangent * z, axis=1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)
