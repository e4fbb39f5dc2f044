"""The installed ``feedopt`` command on bad inputs, run as a user runs it (issue 18).

Every case runs ``.venv/bin/feedopt`` in a subprocess, in a folder of its own that holds the
same small fixture files, and asserts: exit code 2, a fragment of the one error message, no
Python traceback on stderr, nothing on stdout (every check happens before the work) and the
folder's listing unchanged (no output file, temporary file or folder left behind).

A subprocess costs about two seconds of imports, so the selected cases are started together
(a thread pool as wide as the machine) by one module fixture and each test only reads its
result.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
ROBOT = ROOT / "robots" / "kuka_kr500_3"
FEEDOPT = Path(sys.executable).parent / "feedopt"
if not FEEDOPT.exists():  # tests run with another interpreter: the repository's venv
    FEEDOPT = ROOT / ".venv" / "bin" / "feedopt"
TABLE_3_2 = SCEN / "materials" / "thesis_table_3_2_slot_forces.csv"
TOOL = SCEN / "tools" / "hss_2flute_19mm.yaml"
COEFFS = SCEN / "materials" / "6061-T6511.yaml"
#: Bytes that are not UTF-8 (0xff never is), with a NUL: what a binary file looks like.
GARBAGE = bytes(range(256))[::-1] * 4

PATH = ["path", "builtin:triangle", "--radius", "12.7", "--spacing", "1"]
FORCES = ["forces", "--tool", str(TOOL), "--coeffs", str(COEFFS), "--rpm", "2000",
          "--feed-mm-s", "4.23", "--axial-depth-mm", "2.54", "--step-deg", "10"]
CALIBRATE = ["calibrate", str(TABLE_3_2), "--teeth", "2", "--axial-depth-mm", "1.27"]
RUN = ["run", "scenario/quick.yaml"]
#: G-code programs with one flaw each (issue 11): the head of a valid program, then the flaw
NC_HEAD = "%\nO1\nG21 G17 G90 G94\nT1 M6\nS2500 M3\nG0 X0 Y0 Z5.\nG1 Z0.5 F300.\n"
BAD_PROGRAMS = {
    "unknown_word": NC_HEAD + "G1 X10. Y0 Z-1. A5. F200.\nM30\n",
    "radius_mismatch": NC_HEAD + "G1 X10. Z-1. F200.\nG2 X30.05 Y0 I10. J0\nM30\n",
    "circle_without_centre": NC_HEAD + "G1 X10. Z-1. F200.\nG2 X10. Y0 R5.\nM30\n",
    "zero_radius_arc": NC_HEAD + "G1 X10. Z-1. F200.\nG2 X20. Y0 I0 J0\nM30\n",
    "no_feed": "G21 G90\nS2500 M3\nG0 X0 Y0 Z5.\nG1 X10. Z-1.\nM30\n",
    "feed_zero": NC_HEAD + "G1 X10. Z-1. F0\nM30\n",
    "units_switch": NC_HEAD + "G1 X10. Z-1. F200.\nG20\nG1 X1.\nM30\n",
    "no_cut": NC_HEAD + "G0 Z5.\nM30\n",
    "lost_in_stock": NC_HEAD + "G1 X10. Z-1. F200.\nG28 G91 Z0\nG90\nG0 X20. Y0 Z5.\n"
                     "G1 Z-1. F100.\nG1 X30.\nM30\n",
    "stop_in_chain": NC_HEAD + "G1 X1. Z-1. F200.\nG1 X2.\nG1 X3.\nM0\nG1 X4.\nG1 X5.\nM30\n",
    "second_tool": NC_HEAD + "G1 X10. Z-1. F200.\nG0 Z5.\nT2 M6\nG0 X0 Y0 Z5.\n"
                   "G1 X10. Z-1. F200.\nM30\n",
}


@dataclass(frozen=True)
class Case:
    """One command line (``{work}``: the case's folder) and what its error must say."""

    id: str
    argv: tuple[str, ...]
    fragment: str


def case(id_: str, argv: list[str], fragment: str) -> Case:
    return Case(id_, tuple(argv), fragment)


CASES = [
    # path: --out / --plot
    case("path-out-folder", PATH + ["--out", "existing"],
         "--out existing is a folder, not a file: give a file name (e.g. --out existing/path.csv)"),
    case("path-out-missing-folder", PATH + ["--out", "nodir/p.csv"],
         "--out: directory {work}/nodir does not exist"),
    case("path-out-proc", PATH + ["--out", "/proc/p.csv"],
         "--out /proc/p.csv: cannot write in /proc"),
    case("path-plot-sys", PATH + ["--plot", "/sys/p.png"],
         "--plot /sys/p.png: cannot write in /sys"),
    case("path-out-device", PATH + ["--out", "/dev/null"], "--out /dev/null exists and is not a "
         "regular file"),
    case("path-plot-unknown-format", PATH + ["--out", "p.csv", "--plot", "p.xyz"],
         "--plot p.xyz: cannot write a file with '.xyz'; give a name ending in one of"),
    case("path-plot-no-extension", PATH + ["--plot", "p"], "--plot p: cannot write a file with no "
         "extension"),
    case("path-out-equals-plot", PATH + ["--out", "p.png", "--plot", "p.png"],
         "--out and --plot are the same file p.png"),
    case("path-out-is-the-waypoints", ["path", "waypoints.csv", "--blend", "none", "--out",
                                       "waypoints.csv"],
         "--out waypoints.csv is the input file waypoints.csv"),
    case("path-waypoints-garbage", ["path", "garbage.bin", "--blend", "none", "--out", "p.csv"],
         "waypoint file garbage.bin is not UTF-8 text"),
    # forces
    case("forces-out-folder", FORCES + ["--out", "existing"], "--out existing is a folder"),
    case("forces-plot-unknown-format", FORCES + ["--out", "f.csv", "--plot", "f.xyz"],
         "--plot f.xyz: cannot write a file with '.xyz'"),
    case("forces-plot-missing-folder", FORCES + ["--plot", "nodir/f.png"],
         "--plot: directory {work}/nodir does not exist"),
    case("forces-out-proc", FORCES + ["--out", "/proc/f.csv"], "cannot write in /proc"),
    case("forces-coeffs-garbage", ["forces", "--tool", str(TOOL), "--coeffs", "garbage.bin",
                                   "--rpm", "2000", "--feed-mm-s", "4", "--axial-depth-mm", "2"],
         "coefficients garbage.bin is not UTF-8 text"),
    case("forces-tool-garbage", ["forces", "--tool", "garbage.bin", "--coeffs", str(COEFFS),
                                 "--rpm", "2000", "--feed-mm-s", "4", "--axial-depth-mm", "2"],
         "tool garbage.bin is not UTF-8 text"),
    # calibrate
    case("calibrate-out-folder", CALIBRATE + ["--out", "existing"],
         "--out existing is a folder, not a file: give a file name (e.g. --out "
         "existing/coeffs.yaml)"),
    case("calibrate-out-missing-folder", CALIBRATE + ["--out", "nodir/c.yaml"],
         "--out: directory {work}/nodir does not exist"),
    case("calibrate-out-proc", CALIBRATE + ["--out", "/proc/c.yaml"], "cannot write in /proc"),
    case("calibrate-out-is-the-data", ["calibrate", "cuts.csv", "--teeth", "2",
                                       "--axial-depth-mm", "1.27", "--out", "./cuts.csv"],
         "--out ./cuts.csv is the input file cuts.csv"),
    case("calibrate-data-garbage", ["calibrate", "garbage.bin", "--teeth", "2",
                                    "--axial-depth-mm", "1.27"],
         "forces CSV garbage.bin is not UTF-8 text"),
    # validate
    case("validate-schema-out-folder", ["validate", "--schema", "--out", "existing"],
         "--out existing is a folder, not a file"),
    case("validate-schema-out-missing-folder", ["validate", "--schema", "--out", "nodir/r.md"],
         "--out: directory {work}/nodir does not exist"),
    case("validate-schema-out-sys", ["validate", "--schema", "--out", "/sys/r.md"],
         "cannot write in /sys"),
    case("validate-scenario-garbage", ["validate", "garbage.bin"],
         "scenario file garbage.bin is not UTF-8 text"),
    # compare (writes nothing: its inputs)
    case("compare-summary-garbage", ["compare", "garbage_run"],
         "run summary garbage_run/summary.json is not UTF-8 text"),
    case("compare-missing-run", ["compare", "nodir"], "run summary nodir does not exist"),
    # robot
    case("robot-yaml-garbage", ["robot", "garbage_robot", "--q-deg=0,-65,108,0,47,0"],
         "robot file garbage_robot/robot.yaml is not UTF-8 text"),
    case("robot-missing-folder", ["robot", "nodir", "--q-deg=0,-65,108,0,47,0"],
         "nodir: no robot.yaml found"),
    # run: a few of the output-folder refusals (the rest: tests/test_run_safety.py)
    case("run-out-existing-file", RUN + ["--out", "existing/keep.txt"],
         "--out existing/keep.txt is an existing file, not a folder"),
    case("run-out-proc", RUN + ["--out", "/proc/feedopt_out"], "cannot write in /proc"),
    case("run-out-current-folder", RUN + ["--out", "."], "--out . is the current directory"),
    case("run-rsi-cycle-tiny", ["run", "scenario/tiny_cycle.yaml"], "is not an RSI cycle"),
    case("run-rsi-cycle-huge", ["run", "scenario/huge_cycle.yaml"], "is not an RSI cycle"),
    case("run-force-workload", ["run", "scenario/fine_forces.yaml"],
         "force evaluations, more than the 1e+11"),
    case("run-scenario-garbage", ["run", "garbage.bin"],
         "scenario file garbage.bin is not UTF-8 text"),
    # G-code programs (issue 11): the line and the word or what is wrong
    case("nc-unknown-word", ["path", "unknown_word.nc"], "line 8: A5.: rotary and extra axes"),
    case("nc-radius-mismatch", ["path", "radius_mismatch.nc"],
         "line 9: G2: start and end are not on one circle"),
    case("nc-circle-without-centre", ["path", "circle_without_centre.nc"],
         "line 9: G2 R5.: start and end are the same point"),
    case("nc-zero-radius-arc", ["path", "zero_radius_arc.nc"],
         "line 9: G2: the centre is at the start point (radius 0)"),
    case("nc-no-feed", ["path", "no_feed.nc"], "line 4: feed move without a feed rate"),
    case("nc-feed-zero", ["path", "feed_zero.nc"], "line 8: F0: feed must be > 0"),
    case("nc-units-switch", ["path", "units_switch.nc"],
         "line 9: G20: switching units after the first move"),
    case("nc-no-cut", ["path", "no_cut.nc", "--out", "p.csv"], "the program has no cutting move"),
    case("nc-lost-in-stock", ["path", "lost_in_stock.nc", "--out", "p.csv"],
         "line 8: the tool is at Z-1 mm, below the stock top (Z0 mm), when the program loses "
         "its position after this move"),
    case("nc-stop-in-chain", ["path", "stop_in_chain.nc"],
         "line 11: an M0 inside a run of short moves smoothed as one curve (lines 9-13"),
    case("nc-garbage", ["path", "garbage.nc"], "G-code program garbage.nc is not UTF-8 text"),
    case("run-nc-second-tool", ["run", "scenario/program_t2.yaml"],
         "second_tool.nc line 12: the program cuts with tools T1, T2; the scenario describes "
         "one tool"),
    case("run-nc-nominal-feed", ["run", "scenario/program_nominal.yaml"],
         "the program's F words are the nominal feed"),
    # no command writes over its inputs (issue 26): local.yaml reads scenario/tools/tool.yaml,
    # scenario/materials/material.yaml and the robot directory robot/
    case("run-out-holds-the-tool", ["run", "scenario/local.yaml", "--out", "scenario/tools",
                                    "--overwrite"],
         "--out scenario/tools holds the input file {work}/scenario/tools/tool.yaml of this run: "
         "feedopt never writes over or replaces its inputs (not even with --overwrite)"),
    case("run-out-is-the-robot-dir", ["run", "scenario/local.yaml", "--out", "robot",
                                      "--overwrite"],
         "--out robot holds the input file {work}/robot/"),
    case("run-out-is-the-material", ["run", "scenario/local.yaml", "--out",
                                     "scenario/materials/material.yaml"],
         "--out scenario/materials/material.yaml is the input file"),
    case("engagement-out-is-the-tool", ["engagement", "scenario/local.yaml", "--out",
                                        "scenario/tools/tool.yaml"],
         "--out scenario/tools/tool.yaml is the input file {work}/scenario/tools/tool.yaml"),
    case("engagement-intervals-is-the-urdf", ["engagement", "scenario/local.yaml",
                                              "--intervals", "robot/kr500_3.urdf"],
         "--intervals robot/kr500_3.urdf is the input file {work}/robot/kr500_3.urdf"),
    case("engagement-plot-is-the-robot-yaml", ["engagement", "scenario/local.yaml", "--plot",
                                               "robot/robot.yaml"],
         "--plot robot/robot.yaml is the input file {work}/robot/robot.yaml"),
    case("calibrate-stiffness-out-is-the-urdf",
         ["calibrate-stiffness", "--suggest", "3", "--robot", "robot", "--out",
          "robot/kr500_3.urdf"],
         "--out robot/kr500_3.urdf is a file of the input folder robot"),
    # every text input is capped before it is parsed (issue 26): sparse files, no disk used
    case("validate-500mb-scenario", ["validate", "huge.yaml"],
         "scenario file huge.yaml is 476.8 MiB (500,000,000 bytes), more than the 4.0 MiB"),
    case("validate-huge-tool", ["validate", "scenario/huge_tool.yaml"],
         "tool {work}/scenario/tools/huge.yaml is 100.0 MiB (104,857,600 bytes), more than the "
         "1.0 MiB (1,048,576 bytes) a tool may have"),
    case("compare-huge-summary", ["compare", "huge_run"],
         "run summary huge_run/summary.json is 1.0 GiB"),
    case("compare-deep-summary", ["compare", "deep_run"], "deep_run/summary.json: the JSON is "
         "nested too deeply"),
    case("compare-nan-cycle-time", ["compare", "nan_run"],
         "nan_run/summary.json: laws.thesis.cycle_time_s = nan: a run writes a finite number"),
    # what a scenario file is when it is not a file (issue 26)
    case("validate-dev-zero", ["validate", "/dev/zero"],
         "scenario file /dev/zero is not a regular file but a character device"),
    case("validate-fifo", ["validate", "fifo.yaml"],
         "scenario file fifo.yaml is not a regular file but a named pipe (FIFO)"),
    case("run-fifo", ["run", "fifo.yaml"],
         "scenario file fifo.yaml is not a regular file but a named pipe (FIFO)"),
    case("run-out-marker-is-a-fifo", RUN + ["--out", "fifo_out"],
         "--out fifo_out already holds files feedopt did not write (.feedopt-output.json)"),
    case("validate-fifo-tool", ["validate", "scenario/fifo_tool.yaml"],
         "tool {work}/scenario/tools/fifo.yaml is not a regular file but a named pipe"),
]


def _fixture_files(work: Path) -> None:
    """The files every case's folder starts with."""
    (work / "existing").mkdir()
    (work / "existing" / "keep.txt").write_text("a user's file\n")
    (work / "garbage.bin").write_bytes(GARBAGE)
    (work / "waypoints.csv").write_text("x_mm,y_mm,z_mm\n0,0,0\n10,0,0\n10,10,0\n")
    shutil.copy(TABLE_3_2, work / "cuts.csv")
    (work / "garbage_run").mkdir()
    (work / "garbage_run" / "summary.json").write_bytes(GARBAGE)
    (work / "garbage_robot").mkdir()
    (work / "garbage_robot" / "robot.yaml").write_bytes(GARBAGE)
    doc = yaml.safe_load((SCEN / "linear_peripheral.yaml").read_text())
    doc["robot"]["directory"] = str(ROBOT)
    doc["tool"] = str(SCEN / doc["tool"])
    doc["material"] = str(SCEN / doc["material"])
    doc["path"]["spacing_mm"] = 2.0
    doc["schedule"]["laws"] = ["constant", "jerk"]
    (work / "scenario").mkdir()
    (work / "scenario" / "quick.yaml").write_text(yaml.safe_dump(doc))
    # Inputs that would eat the machine (issue 18): refused before any work.
    for name, section, key, value in (
        ("tiny_cycle", "export", "rsi_cycle_ms", 0.001),
        ("huge_cycle", "export", "rsi_cycle_ms", 100000),
        ("fine_forces", "schedule", "angle_step_deg", 0.01),
    ):
        bad = yaml.safe_load(yaml.safe_dump(doc))
        bad.setdefault(section, {})[key] = value
        if name == "fine_forces":
            bad["schedule"]["axial_slices"] = 500
            bad["path"]["spacing_mm"] = 0.01
        (work / "scenario" / f"{name}.yaml").write_text(yaml.safe_dump(bad))
    for name, text in BAD_PROGRAMS.items():
        (work / f"{name}.nc").write_text(text)
    (work / "garbage.nc").write_bytes(GARBAGE)
    prog = yaml.safe_load((SCEN / "profile.yaml").read_text())
    prog["robot"]["directory"] = str(ROBOT)
    prog["tool"] = str(SCEN / prog["tool"])
    prog["material"] = str(SCEN / prog["material"])
    prog["path"]["file"] = str(work / "second_tool.nc")
    (work / "scenario" / "program_t2.yaml").write_text(yaml.safe_dump(prog))
    prog["path"]["file"] = str(SCEN / "gcode" / "profile.nc")
    prog["feed"]["nominal_mm_s"] = 4.0
    (work / "scenario" / "program_nominal.yaml").write_text(yaml.safe_dump(prog))
    _local_inputs(work, doc)


def _local_inputs(work: Path, doc: dict) -> None:
    """A scenario whose tool, material and robot are files of the case's folder (issue 26),
    the same with a FIFO and with a 100 MiB tool file, and hostile inputs of their own kinds:
    a 500 MB scenario, a FIFO, run summaries that are huge, deep or hold NaN."""
    shutil.copytree(ROBOT, work / "robot")
    (work / "scenario" / "tools").mkdir()
    shutil.copy(TOOL, work / "scenario" / "tools" / "tool.yaml")
    (work / "scenario" / "materials").mkdir()
    shutil.copy(COEFFS, work / "scenario" / "materials" / "material.yaml")
    local = {**doc, "robot": {**doc["robot"], "directory": "../robot"},
             "tool": "tools/tool.yaml", "material": "materials/material.yaml"}
    (work / "scenario" / "local.yaml").write_text(yaml.safe_dump(local))
    for name, tool in (("huge_tool", "tools/huge.yaml"), ("fifo_tool", "tools/fifo.yaml")):
        (work / "scenario" / f"{name}.yaml").write_text(yaml.safe_dump({**local, "tool": tool}))
    os.mkfifo(work / "scenario" / "tools" / "fifo.yaml")
    os.mkfifo(work / "fifo.yaml")
    (work / "fifo_out").mkdir()  # a marker that would block a reader that opened it
    os.mkfifo(work / "fifo_out" / ".feedopt-output.json")
    for path, size, head in ((work / "scenario" / "tools" / "huge.yaml", 100 * 2**20, b"# x\n"),
                             (work / "huge.yaml", 500 * 10**6, b"# all comment\n"),
                             (work / "huge_run" / "summary.json", 2**30, b'{"laws": ')):
        path.parent.mkdir(exist_ok=True)
        with open(path, "wb") as fh:  # sparse: the size without the disk space
            fh.write(head)
            fh.truncate(size)
    (work / "deep_run").mkdir()
    (work / "deep_run" / "summary.json").write_text('{"laws": ' + "[" * 50_000
                                                    + "]" * 50_000 + "}")
    (work / "nan_run").mkdir()
    (work / "nan_run" / "summary.json").write_text(json.dumps(
        {"laws": {"thesis": {"cycle_time_s": float("nan"), "lower_bound_s": 1.0,
                             "max_deflection_mm": 0.1, "max_feed_mm_s": 4.0,
                             "min_feed_mm_s": 1.0, "max_accel_mm_s2": 1.0,
                             "max_jerk_mm_s3": 1.0, "c2": True, "verified": True,
                             "planning_time_s": 0.1}}}))


def _listing(folder: Path) -> list[str]:
    """Every entry under ``folder``, hidden ones too, with its size for files."""
    out = []
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        out.append(rel + "/" if p.is_dir() else f"{rel} {p.stat().st_size}")
    return out


@dataclass
class Outcome:
    """What one case's process did."""

    returncode: int
    stdout: str
    stderr: str
    before: list[str]
    after: list[str]
    work: Path


def _run(c: Case, work: Path) -> Outcome:
    work.mkdir()
    _fixture_files(work)
    before = _listing(work)
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONWARNINGS="ignore")
    proc = subprocess.run([str(FEEDOPT), *c.argv], cwd=work, env=env, capture_output=True,
                          text=True, timeout=120)
    return Outcome(proc.returncode, proc.stdout, proc.stderr, before, _listing(work), work)


@pytest.fixture(scope="module")
def outcomes(request, tmp_path_factory) -> dict[str, Outcome]:
    """Run every selected case at once; their outcomes by case id."""
    wanted = {item.callspec.params["c"].id for item in request.session.items
              if item.module is sys.modules[__name__] and hasattr(item, "callspec")}
    selected = [c for c in CASES if c.id in wanted]
    root = tmp_path_factory.mktemp("cli")
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {c.id: pool.submit(_run, c, root / c.id) for c in selected}
        return {cid: f.result() for cid, f in futures.items()}


def test_cases_are_unique():
    assert len({c.id for c in CASES}) == len(CASES)
    assert FEEDOPT.exists(), f"install feedopt first: {FEEDOPT} is missing"


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_bad_input_exits_2_with_one_message_and_leaves_nothing(outcomes, c):
    o = outcomes[c.id]
    err = o.stderr
    assert o.returncode == 2, err
    assert "Traceback" not in err
    command = c.argv[0]
    errors = [ln for ln in err.splitlines() if ln.startswith(f"feedopt {command}: error: ")]
    assert len(errors) == 1, err
    assert c.fragment.format(work=o.work) in err
    assert o.stdout == ""
    assert o.after == o.before
