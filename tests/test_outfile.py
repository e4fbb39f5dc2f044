"""feedopt.outfile: single output files checked before the work and written whole."""

from __future__ import annotations

import os
import stat

import pytest

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.outfile import (
    check_output_file,
    plot_suffixes,
    write_atomically,
    write_files_atomically,
)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "scenarios", "tools", "hss_2flute_19mm.yaml")
COEFFS = os.path.join(ROOT, "scenarios", "materials", "6061-T6511.yaml")
FORCES = ["forces", "--tool", TOOL, "--coeffs", COEFFS, "--rpm", "2000", "--feed-mm-s", "4.23",
          "--axial-depth-mm", "2.54", "--step-deg", "10", "--axial-slices", "4"]


def _listing(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_check_accepts_a_new_and_an_existing_file_and_leaves_no_probe(tmp_path):
    assert check_output_file(tmp_path / "a.csv", "--out") == (tmp_path / "a.csv").resolve()
    (tmp_path / "b.csv").write_text("old")
    assert check_output_file(str(tmp_path / "b.csv"), "--out") == tmp_path / "b.csv"
    assert _listing(tmp_path) == ["b.csv"]
    assert (tmp_path / "b.csv").read_text() == "old"


def test_check_resolves_a_symbolic_link_to_its_target(tmp_path):
    (tmp_path / "real.csv").write_text("x")
    (tmp_path / "link.csv").symlink_to(tmp_path / "real.csv")
    assert check_output_file(tmp_path / "link.csv", "--out") == tmp_path / "real.csv"


@pytest.mark.parametrize(("name", "fragment"), [
    ("", "--out is empty: give a file name"),
    ("{tmp}", "is a folder, not a file: give a file name (e.g. --out {tmp}/out.csv)"),
    ("{tmp}/no/such/x.csv", "--out: directory {tmp}/no/such does not exist; create it first"),
    ("{tmp}/file.txt/x.csv", "{tmp}/file.txt is a file, not a folder"),
    ("/proc/x.csv", "cannot write in /proc (No such file or directory)"),
    ("/sys/x.csv", "cannot write in /sys"),
    ("/dev/null", "exists and is not a regular file"),
    ("{tmp}/in.csv", "is the input file {tmp}/in.csv: writing it would destroy your input"),
])
def test_check_refuses(tmp_path, name, fragment):
    (tmp_path / "file.txt").write_text("")
    (tmp_path / "in.csv").write_text("")
    before = _listing(tmp_path)
    with pytest.raises(InputError) as err:
        check_output_file(name.format(tmp=tmp_path), "--out", example="out.csv",
                          inputs=[tmp_path / "in.csv"])
    assert fragment.format(tmp=tmp_path) in str(err.value)
    assert _listing(tmp_path) == before


def test_check_refuses_an_input_given_by_another_name(tmp_path, monkeypatch):
    (tmp_path / "in.csv").write_text("")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match="--out ./in.csv is the input file .*in.csv"):
        check_output_file("./in.csv", "--out", inputs=[tmp_path / "in.csv"])
    (tmp_path / "hard.csv").hardlink_to(tmp_path / "in.csv")
    with pytest.raises(InputError, match="is the input file in.csv"):
        check_output_file("hard.csv", "--out", inputs=["in.csv"])


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_an_input_is_named_before_the_suffix_is_checked(tmp_path, monkeypatch):
    """--plot tool.yaml: the message that matters is that it is an input, not its suffix."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tool.yaml").write_text("keep")
    with pytest.raises(InputError, match="--plot tool.yaml is the input file tool.yaml"):
        check_output_file("tool.yaml", "--plot", plot_suffixes(), inputs=["tool.yaml"])
    assert (tmp_path / "tool.yaml").read_text() == "keep"


def test_an_input_folder_protects_its_files_not_new_names(tmp_path, monkeypatch):
    """A folder among the inputs (a robot directory): its existing files, deep or linked,
    are refused; a new file in it is fine."""
    monkeypatch.chdir(tmp_path)
    robot = tmp_path / "robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "robot.yaml").write_text("keep")
    (robot / "meshes" / "base.stl").write_text("keep")
    (tmp_path / "sym.csv").symlink_to(robot / "meshes" / "base.stl")
    os.link(robot / "robot.yaml", tmp_path / "hard.csv")
    for name in ("robot/robot.yaml", "robot/meshes/base.stl", "sym.csv", "hard.csv"):
        with pytest.raises(InputError, match=f"--out {name} is a file of the input folder "
                                             "robot: writing it would destroy your input"):
            check_output_file(name, "--out", inputs=["robot"])
    assert check_output_file("robot/new.yaml", "--out", inputs=["robot"]) == robot / "new.yaml"
    (tmp_path / "other.csv").write_text("x")
    os.link(tmp_path / "other.csv", tmp_path / "other2.csv")  # a hard link, not to the robot
    assert check_output_file("other.csv", "--out", inputs=["robot"]) == tmp_path / "other.csv"
    assert (robot / "robot.yaml").read_text() == (robot / "meshes" / "base.stl").read_text()


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write in a read-only folder")
def test_check_refuses_a_read_only_folder_and_file(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    (ro / "old.csv").write_text("")
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.raises(InputError, match="cannot write in"):
            check_output_file(ro / "x.csv", "--out")
    finally:
        ro.chmod(stat.S_IRWXU)
    (tmp_path / "f.csv").write_text("")
    (tmp_path / "f.csv").chmod(stat.S_IRUSR)
    with pytest.raises(InputError, match="is read-only"):
        check_output_file(tmp_path / "f.csv", "--out")


def test_check_suffixes():
    formats = plot_suffixes()
    assert ".png" in formats and ".pdf" in formats and ".svg" in formats
    with pytest.raises(InputError) as err:
        check_output_file("path.xyz", "--plot", formats)
    assert "--plot path.xyz: cannot write a file with '.xyz'" in str(err.value)
    assert ".png" in str(err.value) and "(e.g. --plot out" in str(err.value)
    with pytest.raises(InputError, match="no extension"):
        check_output_file("path", "--plot", formats)
    assert check_output_file("PATH.PNG", "--plot", formats).name == "PATH.PNG"


def test_write_text_and_callable(tmp_path):
    out = tmp_path / "a.md"
    assert write_atomically(out, "héllo\n") == out
    assert out.read_text(encoding="utf-8") == "héllo\n"
    seen = []

    def writer(tmp):
        seen.append(tmp)
        tmp.write_text("second")

    write_atomically(out, writer)
    assert out.read_text() == "second"
    assert seen[0].parent == tmp_path and seen[0].suffix == ".md" and not seen[0].exists()
    assert _listing(tmp_path) == ["a.md"]
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask


def test_write_keeps_the_mode_of_the_file_it_replaces(tmp_path):
    out = tmp_path / "a.csv"
    out.write_text("old")
    out.chmod(0o640)
    write_atomically(out, "new")
    assert out.read_text() == "new" and stat.S_IMODE(out.stat().st_mode) == 0o640


def test_write_through_a_symbolic_link_keeps_the_link(tmp_path):
    (tmp_path / "real.csv").write_text("old")
    (tmp_path / "link.csv").symlink_to("real.csv")
    write_atomically(tmp_path / "link.csv", "new")
    assert (tmp_path / "link.csv").is_symlink()
    assert (tmp_path / "real.csv").read_text() == "new"


@pytest.mark.parametrize("exc", [ValueError("boom"), KeyboardInterrupt()])
def test_failed_write_leaves_the_previous_file_and_no_temporary(tmp_path, exc):
    out = tmp_path / "a.png"
    out.write_text("previous")

    def writer(tmp):
        tmp.write_text("half")
        raise exc

    with pytest.raises(type(exc)):
        write_atomically(out, writer)
    assert _listing(tmp_path) == ["a.png"] and out.read_text() == "previous"


def test_several_files_all_or_none(tmp_path):
    (tmp_path / "a.csv").write_text("old a")

    def bad(tmp):
        raise RuntimeError("plot failed")

    with pytest.raises(RuntimeError):
        write_files_atomically([(tmp_path / "a.csv", "new a", "--out"),
                                (tmp_path / "b.png", bad, "--plot")])
    assert _listing(tmp_path) == ["a.csv"] and (tmp_path / "a.csv").read_text() == "old a"
    write_files_atomically([(tmp_path / "a.csv", "new a", "--out"),
                            (tmp_path / "b.txt", "b", "--plot")])
    assert (tmp_path / "a.csv").read_text() == "new a" and (tmp_path / "b.txt").read_text() == "b"


def test_os_error_while_writing_is_input_error(tmp_path):
    def full(tmp):
        raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match=r"--plot .*b.png: cannot write it \(No space left"):
        write_atomically(tmp_path / "b.png", full, "--plot")
    assert _listing(tmp_path) == []


def test_forces_writes_both_files_and_replaces_old_ones(tmp_path, capsys):
    out, png = tmp_path / "f.csv", tmp_path / "f.PNG"
    out.write_text("old")
    assert main(FORCES + ["--out", str(out), "--plot", str(png)]) == 0
    assert out.read_text().startswith("angle_deg,")
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert _listing(tmp_path) == ["f.PNG", "f.csv"]
    assert f"wrote {out} (36 angles)" in capsys.readouterr().out


def test_forces_plot_failure_leaves_nothing(tmp_path, capsys, monkeypatch):
    import feedopt.commands.forces as forces

    def broken(*_args):
        raise RuntimeError("matplotlib broke")

    monkeypatch.setattr(forces, "_draw", broken)
    out = tmp_path / "f.csv"
    assert main(FORCES + ["--out", str(out), "--plot", str(tmp_path / "f.png")]) == 1
    assert _listing(tmp_path) == []
    assert "wrote" not in capsys.readouterr().out


def test_path_writes_csv_and_svg(tmp_path, capsys):
    out, svg = tmp_path / "p.csv", tmp_path / "p.svg"
    args = ["path", "builtin:line", "--blend", "none", "--spacing", "5", "--out", str(out),
            "--plot", str(svg)]
    assert main(args) == 0
    assert out.read_text().startswith("s_mm,") and b"<svg" in svg.read_bytes()[:400]
    assert _listing(tmp_path) == ["p.csv", "p.svg"]


def test_validate_schema_out_replaces_atomically(tmp_path, capsys):
    out = tmp_path / "ref.md"
    out.write_text("old")
    assert main(["validate", "--schema", "--out", str(out)]) == 0
    assert out.read_text().startswith("#") and _listing(tmp_path) == ["ref.md"]
