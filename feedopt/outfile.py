"""Single output files (``--out FILE``, ``--plot FILE``) that are checked first and written whole.

The commands that write one file per option (``path``, ``forces``, ``calibrate``,
``validate --schema``) check every destination with :func:`check_output_file` before any
work: the folder exists and is a folder, the target is not a folder, a device or one of the
command's input files, and a file can be created there (a temporary file is created and
removed beside the target, which is what catches read-only folders and ``/proc``/``/sys``).
Each failure is an :class:`~feedopt.errors.InputError` (exit code 2) that names the option
and says what would work.

:func:`write_atomically` (and :func:`write_files_atomically` for several files of one
command) writes into a hidden temporary file in the target's folder and moves it into place
with :func:`os.replace`: a failure or an interrupt at any point removes the temporary file
and leaves a previous file of that name untouched. The temporary file keeps the target's
extension, so writers that choose the format by extension (matplotlib, ``numpy.savetxt`` with
``.gz``) write what the target name asks for. :mod:`feedopt.outdir` does the same for the
output folder of ``feedopt run``.
"""

from __future__ import annotations

import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from feedopt.errors import InputError

#: A writer: a callable that writes the whole file at the path it is given, or the text itself.
Writer = Callable[[Path], object] | str

#: Formats matplotlib can write only with an external program: (extension, rcParams key).
_NEEDS_PROGRAM = {"pgf": "pgf.texsystem"}


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def plot_suffixes() -> tuple[str, ...]:
    """Extensions (with the dot, sorted) that matplotlib can save a figure as here.

    The formats of :meth:`FigureCanvasBase.get_supported_filetypes`, without those that need
    a program that is not installed (``.pgf`` needs the LaTeX of ``rcParams["pgf.texsystem"]``).
    """
    import matplotlib
    from matplotlib.backend_bases import FigureCanvasBase

    out = []
    for ext in FigureCanvasBase.get_supported_filetypes():
        key = _NEEDS_PROGRAM.get(ext)
        if key is not None and shutil.which(str(matplotlib.rcParams[key])) is None:
            continue
        out.append(f".{ext}")
    return tuple(sorted(out))


#: Most entries of an input folder searched for a hard link to an existing target.
_MAX_FOLDER_SCAN = 100_000


def _in_folder(a: Path, folder: Path) -> bool:
    """Whether the existing file ``a`` (resolved) is one of the files under ``folder``
    (resolved): by its name, or as a hard link to one of them."""
    if folder in a.parents:
        return True
    st = a.stat()
    if st.st_nlink < 2:
        return False
    seen = 0
    for root, _dirs, names in os.walk(folder):
        seen += len(names)
        for name in names:
            try:
                other = os.stat(os.path.join(root, name))
            except OSError:
                continue
            if (other.st_dev, other.st_ino) == (st.st_dev, st.st_ino):
                return True
        if seen > _MAX_FOLDER_SCAN:
            break
    return False


def _same_file(a: Path, b: Path) -> bool:
    """Whether the resolved target ``a`` is the input ``b``: the same name once links are
    resolved, the same file (a hard link), or, when ``b`` is a folder, an existing file under
    it (a new file in it is fine)."""
    try:
        b_real = b.resolve()
        if a == b_real:
            return True
        if not (a.exists() and b.exists()):
            return False
        return _in_folder(a, b_real) if b_real.is_dir() else os.path.samefile(a, b)
    except (OSError, RuntimeError):
        return False


#: Longest file or folder name most file systems take (bytes, UTF-8).
NAME_MAX = 255


def check_name(text: str, what: str) -> None:
    """InputError for a name no file system takes: a NUL byte, a component over NAME_MAX."""
    if "\0" in text:
        raise InputError(f"{what}: the name contains a NUL byte; give a plain file name")
    for part in Path(text).parts:
        if len(part.encode("utf-8", "surrogateescape")) > NAME_MAX:
            raise InputError(f"{what}: the name part {part[:40]}... is longer than {NAME_MAX} "
                             "bytes, more than file systems take; give a shorter name")


