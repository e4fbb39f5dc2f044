"""The envelope a cutter's flutes are wrapped on: flat, ball-nose, bull-nose, tapered, face mills.

Engin & Altintas ("Mechanics and dynamics of general milling cutters. Part I: helical end
mills", IJMTM 41, 2001, Fig. 1) describe an end mill by the profile its cutting edges sweep in
a meridian plane. The profiles feedopt models are their special cases with a corner arc and a
straight line, in the tool frame (z up the tool axis from the tip, r from the axis)::

    corner arc (radius rc, centre (r0, rc)), axial immersion kappa from 0 to kappa1:
        r = r0 + rc sin(kappa),   z = rc (1 - cos(kappa))
    then a straight edge at kappa1 (r grows with z unless kappa1 = 90 deg):
        r = r_e + t cos(kappa1),  z = z_e + t sin(kappa1)

with ``r0 + rc = D / 2``. kappa is the axial immersion angle of E&A (the angle between the tool
axis and the edge's outward normal, 90 deg on a cylinder): flat end mill rc = 0, kappa1 = 90;
ball-nose rc = D/2, r0 = 0; bull-nose 0 < rc < D/2; tapered kappa1 = 90 - taper (its tip
diameter D, a flat or ball tip); face mill with inserts: kappa1 = the insert's entering (lead)
angle kappa_r and rc its nose radius, D the cutting diameter at the insert's tip (Dc). The flat
bottom ``r < r0`` has kappa = 0 and cuts no chip on a feed across the axis (end cutting is
:mod:`feedopt.process.plunge`).

Slices are taken of equal length ds along the profile (not of equal height: near a ball's tip
the edge is nearly horizontal, dz = ds sin(kappa)), so that each has chip width db = ds
(E&A Eq. 10: db = dz / sin(kappa)). On a flat end mill ds = dz = a / L at heights
(j + 1/2) a / L: exactly the slices of thesis Algorithm 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np


class CutterShape(Enum):
    """The cutter shapes of a tool file (``shape:``)."""

    FLAT = "flat"
    BALL = "ball"
    BULL = "bull"
    TAPERED = "tapered"
    FACE = "face"


@dataclass(frozen=True)
class Profile:
    """A corner arc then a straight edge (module docstring), SI units.

    Attributes
    ----------
    r0 : radius [m] where the corner arc leaves the flat bottom
    corner : corner (nose) radius rc [m], 0 for a sharp corner
    kappa1 : axial immersion of the straight edge [rad], in (0, pi/2]
    """

    r0: float
    corner: float
    kappa1: float

    @property
    def arc_length(self) -> float:
        """Length of the corner arc [m]."""
        return self.corner * self.kappa1

    @property
    def arc_top(self) -> tuple[float, float]:
        """(r_e, z_e) where the arc meets the straight edge [m]."""
        return (self.r0 + self.corner * math.sin(self.kappa1),
                self.corner * (1.0 - math.cos(self.kappa1)))

    @property
    def is_cylinder(self) -> bool:
        """True for a flat end mill (no corner, straight edge along the axis)."""
        return self.corner == 0.0 and self.kappa1 == math.pi / 2

    def length_to_height(self, z: np.ndarray | float) -> np.ndarray:
        """Profile length s [m] from the arc's start up to height z [m] (z >= 0)."""
        z = np.asarray(z, dtype=float)
        r_e, z_e = self.arc_top
        on_arc = z < z_e
        with np.errstate(invalid="ignore", divide="ignore"):  # 1 - cos k = 2 sin^2(k / 2)
            arc = 2.0 * self.corner * np.arcsin(np.sqrt(np.clip(
                z / (2.0 * max(self.corner, 1e-300)), 0.0, 1.0)))
        line = self.arc_length + (z - z_e) / math.sin(self.kappa1)
        return np.where(on_arc, arc, line)

    def at_length(self, s: np.ndarray) -> tuple[np.ndarray, ...]:
        """(r, z, sin kappa, cos kappa) at profile lengths ``s`` [m] (any shape)."""
        s = np.asarray(s, dtype=float)
        r_e, z_e = self.arc_top
        on_arc = s < self.arc_length
        kappa = np.where(on_arc, s / max(self.corner, 1e-300), self.kappa1)
        t = s - self.arc_length
        sk, ck = np.sin(kappa), np.cos(kappa)
        if self.kappa1 == math.pi / 2:  # exact 1 and 0 on the straight part of a cylinder
            sk = np.where(on_arc, sk, 1.0)
            ck = np.where(on_arc, ck, 0.0)
        r = np.where(on_arc, self.r0 + self.corner * sk, r_e + t * math.cos(self.kappa1))
        z = np.where(on_arc, 2.0 * self.corner * np.sin(0.5 * kappa) ** 2,  # rc (1 - cos k)
                     z_e + t * math.sin(self.kappa1))
        if self.kappa1 == math.pi / 2:
            r = np.where(on_arc, r, r_e)
            z = np.where(on_arc, z, z_e + t)
        return r, z, sk, ck

    def height_at_radius(self, rho: np.ndarray) -> np.ndarray:
        """Height [m] of the cutter's lower surface above its tip at distance ``rho`` [m]
        from the axis: 0 on the flat bottom, the corner arc, then the straight edge extended
        without limit (a cylinder's is ``inf`` beyond its radius): the stock sweep's removal
        surface."""
        rho = np.asarray(rho, dtype=float)
        r_e, z_e = self.arc_top
        with np.errstate(invalid="ignore"):
            arc = self.corner - np.sqrt(np.maximum(self.corner**2 - (rho - self.r0) ** 2, 0.0))
        line = z_e + (rho - r_e) * math.tan(self.kappa1) if self.kappa1 < math.pi / 2 else (
            np.where(rho <= r_e, z_e, np.inf))
        return np.where(rho <= self.r0, 0.0, np.where(rho <= r_e, arc, line))


