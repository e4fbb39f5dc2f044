"""General-cutter forces (ball, bull, tapered, face; Engin & Altintas 2001) against an
independent brute-force integration of the cutting edge over its height.

The reference below is written from the physics only (nothing of feedopt.process.cutter or
general_forces): the edge is integrated in height z (not in profile length as the model
does) with chip width db = dz / sin(kappa(z)); on the corner arc the substitution z = u^2
removes the 1 / sqrt(z) of db at a ball's tip (db = 2 rc du / sqrt(2 rc - u^2)). The in-cut
test is the material's lateral extent y_lo <= r(z) cos(theta) <= y_hi on the leading half
0 <= theta < pi, below the axial depth.

Tolerances: the model sums L slices of equal profile length, each wholly in or out of the
cut, so a slice crossing an entry/exit boundary errs by up to one slice's force: pointwise
O(1/L) of the force; the revolution mean (the model's on a fine angle grid against the exact
one of the reference) is a midpoint rule on a piecewise smooth integrand, O(1/L^2). The
measured agreement at L = 300 is in the comments of each test; tolerances are ~2-5x it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedopt.process.coefficients import CuttingCoefficients
from feedopt.process.cutter import CutterShape, profile_slices
from feedopt.process.engagement import Engagement
from feedopt.process.forces import critical_angles, milling_forces, milling_forces_at
from feedopt.process.tool import Tool

K = CuttingCoefficients(ktc=800e6, krc=300e6, kac=-100e6, kte=20e3, kre=25e3, kae=-2e3)
MM = 1e-3
L = 300  # model slices
NZ = 10000  # reference height steps per part of the profile (arc, straight edge)
TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- reference
def _edge_points(d, rc, taper, depth, n=NZ):
    """Midpoint-rule nodes in height of the edge below ``depth``: (z, db, r, sin k, cos k)."""
    k1 = math.pi / 2 - taper
    r0 = d / 2 - rc
    z_e, r_e = rc * (1 - math.cos(k1)), r0 + rc * math.sin(k1)
    parts = []
    if rc > 0 and z_e > 0:  # corner arc, z = u^2
        top = math.sqrt(min(depth, z_e))
        du = top / n
        u = (np.arange(n) + 0.5) * du
        z = u * u
        ck = 1 - z / rc
        sk = u * np.sqrt(2 * rc - z) / rc
        parts.append((z, 2 * rc * du / np.sqrt(2 * rc - z), r0 + rc * sk, sk, ck))
    if depth > z_e:  # straight edge at kappa1: r grows by cot(kappa1) per unit height
        dz = (depth - z_e) / n
        z = z_e + (np.arange(n) + 0.5) * dz
        sk, ck = math.sin(k1), math.cos(k1)
        parts.append((z, np.full(n, dz / sk), r_e + (z - z_e) * ck / sk,
                      np.full(n, sk), np.full(n, ck)))
    return tuple(np.concatenate(a) for a in zip(*parts, strict=True))


def _sums(ft, fr, fa, geo, rows=None, count=1):
    """Force on the tool and torque (count, 4) [x, y, z, T], summed per row (all in one
    without ``rows``)."""
    s, c, sk, ck, r = geo
    terms = (-ft * c - fr * sk * s + fa * ck * s, ft * s - fr * sk * c + fa * ck * c,
             fr * ck + fa * sk, r * ft)
    if rows is None:
        return np.array([[np.sum(t) for t in terms]])
    return np.stack([np.bincount(rows, t, minlength=count) for t in terms], axis=-1)


def _front(h, keep, fz):
    """The elements on the front of the tool (chip > 0) when the feed leans (fz != 0)."""
    return keep if fz == 0 else keep & (h > 0)


def reference(shape, k, eng, phis, n=NZ, feed=(1.0, 0.0)):
    """(cutting (m, 4), edge (m, 4)) [x, y, z, torque] at tooth-1 angles ``phis``.
    ``shape`` = (D, teeth, helix, rc, taper), ``eng`` = (entry, exit, depth), ``feed`` =
    (fx, fz) the unit feed in the tool frame: the chip ``c (fx sin k sin t - fz cos k)``
    (the advance per tooth on the edge normal), the element cutting only where it is > 0,
    then on the whole turn wherever the lateral band has material (a descending feed cuts
    behind the tool's bottom)."""
    fx, fz = feed
    d, teeth, helix, rc, taper = shape
    entry, exit_, depth = eng
    z, db, r, sk, ck = _edge_points(d, rc, taper, depth, n)
    y_hi = math.inf if entry <= 0 else d / 2 * math.cos(entry)
    y_lo = -math.inf if exit_ >= math.pi else d / 2 * math.cos(exit_)
    lag = 2 * math.tan(helix) / d * z
    phis = np.asarray(phis, dtype=float)
    cut, edge = np.zeros((phis.size, 4)), np.zeros((phis.size, 4))
    for tooth in range(teeth):
        for start in range(0, phis.size, 16):
            sl = slice(start, start + 16)
            th = np.mod(phis[sl, None] + tooth * TWO_PI / teeth - lag, TWO_PI)
            y = r * np.cos(th)
            # the lateral band of material in front; a leaning feed (fz != 0): behind the
            # tool too, wherever the chip is positive (a descending bottom)
            inside = ((th < math.pi) | (fz != 0)) & (y >= y_lo) & (y <= y_hi)
            chip = fx * np.sin(th) * sk - fz * ck
            rows, cols = np.nonzero(_front(chip, inside, fz))
            t = th[rows, cols]
            w, skj, ckj = db[cols], sk[cols], ck[cols]
            geo = (np.sin(t), np.cos(t), skj, ckj, r[cols])
            h = w * chip[rows, cols]  # chip per unit feed per tooth times db
            m = th.shape[0]
            cut[sl] += _sums(k.ktc * h, k.krc * h, k.kac * h, geo, rows, m)
            edge[sl] += _sums(k.kte * w, k.kre * w, k.kae * w, geo, rows, m)
    return cut, edge


def reference_mean(shape, k, eng, n=2000, n_theta=4096, feed=(1.0, 0.0)):
    """Revolution means (cutting (4,), edge (4,)): over a whole turn the helix lag drops out,
    so the mean is N / (2 pi) times the double integral over theta in [0, pi) (outside it
    nothing cuts) and height. The theta grid of height node j is shifted by frac(j g), g the
    golden ratio, so that the errors of the cells cut by an entry/exit do not add up over
    heights at which it is the same (e.g. all of a cylinder). ``feed`` as in
    :func:`reference`."""
    fx, fz = feed
    d, teeth, _, rc, taper = shape
    entry, exit_, depth = eng
    z, db, r, sk, ck = _edge_points(d, rc, taper, depth, n)
    y_hi = math.inf if entry <= 0 else d / 2 * math.cos(entry)
    y_lo = -math.inf if exit_ >= math.pi else d / 2 * math.cos(exit_)
    dth = math.pi / n_theta
    count = n_theta * (2 if fz != 0 else 1)  # a leaning feed: behind the tool too
    shift = np.mod(np.arange(z.size) * (math.sqrt(5) - 1) / 2, 1.0)
    cut, edge = np.zeros(4), np.zeros(4)
    for start in range(0, count, 256):
        th = (np.arange(start, min(start + 256, count))[:, None] + shift) * dth
        y = r * np.cos(th)
        chip = fx * np.sin(th) * sk - fz * ck
        rows, cols = np.nonzero(_front(chip, (y >= y_lo) & (y <= y_hi), fz))
        t = th[rows, cols]
        w, skj = db[cols] * (teeth * dth / TWO_PI), sk[cols]
        geo = (np.sin(t), np.cos(t), skj, ck[cols], r[cols])
        h = w * chip[rows, cols]
        cut += _sums(k.ktc * h, k.krc * h, k.kac * h, geo)[0]
        edge += _sums(k.kte * w, k.kre * w, k.kae * w, geo)[0]
    return cut, edge


# ----------------------------------------------------------------------------- helpers
def _tool(shape, d, teeth, helix_deg, rc=0.0, taper_deg=0.0, flute=30 * MM):
    return Tool("t", d, teeth, math.radians(helix_deg), flute, shape=shape, corner_radius=rc,
                taper=math.radians(taper_deg))


def _model(tool, eng, phis, slices=L, lean=0.0):
    """(cutting, edge) (m, 4) of one sample; ``lean``: the feed's component along the axis."""
    e = Engagement(np.array([eng[0]]), np.array([eng[1]]), np.array([eng[2]]),
                   feed_axial=np.array([lean]))
    f = milling_forces(tool, K, e, phis, slices)
    return (np.column_stack([f.cutting[0], f.cutting_torque[0]]),
            np.column_stack([f.edge[0], f.edge_torque[0]]))


def _shape(tool):
    return tool.diameter, tool.teeth, tool.helix, tool.corner_radius, tool.taper


def _errors(got, ref):
    """(mean error, pointwise error) of (m, 4) [x, y, z, T] rows relative to the force /
    torque scale: forces by the norm of the mean (resp. largest) reference force vector,
    torque by its own."""
    out = []
    for g, r in ((got.mean(axis=0)[None], ref.mean(axis=0)[None]), (got, ref)):
        f_scale = np.max(np.linalg.norm(r[:, :3], axis=1))
        t_scale = np.max(np.abs(r[:, 3]))
        out.append(max(np.max(np.abs(g[:, :3] - r[:, :3])) / f_scale,
                       np.max(np.abs(g[:, 3] - r[:, 3])) / t_scale))
    return out


def measure(tool, eng, count=96, fine=4000, lean=0.0):
    """Model vs reference: ((mean error, pointwise error) of the cutting part, (...) of the
    edge part). Pointwise on ``count`` midpoint angles over one pitch; the model's mean on
    ``fine`` angles (so that its own steps, one slice wide, average out) against the
    revolution mean of the reference (:func:`reference_mean`). ``lean``: the feed's component
    along the tool axis (fz; fx = sqrt(1 - fz^2))."""
    phis = (np.arange(count) + 0.5) * tool.pitch / count
    dense = (np.arange(fine) + 0.5) * tool.pitch / fine
    feed = (math.sqrt(1 - lean * lean), lean)
    ref = reference(_shape(tool), K, eng, phis, feed=feed)
    ref_mean = reference_mean(_shape(tool), K, eng, feed=feed)
    out = []
    for g, r, gm, rm in zip(_model(tool, eng, phis, lean=lean), ref,
                            _model(tool, eng, dense, lean=lean), ref_mean, strict=True):
        assert np.max(np.abs(r)) > 0
        out.append((_errors(gm.mean(axis=0)[None], rm[None])[0], _errors(g, r)[1]))
    return out


def check(tool, eng, mean_tol, point_tol, cut_point_tol=None, lean=0.0):
    """Assert the errors of :func:`measure`; ``cut_point_tol`` for the cutting part where
    it is continuous in the angle (zero chip at the entry/exit)."""
    (cut_mean, cut_point), (edge_mean, edge_point) = measure(tool, eng, lean=lean)
    assert max(cut_mean, edge_mean) < mean_tol, (cut_mean, edge_mean)
    assert max(cut_point, edge_point) < point_tol, (cut_point, edge_point)
    if cut_point_tol is not None:
        assert cut_point < cut_point_tol, cut_point


BALL = _tool(CutterShape.BALL, 10 * MM, 2, 30.0, rc=5 * MM)
BULL = _tool(CutterShape.BULL, 12 * MM, 4, 35.0, rc=2 * MM)
SLOT = (0.0, math.pi)
# Slots: the chip is zero at entry and exit, so the cutting part is continuous in the angle
# and converges as 1 / L^2 pointwise (measured <= 6e-6); the edge part jumps by one slice's
# force whenever a slice enters/leaves (pointwise measured <= 2.9e-3); means <= 4e-6.
SLOT_TOL = (2e-5, 6e-3, 2e-5)


# ----------------------------------------------------------------------------- cases
@pytest.mark.parametrize("depth", [1 * MM, 3 * MM, 7 * MM])
def test_ball_slot(depth):
    check(BALL, (*SLOT, depth), *SLOT_TOL)


def test_ball_side_cut_engages_only_the_wide_part():
    ae, r = 2 * MM, 5 * MM
    eng = (0.0, math.acos((r - ae) / r), 4 * MM)
    # measured: mean 4.2e-5 (the reference's own error ~6e-5: the cut's width grows as
    # sqrt(r - (R - ae))), pointwise 5.6e-3 (the chip jumps at the exit arccos((R-ae)/r))
    check(BALL, eng, 2e-4, 1.2e-2)
    # nothing of the edge below r(z) = R - ae (z = 1 mm) cuts: depth 1 mm gives zero force
    low = _model(BALL, (eng[0], eng[1], 0.99 * MM), np.linspace(0, math.pi, 50))
    assert np.all(low[0] == 0) and np.all(low[1] == 0)


@pytest.mark.parametrize("depth", [1 * MM, 5 * MM], ids=["corner-only", "5mm"])
def test_bull_nose_slot(depth):
    check(BULL, (*SLOT, depth), *SLOT_TOL)


def test_bull_nose_down_milling_step():
    r, ae = 6 * MM, 1.5 * MM  # material y in (-inf, -(R - ae)]
    # measured: mean 4.1e-5, pointwise 3.5e-3 (thick chip at each slice's entry)
    check(BULL, (math.acos(-(r - ae) / r), math.pi, 5 * MM), 2e-4, 1.2e-2)


@pytest.mark.parametrize("rc", [0.0, 3 * MM], ids=["flat-tip", "ball-tip"])
def test_tapered_slot(rc):
    """The straight edge's radius grows above the tip (r > D/2); the slot's material
    reaches past any radius."""
    tool = _tool(CutterShape.TAPERED, 6 * MM, 3, 30.0, rc=rc, taper_deg=5.0)
    check(tool, (*SLOT, 10 * MM), *SLOT_TOL)


def test_face_mill():
    tool = _tool(CutterShape.FACE, 50 * MM, 8, 0.0, rc=0.8 * MM, taper_deg=45.0, flute=5 * MM)
    # measured: mean 5.4e-6, pointwise 5.5e-4 (straight inserts: the slices of one insert
    # enter at radii-dependent angles arccos(y_hi / r), so one slice at a time)
    check(tool, (0.3, 2.5, 2 * MM), 2e-5, 1.5e-3)


# ----------------------------------------------------------------------------- limits
def test_tiny_corner_bull_nose_is_the_flat_end_mill():
    """rc = 1e-6 mm: the general sums equal the flat end mill's prefix-sum code."""
    flat = _tool(CutterShape.FLAT, 12 * MM, 4, 35.0)
    bull = _tool(CutterShape.BULL, 12 * MM, 4, 35.0, rc=1e-9)
    phis = np.linspace(0.0, TWO_PI, 181)
    for eng in [(*SLOT, 5 * MM), (0.4, 2.0, 3 * MM), (0.0, 1.0, 8 * MM)]:
        for g, f in zip(_model(bull, eng, phis), _model(flat, eng, phis), strict=True):
            scale = np.max(np.abs(f), axis=0)
            assert np.all(np.abs(g - f) <= 1e-5 * scale), (eng, np.max(np.abs(g - f) / scale))


def _straight_ball(rc, depth, th):
    """Closed form of a straight-tooth ball-nose (one tooth at theta = ``th`` in the cut):
    the arc integrals in kappa (db = rc dk) plus the cylinder above rc."""
    kk = math.acos(1 - min(depth, rc) / rc)
    cyl = max(depth - rc, 0.0)
    i_1, i_s = rc * kk + cyl, min(depth, rc) + cyl  # int db, int sin k db
    i_c, i_sc = rc * math.sin(kk), rc * math.sin(kk) ** 2 / 2
    i_ss = rc * (kk / 2 - math.sin(2 * kk) / 4) + cyl
    i_rs, i_r = rc * i_ss, rc * i_s  # r = rc sin k on the arc, rc on the cylinder
    s, c = math.sin(th), math.cos(th)
    cut = [s * (-K.ktc * c * i_s - K.krc * s * i_ss + K.kac * s * i_sc),
           s * (K.ktc * s * i_s - K.krc * c * i_ss + K.kac * c * i_sc),
           s * (K.krc * i_sc + K.kac * i_ss), s * K.ktc * i_rs]
    edge = [-K.kte * c * i_1 - K.kre * s * i_s + K.kae * s * i_c,
            K.kte * s * i_1 - K.kre * c * i_s + K.kae * c * i_c,
            K.kre * i_c + K.kae * i_s, K.kte * i_r]
    return np.array(cut), np.array(edge)


@pytest.mark.parametrize("depth", [3 * MM, 7 * MM])
def test_straight_tooth_ball_is_the_closed_form(depth):
    tool = _tool(CutterShape.BALL, 10 * MM, 2, 0.0, rc=5 * MM)
    phis = np.linspace(0.05, math.pi - 0.05, 31)  # tooth 1 alone in the slot, away from 0, pi
    got = _model(tool, (*SLOT, depth), phis)
    ref = [np.array(a) for a in zip(*(_straight_ball(5 * MM, depth, p) for p in phis),
                                     strict=True)]
    brute = reference(_shape(tool), K, (*SLOT, depth), phis)
    for g, r, b in zip(got, ref, brute, strict=True):
        # midpoint rule in kappa on a smooth integrand: O((kappa1 / L)^2), measured 1.3e-6
        assert _errors(g, r)[1] < 1e-5
        assert _errors(b, r)[1] < 1e-7  # the reference itself (z = u^2), measured 2e-9


def test_ball_nose_pushed_up_flat_end_mill_pulled_down():
    """Kac, Kae < 0: a flat end mill's Fz is negative; on a ball's nose the radial force
    (normal pointing down-out) pushes the tool up, Fz > 0."""
    flat = _tool(CutterShape.FLAT, 10 * MM, 2, 30.0)
    phis = np.linspace(0.0, math.pi, 90, endpoint=False)
    c = 0.1 * MM
    ball_cut, ball_edge = _model(BALL, (*SLOT, 3 * MM), phis)
    flat_cut, flat_edge = _model(flat, (*SLOT, 3 * MM), phis)
    assert np.all(ball_cut[:, 2] >= 0) and np.mean(ball_edge[:, 2]) > 0
    assert np.mean(c * ball_cut[:, 2] + ball_edge[:, 2]) > 0
    assert np.all(flat_cut[:, 2] <= 0) and np.all(flat_edge[:, 2] <= 0)
    assert np.mean(c * flat_cut[:, 2] + flat_edge[:, 2]) < 0


# ----------------------------------------------------------------------------- critical angles
@pytest.mark.parametrize("tool, eng", [
    (BALL, (0.0, math.acos(3 / 5), 4 * MM)),  # up milling, ae = 2 mm
    (BALL, (*SLOT, 3 * MM)),
    (BULL, (math.acos(-4.5 / 6), math.pi, 5 * MM)),  # down milling, ae = 1.5 mm
], ids=["ball-up", "ball-slot", "bull-down"])
def test_critical_angles_are_one_sided_limits(tool, eng):
    slices = 100
    e = Engagement(np.array([eng[0]]), np.array([eng[1]]), np.array([eng[2]]))
    crit = critical_angles(tool, e, slices)
    assert crit.shape == (1, 2 * slices)
    assert np.all((crit >= 0) & (crit < tool.pitch))
    step = np.r_[np.full(slices, 1e-7), np.full(slices, -1e-7)]

    def parts(angles):
        f = milling_forces_at(tool, K, e, angles, slices)
        return [np.concatenate([f.cutting[0], f.cutting_torque[0][:, None]], axis=1),
                np.concatenate([f.edge[0], f.edge_torque[0][:, None]], axis=1)]

    at, inside, outside = parts(crit), parts(crit + step), parts(crit - step)
    jumps = 0.0
    for a, b, o in zip(at, inside, outside, strict=True):
        f_scale = np.max(np.linalg.norm(a[:, :3], axis=1))
        t_scale = np.max(np.abs(a[:, 3]))
        scale = np.r_[f_scale, f_scale, f_scale, t_scale]
        assert np.all(np.abs(a - b) <= 1e-4 * scale), np.max(np.abs(a - b) / scale)
        jumps = max(jumps, np.max(np.abs(a - o) / scale))
    assert jumps > 1e-3  # the other side differs by a slice's force: the test can see it


# --- pieces: several engaged intervals of their own depths (the stock's) -----------------

def _pieced(entries, exits, depths):
    """One sample engaged on the given pieces (hull and largest depth as its summary)."""
    from feedopt.process.engagement import EngagementPieces
    p = EngagementPieces(np.zeros(len(entries), dtype=int), entries, exits, depths)
    return Engagement(np.array([min(entries)]), np.array([max(exits)]),
                      np.array([max(depths)]), pieces=p)


def test_touching_pieces_of_one_depth_are_one_interval():
    tool = Tool("ball", 10e-3, 2, np.radians(30), 20e-3, shape=CutterShape.BALL,
                corner_radius=5e-3)
    angles = np.linspace(0.0, np.pi, 97, endpoint=False)
    one = milling_forces(tool, K, Engagement(np.array([0.2]), np.array([2.5]),
                                                  np.array([3e-3])), angles, 40)
    split = milling_forces(tool, K, _pieced([0.2, 1.1], [1.1, 2.5], [3e-3, 3e-3]),
                           angles, 40)
    np.testing.assert_allclose(split.cutting, one.cutting, rtol=0, atol=1e-9 * np.abs(
        one.cutting).max())
    np.testing.assert_allclose(split.edge, one.edge, rtol=0, atol=1e-9 * np.abs(one.edge).max())


def test_pieces_of_different_depths_sum_to_their_separate_forces():
    """Each piece alone (sliced over its own depth) against the pieces together (sliced over
    the largest depth, a slice taking the pieces deeper than it): the same integral, so they
    agree to the slicing's resolution (revolution means, fine slices)."""
    tool = Tool("bull", 12e-3, 4, np.radians(35), 20e-3, shape=CutterShape.BULL,
                corner_radius=2e-3)
    angles = np.linspace(0.0, np.pi / 2, 2000, endpoint=False)
    pieces = ([0.0, 0.9, 2.0], [0.9, 2.0, np.pi], [4e-3, 1.5e-3, 3e-3])
    together = milling_forces(tool, K, _pieced(*pieces), angles, 600).forces(1e-4)
    alone = sum(milling_forces(tool, K, Engagement(np.array([e]), np.array([x]),
                                                        np.array([a])), angles, 600
                               ).forces(1e-4) for e, x, a in zip(*pieces, strict=True))
    scale = np.abs(alone.mean(axis=1)).max()
    np.testing.assert_allclose(together.mean(axis=1), alone.mean(axis=1), atol=2e-3 * scale)


def test_a_piece_deeper_than_the_summary_depth_is_cut_to_its_own_depth():
    from feedopt.process.engagement import EngagementPieces
    tool = Tool("ball", 10e-3, 2, np.radians(30), 20e-3, shape=CutterShape.BALL,
                corner_radius=5e-3)
    angles = np.linspace(0.0, np.pi, 91, endpoint=False)

    def pieced(summary_depth):
        p = EngagementPieces(np.zeros(2, dtype=int), [0.2, 1.4], [1.4, 2.6], [2e-3, 0.5e-3])
        return Engagement(np.array([0.2]), np.array([2.6]), np.array([summary_depth]), pieces=p)

    short = milling_forces(tool, K, pieced(1e-3), angles, 40)
    full = milling_forces(tool, K, pieced(2e-3), angles, 40)
    np.testing.assert_array_equal(short.cutting, full.cutting)
    np.testing.assert_array_equal(short.edge, full.edge)


# --- a feed along the tool axis (lead): the chip c (fx sin k sin t - fz cos k) ----------------


def _reference_tilted(tool, coeffs, phi, se, fx, fz):
    """Forces by assembling each edge element's vector from the physics (no matrices): the
    element of slice j of tooth t at theta takes the chip c f.n (f the feed in the tool frame,
    n the edge normal) and pushes along the tangential, normal and profile directions."""
    k, s = coeffs, se.sliced
    out = np.zeros(phi.shape + (8,))
    lag = tool.helix_rate * s.height
    for i in range(phi.shape[0]):
        for a, p in enumerate(phi[i]):
            for t in range(tool.teeth):
                for j in range(s.radius.shape[1]):
                    th = np.mod(p + t * 2 * np.pi / tool.teeth - lag[i, j], 2 * np.pi)
                    if not np.any((th >= se.lo[i, j]) & (th < se.hi[i, j])):
                        continue
                    sk, ck = s.sin_kappa[i, j], s.cos_kappa[i, j]
                    e_t = np.array([-np.cos(th), np.sin(th), 0.0])
                    n = np.array([sk * np.sin(th), sk * np.cos(th), -ck])
                    e_a = np.array([ck * np.sin(th), ck * np.cos(th), sk])
                    h = fx[i] * sk * np.sin(th) - fz[i] * ck
                    db = s.width[i]
                    cut = db * h * (k.ktc * e_t - k.krc * n + k.kac * e_a)
                    edge = db * (k.kte * e_t - k.kre * n + k.kae * e_a)
                    out[i, a, :3] += cut
                    out[i, a, 3] += s.radius[i, j] * db * h * k.ktc
                    out[i, a, 4:7] += edge
                    out[i, a, 7] += s.radius[i, j] * db * k.kte
    return out


@pytest.mark.parametrize("lead_deg", [0.0, 10.0, -15.0, 30.0])
def test_a_feed_along_the_axis_matches_the_element_by_element_physics(lead_deg):
    from feedopt.process.general_forces import SliceEngagement, general_sums

    tool = Tool("ball", 10e-3, 2, math.radians(30.0), 20e-3, shape=CutterShape.BALL,
                corner_radius=5e-3)
    coeffs = CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3)
    sliced = profile_slices(tool.profile, np.array([2e-3, 4e-3]), 12)
    lo = np.full((2, 12, 1), 0.3)
    hi = np.full((2, 12, 1), 2.6)
    psi = math.radians(lead_deg)
    fx, fz = np.full(2, math.cos(psi)), np.full(2, math.sin(psi))
    phi = np.tile(np.linspace(0.0, 2 * np.pi, 23, endpoint=False), (2, 1))
    got = general_sums(tool, coeffs, phi, SliceEngagement(sliced, lo, hi, fx, fz))
    ref = _reference_tilted(tool, coeffs, phi, SliceEngagement(sliced, lo, hi), fx, fz)
    assert np.allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    if lead_deg == 0.0:  # no axial feed: exactly the untilted sums
        flat = general_sums(tool, coeffs, phi, SliceEngagement(sliced, lo, hi))
        assert np.array_equal(got[..., 4:], flat[..., 4:])
        assert np.allclose(got, flat, rtol=1e-15, atol=0.0)


