"""``feedopt validate``: --schema takes no scenario, --out writes the reference."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
import yaml

from feedopt.cli import main
from feedopt.scenario import schema_reference

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "triangle_slot.yaml"


def test_schema_prints_the_reference(capsys):
    assert main(["validate", "--schema"]) == 0
    out = capsys.readouterr()
    assert out.out == schema_reference()
    assert out.out.startswith("# Scenario reference") and "**path.blend_size_mm**" in out.out
    assert out.err == ""


def test_schema_with_a_scenario_is_refused_and_the_file_untouched(tmp_path, capsys):
    scenario = tmp_path / "mine.yaml"
    scenario.write_bytes(SCENARIO.read_bytes())
    before = scenario.read_bytes()
    assert main(["validate", "--schema", str(scenario)]) == 2
    err = capsys.readouterr()
    assert err.out == ""  # no reference printed either: one clear answer
    assert "--schema prints the field reference and takes no scenario file" in err.err
    assert repr(str(scenario)) in err.err
    assert f"feedopt validate {scenario}" in err.err and "--schema --out reference.md" in err.err
    assert scenario.read_bytes() == before


def test_schema_out_writes_the_reference(tmp_path, capsys):
    out = tmp_path / "reference.md"
    assert main(["validate", "--schema", "--out", str(out)]) == 0
    assert out.read_text() == schema_reference()
    stdout = capsys.readouterr().out
    assert stdout == f"wrote {out}\n"


@pytest.mark.parametrize("name", ["scenario.yaml", "x.yml", "noext"])
def test_schema_out_refuses_non_text_names(tmp_path, capsys, name):
    out = tmp_path / name
    assert main(["validate", "--schema", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "the reference is Markdown text, not a scenario" in err and ".md or .txt" in err
    assert not out.exists()


def test_schema_out_missing_directory(tmp_path, capsys):
    out = tmp_path / "no" / "ref.md"
    assert main(["validate", "--schema", "--out", str(out)]) == 2
    assert f"--out: directory {out.parent} does not exist" in capsys.readouterr().err


def test_out_without_schema_is_refused(tmp_path, capsys):
    out = tmp_path / "ref.md"
    assert main(["validate", str(SCENARIO), "--out", str(out)]) == 2
    assert "--out writes the --schema reference" in capsys.readouterr().err
    assert not out.exists()


def test_no_scenario_no_schema(capsys):
    assert main(["validate"]) == 2
    assert "give a scenario file (or --schema)" in capsys.readouterr().err


def test_help_documents_schema_and_out(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["validate", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "takes no SCENARIO" in text and "--out FILE" in text
    assert "write the reference to FILE (.md or .txt)" in text


# --------------------------------------------------- scenario files that are not files (issue 26)

def _scenario_copy(tmp_path: Path, **fields) -> Path:
    """triangle_slot.yaml in ``tmp_path`` with absolute tool/material/robot and ``fields``."""
    doc = yaml.safe_load(SCENARIO.read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(ROOT / "scenarios" / doc["tool"])
    doc["material"] = str(ROOT / "scenarios" / doc["material"])
    doc.update(fields)
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize(("make", "message"), [
    (lambda p: p.symlink_to(p), "scenario file {p} is a symbolic link loop"),
    (lambda p: p.symlink_to(p.parent / "gone.yaml"),
     "scenario file {p} is a symbolic link to {p.parent}/gone.yaml, which does not exist"),
    (lambda p: p.mkdir(), "scenario file {p} is a folder, not a file"),
    (lambda p: p.symlink_to("/dev/zero"), "scenario file {p} is not a regular file but a "
     "character device"),
    (lambda p: os.mkfifo(p), "scenario file {p} is not a regular file but a named pipe (FIFO)"),
    (lambda p: None, "scenario file not found: {p}"),
])
def test_each_kind_of_non_file_scenario_has_its_message(tmp_path, capsys, make, message):
    p = tmp_path / "s.yaml"
    make(p)
    t0 = time.perf_counter()
    assert main(["validate", str(p)]) == 2  # a FIFO is never opened: this cannot block
    assert time.perf_counter() - t0 < 5.0
    err = capsys.readouterr().err
    assert message.format(p=p) in err, err
    assert "not found" not in err or "not found" in message


@pytest.mark.parametrize("field", ["tool", "material"])
def test_a_referenced_file_that_is_a_link_loop_or_fifo_is_named_as_such(tmp_path, capsys, field):
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(loop)
    assert main(["validate", str(_scenario_copy(tmp_path, **{field: str(loop)}))]) == 2
    assert f"{loop} is a symbolic link loop" in capsys.readouterr().err
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    assert main(["validate", str(_scenario_copy(tmp_path, **{field: str(fifo)}))]) == 2
    assert f"{fifo} is not a regular file but a named pipe" in capsys.readouterr().err


def test_an_all_comment_scenario_over_the_cap_is_refused_at_once(tmp_path, capsys):
    """Issue 26: 500 MB of comments kept validate busy for minutes; now refused by size."""
    p = tmp_path / "comments.yaml"
    with open(p, "wb") as fh:
        for _ in range(5):  # 5 MiB of real comment lines
            fh.write((b"# " + b"c" * 1021 + b"\n") * 1024)
    t0 = time.perf_counter()
    assert main(["validate", str(p)]) == 2
    assert time.perf_counter() - t0 < 2.0
    assert (f"scenario file {p} is 5.0 MiB (5,242,880 bytes), more than the 4.0 MiB "
            "(4,194,304 bytes) a scenario file may have") in capsys.readouterr().err
    with open(p, "r+b") as fh:  # the same just under the cap parses (and is empty)
        fh.truncate(4 * 2**20)
    assert main(["validate", str(p)]) == 2
    assert "a scenario must be a YAML mapping of sections, got NoneType" in \
        capsys.readouterr().err


# ------------------------------------------- validate applies run's stock checks (issue 28)

_CRASH_PROGRAM = """%
O0100
G21 G90 G17
T1 M6
S1500 M3
G0 X-30. Y0. Z5.
G0 Z-2.
G1 X10. F300.
G0 X60.
G0 Z5.
M5
M30
%
"""


def _stock_scenario(tmp_path: Path, program: str) -> Path:
    """pocket.yaml in ``tmp_path`` running ``program`` against its 160 x 120 mm stock box."""
    doc = yaml.safe_load((ROOT / "scenarios" / "pocket.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(ROOT / "scenarios" / doc["tool"])
    doc["material"] = str(ROOT / "scenarios" / doc["material"])
    (tmp_path / "job.nc").write_text(program)
    doc["path"]["file"] = "job.nc"
    doc["path"]["spacing_mm"] = 0.5
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_validate_refuses_a_rapid_through_the_stock_as_run_does(tmp_path, capsys):
    scen = _stock_scenario(tmp_path, _CRASH_PROGRAM)
    assert main(["validate", str(scen)]) == 2
    err = capsys.readouterr().err
    assert "job.nc line 9" in err and "a rapid (G0) meets material" in err


def test_validate_accepts_the_same_cut_without_the_crash(tmp_path, capsys):
    scen = _stock_scenario(tmp_path, _CRASH_PROGRAM.replace("G0 X60.\nG0 Z5.", "G0 Z5.\nG0 X60."))
    assert main(["validate", str(scen)]) == 0
    assert "stock 640 x 480 cells of 0.25 mm" in capsys.readouterr().out
