"""Properties of the tool, material and stock readers (issue 26): on arbitrary input they
raise only InputError; an unknown key is always refused by name; valid inputs round-trip
(tool and coefficient files to the same values, a box STL to the Z-map of the same box)."""

from __future__ import annotations

import math
import struct
from unittest import mock

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

import feedopt.process.stock as stock_module
from feedopt.errors import InputError
from feedopt.process.coefficients import (
    FILE_KEYS,
    FILE_TOP_KEYS,
    CoefficientTable,
    CuttingCoefficients,
    load_coefficients,
    save_coefficients,
)
from feedopt.process.stl import read_stl
from feedopt.process.stock import ZMap
from feedopt.process.tool import TOOL_KEYS, load_tool

from ._support import SCENARIOS, budget, garbage, mutated

trimesh = pytest.importorskip("trimesh")
MM = 1e-3
TOOL = yaml.safe_load((SCENARIOS / "tools" / "hss_2flute_19mm.yaml").read_text())
COEFFS = yaml.safe_load((SCENARIOS / "materials" / "6061-T6511.yaml").read_text())
SMALL_CAP = 20_000  # cells: keeps every fuzzed Z-map small and fast
unknown_keys = st.text(min_size=1, max_size=12).filter(
    lambda k: k not in TOOL_KEYS and k not in FILE_TOP_KEYS)


def _write_yaml(path, doc):
    path.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    return path


def _only_input_error(read, *args):
    """``read(*args)``, or None when it raised InputError (anything else fails the test)."""
    try:
        return read(*args)
    except InputError as exc:
        assert str(exc).strip()
        return None


# --- tool and material files ---------------------------------------------------------------

@budget(150)
@given(doc=mutated(TOOL), key=unknown_keys, value=garbage)
def test_a_tool_file_with_an_unknown_key_is_refused_by_name(tmp_path, doc, key, value):
    p = _write_yaml(tmp_path / "tool.yaml", doc)
    _only_input_error(load_tool, p)
    doc[key] = value
    _write_yaml(p, doc)
    with pytest.raises(InputError) as exc:
        load_tool(p)
    # the first unknown key in the file is named (the mutation may have added another)
    first = next(k for k in doc if k not in TOOL_KEYS)
    assert f"unknown key {str(first)!r}" in str(exc.value)


@budget(150)
@given(doc=mutated(COEFFS), key=unknown_keys, where=st.sampled_from(["top", "speed"]))
def test_a_material_file_with_an_unknown_key_is_refused_by_name(tmp_path, doc, key, where):
    p = _write_yaml(tmp_path / "m.yaml", doc)
    _only_input_error(load_coefficients, p)
    speeds = doc.get("speeds")
    if where == "speed" and isinstance(speeds, list) and speeds and isinstance(speeds[0], dict):
        if key in ("rpm", *FILE_KEYS.values()):
            return
        speeds[0][key] = 1.0
    else:
        doc[key] = 1.0
    _write_yaml(p, doc)
    with pytest.raises(InputError, match="unknown key|expected|missing|must be"):
        load_coefficients(p)


@budget(150)
@given(diameter=st.floats(0.01, 200), teeth=st.integers(1, 40), helix=st.floats(0, 89.99),
       flute=st.floats(0.01, 300), name=st.text(max_size=20))
def test_a_valid_tool_reads_back_its_values(tmp_path, diameter, teeth, helix, flute, name):
    doc = {"name": name, "diameter_mm": diameter, "teeth": teeth, "helix_deg": helix,
           "flute_length_mm": flute}
    tool = load_tool(_write_yaml(tmp_path / "t.yaml", doc))
    assert tool.name == name and tool.teeth == teeth
    assert tool.diameter == pytest.approx(diameter * MM, rel=1e-15)
    assert tool.flute_length == pytest.approx(flute * MM, rel=1e-15)
    assert tool.helix == pytest.approx(math.radians(helix), rel=1e-15, abs=0)