def check_output_file(
    path: str | os.PathLike[str],
    what: str,
    allowed_suffixes: Sequence[str] | None = None,
    *,
    example: str | None = None,
    inputs: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """Check that ``path`` can be written as one file; the resolved target, or InputError.

    Call it before any work, for every output of the command.

    Parameters
    ----------
    path
        The file name the user gave.
    what
        The option that gave it (``"--out"``, ``"--plot"``), named in every message.
    allowed_suffixes
        Extensions (with the dot, any case) the file may have, e.g. :func:`plot_suffixes`;
        ``None`` accepts any name.
    example
        A file name that would work, used in messages (default: ``out`` plus the first
        allowed suffix or the given one).
    inputs
        Files the command reads: the output may not be one of them (nor a hard or symbolic
        link to one). A folder among them (a robot directory) protects every file under it
        (a new file in it may be written).

    Returns
    -------
    Path
        The absolute target with symbolic links resolved: write there (with
        :func:`write_atomically`), so a link is followed rather than replaced.

    Raises
    ------
    InputError
        The suffix is not allowed, the target is a folder, a device or pipe, read-only or one
        of ``inputs``; its folder does not exist or is not a folder; or no file can be created
        in that folder (read-only, ``/proc``, ``/sys``, no permission).
    """
    text = os.fspath(path)
    suffix = Path(text).suffix
    if example is None:
        example = "out" + (allowed_suffixes[0] if allowed_suffixes else (suffix or ".txt"))
    target = _resolved_target(text, what, example)
    for inp in inputs:  # first: the one message that matters most
        if _same_file(target, Path(inp)):
            kind = "a file of the input folder" if Path(inp).is_dir() else "the input file"
            raise InputError(f"{what} {text} is {kind} {os.fspath(inp)}: writing it would "
                             "destroy your input; choose another name")
    if allowed_suffixes is not None:
        allowed = [s.lower() for s in allowed_suffixes]
        if suffix.lower() not in allowed:
            got = f"'{suffix}'" if suffix else "no extension"
            raise InputError(
                f"{what} {text}: cannot write a file with {got}; give a name ending in one of "
                f"{', '.join(allowed)} (e.g. {what} {example})")
    _check_folder(target.parent, text, what, example)
    _check_existing(target, text, what)
    _probe_writable(target, text, what)
    return target


def _resolved_target(text: str, what: str, example: str) -> Path:
    """The absolute target of the name ``text`` (not empty, not a folder)."""
    if not text.strip():
        raise InputError(f"{what} is empty: give a file name (e.g. {what} {example})")
    check_name(text, what)
    try:
        target = Path(text).resolve()
    except (OSError, RuntimeError) as exc:  # a symbolic link loop
        raise InputError(f"{what} {text}: cannot resolve the name ({exc}); give a plain file "
                         "name") from None
    if target.is_dir():
        raise InputError(f"{what} {text} is a folder, not a file: give a file name (e.g. "
                         f"{what} {Path(text) / example})")
    return target


def _check_folder(parent: Path, text: str, what: str, example: str) -> None:
    """The target's folder exists and is a folder."""
    if not parent.exists():
        raise InputError(f"{what}: directory {parent} does not exist; create it first or "
                         f"choose a file in an existing folder (e.g. {what} {example})")
    if not parent.is_dir():
        raise InputError(f"{what} {text}: {parent} is a file, not a folder; choose a file in "
                         "an existing folder")


def _check_existing(target: Path, text: str, what: str) -> None:
    """An existing target is a regular file that may be written."""
    if not (target.exists() or target.is_symlink()):
        return
    try:
        mode = target.stat().st_mode
    except OSError as exc:
        raise InputError(f"{what} {text}: cannot inspect it ({_reason(exc)})") from None
    if not stat.S_ISREG(mode):
        raise InputError(f"{what} {text} exists and is not a regular file (a device, pipe "
                         "or socket): give the name of a file to create or replace")
    if not os.access(target, os.W_OK):
        raise InputError(f"{what} {text} is read-only: make it writable or choose another "
                         "name")


def _probe_writable(target: Path, text: str, what: str) -> None:
    """A file can be created in the target's folder (read-only mounts, /proc, permissions)."""
    parent = target.parent
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".feedopt-probe",
                                     dir=parent)
    except OSError as exc:
        raise InputError(f"{what} {text}: cannot write in {parent} ({_reason(exc)}); choose a "
                         "folder you can write to") from None
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass


