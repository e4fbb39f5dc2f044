"""Reading the text files users hand us (YAML, CSV, JSON, G-code) with one clear error each.

Every user text file goes through :func:`read_user_text` (YAML files through
:func:`feedopt.yamlio.read_yaml`, which calls it). Before a byte is read the path is
inspected with :func:`os.stat`: a missing file, a dangling link, a symbolic link loop, a
folder, a named pipe (FIFO), a device or a socket each get their own message, and a file
larger than the cap of its kind (:data:`MAX_BYTES_BY_KIND`, :data:`MAX_TEXT_BYTES` for other
kinds) is refused with its size, the cap and the file, before any parsing. A FIFO is never
opened (opening one blocks until a writer comes); the file is opened non-blocking and checked
again on the open descriptor, and at most cap + 1 bytes are read, so a file that is replaced
or grows meanwhile cannot make the reader block or read without bound.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from feedopt.errors import InputError

MIB = 2**20

#: Largest user text file of a kind not in :data:`MAX_BYTES_BY_KIND` (a G-code program of a
#: long job, a long waypoint file are far smaller; a larger file is a mistake).
MAX_TEXT_BYTES = 512 * MIB

#: Largest file of each kind, by the name its reader gives it (``what``). A scenario, tool,
#: material or robot file is hand-written and a few KiB: more than a few MiB is a wrong file
#: (an all-comment 500 MB scenario took validate minutes to parse). Data files get room for
#: the largest input the commands plan: an RSI CSV of the longest exported trajectory
#: (feedopt.outputs.MAX_CONTROLLER_ROWS rows of ~250 bytes).
MAX_BYTES_BY_KIND: dict[str, int] = {
    "scenario file": 4 * MIB,
    "tool": 1 * MIB,
    "tool file": 1 * MIB,
    "coefficients": 4 * MIB,
    "material file": 4 * MIB,
    "robot file": 4 * MIB,
    "run summary": 16 * MIB,
    "forces CSV": 16 * MIB,
    "load-test CSV": 16 * MIB,
    "URDF": 64 * MIB,
    "waypoint file": 256 * MIB,
    "G-code program": 512 * MIB,
    "RSI CSV": 3 * 2**30,
}

#: Bytes read per call (a read of cap + 1 bytes would allocate the whole cap up front).
_CHUNK = 8 * MIB


def max_bytes_for(what: str) -> int:
    """The size cap [bytes] of a text input of kind ``what`` (see :data:`MAX_BYTES_BY_KIND`)."""
    return MAX_BYTES_BY_KIND.get(what, MAX_TEXT_BYTES)


def format_size(n_bytes: int) -> str:
    """``n_bytes`` for a message: bytes, KiB, MiB or GiB with the exact count."""
    for unit, scale in (("GiB", 2**30), ("MiB", MIB), ("KiB", 2**10)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.1f} {unit} ({n_bytes:,} bytes)"
    return f"{n_bytes:,} bytes"


def _too_big(p: Path, what: str, size: str, limit: int) -> InputError:
    return InputError(
        f"{what} {p} is {size}, more than the {format_size(limit)} a {what} may have: is it "
        "the right file? (a larger one is refused before it is parsed)")


def _kind_error(p: Path, what: str, mode: int) -> InputError | None:
    """The refusal of a path that is not a regular file (``mode``: its ``st_mode``)."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return InputError(f"{what} {p} is a folder, not a file: give the file in it")
    if stat.S_ISFIFO(mode):
        kind = "a named pipe (FIFO); feedopt reads its inputs whole and never from a pipe"
    elif stat.S_ISCHR(mode):
        kind = "a character device (like /dev/zero or a terminal)"
    elif stat.S_ISBLK(mode):
        kind = "a block device (a disk)"
    elif stat.S_ISSOCK(mode):
        kind = "a socket"
    else:
        kind = "not a regular file"
    return InputError(f"{what} {p} is not a regular file but {kind}: save the data to a file "
                      "and give that")


def _stat_error(p: Path, what: str, exc: OSError, missing_hint: str) -> InputError:
    """The message for an :func:`os.stat` of ``p`` that failed with ``exc``."""
    if exc.errno == errno.ELOOP:
        return InputError(f"{what} {p} is a symbolic link loop (the links point at each other, "
                          "never at a file): give the file itself")
    if exc.errno == errno.ENOENT:
        if os.path.islink(p):
            return InputError(f"{what} {p} is a symbolic link to {os.readlink(p)}, which does "
                              f"not exist (a dangling link){missing_hint}")
        return InputError(f"{what} {p} does not exist{missing_hint}")
    if exc.errno == errno.ENOTDIR:
        return InputError(f"{what} {p} does not exist: a part of the path is a file, not a "
                          "folder")
    if exc.errno in (errno.EACCES, errno.EPERM):
        return InputError(f"cannot read {what} {p}: permission denied")
    return InputError(f"cannot read {what} {p}: {exc.strerror or exc}")


def _read_at_most(fd: int, limit: int) -> bytes:
    """Up to ``limit`` + 1 bytes of ``fd`` (one more than the cap shows a file that grew)."""
    parts, total = [], 0
    while total <= limit:
        chunk = os.read(fd, min(_CHUNK, limit + 1 - total))
        if not chunk:
            break
        parts.append(chunk)
        total += len(chunk)
    return b"".join(parts)


def read_user_bytes(path: str | Path, what: str, max_bytes: int | None = None,
                    missing_hint: str = "") -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    Parameters
    ----------
    path, what
        The file and what it is (``"scenario file"``, ``"tool"``...), named in every message.
    max_bytes
        The cap; default :func:`max_bytes_for` ``(what)``.
    missing_hint
        Appended to the message of a missing file (what to give instead).

    Raises
    ------
    InputError
        Missing, a dangling link or a link loop, not a regular file (folder, FIFO, device,
        socket), larger than the cap, or unreadable. A FIFO is refused without opening it.
    """
    p = Path(path)
    limit = max_bytes_for(what) if max_bytes is None else max_bytes
    try:
        st = os.stat(p)
    except OSError as exc:
        raise _stat_error(p, what, exc, missing_hint) from None
    except ValueError:  # a NUL byte in the name
        raise InputError(f"{what} {str(p)!r}: the name contains a NUL byte") from None
    problem = _kind_error(p, what, st.st_mode)
    if problem is not None:
        raise problem
    if st.st_size > limit:
        raise _too_big(p, what, format_size(st.st_size), limit)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(p, flags)
    except OSError as exc:
        raise _stat_error(p, what, exc, missing_hint) from None
    try:
        problem = _kind_error(p, what, os.fstat(fd).st_mode)  # replaced since the stat
        if problem is not None:
            raise problem
        data = _read_at_most(fd, limit)
    except OSError as exc:
        raise InputError(f"cannot read {what} {p}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    if len(data) > limit:
        raise _too_big(p, what, f"more than {format_size(limit)} (it grew while read)", limit)
    return data


def read_user_text(path: str | Path, what: str, encoding: str = "utf-8",
                   missing_hint: str = "", max_bytes: int | None = None) -> str:
    """Text of ``path`` (see :func:`read_user_bytes` for the checks and the cap).

    ``encoding="utf-8-sig"`` also accepts a byte-order mark (spreadsheet exports). Line ends
    are read as Python's text mode reads them: ``\\r\\n`` and ``\\r`` become ``\\n``.
    """
    data = read_user_bytes(path, what, max_bytes, missing_hint)
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{what} {path} is not UTF-8 text (undecodable byte at offset {exc.start}): is it "
            "the right file? Save it as UTF-8 text") from None
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text
