"""KRL export: the program parses back to the points and velocities given, and refuses bad input."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from feedopt.errors import InputError
from feedopt.export.krl import parse_krl_spline, write_krl_program


def _triangle_key_points():
    """Key points of a 2-wave triangle slot in the base frame: line ends and blend ends."""
    x = np.array([0, 30, 40, 70, 80, 110, 120, 150], dtype=float) + 1200.0
    y = np.array([0, 60, 60, 0, 0, 60, 60, 0], dtype=float) - 100.0
    z = np.full_like(x, 650.0)
    abc = np.tile([12.5, -0.25, 179.875], (x.size, 1))
    pts = np.column_stack([x, y, z, abc])
    motion = ["SLIN", "SPL", "SLIN", "SPL", "SLIN", "SPL", "SLIN"]
    vel = np.array([4.02, 2.1, 2.75, 2.2, 4.02, 2.05, 2.75]) * 1e-3
    return pts, motion, vel


def _write(tmp_path, name="thesis", **kw):
    pts, motion, vel = _triangle_key_points()
    args = dict(points=pts, motion=motion, velocity_m_s=vel,
                start_axis_deg=[10, -80, 95, 0, 30, -5], comments=["scenario: triangle_slot"])
    args.update(kw)
    return write_krl_program(tmp_path / f"{name}.src", name, **args)


def test_program_parses_back_to_the_inputs(tmp_path):
    pts, motion, vel = _triangle_key_points()
    text = _write(tmp_path).read_text()
    segs = parse_krl_spline(text)
    assert [s["motion"] for s in segs] == motion
    got = np.array([[s[k] for k in "XYZABC"] for s in segs])
    np.testing.assert_allclose(got, pts[1:], atol=5e-5, rtol=0)
    np.testing.assert_allclose([s["vel_m_s"] for s in segs], vel, rtol=1e-6)


def test_program_structure(tmp_path):
    lines = _write(tmp_path).read_text().splitlines()
    code = [ln.split(";", 1)[0].strip() for ln in lines]
    code = [c for c in code if c]
    assert code[0] == "DEF thesis()" and code[-1] == "END"
    i_ptp = next(i for i, c in enumerate(code) if c.startswith("PTP {A1 10, A2 -80, A3 95"))
    i_spline = code.index("SPLINE")
    i_end = code.index("ENDSPLINE")
    assert i_ptp < i_spline < i_end
    assert all("WITH $VEL.CP = " in c for c in code[i_spline + 1:i_end])
    assert any(c.startswith("$ACC.CP = ") for c in code[:i_spline])
    assert "BAS(" not in "\n".join(code)


def test_comment_says_what_the_controller_does_differently(tmp_path):
    text = _write(tmp_path).read_text()
    comments = "\n".join(ln for ln in text.splitlines() if ln.lstrip().startswith(";"))
    for phrase in ("own velocity profile", "acceleration and jerk", "3.7", "SPL segments",
                   "open loop", "scenario: triangle_slot"):
        assert phrase in comments


def test_velocity_per_point_including_the_start_is_accepted(tmp_path):
    pts, motion, vel = _triangle_key_points()
    path = _write(tmp_path, velocity_m_s=np.concatenate([[9.9], vel]))
    np.testing.assert_allclose([s["vel_m_s"] for s in parse_krl_spline(path.read_text())], vel,
                               rtol=1e-6)


def test_successive_slin_is_flagged(tmp_path):
    path = _write(tmp_path, motion=["SLIN"] * 7)
    assert "6 pair(s) of successive SLIN" in path.read_text()


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"motion": ["SLIN"] * 6}, "one of .* per point after the first"),
        ({"motion": ["SLIN", "LIN"] + ["SPL"] * 5}, "point 2 is 'LIN'"),
        ({"velocity_m_s": np.zeros(7)}, "velocity to point 1 is 0.0"),
        ({"velocity_m_s": np.ones(3)}, "one value per point"),
        ({"start_axis_deg": [0, 0, 0]}, "start_axis_deg"),
        ({"points": np.zeros((1, 6))}, "n >= 2"),
    ],
)
def test_bad_inputs_are_refused(tmp_path, kw, message):
    with pytest.raises(InputError, match=message):
        _write(tmp_path, **kw)


def test_name_must_be_a_krl_identifier_and_match_the_file(tmp_path):
    with pytest.raises(InputError, match="not valid.*'my_law_1'"):
        _write(tmp_path, name="my-law 1")
    pts, motion, vel = _triangle_key_points()
    with pytest.raises(InputError, match="must equal the file name stem"):
        write_krl_program(tmp_path / "a.src", "b", pts, motion, vel, np.zeros(6))
    assert not (tmp_path / "a.src").exists()
    path = write_krl_program(tmp_path / "constant.src", None, pts, motion, vel, np.zeros(6))
    assert path.read_text().startswith("DEF constant()")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("DEF a()\nEND\n", "no SPLINE block"),
        ("SPLINE\n  SPL {X 1, Y 2, Z 3, A 0, B 0, C 0}\n", "no ENDSPLINE"),
        ("SPLINE\n  LIN {X 1, Y 2, Z 3, A 0, B 0, C 0}\nENDSPLINE", "line 2: expected SLIN/SPL"),
        ("SPLINE\n  SPL {X 1, Y 2, Z 3, A 0, B 0}\nENDSPLINE", "line 2: position lacks C"),
        ("SPLINE\n  SPL {X 1, Y two, Z 3, A 0, B 0, C 0}\nENDSPLINE", "line 2: cannot read"),
    ],
)
def test_parser_errors(text, message):
    with pytest.raises(InputError, match=message):
        parse_krl_spline(text)


def test_parser_reads_handwritten_kuka_style():
    text = """DEF demo()
  ; a comment
  spline  ; lower case is fine in KRL
    SPL {X 0,Y 638.1,Z -0,A -0,B 35.3,C 120}
    SLIN {X 42.6, Y 595.5, Z 60.2, A 1.2, B 34.7, C 120.7, S 2, T 35} WITH $VEL.CP = .25
  ENDSPLINE
