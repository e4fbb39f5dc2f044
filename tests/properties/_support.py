"""Shared pieces of the reader fuzz tests: example budgets, garbage values, dict mutations."""

from __future__ import annotations

import copy
import math
import os
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
SCENARIO_NAMES = ("linear_peripheral", "triangle_slot", "square_slot")


def budget(ci_examples: int, **kw) -> settings:
    """Settings with ``ci_examples`` under the ci profile (max_examples 100) and proportionally
    more under a larger profile (nightly: 20x)."""
    scale = max(1.0, settings.default.max_examples / 100)
    return settings(max_examples=max(1, math.ceil(ci_examples * scale)),
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture,
                                           HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much], **kw)


def tree(root: Path) -> list[str]:
    """Every entry below ``root`` (relative names, sorted), hidden ones included."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        for n in dirnames + filenames:
            out.append(os.path.relpath(os.path.join(dirpath, n), root))
    return sorted(out)


# --- garbage values ------------------------------------------------------------------------

special_floats = st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, 1e308, -1e308,
                                  5e-324, 1e-300, 2.0**63, -(2.0**63)])
scalars = st.one_of(
    st.none(), st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True), special_floats,
    st.text(max_size=20),
    st.sampled_from(["", "1e-3", "0x1D", "yes", "on", "1:30", "1_000", "nan", ".inf", "~",
                     "null", "NaN", "12 mm", "4,23", "\u00e9t\u00e9", "\U0001f600", "\x00",
                     "constant", "jerk", "../x", "/dev/zero"]),
)
garbage = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.dictionaries(st.one_of(st.text(max_size=8), st.integers(-3, 3)), inner, max_size=4)),
    max_leaves=12)


def _locations(doc, prefix=()):
    """(container, key) of every value in the nested dict/list ``doc``."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield doc, k, prefix + (k,)
            yield from _locations(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield doc, i, prefix + (i,)
            yield from _locations(v, prefix + (i,))


def _numeric_scale(value, factor):
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return int(value * factor)
    if isinstance(value, float):
        return value * factor
    return value


@st.composite
def mutated(draw, base: dict, *, values=garbage, cheap: bool = False, max_mutations: int = 4):
    """A deep copy of ``base`` with 1..max_mutations mutations: a value replaced by garbage,
    a key deleted, an unknown key added, a value wrapped in a list or a mapping, or (``cheap``)
    a number scaled by 0.5..2 (keeps the job small enough for a full run)."""
    doc = copy.deepcopy(base)
    ops = ["replace", "delete", "extra", "wrap", "scale"] if not cheap else [
        "replace_scalar", "delete", "extra", "wrap", "scale", "scale"]
    for _ in range(draw(st.integers(1, max_mutations))):
        locs = list(_locations(doc))
        op = draw(st.sampled_from(ops))
        if op == "extra" or not locs:
            dicts = [doc] + [c[k] for c, k, _ in locs if isinstance(c[k], dict)]
            target = draw(st.sampled_from(dicts))
            target[draw(st.one_of(st.text(max_size=12), st.sampled_from(
                ["nmae", "spacing", "limit", "extra", "laws", "x_mm"])))] = draw(values)
            continue
        container, key, _ = draw(st.sampled_from(locs))
        if op == "replace":
            container[key] = draw(values)
        elif op == "replace_scalar":
            container[key] = draw(scalars.filter(lambda v: not isinstance(v, int | float)
                                                 or isinstance(v, bool)))
        elif op == "delete":
            del container[key]
        elif op == "wrap":
            container[key] = draw(st.sampled_from([[container[key]], {"value": container[key]},
                                                   [container[key], container[key]]]))
        else:  # scale
            container[key] = _numeric_scale(container[key], draw(st.floats(0.5, 2.0)))
    return doc


@st.composite
def text_mutations(draw, text: str, alphabet=None, max_mutations: int = 4):
    """``text`` with lines dropped or duplicated and characters dropped, doubled, replaced or
    inserted (from ``alphabet``, or any character)."""
    chars = st.characters() if alphabet is None else st.one_of(
        st.sampled_from(alphabet), st.characters())
    lines = text.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, max_mutations))):
        if not lines:
            lines = [draw(st.text(max_size=10))]
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["drop_line", "dup_line", "drop_char", "dup_char",
                                   "replace_char", "insert", "crlf", "truncate"]))
        line = lines[i]
        j = draw(st.integers(0, max(0, len(line) - 1)))
        if op == "drop_line":
            del lines[i]
        elif op == "dup_line":
            lines.insert(i, line)
        elif op == "drop_char":
            lines[i] = line[:j] + line[j + 1:]
        elif op == "dup_char":
            lines[i] = line[:j] + line[j:j + 1] + line[j:]
        elif op == "replace_char":
            lines[i] = line[:j] + draw(chars) + line[j + 1:]
        elif op == "insert":
            lines[i] = line[:j] + "".join(draw(st.lists(chars, min_size=1, max_size=6))) + line[j:]
        elif op == "crlf":
            lines[i] = line.rstrip("\n") + "\r\n"
        else:
            lines[i] = line[:j]
    return "".join(lines)
