"""KRL export: the .src + .dat pair parses back to the points, velocities and frames given,
has the cell structure a KRC4 needs (INI, frames from the .dat, approach, spindle, lead-in,
spline, lead-out, retract, spindle off), refuses what KUKA's limits refuse, and the run's
program never asks for a $VEL.CP above the feed bound."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from feedopt.errors import InputError
from feedopt.export import krl
from feedopt.export.frames import EntryExit, cell_frames
from feedopt.export.krl import (
    MIN_SEGMENT_MM,
    KeyPoints,
    KrlSpeeds,
    SpindleControl,
    parse_krl_dat,
    parse_krl_spline,
    write_krl_program,
)
from feedopt.robot.model import load_robot
from tests.conftest import ROOT

FRAMES = cell_frames(load_robot(ROOT / "robots" / "kuka_kr500_3"))


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


def _entry(pts):
    """Lead-in 10 mm before the start along the first line, lead-out 10 mm on, 50 mm up."""
    t0 = (pts[1, :3] - pts[0, :3]) / np.linalg.norm(pts[1, :3] - pts[0, :3])
    t1 = (pts[-1, :3] - pts[-2, :3]) / np.linalg.norm(pts[-1, :3] - pts[-2, :3])
    lead_in = np.concatenate([pts[0, :3] - 10 * t0, pts[0, 3:]])
    lead_out = np.concatenate([pts[-1, :3] + 10 * t1, pts[-1, 3:]])
    up = np.array([0, 0, 50, 0, 0, 0])
    q = np.deg2rad([10, -75, 95, 0, 25, -5])
    return EntryExit(above_lead_in=lead_in + up, lead_in=lead_in, lead_out=lead_out,
                     retract=lead_out + up, q_above_lead_in=q, q_lead_in=q, q_lead_out=q,
                     q_retract=q, approach_axes_deg=np.rad2deg(q))


def _write(tmp_path, name="thesis", **kw):
    pts, motion, vel = _triangle_key_points()
    args = dict(points=pts, motion=motion, velocity_m_s=vel,
                start_axis_deg=[10, -80, 95, 0, 30, -5], comments=["scenario: triangle_slot"],
                frames=FRAMES, entry=_entry(pts))
    args.update(kw)
    keys = KeyPoints(**{f.name: args.pop(f.name) for f in dataclasses.fields(KeyPoints)})
    speeds = KrlSpeeds(**{f.name: args.pop(f.name) for f in dataclasses.fields(KrlSpeeds)
                          if f.name in args})
    return write_krl_program(tmp_path / f"{name}.src", name, keys, speeds=speeds, **args)[0]


def _code(path):
    """Code lines of a KRL file without comments and blank lines."""
    code = [ln.split(";", 1)[0].strip() for ln in path.read_text().splitlines()]
    return [c for c in code if c]


def test_program_parses_back_to_the_inputs(tmp_path):
    pts, motion, vel = _triangle_key_points()
    entry = _entry(pts)
    text = _write(tmp_path).read_text()
    segs = parse_krl_spline(text)
    # the block: lead-in (to the path start), the key points, lead-out
    assert [s["motion"] for s in segs] == ["SLIN", *motion, "SLIN"]
    got = np.array([[s[k] for k in "XYZABC"] for s in segs])
    np.testing.assert_allclose(got, np.vstack([pts, entry.lead_out]), atol=5e-5, rtol=0)
    np.testing.assert_allclose([s["vel_m_s"] for s in segs], [vel[0], *vel, vel[-1]],
                               rtol=1e-6)
    # the lead-in and the first line are collinear (no stop at the path start)
    d_in, d_line = pts[0, :3] - entry.lead_in[:3], pts[1, :3] - pts[0, :3]
    assert np.linalg.norm(np.cross(d_in, d_line)) < 1e-9 * np.linalg.norm(d_line) * 10


def test_dat_holds_the_frames_load_and_approach(tmp_path):
    _write(tmp_path)
    dat_path = tmp_path / "thesis.dat"
    assert _code(dat_path)[0] == "DEFDAT thesis PUBLIC" and _code(dat_path)[-1] == "ENDDAT"
    dat = parse_krl_dat(dat_path.read_text())
    assert dat["FO_TOOL"]["type"] == "FRAME" and dat["FO_BASE"]["type"] == "FRAME"
    assert [dat["FO_TOOL"][k] for k in "XYZABC"] == [0, 0, 400, 180, 0, 180]
    assert [dat["FO_BASE"][k] for k in "XYZABC"] == [0] * 6
    assert dat["FO_LOAD"]["type"] == "LOAD" and dat["FO_LOAD"]["M"] == -1.0
    assert set(dat["FO_LOAD"]["CM"]) == set("XYZABC") and set(dat["FO_LOAD"]["J"]) == set("XYZ")
    np.testing.assert_allclose([dat["FO_APPROACH"][f"A{i}"] for i in range(1, 7)],
                               [10, -75, 95, 0, 25, -5], atol=1e-4)
    assert "PLACEHOLDER" in dat_path.read_text()


def test_program_structure(tmp_path):
    code = _code(_write(tmp_path))
    assert code[0] == "DEF thesis( )" and code[-1] == "END"
    order = ["BAS (#INITMOV,0 )", "$TOOL = FO_TOOL", "$BASE = FO_BASE", "$LOAD = FO_LOAD",
             "PTP FO_APPROACH", "HALT", "SPLINE", "ENDSPLINE", "HALT", "END"]
    pos, at = [], 0
    for stmt in order:
        at = code.index(stmt, at)
        pos.append(at)
        at += 1
    assert pos == sorted(pos)
    i_spline, i_end = code.index("SPLINE"), code.index("ENDSPLINE")
    # the SLIN down to the lead-in point between the spindle start and the block, and the
    # retract after it, at the approach speed; every spline segment has its $VEL.CP
    assert code[i_spline - 1].startswith("SLIN {") and code[i_spline - 1].endswith("0.02")
    assert code[i_end + 1].startswith("SLIN {") and code[i_end + 1].endswith("0.02")
    assert all("WITH $VEL.CP = " in c for c in code[i_spline + 1:i_end])
    assert any(c.startswith("$ACC.CP = ") for c in code[:i_spline])
    # each spindle switch waits for the robot (advance-run stop) first
    for i, c in enumerate(code):
        if c == "HALT":
            assert code[i - 1] == "WAIT SEC 0"


@pytest.mark.parametrize(
    ("spindle", "on", "off"),
    [
        (SpindleControl(output=7, run_up_s=4), ["$OUT[7] = TRUE", "WAIT SEC 4"],
         ["$OUT[7] = FALSE"]),
        (SpindleControl(on_call="MY_SPINDLE_ON", off_call="MY_SPINDLE_OFF"),
         ["MY_SPINDLE_ON()"], ["MY_SPINDLE_OFF()"]),
    ],
)
def test_spindle_output_or_user_macro(tmp_path, spindle, on, off):
    code = _code(_write(tmp_path, spindle=spindle))
    i_ptp, i_spline, i_end = (code.index("PTP FO_APPROACH"), code.index("SPLINE"),
                              code.index("ENDSPLINE"))
    i_on = code.index(on[0])
    assert i_ptp < i_on < i_spline and code[i_on - 1] == "WAIT SEC 0"
    assert code[i_on:i_on + len(on)] == on
    i_off = code.index(off[0])
    assert i_off > i_end + 1 and code[i_off - 1] == "WAIT SEC 0"
    assert "HALT" not in code


@pytest.mark.parametrize(
    ("spindle", "message"),
    [
        (SpindleControl(output=0), "1-8192"),
        (SpindleControl(on_call="my-macro"), "KRL name"),
        (SpindleControl(output=3, run_up_s=-1.0), "run_up_s"),
    ],
)
def test_bad_spindle_settings_are_refused(tmp_path, spindle, message):
    with pytest.raises(InputError, match=message):
        _write(tmp_path, spindle=spindle)
    assert not list(tmp_path.iterdir())


def test_kuka_limits_are_refused_and_nothing_is_written(tmp_path, monkeypatch):
    pts, motion, vel = _triangle_key_points()
    with pytest.raises(InputError, match=r"\[0.001, 2.0\] m/s"):
        _write(tmp_path, velocity_m_s=np.where(np.arange(7) == 3, 0.0005, vel))
    with pytest.raises(InputError, match=r"velocity to point 2 is 2.5"):
        _write(tmp_path, velocity_m_s=np.where(np.arange(7) == 1, 2.5, vel))
    with pytest.raises(InputError, match="approach velocity"):
        _write(tmp_path, approach_vel_m_s=3.0)
    short = pts.copy()
    short[4, :3] = short[3, :3] + [0.004, 0, 0]
    with pytest.raises(InputError, match="segment to point 4 is 0.004 mm"):
        _write(tmp_path, points=short)
    monkeypatch.setattr(krl, "MAX_SEGMENTS", 8)  # 7 segments + lead-in + lead-out = 9
    with pytest.raises(InputError, match="9 segments; KSS 8.x allows 8"):
        _write(tmp_path)
    assert not list(tmp_path.iterdir())


def test_comment_says_what_the_controller_does_differently(tmp_path):
    text = _write(tmp_path).read_text()
    comments = "\n".join(ln for ln in text.splitlines() if ln.lstrip().startswith(";"))
    for phrase in ("own velocity profile", "acceleration and jerk", "3.7", "SPL segments",
                   "open loop", "scenario: triangle_slot"):
        assert phrase in comments


def test_velocity_per_point_including_the_start_is_accepted(tmp_path):
    pts, motion, vel = _triangle_key_points()
    path = _write(tmp_path, velocity_m_s=np.concatenate([[9.9], vel]), entry=None)
    np.testing.assert_allclose([s["vel_m_s"] for s in parse_krl_spline(path.read_text())], vel,
                               rtol=1e-6)
    code = _code(path)  # without an entry: PTP straight to the start joints, from the .dat
    outside = code[:code.index("SPLINE")] + code[code.index("ENDSPLINE"):]
    assert "PTP FO_APPROACH" in code and not any(c.startswith("SLIN") for c in outside)
    dat = parse_krl_dat((tmp_path / "thesis.dat").read_text())
    assert [dat["FO_APPROACH"][f"A{i}"] for i in range(1, 7)] == [10, -80, 95, 0, 30, -5]


def test_successive_slin_is_flagged(tmp_path):
    path = _write(tmp_path, motion=["SLIN"] * 7)
    assert "6 pair(s) of successive SLIN" in path.read_text()


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"motion": ["SLIN"] * 6}, "one of .* per point after the first"),
        ({"motion": ["SLIN", "LIN"] + ["SPL"] * 5}, "point 2 is 'LIN'"),
        ({"velocity_m_s": np.zeros(7)}, "velocity to point 1 is 0.0"),
        ({"velocity_m_s": np.full(7, np.nan)}, "velocity to point 1 is nan"),
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
        write_krl_program(tmp_path / "a.src", "b", KeyPoints(pts, motion, vel, np.zeros(6)),
                          frames=FRAMES)
    assert not (tmp_path / "a.src").exists()
    src, dat = write_krl_program(tmp_path / "constant.src", None,
                                 KeyPoints(pts, motion, vel, np.zeros(6)), frames=FRAMES)
    assert src.read_text().startswith("DEF constant( )")
    assert dat.name == "constant.dat" and dat.read_text().startswith("DEFDAT constant PUBLIC")


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
    vel_exp=st.lists(st.floats(-3, 0.3), min_size=29, max_size=29),
    spl=st.lists(st.booleans(), min_size=29, max_size=29),
)
def test_parse_round_trip_random(tmp_path_factory, data, vel_exp, spl):
    n = data.shape[0]
    pts = data.copy()
    pts[:, 3:] = np.clip(pts[:, 3:], -180, 180)
    pts[:, 0] += 5.0 * np.arange(n)  # points apart (hypothesis likes repeated values)
    assume(np.linalg.norm(np.diff(pts[:, :3], axis=0), axis=1).min() >= MIN_SEGMENT_MM)
    vel = 10.0 ** np.array(vel_exp[: n - 1])
    motion = ["SPL" if b else "SLIN" for b in spl[: n - 1]]
    path = tmp_path_factory.mktemp("krl") / "rnd.src"
    text = write_krl_program(path, None, KeyPoints(pts, motion, vel, np.zeros(6)),
                             frames=FRAMES)[0].read_text()
    code = "\n".join(ln.split(";", 1)[0] for ln in text.splitlines())
    assert not re.search(r"\d[eE][-+]?\d", code)  # no exponent notation in KRL numbers
    segs = parse_krl_spline(text)
    assert [s["motion"] for s in segs] == motion
    got = np.array([[s[k] for k in "XYZABC"] for s in segs])
    np.testing.assert_allclose(got, pts[1:], atol=5.0001e-5, rtol=0)
    np.testing.assert_allclose([s["vel_m_s"] for s in segs], vel, rtol=1e-6)


@pytest.fixture(scope="module")
def triangle_run(thesis_triangle_run):
    return thesis_triangle_run


def test_run_writes_a_program_whose_feeds_keep_the_bound(triangle_run):
    out = triangle_run.out_dir
    assert triangle_run.summary["laws"]["thesis"]["krl_data"] == "thesis.dat"
    segs = parse_krl_spline((out / "thesis.src").read_text())
    pts = np.array([[s[k] for k in "XYZ"] for s in segs])
    # arc length of every point: nearest point of the path in the base frame, 0.01 mm apart
    prepared = triangle_run.prepared
    problem = prepared.problem
    s_fine = np.linspace(0.0, problem.length, int(problem.length / 1e-5) + 1)
    path_mm = prepared.placement.to_base(prepared.path.evaluate(s_fine).position) * 1e3
    d = np.linalg.norm(pts[:, None, :] - path_mm[None, :, :], axis=2)
    s_pt = s_fine[d.argmin(axis=1)]
    inner = slice(0, len(segs) - 1)  # the lead-in ends at the start, the lead-out leaves
    assert d[inner].min(axis=1).max() < 0.01
    assert s_pt[0] == 0 and s_pt[-2] == pytest.approx(problem.length)
    vmax_mm_s = problem.v_max * 1e3
    for k in range(1, len(segs) - 1):  # the bound at the samples the segment covers
        covered = (problem.s >= s_pt[k - 1] - 1e-5) & (problem.s <= s_pt[k] + 1e-5)
        assert covered.any()
        assert segs[k]["vel_m_s"] * 1e3 <= vmax_mm_s[covered].min() * (1 + 1e-6)
    idx = np.searchsorted(problem.s, s_pt)
    # the thesis law's line feeds are what the SLINs ask for (one feed per line, thesis 3.5)
    feed = triangle_run.laws["thesis"].verification.feed * 1e3
    for k in range(2, len(segs) - 1):
        if segs[k]["motion"] == "SLIN":
            mid = (idx[k - 1] + idx[k]) // 2
            assert segs[k]["vel_m_s"] * 1e3 == pytest.approx(feed[mid], rel=0.02)


def test_program_is_refused_not_written_when_the_approach_is_out_of_reach(triangle_run,
                                                                          tmp_path,
                                                                          monkeypatch):
    from feedopt.export import frames

    monkeypatch.setattr(frames, "APPROACH_MM", 5000.0)  # 5 m above the part: out of reach
    prepared = triangle_run.prepared
    res = triangle_run.laws["thesis"]
    from feedopt.export.job import ExportJob, controller_samples

    job = ExportJob(
        law="thesis", scenario_name="t", trajectory=res.trajectory,
        verification=res.verification, problem=prepared.problem, robot=prepared.robot,
        q_of_s=prepared.q_of_s,
        path_in_base=lambda s: prepared.placement.to_base(prepared.path.evaluate(s).position),
        samples=controller_samples(res.trajectory, 0.004, prepared.q_of_s,
                                   prepared.problem.length),
        cycle=0.004, limit_mm=0.29, native_program=True)
    entry = krl.export_krl(job, tmp_path)
    assert entry["krl_program"] is None and "no KRL program" in entry["krl_not_written"]
    assert not list(tmp_path.iterdir())
