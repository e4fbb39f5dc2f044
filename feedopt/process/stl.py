"""A strict STL reader: the triangles of an STL file, or InputError saying what is wrong.

STL comes in two forms. Binary: an 80-byte header, a little-endian uint32 triangle count n,
then n records of 50 bytes (normal, three vertices as float32 x, y, z, a uint16 attribute):
the file is exactly 84 + 50 n bytes. ASCII: ``solid name``, then per triangle ``facet normal
... / outer loop / vertex x y z`` (three times) ``/ endloop / endfacet``, then ``endsolid``.
Some binary files start their header with ``solid`` too, so the size rule decides first.

The file's structure is checked here, before any mesh library sees it, so that a file that is
not an STL is reported as such (not as a missing text-encoding module), a truncated binary
file names its triangle count and size, and a NaN or infinite coordinate names its triangle.
STL has no units: the caller scales the coordinates.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from feedopt.errors import InputError
from feedopt.textio import read_user_bytes

#: Largest STL file read [bytes]: 256 MiB, about 5 million binary triangles (a stock needs
#: far fewer; reading it takes a few seconds and about 1 GB).
MAX_STL_BYTES = 256 * 1024**2
#: Largest ASCII STL read [bytes]: 128 MiB, about 440,000 triangles (parsing text is slower:
#: about 6 s at the cap on one core).
MAX_ASCII_STL_BYTES = 128 * 1024**2

_HEADER = 80
_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertex", "<f4", (3, 3)), ("attribute", "<u2")])
# keywords in any case: some exporters write SOLID / FACET / VERTEX
_VERTEX = re.compile(rb"^[ \t]*vertex[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)[ \t]*\r?$",
                     re.M | re.I)
_FACET = re.compile(rb"^[ \t]*facet\b", re.M | re.I)
#: Largest coordinate magnitude in the file's units (1000 km in mm): beyond it, no stock.
MAX_COORDINATE = 1e9


def read_stl(path: str | Path, what: str = "") -> np.ndarray:
    """The triangles of the STL file ``path`` as an (m, 3, 3) float64 array, file units.

    InputError (starting with ``what``, default "STL <path>") for a file that is not an STL,
    a binary STL whose triangle count does not match its size, an ASCII STL with a malformed
    vertex line, a file with no triangles, or a NaN or infinite coordinate (naming the first
    such triangle, from 0).
    """
    file = Path(path)
    what = what or f"STL {file}"
    try:
        size = file.stat().st_size
        if size > MAX_STL_BYTES:
            raise InputError(
                f"{what}: {size / 1024**2:.0f} MiB is more than the {MAX_STL_BYTES // 1024**2}"
                " MiB an STL stock may have (about 5 million triangles); simplify the mesh")
        data = read_user_bytes(file, what, MAX_STL_BYTES)
    except OSError as exc:
        raise InputError(f"{what}: cannot be read ({exc.strerror or exc})") from None
    if _is_binary(data):
        tri = _binary(data)
    elif data.lstrip()[:5].lower() == b"solid":
        if size > MAX_ASCII_STL_BYTES:
            raise InputError(
                f"{what}: an ASCII STL of {size / 1024**2:.0f} MiB is more than the "
                f"{MAX_ASCII_STL_BYTES // 1024**2} MiB read as text (about 440,000 triangles); "
                "export it as a binary STL (up to 256 MiB) or simplify the mesh")
        tri = _ascii(data, what)
    else:
        raise InputError(f"{what}: {_not_stl(data)}")
    if tri.shape[0] == 0:
        raise InputError(f"{what}: holds no triangles")
    bad = ~np.isfinite(tri).all(axis=(1, 2))
    if bad.any():
        k = int(np.argmax(bad))
        raise InputError(
            f"{what}: triangle {k} (counting from 0) has a NaN or infinite vertex "
            f"coordinate ({_triangle_text(tri[k])}); every vertex must be a finite number")
    far = np.abs(tri).max(axis=(1, 2)) > MAX_COORDINATE
    if far.any():
        k = int(np.argmax(far))
        raise InputError(
            f"{what}: triangle {k} (counting from 0) has a coordinate beyond +-{MAX_COORDINATE:g}"
            f" ({_triangle_text(tri[k])}): no stock is that large (1000 km in mm); is the file "
            "damaged or in other units?")
    return tri


def _is_binary(data: bytes) -> bool:
    """True when ``data`` is exactly a binary STL's header, count and records (and not an
    ASCII STL whose size happens to match: text from ``solid`` to ``endsolid``)."""
    if len(data) < _HEADER + 4:
        return False
    if (data.lstrip()[:5].lower() == b"solid" and b"endsolid" in data[-1024:].lower()
            and b"\x00" not in data):
        return False
    count = int.from_bytes(data[_HEADER:_HEADER + 4], "little")
    return len(data) == _HEADER + 4 + _RECORD.itemsize * count


def _binary(data: bytes) -> np.ndarray:
    records = np.frombuffer(data, dtype=_RECORD, offset=_HEADER + 4)
    return records["vertex"].astype(np.float64)


def _not_stl(data: bytes) -> str:
    """Why ``data`` (neither a well-sized binary STL nor ``solid ...`` text) is not an STL."""
    if len(data) < _HEADER + 4:
        return (f"not an STL: {len(data)} bytes, too short for a binary STL (80-byte header and "
                "a 4-byte triangle count) and not an ASCII STL (which starts with 'solid')")
    count = int.from_bytes(data[_HEADER:_HEADER + 4], "little")
    want = _HEADER + 4 + _RECORD.itemsize * count
    return (f"not an STL, or a damaged binary STL: its triangle count {count:,} (bytes 80-83) "
            f"needs 84 + 50 x {count:,} = {want:,} bytes but the file has {len(data):,} bytes "
            "(a truncated or padded file, or not an STL at all); it does not start with 'solid' "
            "either, as an ASCII STL does")


def _ascii(data: bytes, what: str) -> np.ndarray:
    """Triangles of an ASCII STL; InputError at the first line that is not one."""
    if b"\x00" in data:
        raise InputError(f"{what}: starts with 'solid' but holds NUL bytes: neither an ASCII "
                         "STL (text) nor a binary STL (its size does not match its count)")
    try:
        data.decode("ascii")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputError(f"{what}: starts with 'solid' but line {line} is not ASCII text: "
                         "neither an ASCII STL nor a binary STL (its size does not match its "
                         "triangle count)") from None
    found = _VERTEX.findall(data)
    n_vertex_lines = len(re.findall(rb"^[ \t]*vertex\b", data, re.M | re.I))
    if n_vertex_lines != len(found):
        line = _first_bad_vertex_line(data)
        raise InputError(f"{what}: line {line}: a vertex line must be 'vertex x y z'")
    try:
        xyz = np.array(found, dtype=np.float64)
    except ValueError:
        for i, row in enumerate(found):
            for token in row:
                try:
                    float(token)
                except ValueError:
                    line = _line_of_vertex(data, i)
                    raise InputError(
                        f"{what}: line {line}: vertex coordinate "
                        f"{token.decode('ascii', 'replace')!r} is not a number") from None
        raise  # pragma: no cover - numpy and float() agree on what a number is
    if len(found) % 3:
        raise InputError(f"{what}: {len(found)} vertex lines, not three per facet")
    facets = len(_FACET.findall(data))
    if facets != len(found) // 3:
        raise InputError(f"{what}: {facets} facets but {len(found)} vertex lines; an ASCII "
                         "STL has three vertex lines per facet")
    return xyz.reshape(-1, 3, 3)


def _line_of_vertex(data: bytes, index: int) -> int:
    match = list(_VERTEX.finditer(data))[index]
    return data.count(b"\n", 0, match.start()) + 1


def _first_bad_vertex_line(data: bytes) -> int:
    for match in re.finditer(rb"^[ \t]*vertex\b.*$", data, re.M | re.I):
        if not _VERTEX.match(data, match.start()):
            return data.count(b"\n", 0, match.start()) + 1
    return 0  # pragma: no cover - only called when such a line exists


def _triangle_text(tri: np.ndarray) -> str:
    return "; ".join(", ".join(f"{v:g}" for v in row) for row in tri)
