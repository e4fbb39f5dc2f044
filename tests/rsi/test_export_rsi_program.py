"""The RSI host files of the default run (feedopt/export/rsi_program.py), read back without
feedopt's readers: corrections + the stated start pose give the trajectory, the host program
has the RSI calls in order with limits covering the corrections, the approach is above the
start, the Ethernet configuration has the elements the streamer uses."""

import json
import re
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt.export.frames import APPROACH_MM
from feedopt.export.job import EXPORTERS
from feedopt.export.rsi_program import early_check, ethernet_config_xml, host_program
from feedopt.robot.model import forward_kinematics, load_robot
from feedopt.rsi.corrections import CorrectionMode, plan_from_table
from tests.rsi.conftest import ROOT


def _numbers(path) -> tuple[list[str], np.ndarray]:
    lines = path.read_text().splitlines()
    comments = [line for line in lines if line.startswith("#")]
    data = [line for line in lines if not line.startswith("#")][1:]
    return comments, np.array([[float(v) for v in line.split(",")] for line in data])


def test_registered() -> None:
    assert EXPORTERS["rsi_host"].file_pattern.startswith("{law}_rsi.csv")


def test_corrections_plus_start_pose_are_the_trajectory(default_run) -> None:
    _, traj = _numbers(default_run / "jerk.csv")
    comments, corr = _numbers(default_run / "jerk_rsi.csv")
    assert any("mode: absolute (RSI_ON(#ABSOLUTE" in c for c in comments)
    start_line = next(c for c in comments if c.startswith("# pose at RSI_ON"))
    start = np.array([float(v) for v in re.findall(r"[XYZABC] (\S+?)(?:,|$)", start_line)])
    np.testing.assert_array_equal(corr[:, 0], traj[:, 0])
    np.testing.assert_array_equal(start, traj[0, 1:7])  # the same poses, bit for bit
    np.testing.assert_allclose(start + corr[:, 1:], traj[:, 1:7], atol=1e-9)
    summary = json.loads((default_run / "summary.json").read_text())["laws"]["jerk"]
    assert summary["rsi_corrections"] == "jerk_rsi.csv" and summary["rsi_mode"] == "absolute"
    steps = np.linalg.norm(np.diff(traj[:, 1:4], axis=0), axis=1)
    assert summary["rsi_max_step_mm"] == pytest.approx(steps.max(), rel=1e-9)


def test_host_program(default_run) -> None:
    src = (default_run / "jerk_rsi.src").read_text()
    code = [line.split(";", 1)[0].strip() for line in src.splitlines()]
    code = [c for c in code if c]
    assert code[0] == "DEF jerk_rsi( )" and code[-1] == "END"
    # $TOOL is the TOOL_DATA the header states (the frames every export carries)
    tool_data = re.search(r"^; TOOL_DATA = (\{.*?\})", src, re.M).group(1)
    assert f"$TOOL = {tool_data}" in code
    order = ["BAS (#INITMOV,0 )", "$LOAD = {M -1", "PTP {", "HALT", "LIN {",
             'RSI_CREATE("feedopt_rsi", CONTID, TRUE)', "RSI_SETPUBLICPAR",
             "RSI_ON(#ABSOLUTE, #IPO_FAST)", "RSI_MOVECORR()", "RSI_OFF()",
             "RSI_DELETE(CONTID)", "LIN {", "WAIT SEC 0", "HALT"]
    # the native KRL program's spindle hooks (its default: HALT for the operator)
    from feedopt.export.krl import SpindleControl

    hooks = SpindleControl().lines(True) + SpindleControl().lines(False)
    assert hooks and all(ln in src.splitlines() for ln in hooks)
    at = -1
    for needle in order:  # each after the one before
        at = next(i for i in range(at + 1, len(code)) if needle in code[i])
    for i, c in enumerate(code):  # every RSI call's result is checked
        if c.startswith("ret = "):
            assert code[i + 1:i + 4] == ["IF (ret <> RSIOK) THEN", "HALT", "ENDIF"]
    # the correction limits cover every correction of the trajectory
    _, corr = _numbers(default_run / "jerk_rsi.csv")
    limits = {(o, p): float(v) for o, p, v in re.findall(
        r'RSI_SETPUBLICPAR\(CONTID, "(\w+)", "(\w+)", (\S+)\)', src)}
    for i, axis in enumerate("XYZ"):
        assert limits[("PosCorr_1", f"LowerLim{axis}")] <= corr[:, 1 + i].min()
        assert limits[("PosCorr_1", f"UpperLim{axis}")] >= corr[:, 1 + i].max()
    assert limits[("PosCorrMon_1", "MaxTrans")] >= np.linalg.norm(corr[:, 1:4], axis=1).max()
    assert limits[("PosCorr_1", "MaxRotAngle")] >= np.abs(corr[:, 4:]).max()


