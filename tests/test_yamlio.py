"""The strict YAML reader (issue 19): no silent YAML 1.1 coercions, no duplicate keys,
no alias bombs, short echoes of bad values."""

import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.yamlio import MAX_EXPANDED_NODES, excerpt, parse_yaml, read_yaml


@pytest.mark.parametrize(("text", "value"), [
    ("x: 1e-3", 1e-3), ("x: 1.5E+2", 150.0), ("x: -7", -7), ("x: .5", 0.5), ("x: 3.", 3.0),
    ("x: true", True), ("x: False", False), ("x: ~", None), ("x: null", None),
    ("x: .inf", float("inf")),
])
def test_decimal_numbers_booleans_and_null_resolve(text, value) -> None:
    assert parse_yaml(text, "t")["x"] == value


@pytest.mark.parametrize("text", ["0x1D", "0o17", "017e", "yes", "no", "on", "off", "1:30",
                                  "1_000", "2026-12-02", "=", "y", "n"])
def test_yaml11_coercions_stay_strings(text) -> None:
    assert parse_yaml(f"x: {text}", "t")["x"] == text


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_every_float_python_writes_reads_back(x) -> None:
    assert parse_yaml(f"x: {x!r}", "t")["x"] == x


@given(st.integers(min_value=-10**30, max_value=10**30))
def test_every_integer_reads_back(n) -> None:
    value = parse_yaml(f"x: {n}", "t")["x"]
    assert value == n and isinstance(value, int)


def test_duplicate_key_is_refused_naming_both_lines() -> None:
    text = "deflection:\n  limit_mm: 0.29\n  mode: norm\n  limit_mm: 0.5\n"
    with pytest.raises(InputError, match=r"'limit_mm' is given twice.*lines 2 and 4"):
        parse_yaml(text, "job.yaml")


def test_duplicate_section_is_refused() -> None:
    with pytest.raises(InputError, match=r"job.yaml: key 'feed' .*lines 1 and 3"):
        parse_yaml("feed: {a: 1}\nx: 2\nfeed: {a: 3}\n", "job.yaml")


def test_merge_keys_still_work() -> None:
    doc = parse_yaml("base: &b {a: 1, b: 2}\nderived:\n  <<: *b\n  b: 3\n", "t")
    assert doc["derived"] == {"a": 1, "b": 3}


def test_alias_bomb_is_refused_quickly() -> None:
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 9):
        prev, cur = chr(ord("a") + i - 1), chr(ord("a") + i)
        lines.append(f"{cur}: &{cur} [{', '.join(['*' + prev] * 9)}]")
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=f"expand to more than {MAX_EXPANDED_NODES:,}") as exc:
        parse_yaml("\n".join(lines), "bomb.yaml")
    assert time.perf_counter() - t0 < 1.0
    assert len(str(exc.value)) < 300


def test_small_aliases_are_fine() -> None:
    doc = parse_yaml("a: &v [1, 2, 3]\nb: *v\n", "t")
    assert doc["b"] == [1, 2, 3]


def test_syntax_error_names_line() -> None:
    with pytest.raises(InputError, match="t: not valid YAML at line 2"):
        parse_yaml("a: 1\nb: c: d\n", "t")


def test_binary_garbage_is_bad_input(tmp_path) -> None:
    f = tmp_path / "s.yaml"
    f.write_bytes(bytes(range(128, 256)) * 4)
    with pytest.raises(InputError, match="is not UTF-8 text"):
        read_yaml(f, "scenario file")


def test_excerpt_is_short_for_huge_values() -> None:
    big = [[list(range(1000))] * 1000] * 10
    assert len(excerpt(big)) <= 60
    assert excerpt(0.5) == "0.5"


def test_devices_and_huge_files_are_refused(tmp_path, monkeypatch) -> None:
    import feedopt.textio as textio

    with pytest.raises(InputError, match="not a regular file"):
        read_yaml("/dev/zero", "scenario file")
    f = tmp_path / "big.yaml"
    f.write_text("a: 1\n" * 100)
    monkeypatch.setattr(textio, "MAX_TEXT_BYTES", 100)
    with pytest.raises(InputError, match="MiB, more than"):
        read_yaml(f, "scenario file")
