"""Deflection over one cutter revolution at every path sample, as an affine function of feed.

With the force split F(phi) = c Fc(phi) + Fe(phi) of the process stage (force-model frame),
the rotation R from that frame to the robot base (columns: feed direction, in-plane normal,
tool axis) and the translational compliance C(q) of the robot stage (Eq. 3.19/3.20),
the deflection is d(phi) = c a(phi) + b(phi) with a = C R Fc and b = C R Fe (design.md).

Forces are computed per *distinct* engagement (a slot has one) and in chunks of samples, so
memory stays bounded at 1e5 samples x 360 angles. The bound and the replay use the reduced
per-angle terms |a|^2, a.b, |b|^2 (:class:`AngleTerms`, from the Gram matrix of C R where
samples share their forces); :meth:`DeflectionModel.terms` is the direct route, the
reference the reduced one is tested against.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from feedopt.errors import InputError
from feedopt.parallel import for_each_chunk
from feedopt.process.averages import side_average
from feedopt.process.forces import (
    CuttingCoefficients,
    Engagement,
    ForceSplit,
    Tool,
    critical_angles,
    milling_forces,
    milling_forces_at,
)
from feedopt.process.plunge import plunge_mean

LIMIT_MODES = ("norm", "normal", "direction", "residual")

# Samples per chunk: 4096 samples x 360 angles x 3 x 8 B = 35 MB per array. With more angles
# per sample (a fine angle step, many slices) the chunk shrinks so each array stays that size.
_CHUNK = 4096
_CHUNK_ELEMENTS = _CHUNK * 360


@dataclass(frozen=True)
class ChunkForces:
    """Forces of a chunk of k samples over their distinct rows (:meth:`DeflectionModel.
    chunk_forces`): ``grid`` on the uniform angle grid with ``grid_row`` (k,) the row of each
    sample; ``critical`` (k, K) each sample's critical angles and ``at_critical`` the forces
    there with ``critical_row`` (k,)."""

    grid: ForceSplit
    grid_row: np.ndarray
    critical: np.ndarray
    at_critical: ForceSplit
    critical_row: np.ndarray


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
        normal, the force-model y axis), ``"direction"`` (component along ``direction``) or
        ``"residual"`` (|d(phi) - mean d|: what is left when the commanded path is offset by
        the mean deflection of the revolution, :meth:`mean_terms`).
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
        """Force split on the uniform angle grid for the distinct engagements of ``index``.

        Returns the split over the distinct rows and, per sample, the row it uses.
        """
        distinct = self.distinct_engagements(index)
        if distinct is None:  # pieced samples: no shared rows to find
            split = milling_forces(self.tool, self.coefficients, self.engagement.take(index),
                                   self.angles, axial_slices=self.axial_slices)
            return split, np.arange(index.size)
        unique, inverse = distinct
        return milling_forces(self.tool, self.coefficients, unique, self.angles,
                              axial_slices=self.axial_slices), inverse

    def distinct_engagements(self, index: np.ndarray) -> tuple[Engagement, np.ndarray] | None:
        """The distinct (entry, exit, depth, plunge) rows of samples ``index`` and, per
        sample, the row it has; None for pieced engagements (a sample's pieces are its own)."""
        e = self.engagement
        if e.pieces is not None or e.by_slice is not None:
            return None
        rows = np.stack([e.entry[index], e.exit[index], e.axial_depth[index],
                         _plunge_of(e)[index], _lean_of(e)[index]], axis=1)
        unique, inverse = np.unique(rows, axis=0, return_inverse=True)
        return (Engagement(entry=unique[:, 0], exit=unique[:, 1], axial_depth=unique[:, 2],
                           plunge=unique[:, 3], feed_axial=unique[:, 4]), inverse.ravel())

    def chunk_forces(self, sl: slice | np.ndarray) -> ChunkForces:
        """Forces of samples ``sl`` on the angle grid and at their critical angles (where a
        slice enters or leaves the cut), each over the distinct engagements: a slot's chunk
        has one, so both are computed once, not per sample (the same numbers: every row is
        computed alone)."""
        idx = np.arange(self.n)[sl]
        distinct = self.distinct_engagements(idx)
        if distinct is None:
            grid, row = self.forces(idx)
            crit = critical_angles(self.tool, self.engagement_slice(sl), self.axial_slices)
            at, crit_row = self.distinct_forces_at(sl, crit)
            return ChunkForces(grid, row, crit, at,
                               np.arange(idx.size) if crit_row is None else crit_row)
        unique, row = distinct
        grid = milling_forces(self.tool, self.coefficients, unique, self.angles,
                              axial_slices=self.axial_slices)
        crit = critical_angles(self.tool, unique, self.axial_slices)
        at = milling_forces_at(self.tool, self.coefficients, unique, crit,
                               axial_slices=self.axial_slices)
        return ChunkForces(grid, row, crit[row], at, row)

    def engagement_slice(self, sl: slice | np.ndarray) -> Engagement:
        """The engagement of samples ``sl`` (a slice or increasing indices)."""
        return self.engagement.take(sl)

    def sample_chunks(self, chunk: int) -> Iterator[slice | np.ndarray]:
        """Samples in groups of at most ``chunk``: runs of single-interval samples (slices),
        then the samples on several pieces grouped by their piece count, so that the
        critical angles of a group (padded to its largest count) stay few, with at most
        ``chunk`` / (pieces) samples per group (increasing index arrays)."""
        pieced = self.engagement.pieced
        if not pieced.any():
            for start in range(0, self.n, chunk):
                yield slice(start, min(start + chunk, self.n))
            return
        plain = np.flatnonzero(~pieced)
        for start in range(0, plain.size, chunk):
            yield plain[start : start + chunk]
        counts = np.bincount(self.engagement.pieces.sample, minlength=self.n)
        idx = np.flatnonzero(pieced)
        idx = idx[np.argsort(counts[idx], kind="stable")]
        start = 0
        while start < idx.size:
            # idx is sorted by count: the count at the end of the widest group bounds them all
            width = max(1, chunk // int(counts[idx[min(idx.size, start + chunk) - 1]]))
            group = idx[start : start + width]
            yield np.sort(group)
            start += group.size

    def _project(self, sl: slice, cutting: np.ndarray, edge: np.ndarray):
        """Deflection per unit feed per tooth ``a`` and at zero feed ``b`` from forces."""
        cr = self.compliance[sl] @ self.frames[sl]  # (k, 3, 3): force-model frame -> d
        a = np.einsum("kij,kmj->kmi", cr, cutting, optimize=True)
        b = np.einsum("kij,kmj->kmi", cr, edge, optimize=True)
        if self.mode == "norm":
            return a, b
        if self.mode == "residual":  # d(phi) - mean d: still affine in c
            a_mean, b_mean = self.mean_terms(sl)
            return a - a_mean[:, None, :], b - b_mean[:, None, :]
        u = self._directions(sl)
        return np.einsum("kmi,ki->km", a, u), np.einsum("kmi,ki->km", b, u)

    def forces_at(self, sl: slice | np.ndarray, angles: np.ndarray) -> ForceSplit:
        """Force split of samples ``sl`` at per-sample rotation angles (k, j).

        Samples whose engagement and angles are the same (a slot's critical angles, the
        refinement windows of samples whose worst angle is the same grid angle) are
        evaluated once: the forces depend on them only, not on the pose. Results are those
        of the per-sample evaluation exactly (each row is computed alone).
        """
        split, row = self.distinct_forces_at(sl, angles)
        if row is None:
            return split
        return ForceSplit(np.asarray(angles), split.cutting[row], split.edge[row],
                          split.cutting_torque[row], split.edge_torque[row])

    def distinct_forces_at(self, sl: slice | np.ndarray, angles: np.ndarray
                           ) -> tuple[ForceSplit, np.ndarray | None]:
        """:meth:`forces_at` before expansion: the split over the distinct (engagement,
        angles) rows and, per sample, the row it uses (None: one row per sample)."""
        eng = self.engagement_slice(sl)
        if eng.pieces is None and eng.by_slice is None and eng.n > 1:
            first, row = _same_rows(np.column_stack([eng.entry, eng.exit, eng.axial_depth,
                                                     _plunge_of(eng), _lean_of(eng),
                                                     angles]))
            if first.size <= eng.n // 2:
                split = milling_forces_at(
                    self.tool, self.coefficients, eng.take(first), np.asarray(angles)[first],
                    axial_slices=self.axial_slices)
                return split, row
        return milling_forces_at(self.tool, self.coefficients, eng, angles,
                                 axial_slices=self.axial_slices), None

    def at_angles(self, sl: slice | np.ndarray, angles: np.ndarray):
        """``a``, ``b`` of samples ``sl`` at per-sample rotation angles (k, j)."""
        split = self.forces_at(sl, angles)
        return self._project(sl, split.cutting, split.edge)

    def chunk_size(self) -> int:
        """Samples per chunk of the bound and the replay: a (chunk, angles, 3) array stays
        ~35 MB."""
        table = self.engagement.by_slice  # engaged per slice: its slices and intervals
        n_crit = (2 * self.axial_slices if table is None  # entry/exit angles per sample
                  else 2 * table.lo.shape[1] * table.lo.shape[2])
        return max(1, min(_CHUNK, _CHUNK_ELEMENTS // (self.angles.size + n_crit)))

    def terms(self, sl: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(angles, a, b)`` of samples ``sl`` over the uniform grid joined with every angle
        at which a slice enters or leaves the cut (where the force jumps, so the maximum over
        a revolution sits there or on a smooth part between them).

        ``angles`` is (k, M) per sample; ``a`` and ``b`` have shape (k, M, 3) in the base
        frame [m/m and m], or (k, M) when the mode projects on a direction.
        """
        idx = np.arange(self.n)[sl]
        split, row = self.forces(idx)
        a_grid, b_grid = self._project(sl, split.cutting[row], split.edge[row])
        crit = critical_angles(self.tool, self.engagement_slice(sl), self.axial_slices)
        a_crit, b_crit = self.at_angles(sl, crit)
        grid = np.broadcast_to(self.angles, (idx.size, self.angles.size))
        return (np.concatenate([grid, crit], axis=1), np.concatenate([a_grid, a_crit], axis=1),
                np.concatenate([b_grid, b_crit], axis=1))

    def angle_terms(self, sl: slice | np.ndarray,
                    forces: ChunkForces | None = None) -> AngleTerms:
        """What the bound and the replay need of samples ``sl`` over the angles of
        :meth:`terms` (same angles, same values up to rounding), without forming a and b.

        A slot has one engagement, so its forces over the angles are the same at every
        sample and only the pose differs: with G = (C R)^T (C R) (3 x 3, per sample),
        |a|^2 = Fc^T G Fc, a.b = Fc^T G Fe and |b|^2 = Fe^T G Fe, which for all samples sharing
        a force row is one matrix product (g, 6) x (6, 3 M) (a directional limit: w = (C R)^T u
        and a_n = w . Fc, (g, 3) x (3, 2 M)). Samples that share little (a stock's
        engagement changing every sample, pieced samples) and the residual mode take the
        direct route of :meth:`terms`. ``forces``: :meth:`chunk_forces` of ``sl`` if already
        computed.
        """
        f = self.chunk_forces(sl) if forces is None else forces
        k = f.grid_row.size
        angles = np.concatenate([np.broadcast_to(self.angles, (k, self.angles.size)),
                                 f.critical], axis=1)
        if f.critical_row is f.grid_row:  # both per distinct engagement: one pass, joined
            return AngleTerms(angles, *self._reduced(
                sl, np.concatenate([f.grid.cutting, f.at_critical.cutting], axis=1),
                np.concatenate([f.grid.edge, f.at_critical.edge], axis=1), f.grid_row))
        parts = [self._reduced(sl, f.grid.cutting, f.grid.edge, f.grid_row),
                 self._reduced(sl, f.at_critical.cutting, f.at_critical.edge, f.critical_row)]
        return AngleTerms(angles, *(None if p[0] is None else
                                    np.concatenate([p[0], p[1]], axis=1)
                                    for p in zip(*parts, strict=True)))

    def _reduced(self, sl: slice | np.ndarray, cutting: np.ndarray, edge: np.ndarray,
                 row: np.ndarray) -> tuple[np.ndarray | None, ...]:
        """``(aa, ab, bb, a, b)`` of :class:`AngleTerms` from forces over distinct rows
        (U, M, 3) and the row of each of the k samples (:meth:`angle_terms`)."""
        k, m = row.size, cutting.shape[1]
        n_rows = cutting.shape[0]
        if self.mode == "residual" or n_rows > max(1, k // 8):
            a, b = self._project(sl, cutting[row], edge[row])
            return AngleTerms.from_vectors(np.empty((k, m)), a, b).values()
        cr = self.compliance[sl] @ self.frames[sl]  # (k, 3, 3): force-model frame -> d
        order = np.argsort(row, kind="stable")
        bounds = np.searchsorted(row[order], np.arange(n_rows + 1))
        if self.mode == "norm":
            gram = np.einsum("kji,kjl->kil", cr, cr)
            weights = np.stack([gram[:, 0, 0], gram[:, 1, 1], gram[:, 2, 2], 2.0 * gram[:, 0, 1],
                                2.0 * gram[:, 0, 2], 2.0 * gram[:, 1, 2]], axis=1)  # (k, 6)
            out = np.empty((k, 3 * m))
            for u in range(n_rows):
                members = order[bounds[u]:bounds[u + 1]]
                if members.size:
                    fc, fe = cutting[u], edge[u]
                    products = np.concatenate(
                        [_sym_products(fc, fc), _sym_products(fc, fe), _sym_products(fe, fe)],
                        axis=1)  # (6, 3 m)
                    out[members] = weights[members] @ products
            return out[:, :m], out[:, m:2 * m], out[:, 2 * m:], None, None
        w = np.einsum("kji,kj->ki", cr, self._directions(sl))  # (k, 3): a_n = w . Fc
        out = np.empty((k, 2 * m))
        for u in range(n_rows):
            members = order[bounds[u]:bounds[u + 1]]
            if members.size:
                out[members] = w[members] @ np.concatenate([cutting[u].T, edge[u].T], axis=1)
        return None, None, None, out[:, :m], out[:, m:]

    @property
    def _step(self) -> float:
        """Largest spacing of the uniform angle grid [rad]."""
        if self.angles.size < 2:
            return 2.0 * np.pi / self.tool.teeth
        return float(np.max(np.diff(np.sort(self.angles))))

    def refine(self, sl: slice, angles: np.ndarray, grid: GridExtreme | np.ndarray,
               worst: str, evaluate) -> np.ndarray:
        """Refine the extreme of a per-angle quantity between grid points.

        Between the jumps (which :meth:`terms` samples exactly) the forces are smooth, so
        the extreme lies within one grid step of the best grid or critical angle: evaluate a
        window of 9 angles across +-1 step around it, then the vertex of the parabola
        through the best window point and its neighbours. ``grid`` is the quantity over
        ``angles`` (k, M) or already its extreme per sample (:class:`GridExtreme`). Returns
        the per-sample extreme (max if ``worst == "max"``, else min) over everything
        evaluated.
        """
        pick = np.argmax if worst == "max" else np.argmin
        if not isinstance(grid, GridExtreme):
            grid = GridExtreme.of(grid, worst)
        centre = np.take_along_axis(angles, grid.index[:, None], axis=1)[:, 0]
        h = self._step / 4.0
        window = centre[:, None] + h * np.arange(-4, 5)[None, :]
        vw = evaluate(sl, window)
        j = np.clip(pick(vw, axis=1), 1, 7)
        y0, y1, y2 = (np.take_along_axis(vw, (j + d)[:, None], axis=1)[:, 0] for d in (-1, 0, 1))
        with np.errstate(divide="ignore", invalid="ignore"):  # inf roots: no cutting force
            curv = y0 - 2.0 * y1 + y2
            towards = curv < 0 if worst == "max" else curv > 0
            shift = np.where(towards, 0.5 * (y0 - y2) / curv, 0.0)
        shift = np.where(np.isfinite(shift), shift, 0.0)  # samples without force: inf - inf
        vertex = np.take_along_axis(window, j[:, None], axis=1)[:, 0] + np.clip(shift, -1, 1) * h
        vv = evaluate(sl, vertex[:, None])[:, 0]
        stack = np.column_stack([grid.value,
                                 vw.max(axis=1) if worst == "max" else vw.min(axis=1), vv])
        return stack.max(axis=1) if worst == "max" else stack.min(axis=1)

    def mean_terms(self, sl: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean deflection over a revolution, ``mean d = c a_mean + b_mean`` (k, 3) [m/m, m],
        base frame, for samples ``sl``.

        From the closed-form average forces of Altintas [39] (thesis Eq. 3.24-3.25,
        :func:`feedopt.process.averages.average_forces`), summed over a sample's pieces, plus
        the mean plunge force (:func:`feedopt.process.plunge.plunge_mean`):
        the exact mean of the slice model (over a whole revolution the helix lag does not
        matter), so ``d(phi) - mean d`` averages to zero over the revolution. A feed leaning
        along the tool axis: a flat end mill's cutting part scaled by
        :func:`~feedopt.process.forces.flat_side_scale`, a general cutter's mean of its
        tilted slices (:func:`~feedopt.process.averages.side_average`).
        """
        eng = self.engagement_slice(sl)
        cut, edge = side_average(self.tool, self.coefficients, eng)
        if eng.plunge is not None:  # the end edges of a plunge: constant thrust
            if self.coefficients.plunge is None:
                raise InputError("the path plunges along the tool axis, but the cutting "
                                 "coefficients have no plunge block")
            pc, pe = plunge_mean(self.tool, self.coefficients.plunge, eng.plunge)
            cut, edge = cut + pc, edge + pe
        cr = self.compliance[sl] @ self.frames[sl]
        return np.einsum("kij,kj->ki", cr, cut), np.einsum("kij,kj->ki", cr, edge)

    def mean_deflection(self, feed: np.ndarray) -> np.ndarray:
        """Mean deflection over the revolution at path feeds ``feed`` (n,) [m/s]: (n, 3) [m],
        base frame: the offset that compensation subtracts from the commanded path."""
        c = np.asarray(feed, dtype=float) / self.feed_per_unit_c
        a, b = self.mean_terms(slice(0, self.n))
        return c[:, None] * a + b

    def _directions(self, sl: slice) -> np.ndarray:
        if self.mode == "normal":
            return self.frames[sl, :, 1]
        if self.mode == "direction":
            d = np.asarray(self.direction, dtype=float)
            return np.broadcast_to(d / np.linalg.norm(d), (self.frames[sl].shape[0], 3))
        raise ValueError(f"unknown limit mode {self.mode!r}; expected one of {LIMIT_MODES}")

    def deflection(self, feed: np.ndarray,
                   progress: Callable[[int, int], None] | None = None) -> np.ndarray:
        """Max over the revolution of the limited deflection [m] at path feeds ``feed`` [m/s].

        This is the forward replay used by verification: F = c Fc + Fe at the commanded
        feed per tooth, rotated to the base frame and multiplied by the compliance, over the
        angle grid, every slice entry/exit angle and a refinement around the worst angle.
        ``feed`` is (n,) or (L, n) for L feed profiles (several timing laws): the forces of
        each chunk are then computed once for all of them. The result has ``feed``'s shape.
        ``progress(samples_done, samples)`` after each chunk.
        """
        c_all = np.atleast_2d(np.asarray(feed, dtype=float)) / self.feed_per_unit_c
        out = np.empty(c_all.shape)

        def magnitude(c: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
            d = c[:, None, None] * a + b if a.ndim == 3 else c[:, None] * a + b
            return norm3(d) if d.ndim == 3 else np.abs(d)

        def replay(sl: slice | np.ndarray) -> int:
            terms = self.angle_terms(sl)
            windows = _WindowMemo(self, sl)  # the laws' refinement windows mostly coincide
            for row, c in enumerate(c_all[:, sl]):
                out[row, sl] = self.refine(
                    sl, terms.angles, terms.largest_magnitude(c), "max",
                    lambda s_, w, c=c: magnitude(c, *windows.at_angles(s_, w)))
            return terms.angles.shape[0]

        for_each_chunk(replay, self.sample_chunks(self.chunk_size()),
                       on_done=counting(progress, self.n))
        return out.reshape(np.shape(feed))


def counting(progress: Callable[[int, int], None] | None, total: int
             ) -> Callable[[int], None] | None:
    """An ``on_done`` for :func:`feedopt.parallel.for_each_chunk` whose chunks return their
    sample count: ``progress(samples_done, total)`` (None without ``progress``)."""
    if progress is None:
        return None
    done = [0]

    def update(samples: int) -> None:
        done[0] += samples
        progress(done[0], total)

    return update


class _WindowMemo:
    """``a``, ``b`` at the refinement angles of one chunk, kept from one timing law to the
    next: where a sample's worst grid angle is the same for both laws (most samples), its
    window is the same and is not evaluated again. Only windows (more than one angle per
    sample) are kept: the parabola vertex differs from law to law."""

    def __init__(self, model: DeflectionModel, sl: slice | np.ndarray) -> None:
        self.model, self.index = model, np.arange(model.n)[sl]
        self.last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def at_angles(self, sl: slice | np.ndarray, angles: np.ndarray):
        if angles.shape[1] < 2:
            return self.model.at_angles(sl, angles)
        last = self.last
        if last is None or last[0].shape != angles.shape:
            a, b = self.model.at_angles(sl, angles)
        else:
            rows = np.flatnonzero(np.any(last[0] != angles, axis=1))
            a, b = last[1], last[2]
            if rows.size:
                a, b = a.copy(), b.copy()
                a[rows], b[rows] = self.model.at_angles(self.index[rows], angles[rows])
        self.last = (angles.copy(), a, b)
        return a, b


def norm3(d: np.ndarray) -> np.ndarray:
    """|d| over a trailing axis of 3: the same value as np.linalg.norm, 6x faster (no
    generic reduction)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.sqrt(x * x + y * y + z * z)


def _sym_products(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """(6, M) products of two (M, 3) force series such that, with the weights
    (G00, G11, G22, 2 G01, 2 G02, 2 G12) of a symmetric G, their dot product is f^T G g."""
    return np.stack([f[:, 0] * g[:, 0], f[:, 1] * g[:, 1], f[:, 2] * g[:, 2],
                     0.5 * (f[:, 0] * g[:, 1] + f[:, 1] * g[:, 0]),
                     0.5 * (f[:, 0] * g[:, 2] + f[:, 2] * g[:, 0]),
                     0.5 * (f[:, 1] * g[:, 2] + f[:, 2] * g[:, 1])])


@dataclass(frozen=True)
class AngleTerms:
    """d(phi) = c a(phi) + b(phi) of k samples at M angles each, reduced to what the feed
    bound and the replay use: |d|^2 = c^2 aa + 2 c ab + bb (modes on |d|: ``aa``, ``ab``,
    ``bb``) or the projected d_n = c a + b (``a``, ``b``); every array (k, M).
    """

    angles: np.ndarray
    aa: np.ndarray | None = None
    ab: np.ndarray | None = None
    bb: np.ndarray | None = None
    a: np.ndarray | None = None
    b: np.ndarray | None = None

    @classmethod
    def from_vectors(cls, angles: np.ndarray, a: np.ndarray, b: np.ndarray) -> AngleTerms:
        """From ``a``, ``b`` as :meth:`DeflectionModel.terms` gives them ((k, M, 3) or (k, M))."""
        if a.ndim == 3:
            return cls(angles, np.einsum("kmi,kmi->km", a, a), np.einsum("kmi,kmi->km", a, b),
                       np.einsum("kmi,kmi->km", b, b))
        return cls(angles, a=a, b=b)

    def values(self) -> tuple[np.ndarray | None, ...]:
        """``(aa, ab, bb, a, b)``."""
        return self.aa, self.ab, self.bb, self.a, self.b

    @property
    def quadratic(self) -> bool:
        """True for the modes on |d| (``aa``, ``ab``, ``bb`` set)."""
        return self.aa is not None

    def rows(self, r: slice) -> AngleTerms:
        """The terms of the samples ``r`` (views, no copy)."""
        return AngleTerms(*(None if v is None else v[r] for v in (self.angles, *self.values())))

    def square(self, c: np.ndarray) -> np.ndarray:
        """|d|^2 = c^2 aa + 2 c ab + bb [m^2] at feed per tooth ``c`` (k,) [m] (modes on |d|)."""
        out = np.multiply((c * c)[:, None], self.aa)
        out += (2.0 * c)[:, None] * self.ab
        out += self.bb
        return out

    def magnitude(self, c: np.ndarray) -> np.ndarray:
        """The limited deflection |d| (or |d_n|) [m] at feed per tooth ``c`` (k,) [m]."""
        if self.quadratic:
            return np.sqrt(np.maximum(self.square(c), 0.0))
        return np.abs(c[:, None] * self.a + self.b)

    def zero_feed(self) -> np.ndarray:
        """The deflection [m] of the edge forces alone (c = 0)."""
        return np.sqrt(np.maximum(self.bb, 0.0)) if self.quadratic else np.abs(self.b)

    def largest_magnitude(self, c: np.ndarray) -> GridExtreme:
        """Per sample, the angle of the largest :meth:`magnitude` at ``c`` (k,) and its
        value, without the (k, M) array of magnitudes: the square is formed in blocks of rows
        that stay in cache and the root is taken of the largest square only (the root is
        monotone, so the value is the same)."""
        if not self.quadratic:
            return GridExtreme.blocked(lambda r: self.rows(r).magnitude(c[r]), c.size, "max")
        extreme = GridExtreme.blocked(lambda r: self.rows(r).square(c[r]), c.size, "max")
        return GridExtreme(extreme.index, np.sqrt(np.maximum(extreme.value, 0.0)))

    def largest_zero_feed(self) -> GridExtreme:
        """:meth:`zero_feed`'s largest angle and value per sample (see
        :meth:`largest_magnitude`)."""
        if not self.quadratic:
            return GridExtreme.of(np.abs(self.b), "max")
        extreme = GridExtreme.of(self.bb, "max")
        return GridExtreme(extreme.index, np.sqrt(np.maximum(extreme.value, 0.0)))


#: Rows of a (k, M) per-angle array handled at a time by :meth:`GridExtreme.blocked`: with
#: M ~ 400 angles a block's temporaries (~0.8 MB each) stay in a core's L2 cache.
_ROWS_PER_BLOCK = 256


@dataclass(frozen=True)
class GridExtreme:
    """Per sample (k,), the index of the extreme angle of a per-angle quantity and its value
    (the first such angle on ties, as ``np.argmax`` / ``np.argmin`` of that quantity).

    :meth:`AngleTerms.largest_magnitude` takes it of the squares: two squares a few ulp apart
    whose roots round to the same value can give a later angle than the argmax of the roots
    (the value is the same; :meth:`DeflectionModel.refine` then centres its window there).
    """

    index: np.ndarray
    value: np.ndarray

    @classmethod
    def of(cls, value: np.ndarray, worst: str) -> GridExtreme:
        """Of a (k, M) array: ``worst`` is ``"max"`` or ``"min"``."""
        index = (np.argmax if worst == "max" else np.argmin)(value, axis=1)
        return cls(index, np.take_along_axis(value, index[:, None], axis=1)[:, 0])

    @classmethod
    def blocked(cls, rows: Callable[[slice], np.ndarray], k: int, worst: str,
                block: int | None = None) -> GridExtreme:
        """Of the (k, M) array whose rows ``r`` are ``rows(r)``, formed block by block."""
        block = block or _ROWS_PER_BLOCK
        index, value = np.empty(k, dtype=np.intp), np.empty(k)
        for start in range(0, k, block):
            r = slice(start, min(start + block, k))
            part = cls.of(rows(r), worst)
            index[r], value[r] = part.index, part.value
        return cls(index, value)


_HASH_WEIGHTS = np.random.default_rng(20261202).uniform(0.5, 1.5, 4096)


def _plunge_of(e: Engagement) -> np.ndarray:
    """The plunge column of ``e`` (zeros without plunges), to key distinct rows on."""
    return e.plunge if e.plunge is not None else np.zeros(e.n)


def _lean_of(e: Engagement) -> np.ndarray:
    """The feed-along-axis column of ``e`` (zeros without), to key distinct rows on."""
    return e.feed_axial if e.feed_axial is not None else np.zeros(e.n)


def _same_rows(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``key`` (k, w) that are equal: the first index of each distinct row
    (increasing) and, per row, which of those it equals. Grouped by a random projection of
    the rows, then checked exactly; if the projection confused two different rows (never
    seen), every row is its own."""
    k, w = key.shape
    if w > _HASH_WEIGHTS.size:
        return np.arange(k), np.arange(k)
    h = key @ _HASH_WEIGHTS[:w]
    _, first, inverse = np.unique(h, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    first, row = first[order], rank[inverse.reshape(-1)]
    if not np.array_equal(key, key[first[row]]):
        return np.arange(k), np.arange(k)
    return first, row


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
