"""Grid specifications: values, fields, components, overrides, and refusals naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.sweep.grid import apply_point, parse_axes, parse_grid
from feedopt.sweep.plots import best_over_others

RAW = {
    "name": "t",
    "workpiece": {"position_mm": [1750.0, -300.0, 800.0]},
    "cut": {"type": "slot", "axial_depth_mm": 1.5, "spindle_rpm": 2500},
    "path": {"generator": "triangle_wave"},
}
ROBOT = {"urdf": "r.urdf", "tool": {"tcp_xyz_mm": [400.0, 0.0, 0.0]},
         "joint_stiffness_mnm_per_rad": {"dpp": [2.86, 2.36, 1.67, 0.24, 0.16, 0.14]}}


def test_ranges_are_decimal_and_include_both_ends():
    (axis,) = parse_axes("cut.axial_depth_mm=0.1:0.3:0.1", RAW, ROBOT)
    # 0.1 + 2 * 0.1 is 0.30000000000000004 in binary floating point; the grid says 0.3
    assert axis.values == (0.1, 0.2, 0.3)
    (axis,) = parse_axes("cut.spindle_rpm=1000:2000:300", RAW, ROBOT)
    assert axis.values == (1000.0, 1300.0, 1600.0, 1900.0)  # 2000 is not on the grid
    (axis,) = parse_axes("deflection.limit_mm=0.29;0.2; 0.25", RAW, ROBOT)
    assert axis.values == (0.29, 0.2, 0.25)  # in the order written
    (axis,) = parse_axes("path.waves=1:3:1", RAW, ROBOT)
    assert axis.values == (1, 2, 3) and all(type(v) is int for v in axis.values)


def test_vector_components_are_axes_of_their_own():
    axes = parse_axes("workpiece.position_mm=x:1600:1700:50,z:900", RAW, ROBOT)
    assert [(a.name, a.component, a.values) for a in axes] == [
        ("workpiece.position_mm.x", 0, (1600.0, 1650.0, 1700.0)),
        ("workpiece.position_mm.z", 2, (900.0,))]
    grid = parse_grid(["workpiece.position_mm=x:1600:1700:50,z:900",
                       "cut.axial_depth_mm=1;2"], RAW, ROBOT)
    assert grid.shape == (3, 1, 2) and grid.size == 6
    assert list(grid.points())[:3] == [(1600.0, 900.0, 1.0), (1600.0, 900.0, 2.0),
                                       (1650.0, 900.0, 1.0)]


def test_overrides_change_a_copy_of_the_raw_data():
    grid = parse_grid(["workpiece.position_mm=x:1600,z:900", "limits.spindle_power_w=5000",
                       "workpiece.rpy_deg=z:90", "robot_yaml.tool.tcp_xyz_mm=x:300",
                       "schedule.law_options.convex.max_gridpoints=500"], RAW, ROBOT)
    raw, robot = apply_point(RAW, ROBOT, grid.axes, next(grid.points()))
    assert raw["workpiece"]["position_mm"] == [1600.0, -300.0, 900.0]
    assert raw["limits"] == {"spindle_power_w": 5000.0}  # a section the file does not have
    assert raw["workpiece"]["rpy_deg"] == [0.0, 0.0, 90.0]  # from the schema's default
    assert raw["schedule"]["law_options"]["convex"]["max_gridpoints"] == 500
    assert robot["tool"]["tcp_xyz_mm"] == [300.0, 0.0, 0.0]
    assert RAW["workpiece"]["position_mm"] == [1750.0, -300.0, 800.0]  # untouched
    assert ROBOT["tool"]["tcp_xyz_mm"] == [400.0, 0.0, 0.0]
    raw, robot = apply_point(RAW, ROBOT, grid.axes[:1], [1700.0])
    assert robot is None  # no robot.yaml axis: the robot directory is used as it is


@pytest.mark.parametrize("spec, words", [
    ("workpiece.positon_mm=x:1:2:1", ["workpiece.positon_mm", "did you mean 'position_mm'"]),
    ("workpiece.position_mm=1500:1900:50", ["workpiece.position_mm", "name the component"]),
    ("workpiece.position_mm=q:1:2:1", ["workpiece.position_mm", "no component 'q'"]),
    ("path.blend=1;2", ["path.blend", "not a numeric field"]),
    ("cut=1", ["--grid cut", "is a section"]),
    ("cut.axial_depth_mm=2:1:1", ["cut.axial_depth_mm", "below lo"]),
    ("cut.axial_depth_mm=1:2:0", ["cut.axial_depth_mm", "step 0 must be positive"]),
    ("cut.axial_depth_mm=1:2", ["cut.axial_depth_mm", "not lo:hi:step"]),
    ("cut.axial_depth_mm=1;abc", ["cut.axial_depth_mm", "'abc' is not a decimal number"]),
    ("cut.axial_depth_mm=1;1", ["cut.axial_depth_mm", "repeats a value"]),
    ("path.waves=1:3:0.5", ["path.waves", "integer field"]),
    ("schedule.law_options.convx.a=1", ["schedule.law_options", "did you mean 'convex'"]),
    ("robot_yaml.tool.tcp_xyz=x:1", ["robot_yaml.tool.tcp_xyz", "did you mean 'tcp_xyz_mm'"]),
    ("cut.axial_depth_mm", ["--grid cut.axial_depth_mm", "FIELD=VALUES"]),
    ("workpiece.position_mm=x:1:100000:1", ["workpiece.position_mm.x", "more than 10000"]),
])
def test_malformed_specs_are_refused_naming_the_field(spec, words):
    with pytest.raises(InputError) as err:
        parse_grid([spec], RAW, ROBOT)
    for w in words:
        assert w in str(err.value)


def test_too_many_points_are_refused():
    with pytest.raises(InputError, match="points, more than 100000"):
        parse_grid(["workpiece.position_mm=x:1:400:1,y:1:400:1"], RAW, ROBOT)


@pytest.mark.parametrize("spec, words", [
    ("workpiece.positon_mm=x:1700", ["--grid workpiece.positon_mm", "did you mean"]),
    # valid syntax, but the schema refuses the value: validated like the user's own file
    ("cut.axial_depth_mm=-1:1:1", ["--grid cut.axial_depth_mm=-1.0", "cut.axial_depth_mm",
                                   "greater than 0"]),
    ("robot_yaml.joint_stiffness_mnm_per_rad.dpp=0:-1;1",
     ["--grid robot_yaml.joint_stiffness_mnm_per_rad.dpp.0=-1.0", "must be > 0",
      "kuka_kr500_3/robot.yaml"]),
])
def test_the_command_exits_2_naming_the_field_and_writes_nothing(spec, words, quick_scenario,
                                                                 tmp_path, capsys):
    scenario = quick_scenario("triangle_slot")
    out = tmp_path / "sweep"
    code = main(["sweep", str(scenario), "--grid", spec, "--out", str(out), "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("feedopt sweep: error: ")
    for w in words:
        assert w in err
    assert "/tmp/feedopt-sweep-" not in err  # the user's files are named, not the copies
    assert not out.exists()


def test_best_over_other_axes_is_the_smallest_value_per_cell():
    rng = np.random.default_rng(3)
    values = rng.uniform(1, 2, (3, 4, 5))
    values[rng.uniform(size=values.shape) < 0.3] = np.nan
    values[1, :, 2] = np.nan  # a cell of axes (0, 2) with no feasible point
    reduced = best_over_others(values, (0, 2))
    for i in range(3):
        for k in range(5):
            column = values[i, :, k][~np.isnan(values[i, :, k])]
            expected = column.min() if column.size else np.nan
            np.testing.assert_equal(reduced[i, k], expected)


def test_a_fit_note_on_a_swept_field_is_dropped_at_every_point():
    raw = {**RAW, "fits": [{"field": "cut.axial_depth_mm", "value": 1.5, "why": "fit"},
                           {"field": "workpiece.position_mm[2]", "value": 800.0, "why": "fit"},
                           {"field": "cut.spindle_rpm", "value": 2500, "why": "kept"}]}
    grid = parse_grid(["cut.axial_depth_mm=2.54", "workpiece.position_mm=z:900"], raw, ROBOT)
    new, _ = apply_point(raw, ROBOT, grid.axes, next(grid.points()))
    assert [f["field"] for f in new["fits"]] == ["cut.spindle_rpm"]
    assert len(raw["fits"]) == 3


def test_a_field_given_twice_is_refused():
    with pytest.raises(InputError, match="given twice"):
        parse_grid(["workpiece.position_mm=x:1600", "workpiece.position_mm=0:1700"], RAW, ROBOT)
    with pytest.raises(InputError, match="given twice"):
        parse_grid(["cut.axial_depth_mm=1", "cut.axial_depth_mm=2"], RAW, ROBOT)
