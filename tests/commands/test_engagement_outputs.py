"""``feedopt engagement --out/--intervals/--plot`` never writes over a file the scenario reads
(issue 26, item 1): the tool, the material, every file of the robot directory, the stock mesh,
the waypoint CSV or the G-code program; named directly, through a symbolic link or a hard link.
Each refusal exits 2 naming the file, before any work, and leaves every byte as it was.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
import yaml

from feedopt.cli import main
from feedopt.scenario import load_scenario, scenario_input_files

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
#: A closed box (not read: the refusal comes first, but it is what a stock mesh looks like).
BOX_STL = "solid box\nendsolid box\n"


def _scenario(base: dict, **changes) -> dict:
    doc = yaml.safe_load(yaml.safe_dump(base))
    doc.pop("fits", None)
    doc.update({"robot": {**doc["robot"], "directory": "robot"}, "tool": "tools/tool.yaml",
                "material": "materials/material.yaml"})
    for key, value in changes.items():
        doc[key] = {**doc.get(key, {}), **value}
    return doc


@pytest.fixture
def job(tmp_path: Path) -> Path:
    """A job folder: two scenarios (waypoint CSV + STL stock, G-code + box stock) and all
    the files they read, including extra files of the robot directory."""
    shutil.copytree(ROOT / "robots" / "kuka_kr500_3", tmp_path / "robot")
    (tmp_path / "robot" / "meshes").mkdir()
    (tmp_path / "robot" / "meshes" / "link1.stl").write_text(BOX_STL)
    (tmp_path / "robot" / "meshes" / "texture.png").write_bytes(b"\x89PNG not really")
    (tmp_path / "tools").mkdir()
    shutil.copy(SCEN / "tools" / "hss_2flute_19mm.yaml", tmp_path / "tools" / "tool.yaml")
    (tmp_path / "materials").mkdir()
    shutil.copy(SCEN / "materials" / "6061-T6511.yaml", tmp_path / "materials" / "material.yaml")
    (tmp_path / "waypoints.csv").write_text("x_mm,y_mm,z_mm\n0,0,0\n50,0,0\n50,30,0\n")
    (tmp_path / "part.stl").write_text(BOX_STL)
    shutil.copy(SCEN / "gcode" / "profile.nc", tmp_path / "profile.nc")
    csv = _scenario(yaml.safe_load((SCEN / "linear_peripheral_stock.yaml").read_text()),
                    path={"generator": "csv", "file": "waypoints.csv"},
                    stock={"mesh": "part.stl", "box_mm": None})
    (tmp_path / "csv.yaml").write_text(yaml.safe_dump(csv))
    prog = _scenario(yaml.safe_load((SCEN / "profile.yaml").read_text()),
                     path={"file": "profile.nc", "spacing_mm": 2.0})
    (tmp_path / "gcode.yaml").write_text(yaml.safe_dump(prog))
    return tmp_path


def _snapshot(folder: Path) -> dict[str, bytes | str]:
    """Every entry under ``folder``: a file's bytes, a link's target."""
    out: dict[str, bytes | str] = {}
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        out[rel] = (f"-> {os.readlink(p)}" if p.is_symlink() else
                    "dir" if p.is_dir() else p.read_bytes())
    return out


#: (scenario, input file, a name of the same kind a plot can have or None)
INPUTS = [
    ("csv.yaml", "tools/tool.yaml"),
    ("csv.yaml", "materials/material.yaml"),
    ("csv.yaml", "robot/robot.yaml"),
    ("csv.yaml", "robot/kr500_3.urdf"),
    ("csv.yaml", "robot/meshes/link1.stl"),
    ("csv.yaml", "robot/meshes/texture.png"),
    ("csv.yaml", "part.stl"),
    ("csv.yaml", "waypoints.csv"),
    ("gcode.yaml", "profile.nc"),
    ("gcode.yaml", "gcode.yaml"),
]


@pytest.mark.parametrize("option", ["--out", "--intervals", "--plot"])
@pytest.mark.parametrize(("scenario", "target"), INPUTS, ids=[i[1] for i in INPUTS])
def test_an_input_as_output_is_refused_and_kept(job, capsys, monkeypatch, scenario, target,
                                                option) -> None:
    monkeypatch.chdir(job)
    before = _snapshot(job)
    assert main(["engagement", scenario, option, target]) == 2
    err = capsys.readouterr().err
    assert f"{option} {target} is the input file" in err, err
    assert target.split("/")[-1] in err.split("is the input file", 1)[1]
    assert "destroy your input" in err
    assert _snapshot(job) == before


@pytest.mark.parametrize("option", ["--out", "--intervals", "--plot"])
@pytest.mark.parametrize("how", ["symlink", "hardlink"])
@pytest.mark.parametrize("target", ["tools/tool.yaml", "robot/kr500_3.urdf", "part.stl",
                                    "waypoints.csv"])
def test_a_link_to_an_input_is_refused(job, capsys, monkeypatch, option, how, target) -> None:
    monkeypatch.chdir(job)
    (job / "elsewhere").mkdir()
    link = job / "elsewhere" / "result.png"  # a name any of the options accepts
    if how == "symlink":
        link.symlink_to(job / target)
    else:
        os.link(job / target, link)
    before = _snapshot(job)
    assert main(["engagement", "csv.yaml", option, str(link)]) == 2
    err = capsys.readouterr().err
    assert f"{option} {link} is the input file" in err and Path(target).name in err, err
    assert _snapshot(job) == before


def test_a_robot_directory_over_the_listing_cap_protects_every_file(job, capsys, monkeypatch):
    """A robot directory too large to list one by one is protected as a folder: its existing
    files are refused (a hard link to one too), a new file in it is written."""
    import feedopt.scenario as scenario_module

    monkeypatch.setattr(scenario_module, "MAX_ROBOT_DIR_FILES", 2)
    monkeypatch.chdir(job)
    scenario, base = load_scenario("csv.yaml")
    assert (job / "robot").resolve() in [p.resolve() for p in
                                         scenario_input_files(scenario, base)]
    os.link(job / "robot" / "robot.yaml", job / "hard.csv")
    before = _snapshot(job)
    for target in ("robot/meshes/link1.stl", "hard.csv"):
        assert main(["engagement", "csv.yaml", "--out", target]) == 2
        assert "is a file of the input folder" in capsys.readouterr().err
    assert _snapshot(job) == before


def test_input_files_lists_what_the_scenario_reads(job) -> None:
    scenario, base = load_scenario(job / "csv.yaml")
    listed = {p.relative_to(job).as_posix() for p in scenario_input_files(scenario, base)}
    assert listed == {"tools/tool.yaml", "materials/material.yaml", "waypoints.csv", "part.stl",
                      "robot/robot.yaml", "robot/kr500_3.urdf", "robot/meshes/link1.stl",
                      "robot/meshes/texture.png"}
    scenario, base = load_scenario(job / "gcode.yaml")
    listed = {p.relative_to(job).as_posix() for p in scenario_input_files(scenario, base)}
    assert "profile.nc" in listed and "part.stl" not in listed


def test_fresh_outputs_are_written(job, capsys, monkeypatch) -> None:
    """The control: the same command with new names writes all three files."""
    monkeypatch.chdir(job)
    assert main(["engagement", "gcode.yaml", "--out", "e.csv", "--intervals", "i.csv",
                 "--plot", "robot/meshes/new.png"]) == 0
    assert (job / "e.csv").read_text().startswith("s_mm,x_mm")
    assert (job / "i.csv").read_text().startswith("sample,s_mm")
    assert (job / "robot" / "meshes" / "new.png").read_bytes()[:4] == b"\x89PNG"


def test_two_outputs_of_the_same_name_are_one_file_not_an_input(job, capsys, monkeypatch) -> None:
    """--out x.csv --intervals x.csv (x.csv new): the message says they are the same file,
    not that x.csv is an input (a hostile re-check found the wrong message)."""
    monkeypatch.chdir(job)
    before = _snapshot(job)
    assert main(["engagement", "csv.yaml", "--out", "x.csv", "--intervals", "x.csv"]) == 2
    err = capsys.readouterr().err
    assert "--out and --intervals are the same file x.csv" in err, err
    assert "input" not in err
    assert _snapshot(job) == before