positive = st.floats(1e-3, 1e12)
any_sign = st.floats(-1e12, 1e12)
speed_rows = st.tuples(positive, positive, any_sign, st.floats(0, 1e9), st.floats(0, 1e9),
                       any_sign)


@budget(150)
@given(rpms=st.lists(st.integers(1, 100_000), min_size=1, max_size=5, unique=True),
       rows=st.lists(speed_rows, min_size=5, max_size=5), text=st.text(max_size=15),
       rng=st.one_of(st.none(), st.tuples(st.floats(1e-4, 1.0), st.floats(1.0, 10.0))))
def test_a_saved_coefficient_table_reads_back(tmp_path, rpms, rows, text, rng):
    speeds = {float(r): CuttingCoefficients(*rows[i]) for i, r in enumerate(rpms)}
    table = CoefficientTable.from_speeds(speeds, material=text, tool=text, source=text,
                                         feed_per_tooth_range=None if rng is None else
                                         (rng[0] * MM, rng[1] * MM))
    p = tmp_path / "c.yaml"
    save_coefficients(table, p)
    back = load_coefficients(p)
    np.testing.assert_array_equal(back.rpm, table.rpm)
    np.testing.assert_allclose(back.values, table.values, rtol=1e-5, atol=0)
    assert (back.material, back.tool, back.source) == (text, text, text)
    if rng is None:
        assert back.feed_per_tooth_range is None
    else:
        assert back.feed_per_tooth_range == pytest.approx(table.feed_per_tooth_range, rel=1e-5)


# --- stock: boxes ---------------------------------------------------------------------------

box_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                       st.sampled_from([1e308, -1e308, 0.0, 5e-324, 1e-3, 0.1]),
                       st.floats(-1.0, 1.0))


@budget(200)
@given(box=st.lists(box_values, min_size=6, max_size=6),
       cell=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(1e-5, 1e-2)))
def test_any_box_is_a_bounded_zmap_or_an_input_error(box, cell):
    with mock.patch.object(stock_module, "MAX_CELLS", SMALL_CAP):
        got = _only_input_error(ZMap.box, *box, cell)
    if got is not None:
        x0, x1, y0, y1, z0, z1 = box
        assert got.heights.size <= SMALL_CAP
        assert got.shape[0] * cell >= (x1 - x0) * (1 - 1e-6)
        assert got.shape[1] * cell >= (y1 - y0) * (1 - 1e-6)
        assert np.all(got.heights == np.float32(max(z1, z0)))


# --- stock: STL files -----------------------------------------------------------------------

def _binary_stl(tri: np.ndarray) -> bytes:
    """A binary STL written here (header, count, 50-byte records), independent of trimesh."""
    out = [b"feedopt fuzz".ljust(80, b" "), struct.pack("<I", len(tri))]
    out += [struct.pack("<12fH", 0, 0, 0, *t.reshape(-1), 0) for t in tri]
    return b"".join(out)


def _box_triangles(extents, corner) -> np.ndarray:
    box = trimesh.creation.box(extents=extents)
    box.apply_translation(np.asarray(corner) + np.asarray(extents) / 2)
    return np.asarray(box.triangles)


BOX_TRI = _box_triangles([100.0, 50.0, 20.0], [0.0, 0.0, 0.0])
BOX_BINARY = _binary_stl(BOX_TRI)
BOX_ASCII = trimesh.exchange.stl.export_stl_ascii(
    trimesh.Trimesh(BOX_TRI.reshape(-1, 3), np.arange(36).reshape(-1, 3))).encode()


def _from_mesh(path):
    with mock.patch.object(stock_module, "MAX_CELLS", SMALL_CAP):
        return _only_input_error(ZMap.from_mesh, path, 2.0 * MM)


@budget(200)
@given(raw=st.one_of(st.binary(max_size=600),
                     st.binary(max_size=200).map(lambda b: b"solid " + b),
                     st.binary(min_size=80, max_size=80).map(
                         lambda h: h + struct.pack("<I", 2) + b"\x00" * 100)))
