"""The scenario path stage: path_from_section gives the runner's path bit for bit, and the
runner's error texts."""

from pathlib import Path as FilePath
from types import SimpleNamespace

import numpy as np
import pytest

from feedopt import runner
from feedopt.errors import InputError
from feedopt.geometry.path import build_lipb_path
from feedopt.geometry.stage import path_from_section, waypoints_from_section
from feedopt.geometry.waves import square_wave, straight_line, triangle_wave
from feedopt.geometry.waypoints import read_waypoints_csv
from feedopt.scenario import load_scenario, resolve
from feedopt.units import MM

SCENARIOS = FilePath(__file__).resolve().parents[2] / "scenarios"
BUNDLED = ("triangle_slot", "square_slot", "linear_peripheral")


def _old_waypoints(scenario, base_dir):
    """feedopt/runner.py's waypoints_of before the stage existed."""
    p = scenario.path
    if p.generator == "triangle_wave":
        w = triangle_wave(p.length_mm * MM, p.height_mm * MM, p.waves)
    elif p.generator == "square_wave":
        w = square_wave(p.length_mm * MM, p.height_mm * MM, p.waves)
    elif p.generator == "line":
        w = straight_line(np.asarray(p.start_mm) * MM, np.asarray(p.end_mm) * MM)
    else:
        w = read_waypoints_csv(resolve(base_dir, p.file, "path.file (waypoint CSV)"))
    w = np.array(w, dtype=float)
    if p.generator in ("triangle_wave", "square_wave"):
        w[:, 2] += p.z_mm * MM
    return w


def _old_runner_path(scenario, base_dir):
    """feedopt/runner.py's build_path before the stage existed."""
    p = scenario.path
    try:
        return build_lipb_path(_old_waypoints(scenario, base_dir), p.blend,
                               p.blend_size_mm * MM, drop_repeated=p.drop_repeated_waypoints)
    except InputError as exc:
        msg = str(exc).replace("or pass drop_repeated=True (CLI: --drop-repeated)",
                               "or set path.drop_repeated_waypoints: true")
        raise InputError(f"path ({p.generator}, blend {p.blend} {p.blend_size_mm:g} mm): "
                         f"{msg}") from None


def _references(scenario, base_dir):
    refs = [_old_runner_path]
    if hasattr(runner, "build_path"):
        refs.append(runner.build_path)
    return [ref(scenario, base_dir) for ref in refs]


def _assert_identical(a, b, spacing):
    assert a.length == b.length
    assert len(a.segments) == len(b.segments)
    for x, y in zip(a.segments, b.segments, strict=True):
        assert (x.kind, x.s_start, x.length, x.corner_index) == (
            y.kind, y.s_start, y.length, y.corner_index)
        assert x.params.keys() == y.params.keys()
        for key in x.params:
            np.testing.assert_array_equal(x.params[key], y.params[key])
    pa, pb = a.sample(spacing), b.sample(spacing)
    for f in ("s", "position", "tangent", "curvature", "dcurvature", "segment"):
        np.testing.assert_array_equal(getattr(pa, f), getattr(pb, f))


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_scenarios_give_the_runners_path(name):
    scenario, base_dir = load_scenario(SCENARIOS / f"{name}.yaml")
    path = path_from_section(scenario.path, base_dir)
    for ref in _references(scenario, base_dir):
        _assert_identical(path, ref, scenario.path.spacing_mm * MM)


def _csv_scenario(tmp_path, rows, **path_fields):
    scenario, _ = load_scenario(SCENARIOS / "triangle_slot.yaml")
    f = tmp_path / "w.csv"
    f.write_text("x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n")
    section = scenario.path.model_copy(update={"generator": "csv", "file": "w.csv",
                                               "blend": "circle", "blend_size_mm": 5.0,
                                               **path_fields})
    return scenario.model_copy(update={"path": section})


ROWS = ["0,0,0", "0,0,0", "50,0,0", "50,50,0", "100,50,0"]


def test_csv_scenario_and_dropped_waypoints(tmp_path):
    scenario = _csv_scenario(tmp_path, ROWS, drop_repeated_waypoints=True)
    path = path_from_section(scenario.path, tmp_path)
    assert path.dropped_waypoints == (1,)
    for ref in _references(scenario, tmp_path):
        _assert_identical(path, ref, 1e-4)


@pytest.mark.parametrize(("rows", "fields"), [
    (ROWS, {}),  # repeated waypoint refused: the hint names the scenario field
    (ROWS[1:], {"blend_size_mm": 60.0}),  # blend does not fit
    (ROWS[1:], {"file": "missing.csv"}),  # file not found
    (["0,0,0", "1,abc,0"], {}),  # bad CSV
])
def test_error_text_is_the_runners(tmp_path, rows, fields):
    scenario = _csv_scenario(tmp_path, rows, **fields)
    with pytest.raises(InputError) as ours:
        path_from_section(scenario.path, tmp_path)
    for ref in (_old_runner_path, getattr(runner, "build_path", _old_runner_path)):
        with pytest.raises(InputError) as theirs:
            ref(scenario, tmp_path)
        assert str(ours.value) == str(theirs.value)
    assert str(ours.value).startswith("path (csv, blend circle ")


def test_repeat_hint_names_the_scenario_field(tmp_path):
    scenario = _csv_scenario(tmp_path, ROWS)
    with pytest.raises(InputError, match=r"indices 1\); remove them or set "
                                         r"path.drop_repeated_waypoints: true$"):
        path_from_section(scenario.path, tmp_path)


def test_duck_typed_section_and_resolver(tmp_path):
    section = SimpleNamespace(generator="triangle_wave", length_mm=304.8, height_mm=76.2,
                              waves=3, z_mm=2.0, blend="bezier5", blend_size_mm=10.0,
                              drop_repeated_waypoints=False)
    w = waypoints_from_section(section, tmp_path)
    np.testing.assert_array_equal(w[:, 2], 2.0 * MM)
    assert path_from_section(section, tmp_path).segment_kind[1] == "bezier5"
    seen = []

    def resolver(base, relative, what):
        seen.append((base, relative, what))
        return FilePath(SCENARIOS / "waypoints" / "example.csv")

    csv = SimpleNamespace(generator="csv", file="anything.csv", blend="none",
                          blend_size_mm=12.7, drop_repeated_waypoints=False)
    path = path_from_section(csv, tmp_path, resolve=resolver)
    assert seen == [(tmp_path, "anything.csv", "path.file (waypoint CSV)")]
    assert set(path.segment_kind) == {"line"}