# --- a leaning feed through the force functions (Engagement.feed_axial) ------------------------
@pytest.mark.parametrize("lead_deg", [10.0, -15.0, 30.0])
@pytest.mark.parametrize("depth", [1 * MM, 3 * MM, 7 * MM])
def test_ball_nose_at_a_lead_angle_matches_the_reference(lead_deg, depth):
    """A ball-nose slotting with its feed leaning by the lead angle: the model (front of the
    tool cut per slice in closed form) against the element-wise reference (the chip's sign
    tested per element). The front's boundary theta = arcsin(tan(lead) cot(kappa)) runs
    through the slices like an entry angle: one slice wide pointwise (measured <= 9.2e-3, the
    edge part at 30 deg, 1 mm); the means <= 2.7e-4 (the same case: the front's width grows
    as sqrt(kappa - lead) from kappa = lead, which a midpoint rule in slices follows at
    O(L^-1.5); the cutting part's means <= 5.3e-5)."""
    check(BALL, (*SLOT, depth), 6e-4, 1.5e-2, lean=math.sin(math.radians(lead_deg)))


@pytest.mark.parametrize("eng", [(0.0, math.acos(3 / 5), 4 * MM),  # up milling, ae = 2 mm
                                 (math.acos(-3 / 5), math.pi, 2 * MM)],  # down milling
                         ids=["up", "down"])
