"""Robot model: loading, forward kinematics against independent chains, Jacobians, Table A.3."""

from __future__ import annotations

import shutil

import numpy as np
import pinocchio as pin
import pytest

from feedopt.errors import InputError
from feedopt.robot.model import forward_kinematics, load_robot, tcp_jacobians
from tests.robot.helpers import KUKA_DIR, TABLE_A3_DEG


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _h(r=None, t=(0, 0, 0)):
    m = np.eye(4)
    m[:3, :3] = np.eye(3) if r is None else r
    m[:3, 3] = t
    return m


def kuka_fk_by_hand(q):
    """KR500-3 TCP from the public dimensions and KUKA axis conventions, without pinocchio."""
    chain = [
        _h(t=(0, 0, 1.045)), _h(_rz(-q[0])), _h(t=(0.5, 0, 0)), _h(_ry(q[1])),
        _h(t=(1.3, 0, 0)), _h(_ry(q[2])), _h(t=(0, 0, -0.055)), _h(_rx(-q[3])),
        _h(t=(1.025, 0, 0)), _h(_ry(q[4])), _h(t=(0.29, 0, 0)), _h(_rx(-q[5])),
        _h(_ry(-np.pi / 2), (0.4, 0, 0)),  # tool: 400 mm along the flange x, TCP z = -x
    ]
    out = np.eye(4)
    for m in chain:
        out = out @ m
    return out


def ur10_fk_dh(q):
    """UR10 flange + 200 mm tool from the published standard DH parameters."""
    d = [0.1273, 0, 0, 0.163941, 0.1157, 0.0922]
    a = [0, -0.612, -0.5723, 0, 0, 0]
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    out = np.eye(4)
    for i in range(6):
        out = out @ _h(_rz(q[i])) @ _h(t=(a[i], 0, d[i])) @ _h(_rx(alpha[i]))
    return out @ _h(_rx(np.pi), (0, 0, 0.2))


def test_kuka_loads_with_thesis_stiffness_and_sources(kuka):
    assert kuka.dof == 6
    np.testing.assert_allclose(kuka.stiffness["cp"] / 1e6, [3.93, 3.46, 2.77, 1.57, 0.24, 0.17])
    np.testing.assert_allclose(kuka.stiffness["dpp"] / 1e6, [2.86, 2.36, 1.67, 0.24, 0.16, 0.14])
    np.testing.assert_allclose(np.rad2deg(kuka.q_lower), [-185, -130, -100, -350, -120, -350])
    np.testing.assert_allclose(np.rad2deg(kuka.q_upper), [185, 20, 144, 350, 120, 350])
    for key in ("kinematics", "joint_limits", "tool", "stiffness", "joint_velocity",
                "joint_acceleration"):
        assert len(kuka.sources[key]) > 10, key
    assert "PLACEHOLDER" in kuka.sources["joint_acceleration"]
    np.testing.assert_allclose(kuka.tcp_offset[:3, 3], [0.4, 0, 0])


def test_kuka_home_pose_tool_down():
    """KUKA HOME with A5 = 90 deg: wrist centre at (1.525, 0, 2.29), tool 690 mm below it."""
    robot = load_robot(KUKA_DIR)
    pose = forward_kinematics(robot, np.deg2rad([0, -90, 90, 0, 90, 0]))
    np.testing.assert_allclose(pose[:3, 3], [1.525, 0.0, 2.29 - 0.69], atol=1e-12)
    np.testing.assert_allclose(pose[:3, 2], [0, 0, 1], atol=1e-12)  # TCP +z up: tool points down


def test_fk_matches_independent_chains(kuka, ur10):
    rng = np.random.default_rng(1)
    for robot, reference in ((kuka, kuka_fk_by_hand), (ur10, ur10_fk_dh)):
        q = rng.uniform(robot.q_lower, robot.q_upper, size=(20, 6)) * 0.5
        poses = forward_kinematics(robot, q)
        assert poses.shape == (20, 4, 4)
        for qi, p in zip(q, poses, strict=True):
            np.testing.assert_allclose(p, reference(qi), atol=1e-12)


