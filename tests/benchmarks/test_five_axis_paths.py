"""benchmarks/five_axis_paths.py: the swarf and tilted ball-nose CL paths against geometry
computed here independently, and the APT CL text read back with a regex of this file.

Independent pieces (none calls the generator's geometry):

- the ruled wall: bottom arc B(l) = (sin(kl)/k, (1 - cos(kl))/k, 0) (a line for k = 0), top
  T(l) = B(l) + H (e_z - tan(phi) n_h), phi the half-cosine lean profile, written again below;
  its normal by central differences of W(l, s) = B + s (T - B); the arc length of a bottom
  point by inverting the arc (kl = atan2(kx, 1 - ky));
- distances from points to lines and segments, written here;
- the ball: the nearest surface point to the ball's centre by a numerical minimisation of the
  distance (scipy), the normal and feed direction from the surface's own derivatives here, and
  lead = asin(a . f), tilt = atan2(a . (n x f), a . n) (the module's stated convention).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from tests.conftest import ROOT, load_benchmark

fa = load_benchmark("five_axis_paths")

EZ = np.array([0.0, 0.0, 1.0])


# --- independent geometry ------------------------------------------------------------------


def _lean(spec, l):
    """phi(l) [rad]: half-cosine from lean[0] to lean[1] at peak, then to lean[2] at L."""
    p0, p1, p2 = (math.radians(d) for d in spec.lean_deg)
    lp = spec.peak_frac * spec.length_mm
    out = []
    for x in np.atleast_1d(l):
        if x <= lp:
            out.append(p0 + (p1 - p0) * (1 - math.cos(math.pi * x / lp)) / 2)
        else:
            u = (x - lp) / (spec.length_mm - lp)
            out.append(p1 + (p2 - p1) * (1 - math.cos(math.pi * u)) / 2)
    return np.array(out)


def _bottom_top(spec, l):
    """Bottom and top points of the rulings at arc lengths l, and n_h (towards the tool)."""
    l = np.atleast_1d(np.asarray(l, dtype=float))
    k = 1.0 / spec.arc_radius_mm if spec.arc_radius_mm else 0.0
    if k:
        b = np.column_stack([np.sin(k * l) / k, (1 - np.cos(k * l)) / k, 0 * l])
    else:
        b = np.column_stack([l, 0 * l, 0 * l])
    nh = np.column_stack([np.sin(k * l), -np.cos(k * l), 0 * l])
    top = b + spec.height_mm * (EZ - np.tan(_lean(spec, l))[:, None] * nh)
    return b, top, nh


def _arc_length(spec, p):
    """l of a point p on the bottom curve."""
    if not spec.arc_radius_mm:
        return p[0]
    k = 1.0 / spec.arc_radius_mm
    return math.atan2(k * p[0], 1 - k * p[1]) / k


def _normal(spec, l, s, h=1e-5):
    """Unit wall normal at W(l, s) = B + s (T - B) (s in [0, 1]), towards the tool, by central
    differences in l."""
    def w(x):
        b, t, _ = _bottom_top(spec, [x])
        return b[0] + s * (t[0] - b[0])

    b, t, nh = _bottom_top(spec, [l])
    n = np.cross((w(l + h) - w(l - h)) / (2 * h), t[0] - b[0])
    n /= np.linalg.norm(n)
    return n if n @ nh[0] > 0 else -n


def _line_distance(p, origin, direction):
    """Distance of points p from the line origin + t direction (any length direction)."""
    d = direction / np.linalg.norm(direction)
    q = np.asarray(p, dtype=float) - origin
    return np.linalg.norm(q - np.outer(q @ d, d) if q.ndim > 1 else q - (q @ d) * d, axis=-1)


def _segment_distance(p, a, b):
    """Distance of points p (m, 3) from the segment a-b."""
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(p - a - t[:, None] * (b - a), axis=1)


def _cut_rows(path):
    """Indices of the feed points that lie on the part (contact known)."""
    return np.flatnonzero(path.cut & ~np.isnan(path.contact[:, 0]))


# --- swarf ---------------------------------------------------------------------------------


def _check_swarf(spec, path, atol=1e-9):
    """Axis = unit ruling, the tip's cylinder through the ruling's ends, tool on the wall's
    outside, chords within tolerance; returns the arc lengths of the CL rulings."""
    r = spec.diameter_mm / 2
    rows = _cut_rows(path)
    ls = np.array([_arc_length(spec, path.contact[i]) for i in rows])
    b, t, _ = _bottom_top(spec, ls)
    assert np.allclose(path.contact[rows], b, atol=atol)  # the contact is on the bottom curve
    assert ls[0] == pytest.approx(0, abs=atol) and ls[-1] == pytest.approx(spec.length_mm)
    assert np.all(np.diff(ls) > 0)
    assert np.abs(ls - spec.peak_frac * spec.length_mm).min() < atol  # a ruling at the peak
    tips, axes = path.points[rows], path.axes[rows]
    assert np.allclose(np.linalg.norm(axes, axis=1), 1, atol=1e-12)
    ruling = (t - b) / np.linalg.norm(t - b, axis=1)[:, None]
    assert np.allclose(axes, ruling, atol=atol)
    for j in range(len(rows)):
        for end in (b[j], t[j]):
            assert _line_distance(end, tips[j], axes[j]) == pytest.approx(r, abs=atol)
        n0 = _normal(spec, ls[j], 0.0)
        assert (tips[j] - b[j]) @ n0 > 0.9 * r  # on the tool's side of the wall
        assert (tips[j] - b[j]) @ axes[j] == pytest.approx(-spec.below_floor_mm, abs=atol)
    _check_swarf_chords(spec, path.points[rows], ls)
    return ls


def _check_swarf_chords(spec, tips, ls, n=40):
    """Bottom, top and tip curves within the chord tolerance of the polylines."""
    r = spec.diameter_mm / 2
    tol = spec.chord_tol_mm * (1 + 1e-6) + 1e-7  # 1e-7: the normals' central differences
    b, t, _ = _bottom_top(spec, ls)
    for j in range(len(ls) - 1):
        sub = np.linspace(ls[j], ls[j + 1], n)
        bs, ts, _ = _bottom_top(spec, sub)
        assert _segment_distance(bs, b[j], b[j + 1]).max() <= tol
        assert _segment_distance(ts, t[j], t[j + 1]).max() <= tol
        if j % 8 == 0:  # the tip curve: B + r (bisector of bottom and top normals) - e a
            mid = sub[1:-1:4]
            nb = np.array([_normal(spec, x, 0.0) + _normal(spec, x, 1.0) for x in mid])
            a = (ts - bs)[1:-1:4]
            a /= np.linalg.norm(a, axis=1)[:, None]
            exact = bs[1:-1:4] + r * nb / np.linalg.norm(nb, axis=1)[:, None]
            exact -= spec.below_floor_mm * a
            assert _segment_distance(exact, tips[j], tips[j + 1]).max() <= tol
    assert np.linalg.norm(np.diff(tips, axis=0), axis=1).max() <= spec.max_step_mm + 1e-9


def _overcut(spec, path, half_frac=1.5, n_s=801, n_v=31):
    """Deepest entry [mm] of the wall into the tool cylinders, the wall sampled around each
    ruling (arc length +- half_frac r, its full height)."""
    r = spec.diameter_mm / 2
    worst = 0.0
    for i in _cut_rows(path):
        l0 = _arc_length(spec, path.contact[i])
        ls = np.clip(l0 + np.linspace(-half_frac * r, half_frac * r, n_s), 0, spec.length_mm)
        b, t, _ = _bottom_top(spec, ls)
        s = np.linspace(0, 1, n_v)
        pts = (b[:, None, :] + s[None, :, None] * (t - b)[:, None, :]).reshape(-1, 3)
        d = _line_distance(pts, path.points[i], path.axes[i])
        worst = max(worst, r - d.min())
    return worst


def test_default_swarf_geometry():
    spec = fa.Swarf()
    path = fa.swarf_cl(spec)
    ls = _check_swarf(spec, path)
    lean = np.degrees(np.arccos(path.axes[_cut_rows(path), 2]))
    assert lean.min() == pytest.approx(0, abs=1e-6) and lean.max() == pytest.approx(20, abs=1e-9)
    assert len(ls) < 400


def test_swarf_overcut_is_small_and_matches_the_module():
    """The twisting wall enters the tool by ~ r (1 - cos(half twist)): sampled here and by the
    module (different grids) it is positive and under 0.01 mm for the defaults."""
    spec = fa.Swarf()
    path = fa.swarf_cl(spec)
    here = _overcut(spec, path)
    ls = fa.swarf_params(spec)
    module = fa.swarf_overcut_mm(spec, ls).max()
    closed = (spec.diameter_mm / 2 * (1 - np.cos(fa.swarf_twist_rad(spec, ls)))).max()
    assert 0.001 < here < 0.01
    assert module == pytest.approx(here, abs=2e-5)
    assert closed == pytest.approx(here, rel=0.1)


def test_developable_wall_has_no_overcut():
    """Constant lean on an arc (a cone's piece) or a line (a plane): the tool cylinder touches
    the wall along the whole ruling and stays outside it."""
    for radius in (400.0, 0.0):
        spec = fa.Swarf(lean_deg=(12.0, 12.0, 12.0), arc_radius_mm=radius, length_mm=60)
        path = fa.swarf_cl(spec)
        _check_swarf(spec, path)
        assert _overcut(spec, path, n_s=201, n_v=11) < 1e-9
        assert fa.swarf_twist_rad(spec, fa.swarf_params(spec)).max() < 1e-9


def test_swarf_below_floor_and_flute_check():
    spec = fa.Swarf(below_floor_mm=0.5, length_mm=50, lean_deg=(0, 8, 4))
    _check_swarf(spec, fa.swarf_cl(spec))
    with pytest.raises(ValueError, match="flutes"):
        fa.swarf_cl(spec, flute_mm=15.0)


@settings(max_examples=25, deadline=None)
@given(d=st.floats(4, 16), h=st.floats(4, 20), length=st.floats(40, 200),
       lean=st.tuples(*[st.floats(-15, 25)] * 3), peak=st.floats(0.2, 0.8),
       radius=st.sampled_from([0.0, 150.0, 400.0, -300.0, 1000.0]),
       below=st.floats(0, 1), tol=st.sampled_from([0.005, 0.02]))
def test_swarf_properties(d, h, length, lean, peak, radius, below, tol):
    spec = fa.Swarf(diameter_mm=d, height_mm=h, length_mm=length, lean_deg=lean,
                    peak_frac=peak, arc_radius_mm=radius, below_floor_mm=below,
                    chord_tol_mm=tol, flute_mm=40.0)
    _check_swarf(spec, fa.swarf_cl(spec), atol=1e-8)


# --- ball ----------------------------------------------------------------------------------


def _surface(kind, rs, x, y):
    """z, z_x, z_y of the saddle (x^2 - y^2) / (2 rs) or the cylinder sqrt(rs^2 - x^2) - rs."""
    if kind == "saddle":
        return (x * x - y * y) / (2 * rs), x / rs, -y / rs
    h = np.sqrt(rs * rs - x * x)
    return h - rs, -x / h, 0.0 * x


def _nearest(kind, rs, c):
    """Nearest surface point to c: minimise |c - (x, y, z(x, y))|^2 from (c_x, c_y)."""
    def f(q):
        z = _surface(kind, rs, q[0], q[1])[0]
        return (q[0] - c[0]) ** 2 + (q[1] - c[1]) ** 2 + (z - c[2]) ** 2

    res = minimize(f, c[:2], method="Nelder-Mead",
                   options={"xatol": 1e-11, "fatol": 1e-16, "maxiter": 4000})
    q = res.x
    return np.array([q[0], q[1], _surface(kind, rs, q[0], q[1])[0]])


def _check_ball(spec, path, every=1):
    """Ball centre R from the surface at the contact; lead and tilt recovered; passes and
    step-over as asked; chords within tolerance."""
    r = spec.diameter_mm / 2
    rows = _cut_rows(path)
    breaks = np.flatnonzero(np.diff(rows) > 1) + 1
    passes = np.split(rows, breaks)
    ys = [path.contact[p[0], 1] for p in passes]
    assert ys[0] == pytest.approx(-spec.length_mm / 2) and ys[-1] == pytest.approx(
        spec.length_mm / 2)
    assert len(ys) == 1 or np.diff(ys).max() <= spec.stepover_mm + 1e-9
    for j, p in enumerate(passes):
        x = path.contact[p, 0]
        sign = -1.0 if spec.zigzag and j % 2 else 1.0
        assert x[0] == pytest.approx(-sign * spec.width_mm / 2)
        assert x[-1] == pytest.approx(sign * spec.width_mm / 2)
        assert np.all(sign * np.diff(x) > 0)
        for i in p[::every]:
            _check_ball_point(spec, path, i, sign, r)
        q = path.contact[p]
        for a, b in zip(q[:-1], q[1:], strict=True):
            xs = np.linspace(a[0], b[0], 30)
            zs = _surface(spec.surface, spec.surface_radius_mm, xs, a[1])[0]
            exact = np.column_stack([xs, np.full_like(xs, a[1]), zs])
            assert _segment_distance(exact, a, b).max() <= spec.chord_tol_mm * (1 + 1e-6)


def _check_ball_point(spec, path, i, sign, r):
    """One CL point: centre R from its nearest surface point, the contact; lead and tilt."""
    tip, a = path.points[i], path.axes[i]
    assert np.linalg.norm(a) == pytest.approx(1, abs=1e-12)
    centre = tip + r * a
    near = _nearest(spec.surface, spec.surface_radius_mm, centre)
    assert np.linalg.norm(centre - near) == pytest.approx(r, abs=1e-8)
    assert np.allclose(near, path.contact[i], atol=1e-5)
    p = path.contact[i]
    _, zx, zy = _surface(spec.surface, spec.surface_radius_mm, p[0], p[1])
    n = np.array([-zx, -zy, 1.0]) / math.sqrt(zx * zx + zy * zy + 1)
    f = sign * np.array([1.0, 0.0, zx]) / math.sqrt(1 + zx * zx)
    lead = math.degrees(math.asin(a @ f))
    tilt = math.degrees(math.atan2(a @ np.cross(n, f), a @ n))
    assert lead == pytest.approx(spec.lead_deg, abs=1e-9)
    assert tilt == pytest.approx(spec.tilt_deg, abs=1e-9)


def test_default_ball_geometry():
    spec = fa.Ball()
    path = fa.ball_cl(spec)
    _check_ball(spec, path, every=25)
    assert len(np.split(_cut_rows(path), np.flatnonzero(np.diff(_cut_rows(path)) > 1) + 1)) == 31


@pytest.mark.parametrize("surface", ["saddle", "cylinder"])
@pytest.mark.parametrize("zigzag", [True, False])
def test_ball_small_patches(surface, zigzag):
    spec = fa.Ball(surface=surface, zigzag=zigzag, width_mm=20, length_mm=3.5,
                   stepover_mm=1.0, lead_deg=-15, tilt_deg=5, max_step_mm=3.0)
    _check_ball(spec, fa.ball_cl(spec))


@settings(max_examples=25, deadline=None)
@given(d=st.floats(2, 16), lead=st.floats(-30, 30), tilt=st.floats(-15, 15),
       surface=st.sampled_from(["saddle", "cylinder"]), rs=st.floats(100, 400),
       stepover=st.floats(0.4, 2.0), zigzag=st.booleans())
def test_ball_properties(d, lead, tilt, surface, rs, stepover, zigzag):
    spec = fa.Ball(diameter_mm=d, lead_deg=lead, tilt_deg=tilt, surface=surface,
                   surface_radius_mm=rs, width_mm=12.0, length_mm=2.0, stepover_mm=stepover,
                   zigzag=zigzag, max_step_mm=2.0)
    _check_ball(spec, fa.ball_cl(spec), every=3)


# --- air moves -----------------------------------------------------------------------------


@pytest.mark.parametrize("path,z_safe", [(fa.swarf_cl(), 25.0), (fa.ball_cl(), None)])
def test_air_moves_run_along_the_tool_axis(path, z_safe):
    """Every pass: rapid to the safe height above its start on the start's axis, rapid to
    approach_mm above, feed to the start; after its end, rapid up its axis to the safe height."""
    rows = _cut_rows(path)
    starts = np.r_[rows[0], rows[1:][np.diff(rows) > 1]]
    ends = np.r_[rows[:-1][np.diff(rows) > 1], rows[-1]]
    safe = path.points[~path.cut, 2]
    zs = z_safe if z_safe is not None else safe.max()
    for s, e in zip(starts, ends, strict=True):
        for q in (s - 2, e + 1):  # the safe points
            ref = s if q < s else e
            assert not path.cut[q] and path.points[q, 2] == pytest.approx(zs)
            assert _line_distance(path.points[q], path.points[ref], path.axes[ref]) < 1e-9
            assert (path.points[q] - path.points[ref]) @ path.axes[ref] > 2.0
        assert not path.cut[s - 1] and path.cut[s]
        assert np.linalg.norm(path.points[s - 1] - path.points[s]) == pytest.approx(2.0)
        assert (path.points[s - 1] - path.points[s]) @ path.axes[s] == pytest.approx(2.0)
    assert len(path.cut) == len(rows) + 3 * len(starts)


# --- APT text ------------------------------------------------------------------------------

NUM = r"(-?\d+\.\d{6})"
GOTO = re.compile(r"GOTO/" + ",".join([NUM] * 6))
FEDRAT = re.compile(r"FEDRAT/" + NUM + r",MMPM")


def _parse(text):
    """(points, axes, rapid flags, feeds) from the GOTO/RAPID/FEDRAT lines; header checked."""
    lines = text.splitlines()
    body = [ln for ln in lines if not ln.startswith("$$")]
    assert lines[0].startswith("$$ generated by benchmarks/five_axis_paths.py")
    assert body[:3] == ["UNITS/MM", "MULTAX/ON", body[2]] and body[2].startswith("CUTTER/")
    assert body[3:5] == ["LOADTL/1", body[4]] and re.fullmatch(r"SPINDL/" + NUM + ",CLW", body[4])
    assert body[-1] == "FINI" and "FINI" not in body[:-1]
    rows, rapid, feeds = [], [], []
    pending, feed, last_fedrat = False, None, None
    for ln in body[5:-1]:
        if ln == "RAPID":
            assert not pending
            pending = True
        elif m := FEDRAT.fullmatch(ln):
            assert not pending and float(m.group(1)) != last_fedrat  # only when it changes
            feed = last_fedrat = float(m.group(1))
        else:
            m = GOTO.fullmatch(ln)
            assert m, ln
            rows.append([float(g) for g in m.groups()])
            rapid.append(pending)
            assert pending or feed is not None  # FEDRAT before the first feed move
            feeds.append(None if pending else feed)
            pending = False
    assert not pending
    rows = np.array(rows)
    return rows[:, :3], rows[:, 3:], np.array(rapid), feeds


@pytest.mark.parametrize("kind", ["swarf", "ball"])
def test_apt_text_reads_back(kind):
    spec = fa.Swarf(length_mm=40) if kind == "swarf" else fa.Ball(width_mm=10, length_mm=2)
    path, text, _ = fa.program(spec)
    pts, axes, rapid, feeds = _parse(text)
    assert np.abs(pts - path.points).max() <= 5e-7 + 1e-12
    assert np.abs(axes - path.axes).max() <= 5e-7 + 1e-12
    assert np.array_equal(rapid, ~path.cut)
    after_rapid = np.r_[False, rapid[:-1]]
    for f, cut, ar in zip(feeds, path.cut, after_rapid, strict=True):
        if cut:
            assert f == (spec.plunge_mm_min if ar else spec.feed_mm_min)
    d = spec.diameter_mm
    cutter = f"CUTTER/{d:.6f},{(d / 2 if kind == 'ball' else 0.0):.6f}"
    assert cutter in text.splitlines()


def test_apt_single_feed_and_no_negative_zero():
    path = fa.ClPath(np.array([[0, 0, 10.0], [-1e-9, 0, 1], [1, 0, 1], [1, 0, 10]]),
                     np.array([[0, 0, 1.0]] * 4), np.array([False, True, True, False]),
                     np.full((4, 3), np.nan))
    text = fa.apt_text(path, cutter_mm=(6, 3), feed_mm_min=1500)
    assert text.count("FEDRAT/") == 1 and "-0.000000" not in text
    assert text.splitlines()[-4:] == ["GOTO/1.000000,0.000000,1.000000,0.000000,0.000000,"
                                      "1.000000", "RAPID", "GOTO/1.000000,0.000000,10.000000,"
                                      "0.000000,0.000000,1.000000", "FINI"]
    _parse(text)


# --- command line and the scenario files ----------------------------------------------------


def test_main_writes_refuses_and_forces(tmp_path, capsys):
    out = tmp_path / "b.cls"
    args = ["--kind", "ball", "--out", str(out), "--width-mm", "6", "--length-mm", "1",
            "--lead-deg", "5", "--zigzag", "false"]
    assert fa.main(args) == 0
    assert "lead 5 deg" in out.read_text() and "GOTO" in capsys.readouterr().out
    before = out.read_text()
    with pytest.raises(SystemExit) as exc:
        fa.main(args[:-2] + ["--lead-deg", "7"])
    assert exc.value.code == 2 and out.read_text() == before
    assert fa.main(args + ["--tilt-deg", "2", "--force"]) == 0
    assert "tilt 2 deg" in out.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.cls"]  # no temporary left
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask


def test_main_swarf_options_and_stray_option(tmp_path):
    out = tmp_path / "s.cls"
    assert fa.main(["--kind", "swarf", "--out", str(out), "--lean-deg", "0", "10", "5",
                    "--length-mm", "40"]) == 0
    _, axes, rapid, _ = _parse(out.read_text())
    lean = np.degrees(np.arccos(axes[~rapid, 2]))
    assert lean.max() == pytest.approx(10, abs=1e-3)
    with pytest.raises(SystemExit):
        fa.main(["--kind", "swarf", "--out", str(tmp_path / "t.cls"), "--lead-deg", "5"])
    assert not (tmp_path / "t.cls").exists()


@pytest.mark.parametrize("name,spec", [("swarf_wall", fa.Swarf()), ("ball_saddle", fa.Ball())])
def test_scenario_files_are_the_default_outputs(name, spec):
    f = ROOT / "scenarios" / "five_axis" / f"{name}.cls"
    text = f.read_text()
    assert text.count("GOTO/") < 3000 and f.stat().st_size < 400_000
    path, _, _ = fa.program(spec)
    pts, axes, rapid, _ = _parse(text)
    assert pts.shape == path.points.shape and np.array_equal(rapid, ~path.cut)
    assert np.abs(pts - path.points).max() < 2e-6 and np.abs(axes - path.axes).max() < 2e-6


def test_dataclass_overrides():
    assert fa.swarf_cl(length_mm=30).points.shape == fa.swarf_cl(
        dataclasses.replace(fa.Swarf(), length_mm=30)).points.shape
    with pytest.raises(ValueError, match="surface"):
        fa.ball_cl(surface="torus")