def test_a_descending_ball_nose_cuts_behind_its_bottom_in_the_band(eng):
    """A side cut while the feed descends by 15 deg: behind the tool the edge cuts where the
    chip is positive and the stated lateral band has material (the band's back intervals
    mirror the front's), as the element-wise reference finds it (measured: means <= 2.4e-4,
    the down cut, whose band edge crosses the ball where the cut's width grows as a square
    root: 1.9e-4 there without the lean; pointwise <= 6.7e-3)."""
    check(BALL, eng, 5e-4, 1.5e-2, lean=-math.sin(math.radians(15.0)))


def test_a_ball_nose_tip_inside_the_lead_angle_does_not_cut():
    """At a lead of 20 deg the edge below kappa = 20 deg moves away from the material
    (tan(lead) cot(kappa) >= 1: no theta has a positive chip): a cut shallower than
    R (1 - cos 20 deg) = 0.30 mm gives no force at all; one just deeper does."""
    lean = math.sin(math.radians(20.0))
    limit = 5 * MM * (1 - math.cos(math.radians(20.0)))
    phis = np.linspace(0.0, TWO_PI, 73)
    cut, edge = _model(BALL, (*SLOT, 0.98 * limit), phis, lean=lean)
    assert np.all(cut == 0) and np.all(edge == 0)
    cut, edge = _model(BALL, (*SLOT, 1.3 * limit), phis, lean=lean)
    assert np.abs(cut).max() > 0 and np.abs(edge).max() > 0


