"""Output folders never lose a user's file (issue 19): feedopt.outdir on its own."""

import json
import os
import subprocess
import sys

import pytest

from feedopt import outdir
from feedopt.errors import InputError
from feedopt.outdir import MARKER, STAGING_MARKER, DestinationKind


def _stage(dest: outdir.Destination, files: dict[str, str]) -> None:
    for name, text in files.items():
        (dest.staging / name).write_text(text)


def test_new_destination_gets_files_and_marker(tmp_path) -> None:
    out = tmp_path / "a" / "b" / "run"
    dest = outdir.open_destination(out, protected=[tmp_path / "scen"], overwrite=False)
    assert dest.kind is DestinationKind.NEW
    _stage(dest, {"x.csv": "1", "summary.json": "{}"})
    outdir.commit(dest)
    assert sorted(p.name for p in out.iterdir()) == sorted([MARKER, "x.csv", "summary.json"])
    assert json.loads((out / MARKER).read_text())["files"] == ["summary.json", "x.csv"]
    assert not any(p.name.startswith(".run.") for p in out.parent.iterdir())


def test_previous_output_is_replaced_as_a_whole(tmp_path) -> None:
    out = tmp_path / "run"
    for files in ({"old.csv": "1", "summary.json": "a"}, {"summary.json": "b"}):
        dest = outdir.open_destination(out, protected=[], overwrite=False)
        _stage(dest, files)
        outdir.commit(dest)
    assert (out / "summary.json").read_text() == "b"
    assert not (out / "old.csv").exists()  # ours, from the earlier run: gone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no staging / old left


def test_folder_with_a_user_file_is_refused_and_untouched(tmp_path) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis_notes.txt").write_text("precious")
    with pytest.raises(InputError, match=r"thesis_notes.txt.*--overwrite"):
        outdir.open_destination(out, protected=[], overwrite=False)
    assert (out / "thesis_notes.txt").read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_user_file_added_to_a_previous_output_is_refused(tmp_path) -> None:
    out = tmp_path / "run"
    dest = outdir.open_destination(out, protected=[], overwrite=False)
    _stage(dest, {"summary.json": "a"})
    outdir.commit(dest)
    (out / "my_analysis.py").write_text("keep")
    with pytest.raises(InputError, match="my_analysis.py"):
        outdir.open_destination(out, protected=[], overwrite=False)


def test_overwrite_replaces_same_names_and_keeps_the_rest(tmp_path) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    (out / "summary.json").write_text("user's own summary")
    dest = outdir.open_destination(out, protected=[], overwrite=True)
    assert dest.kind is DestinationKind.WRITE_INTO
    _stage(dest, {"summary.json": "feedopt", "a.csv": "1"})
    outdir.commit(dest)
    assert (out / "keep.txt").read_text() == "precious"
    assert (out / "summary.json").read_text() == "feedopt"
    # The next overwrite run removes only its own stale file, never keep.txt.
    dest = outdir.open_destination(out, protected=[], overwrite=True)
    _stage(dest, {"summary.json": "feedopt 2"})
    outdir.commit(dest)
    assert sorted(p.name for p in out.iterdir()) == sorted([MARKER, "keep.txt", "summary.json"])


@pytest.mark.parametrize("which", ["same", "parent"])
def test_protected_folders_and_their_parents_are_refused(tmp_path, which) -> None:
    scen = tmp_path / "job" / "scenarios"
    scen.mkdir(parents=True)
    out = scen if which == "same" else tmp_path / "job"
    with pytest.raises(InputError, match="holds your files"):
        outdir.open_destination(out, protected=[scen], overwrite=True)


def test_existing_file_is_refused(tmp_path) -> None:
    f = tmp_path / "result"
    f.write_text("x")
    with pytest.raises(InputError, match="existing file"):
        outdir.open_destination(f, protected=[], overwrite=True)
    assert f.read_text() == "x"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_parent_fails_before_any_work(tmp_path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(InputError, match="cannot write"):
            outdir.open_destination(ro / "run", protected=[], overwrite=False)
    finally:
        ro.chmod(0o755)


def test_unwritable_location_fails_before_any_work(tmp_path) -> None:
    with pytest.raises(InputError, match="cannot write"):
        outdir.open_destination(__import__("pathlib").Path("/proc/feedopt_run"), protected=[],
                                overwrite=False)


def test_failed_run_leaves_nothing_not_even_created_parents(tmp_path) -> None:
    out = tmp_path / "new_parent" / "run"
    dest = outdir.open_destination(out, protected=[], overwrite=False)
    _stage(dest, {"half.csv": "1"})
    outdir.discard(dest)
    assert list(tmp_path.iterdir()) == []


def test_stale_staging_of_a_dead_run_is_removed_and_others_are_kept(tmp_path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / ".run.feedopt-abc"
    stale.mkdir()
    (stale / STAGING_MARKER).write_text(dead.stdout)
    (stale / "partial.csv").write_text("1")
    alive = tmp_path / ".run.feedopt-live"
    alive.mkdir()
    (alive / STAGING_MARKER).write_text(f"{os.getppid()}\n")
    lookalike = tmp_path / ".run.feedopt-user"  # no marker: not ours, never removed
    lookalike.mkdir()
    removed = outdir.remove_stale_staging(tmp_path, "run")
    assert removed == [stale]
    assert alive.exists() and lookalike.exists()


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_the_output_folder_has_the_mode_mkdir_would_give_it(tmp_path, mask) -> None:
    old = os.umask(mask)
    try:
        out = tmp_path / f"run{mask:o}"
        dest = outdir.open_destination(out, protected=[], overwrite=False)
        _stage(dest, {"x.csv": "1"})
        outdir.commit(dest)
        (tmp_path / "plain").mkdir(exist_ok=True)
        want = (tmp_path / "plain").stat().st_mode & 0o777
        (tmp_path / "plain").rmdir()
    finally:
        os.umask(old)
    assert out.stat().st_mode & 0o777 == want == 0o777 & ~mask


def test_a_killed_robot_init_is_cleaned_by_the_next(tmp_path, capsys) -> None:
    from pathlib import Path

    from feedopt.cli import main

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / ".r.robot-init-abc"  # what a SIGKILLed init leaves
    stale.mkdir()
    (stale / STAGING_MARKER).write_text(dead.stdout)
    urdf = Path(__file__).parent / "data" / "robots" / "published" / "kr120r2500pro.urdf"
    assert main(["robot", "init", str(urdf), "--out", str(tmp_path / "r")]) == 0
    assert not stale.exists()
    assert sorted(p.name for p in (tmp_path / "r").iterdir()) == ["kr120r2500pro.urdf",
                                                                  "robot.yaml"]