@dataclass(frozen=True)
class Slices:
    """The profile cut into slices of equal length over axial depths ``a`` (per sample).

    Attributes (shape (n, L) unless said)
    ----------
    radius : r_j [m]
    height : z_j above the tip [m] (the helix lag's argument)
    sin_kappa, cos_kappa : of the axial immersion kappa_j
    width : (n,) chip width db = ds of every slice [m]
    """

    radius: np.ndarray
    height: np.ndarray
    sin_kappa: np.ndarray
    cos_kappa: np.ndarray
    width: np.ndarray


@dataclass(frozen=True)
class SliceEngagement:
    """Per sample the slices of the profile over its axial depth and, per slice, the union
    of the engaged intervals ``[lo_w, hi_w)`` (w < W, padded with empty ``lo == hi``).

    ``feed_x``, ``feed_z`` (n,): a tilted tool's unit feed direction in its own frame, across
    and along the tool axis (lead: ``(cos, sin)`` of the angle;
    :mod:`feedopt.process.general_forces`, "Feed along the axis"); None: the feed is across
    the axis (1, 0). Intervals lie in [0, 2 pi) [rad] (the angle of
    :mod:`feedopt.process.general_forces`)."""

    sliced: Slices
    lo: np.ndarray  # (n, L, W) [rad]
    hi: np.ndarray  # (n, L, W) [rad]
    feed_x: np.ndarray | None = None
    feed_z: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.lo.shape[0])

    def rows(self, sl: slice | np.ndarray) -> SliceEngagement:
        """The samples ``sl`` (a slice or an index array)."""
        s = self.sliced
        fx, fz = (None if f is None else f[sl] for f in (self.feed_x, self.feed_z))
        return SliceEngagement(Slices(s.radius[sl], s.height[sl], s.sin_kappa[sl],
                                      s.cos_kappa[sl], s.width[sl]), self.lo[sl], self.hi[sl],
                               fx, fz)

    def without(self, drop: np.ndarray) -> SliceEngagement:
        """These intervals with the samples ``drop`` (n,) bool cutting nothing."""
        drop = np.asarray(drop, dtype=bool)[:, None, None]
        return SliceEngagement(self.sliced, np.where(drop, 0.0, self.lo),
                               np.where(drop, 0.0, self.hi), self.feed_x, self.feed_z)

    @property
    def cutting(self) -> np.ndarray:
        """(n,) bool: some slice of the sample has a non-empty interval."""
        return np.any(self.lo < self.hi, axis=(1, 2))


def profile_slices(profile: Profile, depth: np.ndarray, slices: int) -> Slices:
    """The ``slices`` slices of equal profile length over axial depth ``depth`` (n,) [m],
    at their mid-lengths (module docstring)."""
    depth = np.asarray(depth, dtype=float).reshape(-1)
    total = profile.length_to_height(depth)
    ds = total / slices
    s = (np.arange(slices) + 0.5)[None, :] * ds[:, None]
    r, z, sk, ck = profile.at_length(s)
    return Slices(r, z, sk, ck, ds)