@pytest.mark.parametrize("lead_deg", [20.0, -20.0])
def test_flat_end_mill_leaning_feed_closed_form(lead_deg):
    """A flat end mill's side edges (kappa = 90 deg) take the chip c cos(lead) sin(theta):
    the slot's mean forces are thesis Eq. 3.25's with c cos(lead) (Fx = -N a Krc c' / 4 -
    N a Kre / pi, Fy = N a Ktc c' / 4 + N a Kte / pi, Fz = N a Kac c' / pi + N a Kae / 2),
    for a rising feed; a descending one (the end edges cut too, not modelled) keeps the
    whole feed on the side edges (an upper bound of their chip)."""
    from feedopt.process.averages import side_average

    flat = _tool(CutterShape.FLAT, 10 * MM, 3, 30.0)
    a, c, lean = 4 * MM, 0.1 * MM, math.sin(math.radians(lead_deg))
    c_side = c * (math.cos(math.radians(lead_deg)) if lead_deg > 0 else 1.0)
    n = flat.teeth
    expect = np.array([-n * a * K.krc * c_side / 4 - n * a * K.kre / math.pi,
                       n * a * K.ktc * c_side / 4 + n * a * K.kte / math.pi,
                       n * a * K.kac * c_side / math.pi + n * a * K.kae / 2])
    phis = (np.arange(6000) + 0.5) * flat.pitch / 6000
    cut, edge = _model(flat, (*SLOT, a), phis, lean=lean)
    mean = (c * cut + edge).mean(axis=0)[:3]
    assert np.allclose(mean, expect, rtol=1e-3, atol=0)
    e = Engagement(np.array([0.0]), np.array([math.pi]), np.array([a]),
                   feed_axial=np.array([lean]))
    m_cut, m_edge = side_average(flat, K, e)
    assert np.allclose(c * m_cut[0] + m_edge[0], expect, rtol=1e-12, atol=0)


@pytest.mark.parametrize("lead_deg", [10.0, -15.0])
def test_side_average_of_a_leaning_ball_is_the_reference_mean(lead_deg):
    """The compensation's mean force (slice_average: exact integrals per slice) against the
    element-wise reference's revolution mean."""
    from feedopt.process.averages import side_average

    lean = math.sin(math.radians(lead_deg))
    eng = (0.4, 2.8, 3 * MM)
    e = Engagement(np.array([eng[0]]), np.array([eng[1]]), np.array([eng[2]]),
                   feed_axial=np.array([lean]))
    cut, edge = side_average(BALL, K, e)
    ref_cut, ref_edge = reference_mean(_shape(BALL), K, eng,
                                       feed=(math.sqrt(1 - lean * lean), lean))
    for got, ref in ((cut[0], ref_cut[:3]), (edge[0], ref_edge[:3])):
        assert np.abs(got - ref).max() < 2e-4 * np.linalg.norm(ref), (got, ref)