def test_random_bytes_are_read_or_refused_by_input_error(tmp_path, raw):
    p = tmp_path / "r.stl"
    p.write_bytes(raw)
    _only_input_error(read_stl, p)
    _from_mesh(p)


@st.composite
def mutated_binary(draw) -> bytes:
    data = bytearray(BOX_BINARY)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["byte", "float", "float", "float", "truncate", "append",
                                   "count"]))
        if op == "byte" and data:
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        elif op == "byte":
            data += b"\x00"
        elif op == "float":  # one vertex coordinate replaced by any float32
            k = draw(st.integers(0, len(BOX_TRI) * 9 - 1))
            at = 84 + 50 * (k // 9) + 12 + 4 * (k % 9)
            if at + 4 <= len(data):
                data[at:at + 4] = struct.pack("<f", draw(st.floats(width=32)))
        elif op == "truncate":
            del data[draw(st.integers(0, len(data))):]
        elif op == "append":
            data += draw(st.binary(min_size=1, max_size=60))
        else:
            if len(data) >= 84:
                data[80:84] = struct.pack("<I", draw(st.integers(0, 2**32 - 1)))
    return bytes(data)


@st.composite
def mutated_ascii(draw) -> bytes:
    lines = BOX_ASCII.split(b"\n")
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["drop", "dup", "token", "garbage"]))
        if op == "drop":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "token":
            lines[i] = b"vertex " + b" ".join(draw(st.sampled_from(
                [b"nan", b"inf", b"-1e999", b"1e38", b"x", b"0", b"1e-320", b"12.5"]))
                for _ in range(draw(st.integers(0, 4))))
        else:
            lines[i] = draw(st.binary(max_size=20))
        if not lines:
            lines = [b""]
    return b"\n".join(lines)


@budget(200)
@given(raw=st.one_of(mutated_binary(), mutated_ascii()))
def test_mutated_stls_are_read_or_refused_by_input_error(tmp_path, raw):
    p = tmp_path / "m.stl"
    p.write_bytes(raw)
    tri = _only_input_error(read_stl, p)
    if tri is not None:
        assert tri.ndim == 3 and tri.shape[1:] == (3, 3) and np.all(np.isfinite(tri))
    got = _from_mesh(p)
    if got is not None:
        assert got.heights.size <= SMALL_CAP and np.all(np.isfinite(got.heights))


@budget(100)
@given(size=st.tuples(st.integers(1, 60), st.integers(1, 60), st.integers(1, 40)),
       corner=st.tuples(*[st.integers(-400, 400)] * 3), ascii_=st.booleans())
def test_a_box_stl_in_mm_gives_the_zmap_of_the_box(tmp_path, size, corner, ascii_):
    """Extents and corner in whole 0.5 mm cells (exact in float32): the STL's Z-map equals
    the box's, cell for cell."""
    cell = 0.5
    ext = np.array(size, dtype=float) * cell
    lo = np.array(corner, dtype=float) * cell
    tri = _box_triangles(ext, lo)
    p = tmp_path / "box.stl"
    if ascii_:
        p.write_bytes(trimesh.exchange.stl.export_stl_ascii(
            trimesh.Trimesh(tri.reshape(-1, 3), np.arange(tri.shape[0] * 3).reshape(-1, 3))
        ).encode())
    else:
        p.write_bytes(_binary_stl(tri))
    got = ZMap.from_mesh(p, cell * MM)
    hi = lo + ext
    want = np.full(size[:2], hi[2] * MM)
    assert got.shape == size[:2]
    assert got.origin == pytest.approx(tuple(lo[:2] * MM), abs=1e-12)
    assert got.bottom == pytest.approx(lo[2] * MM, abs=1e-12)
    np.testing.assert_allclose(got.heights, want, atol=1e-9)
    box = ZMap.box(lo[0] * MM, hi[0] * MM, lo[1] * MM, hi[1] * MM, lo[2] * MM, hi[2] * MM,
                   cell * MM)
    assert box.shape == got.shape
    np.testing.assert_allclose(box.heights, got.heights, atol=1e-9)
