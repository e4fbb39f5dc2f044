"""URScript export: the servoj set-points, put through UR's published DH kinematics and the
script's own set_tcp, trace the planned path at the law's timing, inside a program with the
approach, spindle, lead-in/out and retract in order; bad settings and sizes are refused."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from feedopt.errors import InputError
from feedopt.export import urscript
from feedopt.export.urscript import UrEntryExit, UrSpindle, urscript_text
from feedopt.runner import run_scenario
from tests.conftest import ROOT
from tests.export.test_frames import ur10_flange_fk

quiet = lambda _m: None  # noqa: E731
_Q = r"\[([^\]]*)\]"


@pytest.fixture(scope="module")
def ur_run(tmp_path_factory):
    import yaml

    tmp = tmp_path_factory.mktemp("ur")
    doc = yaml.safe_load((ROOT / "scenarios" / "linear_peripheral.yaml").read_text())
    doc["robot"].update(directory=str(ROOT / "robots" / "ur10"),
                        start_configuration_deg=[0, -90, 90, -90, -90, 0])
    doc["tool"] = str(ROOT / "scenarios" / doc["tool"])
    doc["material"] = str(ROOT / "scenarios" / doc["material"])
    doc["workpiece"].update(position_mm=[-688.0, -163.941, 447.1], rpy_deg=[0.0, 0.0, 90.0])
    doc["path"].update(end_mm=[40.0, -1.0, 0.0], spacing_mm=1.0)
    doc["deflection"]["limit_mm"] = 5.0
    doc["schedule"]["laws"] = ["jerk"]
    p = tmp / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    return run_scenario(p, out_dir=tmp / "out", progress=quiet, report=False)


def _script(run):
    return (run.out_dir / "jerk.script").read_text()


def _tcp(script):
    vals = re.search(r"set_tcp\(p\[([^\]]*)\]\)", script).group(1)
    v = np.array([float(x) for x in vals.split(",")])
    return v[:3] * 1e3, Rotation.from_rotvec(v[3:])


def test_setpoints_trace_the_path_at_the_law_timing(ur_run) -> None:
    script = _script(ur_run)
    q = np.array([[float(x) for x in m.split(",")]
                  for m in re.findall(r"^  sj\(" + _Q + r"\)$", script, re.M)])
    traj = ur_run.laws["jerk"].trajectory
    n = int(np.ceil(traj.duration / 0.008 - 1e-9)) + 1
    assert q.shape == (n, 6)
    tcp_pos, tcp_rot = _tcp(script)
    tips = []
    for row in q:
        pos, rot = ur10_flange_fk(row)
        tips.append(pos + rot.apply(tcp_pos))
    tips = np.array(tips)
    prepared = ur_run.prepared
    s = traj.at(0.008 * np.arange(n)).s
    path = prepared.placement.to_base(prepared.path.evaluate(np.clip(s, 0, prepared.problem.length)
                                                             ).position) * 1e3
    err = np.linalg.norm(tips - path, axis=1)
    assert err.max() < 1e-3  # 7-decimal radians and the joint spline between IK samples
    # the speed between set-points is the law's feed (within the rounding of the set-points)
    speed = np.linalg.norm(np.diff(tips, axis=0), axis=1) / 0.008
    feed = traj.at(0.008 * (np.arange(n - 1) + 0.5)).sdot * 1e3
    assert np.max(np.abs(speed - feed)) < 0.05  # mm/s, at feeds of about 4 mm/s
    # the tool axis (TCP +z) of the set-points is the path's tool axis: base +z here
    last = ur10_flange_fk(q[-1])[1] * tcp_rot
    np.testing.assert_allclose(last.apply([0, 0, 1]), [0, 0, 1], atol=1e-5)


def test_program_order_and_entry(ur_run) -> None:
    lines = [ln.strip() for ln in _script(ur_run).splitlines()]
    assert lines[0] == "def feedopt_jerk():" and lines[-1] == "end"
    first_sj = next(i for i, ln in enumerate(lines) if ln.startswith("sj(["))
    order = ["set_tcp(", "movej(", "popup(", "movel(", "movel(", "sj([", "stopj(", "movel(",
             "movel(", "popup("]
    at = 0
    for stmt in order:
        at = next(i for i in range(at, len(lines)) if lines[i].startswith(stmt)) + 1
    # the second movel ends at the first set-point, at the law's feed (no ramp in mm/s^2)
    lead_in = [ln for ln in lines[:first_sj] if ln.startswith("movel(")][-1]
    assert re.search(_Q, lead_in).group(1) == re.search(_Q, lines[first_sj]).group(1)
    assert float(lead_in.rsplit("v=", 1)[1].rstrip(")")) == pytest.approx(0.00423, rel=0.05)
    # the approach joints are 50 mm above the lead-in point (UR DH + set_tcp)
    tcp_pos, _ = _tcp(_script(ur_run))
    movej = next(ln for ln in lines if ln.startswith("movej("))
    movel_down = next(ln for ln in lines if ln.startswith("movel("))
    tips = []
    for ln in (movej, movel_down):
        pos, rot = ur10_flange_fk(np.array([float(x) for x in
                                            re.search(_Q, ln).group(1).split(",")]))
        tips.append(pos + rot.apply(tcp_pos))
    np.testing.assert_allclose(tips[0] - tips[1], [0, 0, 50], atol=2e-3)
    assert ur_run.summary["laws"]["jerk"]["urscript_cycle_s"] == 0.008


def _args(n=10, **kw):
    q = np.tile(np.deg2rad([0, -90, 90, -90, -90, 0]), (n, 1))
    q[:, 0] += np.linspace(0, 0.01, n)
    entry = UrEntryExit(q_above_lead_in=q[0], q_lead_in=q[0], q_lead_out=q[-1],
                        q_retract=q[-1], lead_speed_m_s=kw.pop("lead_speed_m_s", (0.004, 0.004)))
    args = dict(cycle_s=0.008, tcp_pose=(0, 0, 0.2, np.pi, 0, 0), entry=entry)
    args.update(kw)
    return q, args


@pytest.mark.parametrize(
    ("spindle", "on", "off"),
    [
        (UrSpindle(output=3, run_up_s=2), ["set_standard_digital_out(3, True)", "sleep(2)"],
         ["set_standard_digital_out(3, False)"]),
        (UrSpindle(on_call="spindle_on", off_call="spindle_off"), ["spindle_on()"],
         ["spindle_off()"]),
    ],
)
def test_spindle_output_or_function(spindle, on, off) -> None:
    q, args = _args()
    lines = [ln.strip().split("  #")[0] for ln in
             urscript_text("x", q, spindle=spindle, **args).splitlines()]
    i_on, i_off = lines.index(on[0]), lines.index(off[0])
    assert lines[i_on:i_on + len(on)] == on
    assert lines.index(next(ln for ln in lines if ln.startswith("movej("))) < i_on
    assert i_on < lines.index(next(ln for ln in lines if ln.startswith("sj(["))) < i_off
    assert not any(ln.startswith("popup(") for ln in lines)


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"cycle_s": 0.001}, "servoj time"),
        ({"lead_speed_m_s": (0.0, 0.004)}, "lead-in/out speed"),
        ({"spindle": UrSpindle(output=9)}, "0-7"),
        ({"spindle": UrSpindle(on_call="spin-on")}, "URScript name"),
    ],
)
def test_bad_settings_are_refused(kw, message) -> None:
    q, args = _args(**kw)
    with pytest.raises(InputError, match=message):
        urscript_text("x", q, **args)


def test_too_long_a_trajectory_is_not_written(ur_run, tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(urscript, "MAX_SETPOINTS", 100)
    q, args = _args(n=101)
    with pytest.raises(InputError, match="101 servoj set-points, more than the 100"):
        urscript_text("x", q, **args)


def test_kuka_robots_get_no_urscript(tmp_path, quick_scenario) -> None:
    p = quick_scenario(path__spacing_mm=2.0, schedule__laws=["jerk"])
    result = run_scenario(p, out_dir=tmp_path / "out", progress=quiet, report=False)
    assert "controller 'kuka'" in result.summary["laws"]["jerk"]["urscript_not_written"]
    assert not list((tmp_path / "out").glob("*.script"))
