"""Property: any --out name is a checked target (Path / DestinationKind) or one InputError,
and checking it creates nothing."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.outdir import DestinationKind, check_destination
from feedopt.outfile import check_output_file, plot_suffixes

from ._support import budget, tree

DEPTH = 6  # the names are tried from tmp_path/d0/.../d5; at most DEPTH - 1 '..' stay inside

segment = st.one_of(
    st.text(st.characters(blacklist_characters="/"), min_size=1, max_size=12),
    st.sampled_from(["..", ".", "", "out", "a.csv", "x.png", "y.PDF", ".hidden", "~", "con",
                     "existing", "existing/file.txt", "\0", "x\0y", "\u00e9t\u00e9.csv",
                     "\U0001f600.svg", " ", "-", "--out"]),
    st.integers(250, 300).map(lambda n: "n" * n),  # around NAME_MAX (255 bytes)
)
relative_names = st.lists(segment, min_size=1, max_size=5).map("/".join)
raw_names = st.text(max_size=40)
system_names = st.one_of(
    st.sampled_from(["/proc", "/proc/self", "/proc/self/status", "/proc/version", "/sys",
                     "/sys/kernel", "/dev/null", "/dev/zero", "/dev/stdout"]),
    st.builds(lambda base, s: f"{base}/{s}",
              st.sampled_from(["/proc", "/proc/self", "/proc/self/fd", "/sys", "/sys/kernel"]),
              st.text(st.characters(blacklist_characters="/\0"), min_size=1, max_size=10)),
)


def _inside(name: str) -> bool:
    """True if ``name`` stays below tmp_path (relative, fewer than DEPTH '..')."""
    return not name.startswith("/") and name.split("/").count("..") < DEPTH


@contextlib.contextmanager
def _workdir(tmp_path: Path):
    top = tmp_path / "top"
    work = top.joinpath(*(f"d{i}" for i in range(DEPTH)))
    if not work.exists():
        work.mkdir(parents=True)
        (work / "existing").mkdir()
        (work / "existing" / "file.txt").write_text("keep")
        (work / "a.csv").write_text("keep")
        os.mkfifo(work / "fifo")
    with contextlib.chdir(work):
        yield top


def _check_file(name, suffixes):
    try:
        target = check_output_file(name, "--out", suffixes)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert isinstance(target, Path) and target.is_absolute()


def _check_dir(name, overwrite):
    try:
        kind = check_destination(Path(name), [Path.cwd(), Path.cwd() / "existing"], overwrite)
    except InputError as exc:
        assert str(exc).strip()
        return
    assert isinstance(kind, DestinationKind)


SUFFIXES = st.sampled_from([None, None, (".csv",), "plots"])


@budget(150)
@given(name=st.one_of(relative_names, raw_names).filter(_inside), suffixes=SUFFIXES)
def test_output_file_names(tmp_path, name, suffixes):
    with _workdir(tmp_path) as top:
        before = tree(top)
        _check_file(name, plot_suffixes() if suffixes == "plots" else suffixes)
        assert tree(top) == before


@budget(40)
@given(name=system_names, suffixes=SUFFIXES)
def test_output_file_system_names(tmp_path, name, suffixes):
    with _workdir(tmp_path):
        _check_file(name, plot_suffixes() if suffixes == "plots" else suffixes)


@budget(150)
@given(name=st.one_of(relative_names, raw_names).filter(_inside), overwrite=st.booleans())
def test_destination_names(tmp_path, name, overwrite):
    with _workdir(tmp_path) as top:
        before = tree(top)
        _check_dir(name, overwrite)
        assert tree(top) == before


@budget(40)
@given(name=system_names, overwrite=st.booleans())
def test_destination_system_names(tmp_path, name, overwrite):
    with _workdir(tmp_path):
        _check_dir(name, overwrite)
