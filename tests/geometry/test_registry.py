"""The blend registry: a new blend kind registered in one place works end to end (build,
sampling, continuity report, ``feedopt path``, the figure), and the registry's rules."""

from dataclasses import replace

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.geometry import blends, waves
from feedopt.geometry.blend_kinds import CIRCLE, BezierEvaluator, tabulated
from feedopt.geometry.continuity import continuity_report
from feedopt.geometry.path import Path, Segment, build_lipb_path
from feedopt.geometry.plot import UNREGISTERED_COLOUR, path_figure
from feedopt.geometry.registry import (
    RADIUS,
    BlendKind,
    BuiltBlends,
    SizeParameter,
    blend_names,
    get_blend,
    register_blend,
    unregister_blend,
)

BUILTIN = ("circle", "bezier4", "bezier5", "varying_radius", "none")
SETBACK = SizeParameter("setback", "distance from the corner along each line to where the "
                        "toy parabola starts [mm]")
TOY = "toy_parabola"
TOY_COLOUR = "tab:purple"


def _build_parabola(c: blends.Corners, delta: float) -> BuiltBlends:
    """Quadratic Bezier q' = q - delta d_in, q, q'' = q + delta d_out: tangent to both lines
    (G1), curvature jumps at both ends."""
    control = np.stack([c.point - delta * c.d_in, c.point, c.point + delta * c.d_out], axis=1)
    return tabulated({"control": control}, BezierEvaluator(control=control))


def _toy_kind() -> BlendKind:
    return BlendKind(name=TOY, size=SETBACK, tangent_distance=blends.tolerance_tangent_distance,
                     largest_size=blends.tolerance_fitting, build=_build_parabola,
                     evaluator=BezierEvaluator, colour=TOY_COLOUR,
                     description="quadratic Bezier through the corner's control polygon: G1")


@pytest.fixture
def toy():
    before = blend_names()
    kind = register_blend(_toy_kind())
    try:
        yield kind
    finally:
        if TOY in blend_names():
            unregister_blend(TOY)
        assert blend_names() == before


def test_builtin_names_and_lookup():
    assert blend_names() == BUILTIN
    assert get_blend("none") is None
    assert get_blend("circle") is CIRCLE and CIRCLE.size is RADIUS
    with pytest.raises(InputError, match="unknown blend 'nurbs'; choose one of circle, "
                                         "bezier4, bezier5, varying_radius, none"):
        get_blend("nurbs")


def test_registry_refuses_bad_kinds(toy):
    with pytest.raises(ValueError, match="already registered"):
        register_blend(_toy_kind())
    for name in ("line", "none", "Bad Name", ""):
        with pytest.raises(ValueError, match="lower-case identifier"):
            register_blend(replace(_toy_kind(), name=name))
    other = SizeParameter("setback", "something else")
    with pytest.raises(ValueError, match="different meaning"):
        register_blend(replace(_toy_kind(), name="toy2", size=other))
    with pytest.raises(ValueError, match="max_turn"):
        register_blend(replace(_toy_kind(), name="toy3", max_turn=4.0))
    with pytest.raises(ValueError, match="no blend kind named"):
        unregister_blend("toy4")
    assert blend_names() == (*BUILTIN[:-1], TOY, "none")