@pytest.mark.parametrize("name", ["kuka", "ur10"])
def test_jacobian_equals_finite_difference_fk(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(2)
    q = rng.uniform(robot.q_lower, robot.q_upper, size=(5, 6)) * 0.5
    jac = tcp_jacobians(robot, q)
    h = 1e-6
    for qi, ji in zip(q, jac, strict=True):
        fd = np.empty((6, 6))
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            tp, tm = forward_kinematics(robot, qi + dq), forward_kinematics(robot, qi - dq)
            fd[:3, i] = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
            fd[3:, i] = pin.log3(tp[:3, :3] @ tm[:3, :3].T) / (2 * h)
        np.testing.assert_allclose(ji, fd, atol=1e-6)


def test_table_a3_poses_within_reach_and_stiffness_of_thesis_order(kuka):
    """Thesis 3.6.1/3.6.2: reach 2825 mm; max Cartesian stiffness ~12 MN/m over Table A.3."""
    q = np.deg2rad(TABLE_A3_DEG)
    model, data = kuka.model, kuka.model.createData()
    wrist = model.getFrameId("link_5")
    flange = model.getFrameId("flange")
    k_cp = kuka.stiffness["cp"]
    stiff = []
    for qi in q:
        pin.framesForwardKinematics(model, data, qi)
        wc = data.oMf[wrist].translation
        assert np.hypot(wc[0], wc[1]) < 2.825  # horizontal reach of the wrist centre
        a2 = np.array([0.5 * np.cos(-qi[0]), 0.5 * np.sin(-qi[0]), 1.045])
        assert np.linalg.norm(wc - a2) < 1.3 + np.hypot(1.025, 0.055)
        jac = pin.computeFrameJacobian(model, data, qi, flange, pin.LOCAL_WORLD_ALIGNED)
        kx = np.linalg.inv(jac @ np.diag(1 / k_cp) @ jac.T)  # 6x6 Cartesian stiffness
        stiff.append(np.linalg.eigvalsh(kx[:3, :3]).max())
    # Our model gives ~11.2 MN/m (CP, flange, rotation held): same order as the thesis's 12.
    assert 6e6 < max(stiff) < 24e6


def test_second_robot_loads_the_same_way(ur10):
    assert ur10.name == "ur10" and ur10.dof == 6
    assert set(ur10.stiffness) == {"cp", "dpp"}
    np.testing.assert_allclose(np.rad2deg(ur10.joint_velocity_max), [120, 120, 180, 180, 180, 180])


def _copy_robot(tmp_path):
    target = tmp_path / "robot"
    shutil.copytree(KUKA_DIR, target)
    return target


def test_load_errors_name_the_problem(tmp_path):
    with pytest.raises(InputError, match="no robot.yaml"):
        load_robot(tmp_path)
    d = _copy_robot(tmp_path)
    text = (d / "robot.yaml").read_text()
    (d / "robot.yaml").write_text(text.replace("cp: [3.93, 3.46,", "cp: [3.46,"))
    with pytest.raises(InputError, match="joint_stiffness_mnm_per_rad.cp"):
        load_robot(d)
    (d / "robot.yaml").write_text(text.replace("flange_frame: flange", "flange_frame: nope"))
    with pytest.raises(InputError, match="flange_frame"):
        load_robot(d)
    (d / "robot.yaml").write_text(text.replace("urdf: kr500_3.urdf", "urdf: missing.urdf"))
    with pytest.raises(InputError, match="does not exist"):
        load_robot(d)


def _edit(d, old, new):
    text = (d / "robot.yaml").read_text()
    assert old in text, old
    (d / "robot.yaml").write_text(text.replace(old, new))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("urdf: kr500_3.urdf\n", "", "urdf: required field is missing"),
        ("flange_frame: flange\n", "flange_frame: flange\ntcp_frame: nope\n",
         "exactly one of flange_frame"),
        ("flange_frame: flange\n", "tcp_frame: flange\n", "with tcp_frame the URDF frame is"),
        ("  tcp_xyz_mm: [400.0, 0.0, 0.0]\n  tcp_rpy_deg: [0.0, -90.0, 0.0]\n",
         "", "tcp_xyz_mm and tool.tcp_rpy_deg are required"),
        ("flange_frame: flange\n", "flange_frame: flang\n", "did you mean 'flange'"),
        ("flange_frame: flange\n", "flange_frame: base_link\n", "fixed to the base"),
        ("tool:\n  tcp_xyz_mm: [400.0, 0.0, 0.0]",
         "tool: [1, 2]\nx_tool:\n  tcp_xyz_mm: [400.0, 0.0, 0.0]", "x_tool: unknown field"),
        ("tcp_xyz_mm: [400.0, 0.0, 0.0]", "tcp_xyz_mm: [400.0, 0.0]", "tool.tcp_xyz_mm"),
        ("tcp_xyz_mm: [400.0, 0.0, 0.0]", "tcp_xyz: [400.0, 0.0, 0.0]",
         "tool.tcp_xyz: unknown field; did you mean 'tcp_xyz_mm'"),
        ("joint_stiffness_mnm_per_rad:", "stiffness_typo:",
         "joint_stiffness_mnm_per_rad: required field is missing"),
        ("dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]", "dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0]",
         "dpp: joint joint_a6 is 0; stiffness must be > 0"),
        ("dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]",
         "dpp: [2.86e6, 2.36e6, 1.67e6, 0.24e6, 0.16e6, 0.14e6]", "looks like N m/rad"),
        ("dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]",
         "dpp: [1.0e-12, 2.36, 1.67, 0.24, 0.16, 0.14]", "looks like a compliance"),
        ("dpp: [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]", "dpp: [2.86, 2.36, 1.67, 0.24, 0.16]",
         "joint_stiffness_mnm_per_rad.dpp: expected 6 values, one per joint"),
        ("joint_velocity_deg_s:", "joint_speed_deg_s:",
         "joint_speed_deg_s: unknown field; did you mean 'joint_velocity_deg_s'"),
        ("values: [84.0, 79.0, 73.0, 76.0, 74.0, 123.0]\n  source: >-\n    CONSERVATIVE",
         "values: [84.0, 79.0, 73.0, 76.0, 74.0, -1]\n  source: >-\n    CONSERVATIVE",
         "joint_acceleration_deg_s2.values.5: Input should be greater than 0"),
        ("  type: kuka\n", "  type: staubli\n",
         "controller.type: Input should be 'kuka', 'ur', 'abb'"),
        ("    offset_deg: [0, 0, 0, 0, 0, 0]", "    offset_deg: [0, -90, 90]",
         "controller.axes.offset_deg: expected 6 values"),
        ("    sign: [1, 1, 1, 1, 1, 1]", "    sign: [1, 1, 2, 1, 1, 1]",
         "controller.axes.sign.2: Input should be 1 or -1"),
        ("warnings:\n  - >-", "warning:\n  - >-",
         "warning: unknown field; did you mean 'warnings'"),
        ("warnings:\n  - >-", "warnings:\n  - 3\n  - >-",
         "warnings.0: Input should be a valid string"),
        ("name: kuka_kr500_3\n", "name: kuka_kr500_3\nmade_up_key: 1\n",
         "made_up_key: unknown field"),
    ],
)
def test_each_load_phase_names_its_field(tmp_path, old, new, message):
    d = _copy_robot(tmp_path)
    _edit(d, old, new)
    with pytest.raises(InputError, match=message):
        load_robot(d)


