"""Output folders that never destroy a user's files.

A run writes into a hidden staging folder beside its destination and moves it into place
only when everything succeeded. What may be replaced is decided before any planning:

- a destination that does not exist, or an empty folder, is simply created / filled;
- a previous feedopt output (it holds :data:`MARKER`, a JSON list of the files that run
  wrote, and nothing else) is replaced as a whole, atomically (rename, then delete the old);
- any other existing folder is refused unless ``overwrite`` is given; then feedopt writes its
  files into it, replacing only files of the same names and keeping every other file;
- a destination that is a file, or that is the current directory, the scenario's folder or
  one of their parents, or that is or holds one of the run's input files (tool, material,
  path file, stock mesh, robot files), is always refused, ``overwrite`` or not.

Staging folders carry :data:`STAGING_MARKER` with the pid of their run, so a later run can
remove the ones a killed run (SIGKILL, power loss) left behind, and nothing else.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from feedopt import __version__
from feedopt.errors import InputError
from feedopt.textio import read_user_text

#: Written into every output folder: which files feedopt wrote there.
MARKER = ".feedopt-output.json"
#: Written into every staging folder: the pid of the run that owns it.
STAGING_MARKER = ".feedopt-staging"
#: Largest marker read: far more than a run's list of files.
MAX_MARKER_BYTES = 2**20


class DestinationKind(Enum):
    """What committing a run will do to the destination."""

    NEW = "new"  # does not exist yet
    EMPTY = "empty"  # an existing empty folder
    REPLACE_OWN = "replace_own"  # a previous feedopt output, replaced as a whole
    WRITE_INTO = "write_into"  # a foreign folder, --overwrite: same-named files replaced


@dataclass(frozen=True)
class Destination:
    """A checked output location and the staging folder the run writes into."""

    out: Path
    staging: Path
    kind: DestinationKind
    created_parents: tuple[Path, ...]


def _is_same_or_parent(candidate: Path, of: Path) -> bool:
    return candidate == of or candidate in of.parents


def _own_files(folder: Path) -> set[str] | None:
    """Names listed in ``folder``'s marker, or None if it has no readable marker."""
    marker = folder / MARKER
    try:  # the capped reader: a FIFO or a huge file of that name is not ours (and not opened)
        doc = json.loads(read_user_text(marker, "output marker", max_bytes=MAX_MARKER_BYTES))
        files = doc["files"]
    except (InputError, ValueError, KeyError, TypeError, RecursionError):
        return None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return set(files)


def write_marker(folder: Path, files: Iterable[str]) -> None:
    """Write ``folder``'s :data:`MARKER` (atomically): the feedopt version and the sorted
    names of ``files``, every file feedopt wrote there. The one marker of every output folder:
    a run's (:func:`commit`) and a sweep's (:mod:`feedopt.sweep.folder`)."""
    from feedopt.outfile import write_atomically

    write_atomically(folder / MARKER, json.dumps(
        {"feedopt": __version__, "files": sorted(files)}, indent=1) + "\n")


def foreign_entries(folder: Path) -> list[str]:
    """Entries of ``folder`` that no feedopt run recorded writing (empty list: all ours)."""
    own = _own_files(folder)
    names = sorted(p.name for p in folder.iterdir())
    if own is None:
        return names
    return [n for n in names if n != MARKER and (n not in own or (folder / n).is_dir())]


def _describe(names: list[str], limit: int = 5) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _input_inside(target: Path, inputs: Iterable[Path]) -> str | None:
    """How ``target`` meets the first of ``inputs`` that is it or inside it (as named, or
    with its symbolic links resolved): ``"is the input file X"``, ``"holds ..."``; or None."""
    for inp in inputs:
        named = Path(os.path.abspath(inp))
        try:
            real = named.resolve()
        except (OSError, RuntimeError):  # a link loop: its name is what counts
            real = named
        if target in (named, real):
            return f"is the input file {inp}"
        if any(_is_same_or_parent(target, p) for p in (named, real)):
            return f"holds the input file {inp}"
    return None