def test_entry_and_exit_are_the_native_program_s(default_run) -> None:
    """PTP above the lead-in point, LIN down, LIN along the start tangent to the pose at
    RSI_ON; after RSI_OFF the lead-out along the end tangent and the retract up the tool
    axis: against FK of the PTP's axes and the trajectory's own rows."""
    from feedopt.export.frames import LEAD_IN_MM, LEAD_OUT_MM

    src = (default_run / "jerk_rsi.src").read_text()
    ptp = re.search(r"^PTP \{(.*)\}$", src, re.M).group(1)
    q = np.deg2rad([float(v.split()[1]) for v in ptp.split(",")])
    _, traj = _numbers(default_run / "jerk.csv")
    robot = load_robot(ROOT / "robots" / "kuka_kr500_3")
    start = forward_kinematics(robot, np.deg2rad(traj[0, 7:13]))
    above = forward_kinematics(robot, q)
    lins = [[float(v.split()[1]) for v in m.split(",")]
            for m in re.findall(r"^LIN \{(.*)\}$", src, re.M)]
    assert len(lins) == 4  # down, lead-in, lead-out, retract
    t0 = traj[5, 1:4] - traj[0, 1:4]
    t0 /= np.linalg.norm(t0)
    lead_in = traj[0, 1:4] - LEAD_IN_MM * t0
    np.testing.assert_allclose(lins[0][:3], lead_in, atol=2e-3)
    np.testing.assert_allclose(lins[1], traj[0, 1:7], atol=1e-4)  # the pose at RSI_ON
    # 4-decimal degrees in the program: ~1e-3 mm at the 2.8 m reach
    want = lead_in + APPROACH_MM * start[:3, 2]
    assert np.linalg.norm(above[:3, 3] * 1e3 - want) < 3e-3
    np.testing.assert_allclose(above[:3, :3], start[:3, :3], atol=1e-5)
    end = forward_kinematics(robot, np.deg2rad(traj[-1, 7:13]))
    t1 = traj[-1, 1:4] - traj[-6, 1:4]
    t1 /= np.linalg.norm(t1)
    lead_out = traj[-1, 1:4] + LEAD_OUT_MM * t1
    np.testing.assert_allclose(lins[2][:3], lead_out, atol=2e-3)
    np.testing.assert_allclose(lins[3][:3], lead_out + APPROACH_MM * end[:3, 2] * 1.0,
                               atol=2e-3)


def test_ethernet_configuration(default_run) -> None:
    root = ET.fromstring((default_run / "feedopt_rsi_ethernet.xml").read_text())
    assert root.findtext("CONFIG/PORT") == "49152" and root.findtext("CONFIG/SENTYPE") == "ImFree"
    send = {e.get("TAG") for e in root.iterfind("SEND/ELEMENTS/ELEMENT")}
    assert {"DEF_RIst", "DEF_RSol", "DEF_Delay"} <= send
    recv = {e.get("TAG"): e for e in root.iterfind("RECEIVE/ELEMENTS/ELEMENT")}
    for i, a in enumerate("XYZABC", start=1):
        el = recv[f"RKorr.{a}"]
        assert (el.get("INDX"), el.get("HOLDON"), el.get("TYPE")) == (str(i), "1", "DOUBLE")
    assert (recv["Stop"].get("TYPE"), recv["Stop"].get("HOLDON")) == ("BOOL", "0")
    relative = ET.fromstring(ethernet_config_xml(mode=CorrectionMode.RELATIVE))
    assert {e.get("HOLDON") for e in relative.iterfind("RECEIVE/ELEMENTS/ELEMENT")
            if e.get("TAG").startswith("RKorr")} == {"0"}


def test_twelve_ms_cycle_uses_ipo(default_table) -> None:
    from feedopt.export.rsi import RsiTable

    plan = plan_from_table(RsiTable.from_matrix(default_table.as_matrix()[:300:3]), 0.012)
    text = host_program("jerk", plan, entry=None, retract_mm=np.array([0.0, 0.0, 50.0]))
    assert "RSI_ON(#ABSOLUTE, #IPO)" in text and "#IPO_FAST" not in text
    assert "PTP {A1 9.7276" in text  # no approach pose: the start joints
    assert "LIN_REL {X 0, Y 0, Z 50} #BASE" in text


def test_only_for_kuka_controllers() -> None:
    blocker = early_check(SimpleNamespace(controller="ur", name="ur10"), None)
    assert blocker is not None and not blocker.warn and "KUKA" in blocker.reason
    stated = SimpleNamespace(stated=True)
    assert early_check(SimpleNamespace(controller="kuka", name="kr500", dof=6,
                                       axis_convention=stated), None) is None
    # a KUKA robot whose robot.yaml states no axis convention: no program with URDF angles
    unstated = early_check(SimpleNamespace(controller="kuka", name="kr210", dof=6,
                                           axis_convention=SimpleNamespace(stated=False)), None)
    assert unstated is not None and unstated.warn and "controller.axes" in unstated.reason
    track = early_check(SimpleNamespace(controller="kuka", name="kr120_track", dof=7,
                                        joint_names=("joint_e1", *(f"a{i}" for i in range(6))),
                                        axis_convention=stated), None)
    assert track is not None and "has 7 joints (joint_e1" in track.reason
