"""Reading the text files users hand us (CSV, JSON) with one clear error for each failure."""

from __future__ import annotations

from pathlib import Path

from feedopt.errors import InputError

#: Largest user text file read (a scenario, a waypoint CSV, a G-code program of a long job are
#: far smaller; a larger file is a mistake, or /dev/zero).
MAX_TEXT_BYTES = 512 * 2**20


def read_user_text(path: str | Path, what: str, encoding: str = "utf-8",
                   missing_hint: str = "") -> str:
    """Text of ``path``; InputError naming ``what`` and the file if it is missing or unreadable.

    ``encoding="utf-8-sig"`` also accepts a byte-order mark (spreadsheet exports).
    """
    p = Path(path)
    try:
        if p.exists() and not p.is_dir() and not p.is_file():
            raise InputError(f"{what} {p} is not a regular file (a device, pipe or socket): give "
                             "a file")
        if p.is_file() and p.stat().st_size > MAX_TEXT_BYTES:
            raise InputError(f"{what} {p} is {p.stat().st_size / 2**20:.0f} MiB, more than the "
                             f"{MAX_TEXT_BYTES / 2**20:.0f} MiB a text input may have")
        return p.read_text(encoding=encoding)
    except FileNotFoundError:
        raise InputError(f"{what} {p} does not exist{missing_hint}") from None
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{what} {p} is not UTF-8 text (undecodable byte at offset {exc.start}): is it the "
            "right file? Save it as UTF-8 text") from None
    except IsADirectoryError:
        raise InputError(f"{what} {p} is a folder, not a file") from None
    except OSError as exc:
        raise InputError(f"cannot read {what} {p}: {exc.strerror or exc}") from None
