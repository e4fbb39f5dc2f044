"""The output folder of a sweep: :mod:`feedopt.outdir`'s rules, plus resuming.

A run is written into a staging folder and moved into place whole; a sweep cannot be, since
an interrupted sweep must leave its table where the next one resumes from. So a sweep writes
into its folder directly, under the same promises: the folder must be new, empty, or a
previous feedopt output (its :data:`feedopt.outdir.MARKER` lists every file feedopt wrote
there, and nothing else is in it); it is never the current directory, the scenario's folder
or a parent of them; no file feedopt did not write is touched. The marker is a run's own
(:func:`feedopt.outdir.write_marker`), written first, listing every file the sweep may write
(itself included), so even a sweep killed at once leaves a folder the next one recognises.

- A previous sweep of the same inputs (same scenario and files, laws, spacing and columns,
  recorded in ``sweep.json``) is resumed: points already in its table are not evaluated
  again (``error`` rows are retried); the grid's values may differ. Its best.json and plots
  are removed first and drawn again at the end.
- A previous sweep of other inputs, or a ``feedopt run`` output, is refused, naming what
  differs, unless ``restart``: then the files its marker lists are removed first.

While a sweep writes, it holds an exclusive lock on the folder: a second sweep into the same
folder is refused instead of interleaving rows.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from feedopt import outdir
from feedopt.errors import InputError
from feedopt.outfile import write_atomically

TABLE = "sweep.csv"
SPEC = "sweep.json"
BEST = "best.json"
#: Entries of sweep.json that must match for a sweep to resume another one's table.
COMPATIBLE = ("digest", "laws", "spacing_mm", "columns")


@dataclass
class FolderPlan:
    """What opening the folder will do, decided before any work."""

    out: Path
    files: list[str]
    fresh: bool  # start a new table (new, empty, or --restart)
    remove: list[str] = field(default_factory=list)  # our files to remove first (--restart)
    stale: list[str] = field(default_factory=list)  # temporary files a killed sweep left


def _read_spec(path: Path) -> dict | None:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def _is_temporary_of(name: str, files: Sequence[str]) -> bool:
    """``name`` is a temporary file :func:`feedopt.outfile.write_atomically` makes for one
    of ``files`` (left behind only by a killed process)."""
    for f in files:
        stem, suffix = os.path.splitext(f)
        if name.startswith(f".{stem}.feedopt-") and name.endswith(suffix):
            return True
    return False


def check_folder(out: Path, protected: Sequence[Path], spec: dict, files: Sequence[str],
                 restart: bool, inputs: Sequence[Path] = ()) -> FolderPlan:
    """Decide what the sweep may do to ``out``; InputError when it must not touch it.

    Writes nothing. ``spec`` is this sweep's sweep.json (its :data:`COMPATIBLE` entries
    decide whether a previous sweep's table can be resumed); ``files`` every file name the
    sweep may write; ``inputs`` the files the scenario reads (never inside ``out``).
    """
    kind = outdir.check_destination(out, protected, overwrite=True, inputs=inputs)
    target = out.resolve()
    files = [*files, outdir.MARKER]
    if kind in (outdir.DestinationKind.NEW, outdir.DestinationKind.EMPTY):
        return FolderPlan(target, list(files), fresh=True)
    entries = outdir.foreign_entries(target)
    stale = [n for n in entries if _is_temporary_of(n, files)]
    foreign = [n for n in entries if n not in stale]
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5
                                          else "")
        raise InputError(f"--out {out} already holds files feedopt did not write ({shown}). "
                         "Nothing was changed. Choose a new or empty folder (a sweep resumes "
                         "from its own folder, so it never writes into a folder of yours)")
    own = sorted(p.name for p in target.iterdir() if p.name not in stale
                 and p.name != outdir.MARKER)
    previous = _read_spec(target / SPEC)
    if restart:
        return FolderPlan(target, list(files), fresh=True, remove=own, stale=stale)
    if previous is None or "digest" not in previous:
        raise InputError(f"--out {out} holds the output of another feedopt command, not a "
                         "sweep. Nothing was changed. Choose another folder, or pass --restart "
                         "to replace it")
    differ = [k for k in COMPATIBLE if previous.get(k) != spec.get(k)]
    if differ:
        what = {"digest": "the scenario or one of its files", "laws": "the laws",
                "spacing_mm": "the sample spacing", "columns": "the swept fields or metrics"}
        changed = ", ".join(what[k] for k in differ)
        raise InputError(f"--out {out} holds a sweep of other inputs ({changed} "
                         "changed), whose table cannot be resumed. Nothing was changed. Choose "
                         "another folder, or pass --restart to replace that sweep")
    # best.json and the plots of the earlier sweep are stale now: drawn again at the end
    return FolderPlan(target, list(files), fresh=False, stale=stale,
                      remove=[n for n in own if n not in (TABLE, SPEC)])


@dataclass
class OpenFolder:
    """A folder the sweep writes into, locked until :meth:`close`."""

    path: Path
    fd: int

    def close(self) -> None:
        os.close(self.fd)


def open_folder(plan: FolderPlan, spec: dict) -> OpenFolder:
    """Create or take over the folder as ``plan`` says, lock it, write the marker and
    sweep.json. Removes only feedopt's own files (``plan.remove``, ``plan.stale``)."""
    plan.out.mkdir(parents=True, exist_ok=True)
    fd = os.open(plan.out, os.O_RDONLY)
    try:
        try:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # not POSIX: no lock
            pass
        except OSError:
            raise InputError(f"--out {plan.out}: another feedopt sweep is writing into it; "
                             "wait for it or choose another folder") from None
        for name in plan.stale + plan.remove:
            p = plan.out / name
            if p.is_file() or p.is_symlink():
                p.unlink()
        outdir.write_marker(plan.out, plan.files)
        write_spec(plan.out, spec)
    except BaseException:
        os.close(fd)
        raise
    return OpenFolder(plan.out, fd)


def write_spec(folder: Path, spec: dict) -> None:
    """Write sweep.json (atomic)."""
    text = json.dumps(spec, indent=1, default=float, allow_nan=False)
    write_atomically(folder / SPEC, text + "\n")