def check_destination(out: Path, protected: Iterable[Path], overwrite: bool,
                      inputs: Iterable[Path] = ()) -> DestinationKind:
    """Decide what a run may do to ``out``; InputError when it must not touch it.

    ``protected`` are folders whose contents a run must never replace (the current directory,
    the scenario's folder): ``out`` may be inside them, never equal to or above them.
    ``inputs`` are the files the run reads (the scenario, its tool, material, path, stock and
    robot files): ``out`` may not be one of them nor hold one, with or without ``overwrite``.
    """
    from feedopt.outfile import check_name

    check_name(str(out), f"--out {str(out)[:60]}")
    target = out.resolve()
    for p in protected:
        p = p.resolve()
        if _is_same_or_parent(target, p):
            what = "the current directory" if p == Path.cwd().resolve() else f"folder {p}"
            rel = "is" if target == p else "contains"
            raise InputError(
                f"--out {out} {rel} {what}, which holds your files (the scenario, its inputs); "
                "feedopt writes its results into a folder of their own: choose a new folder "
                f"such as {out / 'feedopt_out' if target == p else 'out/<name>'}")
    held = _input_inside(target, inputs)
    if held is not None:
        raise InputError(
            f"--out {out} {held} of this run: feedopt never writes over or replaces its "
            "inputs (not even with --overwrite); choose a new folder such as out/<name>")
    if target.exists() and not target.is_dir():
        raise InputError(f"--out {out} is an existing file, not a folder: choose a folder name "
                         "(it is created if missing)")
    if not target.exists():
        return DestinationKind.NEW
    try:
        entries = list(target.iterdir())
    except OSError as exc:
        raise InputError(f"--out {out}: cannot list the folder ({exc.strerror})") from None
    if not entries:
        return DestinationKind.EMPTY
    foreign = foreign_entries(target)
    if not foreign:
        return DestinationKind.REPLACE_OWN
    if overwrite:
        return DestinationKind.WRITE_INTO
    how = ("it is not a feedopt output (no " + MARKER + ")" if _own_files(target) is None
           else "these were not written by feedopt")
    raise InputError(
        f"--out {out} already holds files feedopt did not write ({_describe(foreign)}): "
        f"{how}. Nothing was changed. Choose a new or empty folder, or pass --overwrite to "
        "write feedopt's files into it (files of the same names are replaced, all others kept)")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def remove_stale_staging(parent: Path, name: str, tag: str = "feedopt") -> list[Path]:
    """Remove staging folders for ``name`` in ``parent`` (:func:`staging_folder` with
    ``tag``) whose run is no longer alive (killed before it could clean up)."""
    removed = []
    for folder in parent.glob(f".{name}.{tag}-*"):
        mark = folder / STAGING_MARKER
        try:
            pid = int(read_user_text(mark, "staging marker", max_bytes=64).strip())
        except (InputError, ValueError):
            continue  # not one of ours, or unreadable: leave it alone
        if pid != os.getpid() and not _pid_alive(pid):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def open_destination(out: Path, protected: Iterable[Path], overwrite: bool,
                     inputs: Iterable[Path] = ()) -> Destination:
    """Check ``out`` (see :func:`check_destination`) and create its staging folder now,
    before any planning.

    Creating the staging folder is the writability check: a read-only or impossible location
    fails here with a clear message instead of after minutes of planning.
    """
    kind = check_destination(out, protected, overwrite, inputs)
    target = out.resolve()
    created: list[Path] = []
    missing = [p for p in [target.parent, *target.parent.parents] if not p.exists()]
    try:
        for p in reversed(missing):
            p.mkdir()
            created.append(p)
        staging = staging_folder(target, "feedopt")
    except OSError as exc:
        for p in reversed(created):
            _rmdir_quiet(p)
        reason = exc.strerror or type(exc).__name__
        raise InputError(
            f"--out {out}: cannot write in {target.parent} ({reason}); choose a folder you can "
            "write to") from None
    return Destination(out=target, staging=staging, kind=kind, created_parents=tuple(created))


def staging_folder(target: Path, tag: str) -> Path:
    """A fresh hidden folder beside ``target`` to write into and rename to it at the end
    (the stale ones of killed runs removed first; its marker names this process), with the
    mode ``mkdir`` would give it (0777 less the umask; ``mkdtemp``'s 0700 would
    make a run's output unreadable to the rest of a shared project folder)."""
    remove_stale_staging(target.parent, target.name, tag)
    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.{tag}-", dir=target.parent))
    mask = os.umask(0o022)
    os.umask(mask)
    staging.chmod(0o777 & ~mask)
    (staging / STAGING_MARKER).write_text(f"{os.getpid()}\n", encoding="utf-8")
    return staging


def _rmdir_quiet(path: Path) -> None:
    try:
        path.rmdir()
    except OSError:
        pass


def discard(dest: Destination) -> None:
    """Remove the staging folder (and parents this run created, if empty): a failed run."""
    shutil.rmtree(dest.staging, ignore_errors=True)
    if not dest.out.exists():
        for p in reversed(dest.created_parents):
            _rmdir_quiet(p)


def commit(dest: Destination) -> Path:
    """Move the staged outputs into place according to ``dest.kind``; returns ``dest.out``."""
    staging, out = dest.staging, dest.out
    (staging / STAGING_MARKER).unlink()
    written = sorted(p.name for p in staging.iterdir())
    write_marker(staging, written)
    if dest.kind is DestinationKind.NEW:
        staging.rename(out)
    elif dest.kind is DestinationKind.EMPTY:
        out.rmdir()  # fails (OSError) if a file appeared meanwhile: nothing is lost
        staging.rename(out)
    elif dest.kind is DestinationKind.REPLACE_OWN:
        foreign = foreign_entries(out)
        if foreign:  # a file appeared after the check: keep it, refuse
            raise InputError(f"--out {out}: files appeared while planning "
                             f"({_describe(foreign)}); nothing was replaced")
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.feedopt-old-", dir=out.parent))
        old.rmdir()
        out.rename(old)
        try:
            staging.rename(out)
        except OSError:
            old.rename(out)
            raise
        shutil.rmtree(old, ignore_errors=True)
    else:  # WRITE_INTO: replace same-named files only, record what is ours
        previous = _own_files(out) or set()
        for name in written + [MARKER]:
            target = out / name
            if target.is_dir():
                raise InputError(f"--out {out}: {name} is a folder there; feedopt would "
                                 "write a file of that name: move it or choose another folder")
        for name in written:
            os.replace(staging / name, out / name)
        for name in sorted(previous - set(written)):  # ours from an earlier run, now stale
            stale = out / name
            if stale.is_file():
                stale.unlink()
        os.replace(staging / MARKER, out / MARKER)
        shutil.rmtree(staging, ignore_errors=True)
    return out
