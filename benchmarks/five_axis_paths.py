"""Generate five-axis tool paths (swarf of a ruled wall, tilted ball-nose surfacing) as APT CL.

Each generator is a pure function of a small frozen spec returning a :class:`ClPath`: CL points
[mm] (the tool TIP, APT's convention: the bottom of the tool on its axis), unit tool vectors
from the tip into the spindle, a flag per point (True: the move to it is a feed move, False: a
rapid) and the surface reference point of each feed point (NaN for air points). Every pass
starts and ends in the air: a rapid to the point above its start on the tool axis at the safe
height (z = ``z_safe``), a rapid down the axis to ``approach_mm`` from the start, a feed move
to the start (at the plunge feed), the pass, and a rapid retract up the axis to the safe
height. :func:`apt_text` writes a path as APT CL text (UNITS/MM, MULTAX/ON, CUTTER, LOADTL,
SPINDL, GOTO/x,y,z,i,j,k with 6 decimals, RAPID before every rapid GOTO, FEDRAT before the
first feed move and whenever the feed changes, FINI).

**Swarf** (:class:`Swarf`, :func:`swarf_cl`): a flat end mill of diameter D flanks a ruled wall
W(l, v) = B(l) + v a(l). The bottom curve B is an arc of radius ``arc_radius_mm`` (0: a line)
in z = 0, parametrised by arc length l in [0, L], starting at the origin along +X and bending
towards +Y (the material side, left of the feed: climb milling with a CLW spindle); n_h(l) is
its horizontal normal towards the tool (right of the feed). The ruling a(l) = cos(phi) e_z -
sin(phi) n_h leans by phi(l) away from the tool (a draft wall facing up and out), phi rising
from ``lean_deg[0]`` to ``lean_deg[1]`` at ``peak_frac`` * L and falling to ``lean_deg[2]`` at
L in half-cosine ramps (C1); the top curve T(l) = B(l) + H (e_z - tan(phi) n_h) lies in z = H.
The tool axis is the ruling; the wall's unit normal N(l, v) ~ W_l x a (towards the tool) turns
about the ruling along it unless dphi/dl = 0 (the wall is not developable), so the tip is
B + (D/2) N_t - ``below_floor_mm`` a with N_t the bisector of the normals at the ruling's
bottom and top. The ruling lies exactly on the tool's cylinder (the axis is parallel to it at
distance D/2); the wall beside it is not: near the ends the wall enters the cylinder by about
(D/2)(1 - cos(delta)), delta the angle between N_t and the end normal (:func:`swarf_twist_rad`).
:func:`swarf_overcut_mm` measures that overcut by dense sampling of the wall around each ruling
(defaults: about 0.007 mm). Rulings are placed by :func:`chord_params`: the chords of the
bottom, top and tip curves stay within ``chord_tol_mm`` and ``max_step_mm``.

**Ball** (:class:`Ball`, :func:`ball_cl`): a ball-nose end mill of radius R finishes a saddle
z = (x^2 - y^2) / (2 Rs) or a cylinder z = sqrt(Rs^2 - x^2) - Rs (axis along Y) over a patch
centred on the origin: passes along X (``width_mm``), stepped over in Y by at most
``stepover_mm`` (``length_mm``), one-way or zigzag. At a contact point p with unit normal n
(upwards), feed direction f = +-(1, 0, z_x)/|.| (tangent to the surface) and side s = n x f
(left of the feed), the tool axis is

    a = sin(lead) f + cos(lead) (cos(tilt) n + sin(tilt) s),

i.e. lead = asin(a . f) tilts the axis forwards (its top ahead of the tip) in the plane (n, f)
and tilt = atan2(a . s, a . n) sideways towards s; the ball's centre is p + R n and the tip
(the CL point) is centre - R a. Points along a pass by :func:`chord_params` (contact and tip
curves).

    .venv/bin/python benchmarks/five_axis_paths.py --kind swarf \
        --out scenarios/five_axis/swarf_wall.cls
    .venv/bin/python benchmarks/five_axis_paths.py --kind ball --lead-deg 10 --tilt-deg 3 \
        --out scenarios/five_axis/ball_saddle.cls
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

EZ = np.array([0.0, 0.0, 1.0])
SURFACES = ("saddle", "cylinder")


class ClPath(NamedTuple):
    """A five-axis CL path: tips (n, 3) [mm], unit axes (n, 3) from the tip into the spindle,
    cut (n,) True where the move to the point is a feed move, contact (n, 3) the surface point
    of each feed point (the ruling's bottom for swarf, the ball's contact) or NaN."""

    points: np.ndarray
    axes: np.ndarray
    cut: np.ndarray
    contact: np.ndarray


@dataclass(frozen=True)
class Swarf:
    """Swarf milling of a ruled wall (module docstring): the flat end mill's diameter and flute
    length, the bottom arc's length and radius (0: a line), the wall height, the lean from
    vertical at start, peak and end [deg], where the peak lies (fraction of the length), the
    tip below the floor along the axis, the chord tolerance and longest step, the safe height
    above the wall top, the approach distance, feeds [mm/min] and spindle speed [rev/min]."""

    diameter_mm: float = 10.0
    flute_mm: float = 25.0
    length_mm: float = 150.0
    arc_radius_mm: float = 400.0
    height_mm: float = 15.0
    lean_deg: tuple[float, float, float] = (0.0, 20.0, 5.0)
    peak_frac: float = 0.6
    below_floor_mm: float = 0.0
    chord_tol_mm: float = 0.01
    max_step_mm: float = 2.0
    clearance_mm: float = 10.0
    approach_mm: float = 2.0
    # the speeds of the thesis's calibrated 6061 coefficients (1000-2500 rpm): 0.04 mm/tooth
    feed_mm_min: float = 300.0
    plunge_mm_min: float = 150.0
    rpm: float = 2500.0


@dataclass(frozen=True)
class Ball:
    """Tilted ball-nose surfacing (module docstring): the ball's diameter, the surface (saddle
    or cylinder) and its radius, the patch along X (passes) and Y (step-over), the step-over,
    lead and tilt [deg], zigzag or one-way passes, the chord tolerance and longest step, the
    safe height above the surface's top, the approach distance, feeds and spindle speed."""

    diameter_mm: float = 10.0
    surface: str = "saddle"
    surface_radius_mm: float = 200.0
    width_mm: float = 60.0
    length_mm: float = 30.0
    stepover_mm: float = 1.0
    lead_deg: float = 10.0
    tilt_deg: float = 3.0
    zigzag: bool = True
    chord_tol_mm: float = 0.01
    max_step_mm: float = 1.0
    clearance_mm: float = 10.0
    approach_mm: float = 2.0
    feed_mm_min: float = 400.0  # 0.08 mm/tooth with two flutes at 2500 rpm
    plunge_mm_min: float = 200.0
    rpm: float = 2500.0


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` scaled to unit length."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points p (..., 3) to the segments a-b (broadcast)."""
    ab = b - a
    w = np.clip(np.sum((p - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-300),
                0.0, 1.0)
    return np.linalg.norm(p - a - w[..., None] * ab, axis=-1)


def chord_params(curves: Callable[[np.ndarray], np.ndarray], t0: float, t1: float,
                 tol_mm: float, max_step_mm: float, samples: int = 16) -> np.ndarray:
    """Parameters t0 = u_0 < ... < u_m = t1 (t1 < t0 allowed) by bisection until, on every
    interval, each curve of ``curves(t) -> (len(t), k, 3)`` stays within ``tol_mm`` of its
    chord (checked at ``samples`` interior points) and no chord is longer than ``max_step_mm``."""
    if not (tol_mm > 0 and max_step_mm > 0):
        raise ValueError("the chord tolerance and the longest step must be > 0")
    out, stack = [t0], [(t0, t1)]
    while stack:
        a, b = stack.pop()
        pts = curves(np.linspace(a, b, samples + 2))
        dev = _segment_distance(pts[1:-1], pts[0], pts[-1]).max()
        step = np.linalg.norm(pts[-1] - pts[0], axis=-1).max()
        if (dev <= tol_mm and step <= max_step_mm) or abs(b - a) < 1e-9 * abs(t1 - t0):
            out.append(b)
        else:
            m = 0.5 * (a + b)
            stack += [(m, b), (a, m)]
    return np.array(out)


def linked(passes: list[tuple[np.ndarray, np.ndarray, np.ndarray]], z_safe: float,
           approach_mm: float) -> ClPath:
    """The passes (tips, axes, contacts) joined by air moves: for each, a rapid to the point on
    the start's axis at height ``z_safe``, a rapid to ``approach_mm`` from the start along the
    axis, the feed moves of the pass, a rapid retract along the end's axis to ``z_safe``."""
    pts, axes, cut, contact = [], [], [], []
    nan = np.full(3, np.nan)

    def add(p, a, c, q):
        pts.append(p)
        axes.append(a)
        cut.append(c)
        contact.append(q)

    for tips, ax, con in passes:
        if min(ax[0, 2], ax[-1, 2]) < 0.1:
            raise ValueError("a tool axis within 84 deg of horizontal: no retract to z_safe")
        up0 = (z_safe - tips[0, 2]) / ax[0, 2]
        if up0 <= approach_mm:
            raise ValueError("the safe height must be above the approach point")
        add(tips[0] + up0 * ax[0], ax[0], False, nan)
        add(tips[0] + approach_mm * ax[0], ax[0], False, nan)
        for p, a, q in zip(tips, ax, con, strict=True):
            add(p, a, True, q)
        add(tips[-1] + (z_safe - tips[-1, 2]) / ax[-1, 2] * ax[-1], ax[-1], False, nan)
    return ClPath(np.array(pts), np.array(axes), np.array(cut), np.array(contact))


# --- swarf ---------------------------------------------------------------------------------


def _check_swarf(spec: Swarf) -> None:
    """ValueError for a spec that cannot be cut as described."""
    if not (spec.diameter_mm > 0 and spec.length_mm > 0 and spec.height_mm > 0):
        raise ValueError("diameter, length and height must be > 0")
    if not 0 < spec.peak_frac < 1:
        raise ValueError("peak_frac must be between 0 and 1")
    if spec.arc_radius_mm and abs(spec.arc_radius_mm) <= spec.diameter_mm:
        raise ValueError("the bottom arc's radius must exceed the tool diameter")
    if max(abs(x) for x in spec.lean_deg) >= 60:
        raise ValueError("the lean must stay below 60 deg")
    reach = spec.height_mm / math.cos(math.radians(max(abs(x) for x in spec.lean_deg)))
    if reach + spec.below_floor_mm > spec.flute_mm:
        raise ValueError(f"the flutes ({spec.flute_mm:g} mm) do not reach the wall top "
                         f"({reach + spec.below_floor_mm:.3f} mm along the axis)")


def lean_rad(spec: Swarf, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ruling's lean phi(l) [rad] from vertical and dphi/dl [rad/mm] (l clipped to the
    wall): half-cosine ramps lean_deg[0] -> [1] over [0, peak] and [1] -> [2] over [peak, L]."""
    big = spec.length_mm
    l = np.clip(np.asarray(l, dtype=float), 0.0, big)
    p0, p1, p2 = np.radians(spec.lean_deg)
    lp = spec.peak_frac * big
    first = l <= lp
    span = np.where(first, lp, big - lp)
    s = np.where(first, l, l - lp) / span
    lo, hi = np.where(first, p0, p1), np.where(first, p1, p2)
    phi = lo + 0.5 * (hi - lo) * (1.0 - np.cos(np.pi * s))
    return phi, 0.5 * np.pi * (hi - lo) * np.sin(np.pi * s) / span


def bottom_frame(spec: Swarf, l: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bottom curve points B(l), unit tangents t and horizontal normals n_h towards the tool
    (right of t), each (len(l), 3)."""
    l = np.asarray(l, dtype=float)
    k = 1.0 / spec.arc_radius_mm if spec.arc_radius_mm else 0.0
    th = k * l
    zero = np.zeros_like(l)
    if k:
        b = np.stack([np.sin(th) / k, (1.0 - np.cos(th)) / k, zero], axis=-1)
    else:
        b = np.stack([l, zero, zero], axis=-1)
    t = np.stack([np.cos(th), np.sin(th), zero], axis=-1)
    return b, t, np.stack([np.sin(th), -np.cos(th), zero], axis=-1)


def ruling(spec: Swarf, l: np.ndarray) -> np.ndarray:
    """Unit ruling directions a(l) = cos(phi) e_z - sin(phi) n_h, bottom to top."""
    phi, _ = lean_rad(spec, l)
    _, _, nh = bottom_frame(spec, l)
    return np.cos(phi)[..., None] * EZ - np.sin(phi)[..., None] * nh


def wall_point(spec: Swarf, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """W(l, v) = B(l) + v a(l) [mm]; v = height / cos(phi) is the top."""
    b, _, _ = bottom_frame(spec, l)
    return b + np.asarray(v, dtype=float)[..., None] * ruling(spec, l)


def wall_normal(spec: Swarf, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The wall's unit normal at W(l, v), towards the tool: W_l x a, where W_l = t + v a_l and
    a_l = dphi/dl (-sin(phi) e_z - cos(phi) n_h) - sin(phi) k t (n_h' = k t)."""
    phi, dphi = lean_rad(spec, l)
    _, t, nh = bottom_frame(spec, l)
    k = 1.0 / spec.arc_radius_mm if spec.arc_radius_mm else 0.0
    sp, cp = np.sin(phi)[..., None], np.cos(phi)[..., None]
    a = cp * EZ - sp * nh
    a_l = dphi[..., None] * (-sp * EZ - cp * nh) - k * sp * t
    return _unit(np.cross(t + np.asarray(v, dtype=float)[..., None] * a_l, a))


def top_v(spec: Swarf, l: np.ndarray) -> np.ndarray:
    """v of the wall's top (z = height) on the ruling at l."""
    return spec.height_mm / np.cos(lean_rad(spec, l)[0])


def swarf_tool(spec: Swarf, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tips and axes flanking the rulings at ``l``: axis a(l), tip B + (D/2) N_t - below a with
    N_t the bisector of the wall normals at the ruling's bottom and top."""
    l = np.asarray(l, dtype=float)
    b, _, _ = bottom_frame(spec, l)
    a = ruling(spec, l)
    nt = _unit(wall_normal(spec, l, np.zeros_like(l)) + wall_normal(spec, l, top_v(spec, l)))
    return b + 0.5 * spec.diameter_mm * nt - spec.below_floor_mm * a, a


def swarf_params(spec: Swarf) -> np.ndarray:
    """Arc lengths l of the CL rulings: :func:`chord_params` on the bottom, top and tip curves
    over [0, peak] and [peak, L]."""
    _check_swarf(spec)

    def curves(l):
        tip, _ = swarf_tool(spec, l)
        return np.stack([wall_point(spec, l, np.zeros_like(l)),
                         wall_point(spec, l, top_v(spec, l)), tip], axis=1)

    peak = spec.peak_frac * spec.length_mm  # a ruling at the lean's peak (its C1 joint)
    first = chord_params(curves, 0.0, peak, spec.chord_tol_mm, spec.max_step_mm)
    return np.r_[first, chord_params(curves, peak, spec.length_mm, spec.chord_tol_mm,
                                     spec.max_step_mm)[1:]]


def swarf_cl(spec: Swarf | None = None, **fields) -> ClPath:
    """The swarf path of ``spec`` (default :class:`Swarf`; ``fields`` replace its fields): one
    pass along the wall, approached and left along the tool axis from z = height + clearance."""
    spec = dataclasses.replace(spec or Swarf(), **fields)
    l = swarf_params(spec)
    tips, axes = swarf_tool(spec, l)
    bottom = wall_point(spec, l, np.zeros_like(l))
    return linked([(tips, axes, bottom)], spec.height_mm + spec.clearance_mm, spec.approach_mm)


def swarf_twist_rad(spec: Swarf, l: np.ndarray) -> np.ndarray:
    """Angle [rad] between the tool's contact normal N_t and the wall normal at the ruling's
    ends (equal at both ends): the wall's turn about the ruling, halved."""
    l = np.asarray(l, dtype=float)
    n0 = wall_normal(spec, l, np.zeros_like(l))
    n1 = wall_normal(spec, l, top_v(spec, l))
    nt = _unit(n0 + n1)
    return np.arccos(np.clip(np.sum(nt * n0, axis=-1), -1.0, 1.0))


def swarf_overcut_mm(spec: Swarf, l: np.ndarray, n_s: int = 481, n_v: int = 21) -> np.ndarray:
    """Per ruling, how deep [mm] the wall enters the tool's cylinder (0: nowhere): the wall
    sampled at arc lengths l +- 1.2 D/2 (``n_s``) by heights 0 .. top (``n_v``), each point's
    distance from the axis line subtracted from D/2. ~ (D/2) (1 - cos(twist))."""
    r = 0.5 * spec.diameter_mm
    tips, axes = swarf_tool(spec, l)
    out = np.empty(len(l))
    for i, li in enumerate(np.asarray(l, dtype=float)):
        ls = np.clip(li + np.linspace(-1.2 * r, 1.2 * r, n_s), 0.0, spec.length_mm)
        v = np.linspace(0.0, 1.0, n_v)[None, :] * top_v(spec, ls)[:, None]
        pts = wall_point(spec, np.broadcast_to(ls[:, None], v.shape), v) - tips[i]
        dist = np.linalg.norm(np.cross(pts, axes[i]), axis=-1)
        out[i] = max(0.0, r - float(dist.min()))
    return out


# --- ball ----------------------------------------------------------------------------------


def surface_z(spec: Ball, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """z and its partial derivatives z_x, z_y of the spec's surface at (x, y) [mm]."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    rs = spec.surface_radius_mm
    if spec.surface == "saddle":
        return (x * x - y * y) / (2 * rs), x / rs, -y / rs
    if spec.surface == "cylinder":
        h = np.sqrt(rs * rs - x * x)
        return h - rs, -x / h, np.zeros_like(x)
    raise ValueError(f"surface must be one of {SURFACES}")


def tool_axis(n: np.ndarray, f: np.ndarray, lead_rad: float, tilt_rad: float) -> np.ndarray:
    """a = sin(lead) f + cos(lead) (cos(tilt) n + sin(tilt) (n x f)) for unit n, f (n . f = 0)."""
    s = np.cross(n, f)
    return (math.sin(lead_rad) * f
            + math.cos(lead_rad) * (math.cos(tilt_rad) * n + math.sin(tilt_rad) * s))


def ball_frame(spec: Ball, x: np.ndarray, y: float,
               sign: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contacts, tips and axes at (x, y) for a pass along sign * X (contact p, normal n, feed
    f = sign (1, 0, z_x)/|.|; tip = p + R n - R a)."""
    x = np.asarray(x, dtype=float)
    z, zx, zy = surface_z(spec, x, np.full_like(x, y))
    p = np.stack([x, np.full_like(x, y), z], axis=-1)
    n = _unit(np.stack([-zx, -zy, np.ones_like(x)], axis=-1))
    f = sign * _unit(np.stack([np.ones_like(x), np.zeros_like(x), zx], axis=-1))
    a = tool_axis(n, f, math.radians(spec.lead_deg), math.radians(spec.tilt_deg))
    r = 0.5 * spec.diameter_mm
    return p, p + r * n - r * a, a


def _check_ball(spec: Ball) -> None:
    """ValueError for a spec that cannot be cut as described."""
    if spec.surface not in SURFACES:
        raise ValueError(f"surface must be one of {SURFACES}")
    if not (spec.diameter_mm > 0 and spec.width_mm > 0 and spec.length_mm >= 0
            and spec.stepover_mm > 0):
        raise ValueError("diameter, width and step-over must be > 0, length >= 0")
    if spec.surface_radius_mm < max(2 * spec.diameter_mm, spec.width_mm):
        raise ValueError("the surface radius must exceed twice the ball and the patch width")
    if abs(spec.lead_deg) > 45 or abs(spec.tilt_deg) > 45:
        raise ValueError("lead and tilt must stay within +-45 deg (contact on the ball)")


def ball_cl(spec: Ball | None = None, **fields) -> ClPath:
    """The raster of ``spec`` (default :class:`Ball`; ``fields`` replace its fields): passes
    along X at y = -length/2 + j * length / m, m = ceil(length / stepover), one-way (+X) or
    zigzag, linked in the air at z = surface max + clearance."""
    spec = dataclasses.replace(spec or Ball(), **fields)
    _check_ball(spec)
    m = math.ceil(spec.length_mm / spec.stepover_mm - 1e-9)
    ys = np.linspace(-0.5 * spec.length_mm, 0.5 * spec.length_mm, m + 1)
    half = 0.5 * spec.width_mm
    passes = []
    for j, y in enumerate(ys):
        sign = -1.0 if spec.zigzag and j % 2 else 1.0

        def curves(x, y=y, sign=sign):
            p, tip, _ = ball_frame(spec, x, y, sign)
            return np.stack([p, tip], axis=1)

        xs = chord_params(curves, -sign * half, sign * half, spec.chord_tol_mm,
                          spec.max_step_mm)
        p, tips, axes = ball_frame(spec, xs, y, sign)
        passes.append((tips, axes, p))
    gx, gy = np.meshgrid(np.linspace(-half, half, 61), ys)
    z_top = float(surface_z(spec, gx, gy)[0].max())
    return linked(passes, z_top + spec.clearance_mm, spec.approach_mm)


# --- APT CL text ---------------------------------------------------------------------------


def _f6(v: float) -> str:
    """``v`` with 6 decimals, never ``-0.000000``."""
    return f"{round(float(v), 6) + 0.0:.6f}"


def apt_text(path: ClPath, *, cutter_mm: tuple[float, float], feed_mm_min: float,
             plunge_mm_min: float | None = None, rpm: float = 12000.0,
             comments: tuple[str, ...] = ()) -> str:
    """APT CL text of ``path``: header (``$$`` comments, UNITS/MM, MULTAX/ON, CUTTER/d,r,
    LOADTL/1, SPINDL/rpm,CLW), RAPID before each rapid GOTO, FEDRAT (feed, or the plunge feed
    for a feed move right after a rapid) before a feed move whose feed differs from the last
    FEDRAT, GOTO/x,y,z,i,j,k, FINI."""
    lines = ["$$ generated by benchmarks/five_axis_paths.py"]
    lines += [f"$$ {c}" for c in comments]
    lines += ["UNITS/MM", "MULTAX/ON", f"CUTTER/{_f6(cutter_mm[0])},{_f6(cutter_mm[1])}",
              "LOADTL/1", f"SPINDL/{_f6(rpm)},CLW"]
    current, prev_cut = None, False
    for p, a, c in zip(path.points, path.axes, path.cut, strict=True):
        if not c:
            lines.append("RAPID")
        else:
            feed = plunge_mm_min if (plunge_mm_min and not prev_cut) else feed_mm_min
            if feed != current:
                lines.append(f"FEDRAT/{_f6(feed)},MMPM")
                current = feed
        lines.append("GOTO/" + ",".join(_f6(v) for v in (*p, *a)))
        prev_cut = bool(c)
    return "\n".join(lines + ["FINI"]) + "\n"


def path_stats(path: ClPath) -> dict[str, float]:
    """Counts, the cut length [mm] and the range of the axis' angle from +Z [deg] (feed
    points)."""
    c = path.cut
    seg = np.linalg.norm(np.diff(path.points, axis=0), axis=1)
    ang = np.degrees(np.arccos(np.clip(path.axes[c, 2], -1.0, 1.0)))
    return {"points": len(c), "feed_points": int(c.sum()), "cut_mm": float(seg[c[1:]].sum()),
            "axis_from_z_min_deg": float(ang.min()), "axis_from_z_max_deg": float(ang.max())}


def write_new(out: Path, text: str, force: bool = False) -> None:
    """Write ``text`` to ``out`` through a temporary file in its folder and a rename; an
    existing ``out`` is replaced only with ``force``."""
    if out.is_dir() or (out.exists() and not force):
        raise FileExistsError(f"{out} exists (use --force to replace a file)")
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="ascii", newline="\n") as fh:
            fh.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 -> what a plain open would give
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _write_bytes(out: Path, data: bytes, force: bool) -> None:
    """``data`` to ``out`` through a temporary file and a rename (as :func:`write_new`)."""
    if out.is_dir() or (out.exists() and not force):
        raise FileExistsError(f"{out} exists (use --force to replace a file)")
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# --- a stock for the ball --------------------------------------------------------------


def surface_stock_stl(spec: Ball, allowance_mm: float, margin_mm: float = 8.0,
                      floor_mm: float = 10.0, step_mm: float = 2.0) -> bytes:
    """A binary STL [mm] of the stock a finishing pass of ``spec`` leaves the surface from:
    the surface raised by ``allowance_mm`` along z, over the patch widened by ``margin_mm``
    on every side, closed by four vertical walls and a flat floor ``floor_mm`` below the
    surface's lowest point (facets ``step_mm``: on the 200 mm saddle a 2 mm facet is within
    step^2 / (8 Rs) = 0.0025 mm of the surface)."""
    hx, hy = 0.5 * spec.width_mm + margin_mm, 0.5 * spec.length_mm + margin_mm
    xs = np.linspace(-hx, hx, max(2, math.ceil(2 * hx / step_mm)) + 1)
    ys = np.linspace(-hy, hy, max(2, math.ceil(2 * hy / step_mm)) + 1)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    top = surface_z(spec, gx, gy)[0] + allowance_mm
    floor = float(top.min()) - allowance_mm - floor_mm
    pts = np.stack([gx, gy, top], axis=-1)
    a, b, c, d = pts[:-1, :-1], pts[1:, :-1], pts[1:, 1:], pts[:-1, 1:]
    tris = [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
    low = pts.copy()
    low[..., 2] = floor
    tris += [np.stack([low[:-1, :-1], low[1:, 1:], low[1:, :-1]], -2).reshape(-1, 3, 3),
             np.stack([low[:-1, :-1], low[:-1, 1:], low[1:, 1:]], -2).reshape(-1, 3, 3)]
    for edge, edge_low in ((pts[:, 0], low[:, 0]), (pts[:, -1], low[:, -1]), (pts[0], low[0]),
                           (pts[-1], low[-1])):
        p0, p1, q0, q1 = edge[:-1], edge[1:], edge_low[:-1], edge_low[1:]
        for t in (np.stack([p0, q0, q1], 1), np.stack([p0, q1, p1], 1)):
            n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
            out = np.einsum("ij,ij->i", n[:, :2], t.mean(axis=1)[:, :2]) > 0  # from the axis
            tris.append(np.where(out[:, None, None], t, t[:, ::-1]))
    tri = np.concatenate(tris).astype(np.float32)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    rec = np.zeros(tri.shape[0], dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"], rec["v"] = normal, tri
    header = b"feedopt benchmarks/five_axis_paths.py surface stock (mm)".ljust(80, b" ")
    return header + np.uint32(tri.shape[0]).tobytes() + rec.tobytes()


# --- command line --------------------------------------------------------------------------


def _options(p: argparse.ArgumentParser) -> None:
    """One ``--field-name`` option per field of :class:`Swarf` and :class:`Ball` (default:
    the spec's)."""
    seen = set()
    for cls in (Swarf, Ball):
        for f in dataclasses.fields(cls):
            if f.name in seen:
                continue
            seen.add(f.name)
            opt = "--" + f.name.replace("_", "-")
            if isinstance(f.default, bool):
                p.add_argument(opt, type=lambda s: s.lower() in ("1", "true", "yes", "on"),
                               metavar="BOOL")
            elif isinstance(f.default, tuple):
                p.add_argument(opt, type=float, nargs=len(f.default))
            else:
                p.add_argument(opt, type=type(f.default))


def spec_from_args(kind: str, a: argparse.Namespace) -> Swarf | Ball:
    """The spec of ``kind`` with the options given; ValueError for options of the other kind."""
    cls = Swarf if kind == "swarf" else Ball
    names = {f.name for f in dataclasses.fields(cls)}
    given = {k: v for k, v in vars(a).items()
             if v is not None and k not in ("kind", "out", "force", "stock_out",
                                            "stock_allowance_mm")}
    stray = sorted(set(given) - names)
    if stray:
        raise ValueError(f"--kind {kind} has no option {', '.join(stray)}")
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})


def program(spec: Swarf | Ball) -> tuple[ClPath, str, list[str]]:
    """The path, its APT text and summary lines for ``spec``."""
    if isinstance(spec, Swarf):
        path = swarf_cl(spec)
        l = swarf_params(spec)
        over = swarf_overcut_mm(spec, l)
        est = 0.5 * spec.diameter_mm * (1 - np.cos(swarf_twist_rad(spec, l)))
        notes = [f"swarf wall L={spec.length_mm:g} H={spec.height_mm:g} "
                 f"lean {spec.lean_deg} deg, flat D={spec.diameter_mm:g}",
                 f"max overcut {over.max():.5f} mm (sampled), {est.max():.5f} mm (closed form)"]
        cutter = (spec.diameter_mm, 0.0)
    else:
        path = ball_cl(spec)
        notes = [f"ball D={spec.diameter_mm:g} on {spec.surface} Rs={spec.surface_radius_mm:g}"
                 f" {spec.width_mm:g} x {spec.length_mm:g} mm, step-over {spec.stepover_mm:g},"
                 f" lead {spec.lead_deg:g} deg, tilt {spec.tilt_deg:g} deg"]
        cutter = (spec.diameter_mm, 0.5 * spec.diameter_mm)
    text = apt_text(path, cutter_mm=cutter, feed_mm_min=spec.feed_mm_min,
                    plunge_mm_min=spec.plunge_mm_min, rpm=spec.rpm, comments=tuple(notes))
    return path, text, notes


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kind", choices=("swarf", "ball"), required=True)
    p.add_argument("--out", type=Path, required=True, help="the CL file to write (.cls)")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--stock-out", type=Path, help="--kind ball: also write the stock the pass "
                   "finishes (binary STL, mm: surface_stock_stl) here")
    p.add_argument("--stock-allowance-mm", type=float, default=0.5,
                   help="the stock's allowance above the surface along z (default 0.5)")
    _options(p)
    a = p.parse_args(argv)
    try:
        spec = spec_from_args(a.kind, a)
        if a.out.exists() and not a.force:
            raise FileExistsError(f"{a.out} exists (use --force to replace it)")
        path, text, notes = program(spec)
        write_new(a.out, text, force=a.force)
        if a.stock_out is not None:
            if not isinstance(spec, Ball):
                raise ValueError("--stock-out is for --kind ball")
            _write_bytes(a.stock_out, surface_stock_stl(spec, a.stock_allowance_mm), a.force)
            notes.append(f"stock {a.stock_out}: the surface + {a.stock_allowance_mm:g} mm")
    except (ValueError, OSError) as exc:
        p.error(str(exc))
    s = path_stats(path)
    print(f"wrote {a.out}: {text.count('GOTO/')} GOTO, {len(text)} bytes; "
          f"{s['feed_points']} feed points, feed-move length {s['cut_mm']:.3f} mm, axis "
          f"{s['axis_from_z_min_deg']:.3f}..{s['axis_from_z_max_deg']:.3f} deg from +Z")
    for n in notes:
        print("  " + n)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
