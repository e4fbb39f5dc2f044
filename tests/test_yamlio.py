"""The strict YAML reader (issue 19): no silent YAML 1.1 coercions, no duplicate keys,
no alias bombs, short echoes of bad values; and the capped reader of every user text file
(issue 26): a cap per kind before parsing, a message for each kind of non-file, never an
exception but InputError."""

import os
import re
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from feedopt.errors import InputError
from feedopt.scenario import load_scenario
from feedopt.textio import MAX_TEXT_BYTES, max_bytes_for, read_user_text
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

    with pytest.raises(InputError, match="is not a regular file but a character device"):
        read_yaml("/dev/zero", "scenario file")
    f = tmp_path / "big.yaml"
    f.write_text("a: 1\n" * 100)
    monkeypatch.setattr(textio, "MAX_TEXT_BYTES", 100)
    with pytest.raises(InputError, match=r"big.yaml is 500 bytes, more than the 100 bytes a "
                       r"notes file may have"):
        read_yaml(f, "notes file")


# ---------------------------------------------------------------- the capped reader (issue 26)

def test_each_kind_has_its_cap_and_the_message_gives_size_cap_and_file(tmp_path) -> None:
    assert max_bytes_for("scenario file") == 4 * 2**20
    assert max_bytes_for("tool") == max_bytes_for("robot file") // 4 == 2**20
    assert max_bytes_for("G-code program") > max_bytes_for("waypoint file") > 16 * 2**20
    assert max_bytes_for("something else") == MAX_TEXT_BYTES
    f = tmp_path / "all_comments.yaml"
    with open(f, "wb") as fh:  # 500 MB of comment, sparse: no disk used
        fh.write(b"# " + b"x" * 78 + b"\n")
        fh.truncate(500 * 10**6)
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        read_yaml(f, "scenario file")
    assert time.perf_counter() - t0 < 1.0
    assert str(exc.value).startswith(
        f"scenario file {f} is 476.8 MiB (500,000,000 bytes), more than the 4.0 MiB "
        "(4,194,304 bytes) a scenario file may have")
    f.write_text("a: 1\n")
    with pytest.raises(InputError, match="is 5 bytes, more than the 4 bytes"):
        read_user_text(f, "tool", max_bytes=4)
    assert read_user_text(f, "tool", max_bytes=5) == "a: 1\n"


def test_a_file_that_grows_past_the_cap_while_read_is_refused(tmp_path, monkeypatch) -> None:
    import feedopt.textio as textio

    f = tmp_path / "grows.csv"
    f.write_text("x" * 10)
    real_fstat = os.fstat

    def grow_then_fstat(fd):  # the file grows between the size check and the read
        with open(f, "a") as fh:
            fh.write("y" * 100)
        return real_fstat(fd)

    monkeypatch.setattr(textio.os, "fstat", grow_then_fstat)
    with pytest.raises(InputError, match="it grew while read"):
        read_user_text(f, "waypoint file", max_bytes=50)


def test_not_regular_files_get_their_own_message_and_a_fifo_is_never_opened(tmp_path) -> None:
    fifo = tmp_path / "job.yaml"
    os.mkfifo(fifo)
    loop_a, loop_b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    loop_a.symlink_to(loop_b)
    loop_b.symlink_to(loop_a)
    dangling = tmp_path / "d.yaml"
    dangling.symlink_to(tmp_path / "gone.yaml")
    (tmp_path / "file").write_text("x")
    cases = [
        (fifo, "is not a regular file but a named pipe (FIFO)"),
        ("/dev/zero", "is not a regular file but a character device"),
        (loop_a, "is a symbolic link loop"),
        (dangling, f"is a symbolic link to {tmp_path / 'gone.yaml'}, which does not exist"),
        (tmp_path, "is a folder, not a file"),
        (tmp_path / "missing.yaml", "missing.yaml does not exist"),
        (tmp_path / "file" / "x.yaml", "a part of the path is a file, not a folder"),
    ]
    for path, message in cases:
        t0 = time.perf_counter()
        with pytest.raises(InputError, match=re.escape(message)):
            read_yaml(path, "tool")  # a FIFO opened for reading would block here forever
        assert time.perf_counter() - t0 < 1.0


def test_line_ends_and_byte_order_mark_read_as_text_mode_does(tmp_path) -> None:
    f = tmp_path / "w.csv"
    f.write_bytes(b"\xef\xbb\xbfx_mm\r\n1\r2\n")
    assert read_user_text(f, "waypoint file", encoding="utf-8-sig") == "x_mm\n1\n2\n"
    assert read_user_text(f, "waypoint file") == "\ufeffx_mm\n1\n2\n"


@pytest.mark.parametrize("text", ["x: " + "9" * 5000, "x: !!float abc", "x: !!int 1_0x",
                                  "a: &a [1, *a]", "a: &a {b: *a}", "[" * 5000 + "]" * 5000])
def test_values_python_cannot_build_are_bad_input(text) -> None:
    with pytest.raises(InputError, match="^t: "):
        parse_yaml(text, "t")


#: YAML-ish text: the characters YAML gives meaning to, in random order and nesting
_YAML_CHARS = list("{}[]:,-?&*!|>'\"%@`#<=~ \n\t.ab019eE+_x")
_YAML_WORDS = ["!!int ", "!!float ", "!!binary ", "!!set ", "!!timestamp ", "<<: ", "&a ",
               "*a", ".inf", ".nan", "0x", "1e999", "9" * 30, "\u00e9", "\x00", "\ufeff"]
YAMLISH = st.lists(st.sampled_from(_YAML_CHARS + _YAML_WORDS), max_size=120).map("".join)


@given(YAMLISH)
@settings(max_examples=400, deadline=None)
def test_parse_yaml_raises_only_input_error_on_yamlish_text(text) -> None:
    try:
        parse_yaml(text, "t")
    except InputError as exc:
        assert str(exc).startswith("t")


@given(st.binary(max_size=400))
@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_reading_random_bytes_raises_only_input_error(tmp_path, data) -> None:
    f = tmp_path / "random.yaml"
    f.write_bytes(data)
    for what in ("scenario file", "tool", "robot file"):
        try:
            read_yaml(f, what)
        except InputError as exc:
            assert str(exc).startswith(what) or str(exc).startswith(f"{what} {f}")
    try:
        load_scenario(f)
    except InputError:
        pass