def test_toy_kind_builds_samples_and_is_g1(toy):
    w = waves.triangle_wave()
    delta = 0.01
    path = build_lipb_path(w, TOY, delta)
    blends_ = [g for g in path.segments if g.kind == TOY]
    assert [g.corner_index for g in blends_] == list(range(1, len(w) - 1))
    ends = path.evaluate([x for g in blends_ for x in (g.s_start, g.s_end)]).position
    np.testing.assert_allclose(np.linalg.norm(ends - np.repeat(w[1:-1], 2, axis=0), axis=1),
                               delta, rtol=1e-12)
    # arc length: unit speed, and tangent / curvature are the s-derivatives (central
    # differences inside each blend)
    pts = path.sample(1e-5)
    np.testing.assert_allclose(np.linalg.norm(pts.tangent, axis=1), 1.0, atol=1e-13)
    h = 1e-6
    s = np.concatenate([np.linspace(g.s_start + 5 * h, g.s_end - 5 * h, 9) for g in blends_])
    fd_t = (path.evaluate(s + h).position - path.evaluate(s - h).position) / (2 * h)
    fd_k = (path.evaluate(s + h).tangent - path.evaluate(s - h).tangent) / (2 * h)
    fd_dk = (path.evaluate(s + h).curvature - path.evaluate(s - h).curvature) / (2 * h)
    mid = path.evaluate(s)
    np.testing.assert_allclose(mid.tangent, fd_t, atol=1e-8)
    np.testing.assert_allclose(mid.curvature, fd_k, atol=1e-5 / delta)
    np.testing.assert_allclose(mid.dcurvature, fd_dk, atol=1e-3 / delta**2)
    # continuity: G0 and G1 hold, the curvature jumps at every junction (a G1 blend) by
    # |p' x p''| / |p'|^3 = sin(turn) / (2 delta) of the quadratic Bezier
    rep = continuity_report(path)
    assert len(rep) == 2 * (len(w) - 2)
    assert rep.max()[0] <= 1e-15 and rep.max()[1] <= 1e-12
    turn = blends.corner_geometry(w).turn
    np.testing.assert_allclose(rep.g2, np.repeat(np.sin(turn) / (2 * delta), 2), rtol=1e-9)
    assert TOY in rep.table()