def test_loads_with_an_existing_tcp_frame(tmp_path):
    d = _copy_robot(tmp_path)
    _edit(d, "flange_frame: flange\n", "tcp_frame: flange\n")
    _edit(d, "  tcp_xyz_mm: [400.0, 0.0, 0.0]\n  tcp_rpy_deg: [0.0, -90.0, 0.0]\n", "")
    robot = load_robot(d)
    np.testing.assert_array_equal(robot.tcp_offset, np.eye(4))
    assert robot.sources["tool"].startswith("Assumed")  # tool.source is kept
    kuka = load_robot(KUKA_DIR)
    q = np.deg2rad(TABLE_A3_DEG)
    flange = forward_kinematics(robot, q)
    np.testing.assert_allclose(forward_kinematics(kuka, q), flange @ kuka.tcp_offset, atol=1e-12)


def test_units_and_defaults_of_the_loaded_model(kuka, ur10):
    np.testing.assert_array_equal(kuka.stiffness["dpp"],
                                  np.array([2.86, 2.36, 1.67, 0.24, 0.16, 0.14]) * 1e6)
    np.testing.assert_array_equal(kuka.joint_velocity_max,
                                  np.array([84.0, 79.0, 73.0, 76.0, 74.0, 123.0]) * (np.pi / 180))
    np.testing.assert_array_equal(kuka.tcp_offset[:3, 3], [0.4, 0.0, 0.0])  # 400 mm * MM
    # tcp_rpy_deg [0, -90, 0]: TCP z = -flange x; UR10 [180, 0, 0]: TCP z = -flange z
    np.testing.assert_allclose(kuka.tcp_offset[:3, 2], [-1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(ur10.tcp_offset[:3, 2], [0, 0, -1], atol=1e-15)
    assert list(kuka.sources) == ["kinematics", "joint_limits", "tool", "stiffness",
                                  "joint_velocity", "joint_acceleration"]
    assert kuka.controller == "kuka" and ur10.controller == "ur"
    assert kuka.joint_names == tuple(f"joint_a{i}" for i in range(1, 7))
    assert all("\n" not in w and "  " not in w for w in kuka.data_warnings)
