"""The strict STL reader (issue 26, item 11): true messages for files that are not STLs,
truncated binary STLs, malformed ASCII lines and non-finite vertices; valid files read."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.process.stl import read_stl

trimesh = pytest.importorskip("trimesh")


def _box():
    return trimesh.creation.box(extents=[100.0, 50.0, 20.0])


def _binary(tri: np.ndarray, header: bytes = b"feedopt test") -> bytes:
    """A binary STL written here, independently of trimesh's exporter."""
    out = [header.ljust(80, b" ")[:80], struct.pack("<I", len(tri))]
    for t in np.asarray(tri, dtype=float):
        out.append(struct.pack("<12fH", 0, 0, 0, *t.reshape(-1), 0))
    return b"".join(out)


def test_binary_and_ascii_stl_read_the_same_triangles(tmp_path):
    box = _box()
    binary, ascii_ = tmp_path / "b.stl", tmp_path / "a.stl"
    box.export(binary)
    ascii_.write_text(trimesh.exchange.stl.export_stl_ascii(box))
    a, b = read_stl(ascii_), read_stl(binary)
    assert a.shape == b.shape == (12, 3, 3)
    np.testing.assert_allclose(a, box.triangles, atol=1e-5)
    np.testing.assert_allclose(b, box.triangles.astype(np.float32), atol=0)


def test_a_binary_stl_whose_header_starts_with_solid_is_binary(tmp_path):
    p = tmp_path / "solid_header.stl"
    p.write_bytes(_binary(_box().triangles, header=b"solid made by some CAD"))
    assert read_stl(p).shape == (12, 3, 3)


def test_random_bytes_are_not_an_stl(tmp_path):
    p = tmp_path / "random.stl"
    p.write_bytes(np.random.default_rng(3).bytes(1000))
    with pytest.raises(InputError) as exc:
        read_stl(p)
    msg = str(exc.value)
    assert "not an STL" in msg and "1,000 bytes" in msg and "charset" not in msg
    short = tmp_path / "short.stl"
    short.write_bytes(b"\x01\x02")
    with pytest.raises(InputError, match="too short for a binary STL"):
        read_stl(short)


def test_a_truncated_binary_stl_names_its_count_and_size(tmp_path):
    data = _binary(_box().triangles)
    p = tmp_path / "cut.stl"
    p.write_bytes(data[:-30])
    with pytest.raises(InputError) as exc:
        read_stl(p)
    msg = str(exc.value)
    assert "triangle count 12" in msg and "84 + 50 x 12 = 684 bytes" in msg
    assert f"{len(data) - 30:,} bytes" in msg


@pytest.mark.parametrize("bad", ["nan", "inf", "-1e999"])
def test_a_non_finite_vertex_names_its_triangle(tmp_path, bad):
    lines = trimesh.exchange.stl.export_stl_ascii(_box()).splitlines()
    vertex_lines = [i for i, line in enumerate(lines) if line.strip().startswith("vertex")]
    lines[vertex_lines[3 * 7 + 1]] = f"      vertex 1 {bad} 2"  # triangle 7, second vertex
    p = tmp_path / "nan.stl"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"triangle 7 \(counting from 0\) has a NaN or infinite"):
        read_stl(p)
    tri = _box().triangles.copy()
    tri[4, 2, 0] = np.nan
    p.write_bytes(_binary(tri))
    with pytest.raises(InputError, match="triangle 4 "):
        read_stl(p)


def test_malformed_ascii_lines_are_named(tmp_path):
    text = trimesh.exchange.stl.export_stl_ascii(_box())
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.strip().startswith("vertex"))
    p = tmp_path / "bad.stl"
    for line, want in (("vertex 1 2 x", "'x' is not a number"),
                       ("vertex 1 2", "must be 'vertex x y z'")):
        changed = list(lines)
        changed[i] = line
        p.write_text("\n".join(changed) + "\n")
        with pytest.raises(InputError, match=f"line {i + 1}: .*{want}"):
            read_stl(p)
    p.write_bytes(b"solid x\n\xff\xfe\n")
    with pytest.raises(InputError, match="line 2 is not ASCII text"):
        read_stl(p)
    p.write_text("solid empty\nendsolid empty\n")
    with pytest.raises(InputError, match="holds no triangles"):
        read_stl(p)
    p.write_bytes(_binary(np.zeros((0, 3, 3))))
    with pytest.raises(InputError, match="holds no triangles"):
        read_stl(p)


def test_oversized_files_are_refused_before_parsing(tmp_path, monkeypatch):
    import feedopt.process.stl as stl

    binary, ascii_ = tmp_path / "b.stl", tmp_path / "a.stl"
    binary.write_bytes(_binary(_box().triangles))  # 684 bytes
    ascii_.write_text(trimesh.exchange.stl.export_stl_ascii(_box()))
    monkeypatch.setattr(stl, "MAX_ASCII_STL_BYTES", 683)
    assert read_stl(binary).shape == (12, 3, 3)
    with pytest.raises(InputError, match="export it as a binary STL"):
        read_stl(ascii_)
    monkeypatch.setattr(stl, "MAX_STL_BYTES", 683)
    with pytest.raises(InputError, match="simplify the mesh"):
        read_stl(binary)


def test_an_upper_case_ascii_stl_reads_as_the_lower_case_one(tmp_path):
    """Some exporters write SOLID / FACET / VERTEX: the same triangles, not 'no triangles'."""
    text = trimesh.exchange.stl.export_stl_ascii(_box())
    lower, upper = tmp_path / "l.stl", tmp_path / "u.stl"
    lower.write_text(text)
    upper.write_text(text.upper())
    np.testing.assert_array_equal(read_stl(upper), read_stl(lower))


@pytest.mark.parametrize("value", [1e308, -3e38, 2e9])
def test_coordinates_no_stock_has_are_refused_without_numpy_warnings(tmp_path, value):
    """A vertex at 1e308 overflowed later arithmetic (RuntimeWarnings before the message):
    beyond 1e9 file units the triangle is named and nothing else is computed."""
    tri = _box().triangles.copy()
    tri[5, 1, 0] = value
    p = tmp_path / "far.stl"
    facets = ["facet normal 0 0 0\nouter loop\n"
              + "".join("vertex " + " ".join(repr(float(v)) for v in vertex) + "\n"
                        for vertex in t) + "endloop\nendfacet\n" for t in tri]
    p.write_text("solid far\n" + "".join(facets) + "endsolid far\n")
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match=r"triangle 5 .* beyond \+-1e\+09"):
            read_stl(p)