def test_circle_under_a_new_name_gives_the_same_numbers():
    register_blend(replace(CIRCLE, name="circle_copy", colour="tab:brown"))
    try:
        a = build_lipb_path(waves.square_wave(), "circle", 0.0127).sample(1e-4)
        b = build_lipb_path(waves.square_wave(), "circle_copy", 0.0127).sample(1e-4)
    finally:
        unregister_blend("circle_copy")
    for f in ("position", "tangent", "curvature", "dcurvature"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


def test_toy_does_not_fit_message_uses_its_size_name(toy):
    w = np.array([[0, 0, 0], [0.04, 0, 0], [0.04, 0.1, 0]])
    with pytest.raises(InputError, match=r"toy_parabola blend does not fit .* setback 30 mm "
                                         r".*largest setback that fits there is 20 mm"):
        build_lipb_path(w, TOY, 0.03)
    with pytest.raises(InputError, match="blend toy_parabola needs a positive, finite setback"):
        build_lipb_path(w, TOY, -1.0)


def test_max_turn_refusal_names_the_kinds_that_can_round_the_corner(toy):
    w = np.array([[0, 0, 0], [0.05, 0, 0], [0.0, 0.004, 0]])  # turns 175.4 deg
    with pytest.raises(InputError) as err:
        build_lipb_path(w, "bezier4", 0.001)
    assert ("Eq. 3.3 gives an almost zero alpha there (a near-cusp); use bezier5, circle, "
            "varying_radius or toy_parabola, or add a waypoint (1 such corner(s))"
            in str(err.value))


def test_cli_with_the_toy_kind(toy, tmp_path, capsys):
    out, png = tmp_path / "p.csv", tmp_path / "p.png"
    rc = main(["path", "builtin:triangle", "--blend", TOY, "--setback", "10", "--out", str(out),
               "--plot", str(png)])
    text = capsys.readouterr().out
    assert rc == 0
    assert f"blend: {TOY}, size 10 mm, 5 corner(s) blended" in text
    assert f"{TOY} 5" in text  # segment counts
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    pts = build_lipb_path(waves.triangle_wave(), TOY, 0.01).evaluate(data[:, 0] * 1e-3)
    np.testing.assert_allclose(data[:, 1:4], pts.position * 1e3, atol=1e-8)
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(("args", "message"), [
    (["--radius", "10"], "--radius is for circle / varying_radius; toy_parabola takes "
     "--setback MM"),
    ([], "blend toy_parabola needs --setback MM (e.g. --setback 12.7)"),
    (["--setback", "-1"], "--setback must be a positive, finite number of mm, got -1"),
])
def test_cli_size_option_comes_from_the_kind(toy, capsys, args, message):
    assert main(["path", "builtin:triangle", "--blend", TOY, *args]) == 2
    assert capsys.readouterr().err.startswith(f"feedopt path: error: {message}")


def test_cli_refuses_other_kinds_size_option(toy, capsys):
    assert main(["path", "builtin:triangle", "--blend", "circle", "--setback", "5"]) == 2
    assert "--setback is for toy_parabola; circle takes --radius MM" in capsys.readouterr().err
    assert main(["path", "builtin:triangle", "--blend", "none", "--setback", "5"]) == 2
    assert "--setback sizes a blend; --blend none has none" in capsys.readouterr().err


def _xy_lines(path, **kw):
    ax = path_figure(path, **kw).axes[0]
    return {ln.get_label(): ln for ln in ax.get_lines()}


def test_figure_draws_every_kind_in_its_colour(toy):
    path = build_lipb_path(waves.triangle_wave(), TOY, 0.01)
    lines = _xy_lines(path, spacing=1e-4)
    assert set(lines) == {"line", TOY}
    toy_line = lines[TOY]
    assert toy_line.get_color() == TOY_COLOUR
    drawn = np.isfinite(np.asarray(toy_line.get_xdata(), dtype=float)).sum()
    assert drawn == pytest.approx(5 * path.segments[1].length / 1e-4, rel=0.01)
    for kind in BUILTIN[:-1]:
        lines = _xy_lines(build_lipb_path(waves.square_wave(), kind, 0.0127))
        assert lines[kind].get_color() == get_blend(kind).colour


def test_figure_draws_a_kind_that_left_the_registry(toy):
    path = build_lipb_path(waves.triangle_wave(), TOY, 0.01)
    unregister_blend(TOY)
    lines = _xy_lines(path)
    assert lines[f"{TOY} (unregistered)"].get_color() == UNREGISTERED_COLOUR
    # the path itself keeps evaluating
    assert path.sample(1e-3).position.shape[1] == 3


def test_figure_marks_blends_shorter_than_the_spacing():
    path = build_lipb_path(waves.triangle_wave(), "circle", 1e-4)  # arcs ~0.2 mm long
    lines = _xy_lines(path, spacing=5e-3)
    assert np.isfinite(np.asarray(lines["circle"].get_xdata(), dtype=float)).sum() >= 1


def test_path_refuses_an_unknown_segment_kind():
    seg = Segment("nurbs", 0.0, 1.0, 1, {})
    with pytest.raises(ValueError, match="unknown segment kind 'nurbs'"):
        Path([seg])


def test_build_returns_the_dropped_waypoints():
    w = waves.triangle_wave()
    wr = np.insert(w, [2, 4], w[[1, 3]], axis=0)  # repeats at new indices 2 and 5
    assert build_lipb_path(wr, "circle", 0.01, drop_repeated=True).dropped_waypoints == (2, 5)
    assert build_lipb_path(w, "circle", 0.01).dropped_waypoints == ()
    with pytest.raises(InputError, match=r"remove them or do what I say$"):
        build_lipb_path(wr, "circle", 0.01, repeat_hint="do what I say")
    with pytest.raises(InputError, match=r"remove them or pass drop_repeated=True \(CLI: "
                                         r"--drop-repeated\)$"):
        build_lipb_path(wr, "circle", 0.01)


def test_cli_refuses_a_size_name_that_clashes_with_its_options():
    register_blend(replace(_toy_kind(), name="toy_clash",
                           size=SizeParameter("spacing", "a bad name for a size")))
    try:
        with pytest.raises(RuntimeError, match="clashes with feedopt path's own option"):
            main(["path", "builtin:triangle", "--blend", "none"])
    finally:
        unregister_blend("toy_clash")
