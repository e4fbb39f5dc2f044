"""Tool files: the cutter's shape and its bending fields (strict, with clear errors)."""

import math

import pytest
import yaml

from feedopt.errors import InputError
from feedopt.process.cutter import CutterShape
from feedopt.process.tool import load_tool

BASE = {"name": "t", "diameter_mm": 6.0, "teeth": 2, "helix_deg": 30, "flute_length_mm": 12}


def _load(tmp_path, **fields):
    p = tmp_path / "tool.yaml"
    p.write_text(yaml.safe_dump(BASE | fields))
    return load_tool(p)


def test_a_file_without_shape_is_the_flat_end_mill_of_before(tmp_path):
    tool = _load(tmp_path)
    assert tool.shape is CutterShape.FLAT and tool.is_flat and not tool.bends
    assert tool.tip_compliance() == (0.0, 0.0)


def test_ball_corner_radius_defaults_to_half_the_diameter(tmp_path):
    tool = _load(tmp_path, shape="ball")
    assert tool.corner_radius == pytest.approx(3e-3) and not tool.is_flat
    assert tool.profile.r0 == pytest.approx(0.0)


@pytest.mark.parametrize(("fields", "want"), [
    ({"shape": "ball", "corner_radius_mm": 1.0}, "a ball-nose has corner radius D/2"),
    ({"shape": "bull"}, "0 < corner radius < D/2"),
    ({"shape": "bull", "corner_radius_mm": 3.0}, "0 < corner radius < D/2"),
    ({"shape": "flat", "corner_radius_mm": 0.5}, "shape: bull or tapered"),
    ({"shape": "tapered"}, "taper_deg in (0, 80]"),
    ({"shape": "bull", "corner_radius_mm": 1, "taper_deg": 3}, "only a tapered mill"),
    ({"shape": "face"}, "needs lead_angle_deg"),
    ({"shape": "face", "lead_angle_deg": 0}, "must be in [10, 90] deg"),
    ({"shape": "face", "lead_angle_deg": 1}, "must be in [10, 90] deg"),
    ({"shape": "ball", "lead_angle_deg": 45}, "only a face mill"),
    ({"shape": "conical"}, "expected one of flat, ball, bull, tapered, face, got 'conical'"),
    ({"shape": None}, "expected one of flat, ball, bull, tapered, face, got null"),
    ({"stickout_mm": 2, "material": "carbide"}, "shorter than the flute length 12 mm"),
    ({"stickout_mm": 1e6, "material": "carbide"}, "outside the plausible 0.1..1000 mm"),
    ({"stickout_mm": 30, "youngs_modulus_gpa": 1e-4}, "outside the plausible 10..1200 GPa"),
    ({"youngs_modulus_gpa": 600}, "only used with stickout_mm"),
    ({"tip_stiffness_n_per_um": 1e-9}, "outside the plausible 0.001..10000 N/um"),
    ({"shape": "bull", "corner_radius_mm": 3.0000000000001},
     "corner radius 3.0000000000001 mm and taper 0 deg: a bull-nose has 0 < corner radius "
     "< D/2 and no taper (corner radius D/2: shape: ball)"),
    ({"stickout_mm": 30}, "material one of carbide, hss, steel"),
    ({"stickout_mm": 30, "material": "carbide", "overall_length_mm": 20},
     "longer than overall_length_mm"),
    ({"tip_stiffness_n_per_um": -2}, "tip_stiffness_n_per_um: -2 N/um is outside"),
    ({"shape": "bull", "corner_radius_mm": 7}, "corner_radius must be in [0, D/2 = 3] mm"),
])
def test_inconsistent_shape_or_bending_fields_are_refused(tmp_path, fields, want):
    with pytest.raises(InputError) as exc:
        _load(tmp_path, **fields)
    message = str(exc.value)
    assert want in message and "tool.yaml" in message
    assert message.count("tool file") == 1 and "tool: " not in message  # one prefix


def test_face_mill_lead_angle_is_its_profile_edge(tmp_path):
    tool = _load(tmp_path, shape="face", lead_angle_deg=45, corner_radius_mm=0.8,
                 diameter_mm=50, teeth=8, helix_deg=0)
    assert tool.taper == pytest.approx(math.radians(45))
    assert tool.profile.kappa1 == pytest.approx(math.radians(45))
    assert tool.profile.r0 == pytest.approx(25e-3 - 0.8e-3)


def test_tapered_ball_and_stickout_bending(tmp_path):
    tool = _load(tmp_path, shape="tapered", taper_deg=3, corner_radius_mm=3, material="carbide",
                 stickout_mm=40, shank_diameter_mm=6)
    assert tool.bends and tool.youngs_modulus == 600e9
    lateral, axial = tool.tip_compliance()
    # uniform 6 mm shank 28 mm plus 12 mm of flutes at 4.8 mm: between the all-flute and
    # all-shank cantilevers P L^3 / (3 E I)
    def cantilever(d):
        return 0.04**3 / (3 * 600e9 * math.pi * d**4 / 64)
    assert cantilever(6e-3) < lateral < cantilever(4.8e-3)
    assert 0 < axial < lateral


def test_shape_and_material_names_are_case_insensitive(tmp_path):
    tool = _load(tmp_path, shape="Ball", material="Carbide", stickout_mm=20)
    assert tool.shape is CutterShape.BALL and tool.youngs_modulus == 600e9


def test_a_measured_tip_stiffness_replaces_the_cantilever(tmp_path):
    tool = _load(tmp_path, tip_stiffness_n_per_um=2.5)
    assert tool.tip_compliance()[0] == pytest.approx(1 / 2.5e6)
    explicit = _load(tmp_path, stickout_mm=30, youngs_modulus_gpa=550)
    assert explicit.youngs_modulus == pytest.approx(550e9)


def test_bundled_tool_files_load():
    from pathlib import Path
    tools = Path(__file__).resolve().parents[2] / "scenarios" / "tools"
    shapes = {load_tool(p).shape for p in tools.glob("*.yaml")}
    assert {CutterShape.FLAT, CutterShape.BALL} <= shapes