END"""
    segs = parse_krl_spline(text)
    assert segs[0] == {"motion": "SPL", "X": 0.0, "Y": 638.1, "Z": 0.0, "A": 0.0, "B": 35.3,
                       "C": 120.0, "vel_m_s": None}
    assert segs[1]["motion"] == "SLIN" and segs[1]["vel_m_s"] == 0.25 and segs[1]["S"] == 2.0


@settings(max_examples=40, deadline=None)
@given(
    data=hnp.arrays(np.float64, st.tuples(st.integers(2, 30), st.just(6)),
                    elements=st.floats(-3000, 3000)),
    vel_exp=st.lists(st.floats(-7, 0.3), min_size=29, max_size=29),
    spl=st.lists(st.booleans(), min_size=29, max_size=29),
)
def test_parse_round_trip_random(tmp_path_factory, data, vel_exp, spl):
    n = data.shape[0]
    pts = data.copy()
    pts[:, 3:] = np.clip(pts[:, 3:], -180, 180)
    vel = 10.0 ** np.array(vel_exp[: n - 1])
    motion = ["SPL" if b else "SLIN" for b in spl[: n - 1]]
    path = tmp_path_factory.mktemp("krl") / "rnd.src"
    text = write_krl_program(path, None, pts, motion, vel, np.zeros(6)).read_text()
    code = "\n".join(ln.split(";", 1)[0] for ln in text.splitlines())
    assert not re.search(r"\d[eE][-+]?\d", code)  # no exponent notation in KRL numbers
    segs = parse_krl_spline(text)
    assert [s["motion"] for s in segs] == motion
    got = np.array([[s[k] for k in "XYZABC"] for s in segs])
    np.testing.assert_allclose(got, pts[1:], atol=5.0001e-5, rtol=0)
    np.testing.assert_allclose([s["vel_m_s"] for s in segs], vel, rtol=1e-6)