def _final_mode(target: Path) -> int:
    """Permission bits for the new file: those of the file it replaces, else 0o666 - umask."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


def _stage(target: Path, write: Writer) -> Path:
    """Write ``write`` into a new temporary file beside ``target``; its path."""
    fd, name = tempfile.mkstemp(prefix=f".{target.stem}.feedopt-", suffix=target.suffix,
                                dir=target.parent)
    tmp = Path(name)
    try:
        if isinstance(write, str):
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
                fh.write(write)
                fh.flush()
                os.fsync(fh.fileno())
        else:
            os.close(fd)
            write(tmp)
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
        os.chmod(tmp, _final_mode(target))
    except BaseException:
        _remove_quiet(tmp)
        raise
    return tmp


def _remove_quiet(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


def write_files_atomically(
    files: Sequence[tuple[str | os.PathLike[str], Writer, str]],
) -> list[Path]:
    """Write several files, all or none: each into a temporary file, then all moved in place.

    Parameters
    ----------
    files
        ``(path, write, what)``: ``write`` is the text of the file (written as UTF-8) or a
        callable that writes the whole file at the temporary path it is given; ``what`` is
        the option named in the message when the system refuses a write (disk full, ...).

    Returns
    -------
    list of Path
        The targets written (symbolic links resolved).

    Raises
    ------
    InputError
        A write failed with an operating-system error; no temporary file is left and every
        previous file is untouched.
    """
    staged: list[tuple[Path, Path]] = []
    try:
        for path, write, what in files:
            target = Path(path).resolve()
            try:
                staged.append((_stage(target, write), target))
            except OSError as exc:
                raise InputError(f"{what} {os.fspath(path)}: cannot write it ({_reason(exc)}); "
                                 "nothing was written") from None
        for tmp, target in staged:
            os.replace(tmp, target)
    except BaseException:
        for tmp, _ in staged:
            _remove_quiet(tmp)
        raise
    return [target for _, target in staged]


def write_atomically(path: str | os.PathLike[str], write: Writer, what: str = "--out") -> Path:
    """Write one file whole: into a temporary file beside ``path``, then :func:`os.replace`.

    Parameters
    ----------
    path
        The target (best the one :func:`check_output_file` returned).
    write
        The text of the file (written as UTF-8), or a callable that writes the whole file at
        the temporary path it is given (the path has the target's extension).
    what
        The option named in the message when the system refuses the write.

    Returns
    -------
    Path
        The target written (symbolic links resolved).

    Raises
    ------
    InputError
        The write failed with an operating-system error (disk full, ...). On that or any other
        failure (an exception of ``write``, Ctrl-C) the temporary file is removed and a
        previous file at ``path`` is untouched.
    """
    return write_files_atomically([(path, write, what)])[0]


def check_data_and_plot(out: str | None, plot: str | None, inputs: list, data_example: str,
                        plot_example: str) -> None:
    """``--out`` (data) and ``--plot`` (figure) of a command: writable files, not one of its
    ``inputs``, a plot format matplotlib writes, not each other — before any work."""
    if out is not None:
        check_output_file(out, "--out", example=data_example, inputs=inputs)
    if plot is not None:
        target = check_output_file(plot, "--plot", plot_suffixes(), example=plot_example,
                                   inputs=inputs)
        if out is not None and Path(out).resolve() == target:
            raise InputError(f"--out and --plot are the same file {plot}: give two names "
                             f"(e.g. --out {data_example} --plot {plot_example})")
