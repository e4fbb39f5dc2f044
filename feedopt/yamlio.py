"""The one YAML reader for user files (scenarios, tools, materials, robot.yaml).

PyYAML's safe loader follows YAML 1.1, which turns text a planning tool must not guess at into
numbers and booleans: ``0x1D`` becomes 29, ``yes``/``on`` become True, ``1:30`` becomes 90,
``1_000`` becomes 1000, while ``1e-3`` stays a string. :class:`StrictLoader` resolves plain
scalars as the YAML 1.2 core schema does for decimals only: ``true``/``false``, ``null``/``~``,
decimal integers and decimal floats (``1e-3`` included, ``.inf``/``.nan``). Everything else
stays a string, so the schema reports "expected a number" with the value the user wrote.

It also refuses, with the line numbers, what YAML allows but a job file must not contain:
a key given twice in one mapping (the last one would silently win), and anchors/aliases that
expand beyond :data:`MAX_EXPANDED_NODES` nodes (an "alias bomb" of a few lines that expands
into gigabytes).
"""

from __future__ import annotations

import math
import re
import reprlib
from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import ConstructorError
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from feedopt.errors import InputError
from feedopt.textio import read_user_text

#: Largest number of nodes a document may expand to through aliases (scenario files have ~100).
MAX_EXPANDED_NODES = 100_000

_DROPPED_TAGS = {
    "tag:yaml.org,2002:bool", "tag:yaml.org,2002:int", "tag:yaml.org,2002:float",
    "tag:yaml.org,2002:timestamp", "tag:yaml.org,2002:value",
}


class StrictLoader(yaml.SafeLoader):
    """Safe loader with YAML 1.2-style decimal scalars and refusal of duplicate keys."""

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if not isinstance(key_node, ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = key_node.value
            line = key_node.start_mark.line + 1
            if key in seen:
                raise InputError(
                    f"key {key!r} is given twice in the same mapping (lines {seen[key]} and "
                    f"{line}); YAML would silently keep the last one: remove one of them")
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


StrictLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in _DROPPED_TAGS]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_BOOL = re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$")
_INT = re.compile(r"^[-+]?[0-9]+$")
_FLOAT = re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
                    r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$")
#: Most digits of an integer (Python refuses to convert more than 4300).
MAX_INT_DIGITS = 1000
StrictLoader.add_implicit_resolver("tag:yaml.org,2002:bool", _BOOL, list("tTfF"))
StrictLoader.add_implicit_resolver("tag:yaml.org,2002:int", _INT, list("-+0123456789"))
StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+.0123456789"))


def _refuse(loader: StrictLoader, node: Node, what: str) -> ConstructorError:
    return ConstructorError(None, None, what, node.start_mark)


def _construct_bool(loader: StrictLoader, node: Node) -> bool:
    value = loader.construct_scalar(node)
    if not _BOOL.match(value):
        raise _refuse(loader, node, f"{excerpt(value)} is not true or false")
    return value.lower() == "true"


def _construct_int(loader: StrictLoader, node: Node) -> int:
    value = loader.construct_scalar(node)
    if not _INT.match(value):
        raise _refuse(loader, node, f"{excerpt(value)} is not a decimal integer")
    if len(value) > MAX_INT_DIGITS:
        raise _refuse(loader, node, f"an integer of {len(value)} digits")
    number = int(value)
    try:
        float(number)  # every number field is used as a float: one beyond it is no number
    except OverflowError:
        raise _refuse(loader, node, f"an integer of {len(value)} digits, beyond the largest "
                      "number feedopt computes with (1.8e308)") from None
    return number


def _construct_float(loader: StrictLoader, node: Node) -> float:
    value = loader.construct_scalar(node)
    if not (_FLOAT.match(value) or _INT.match(value)):
        raise _refuse(loader, node, f"{excerpt(value)} is not a decimal number")
    if len(value) > MAX_INT_DIGITS:
        raise _refuse(loader, node, f"a number of {len(value)} characters")
    low = value.lower()
    if low.endswith(".inf"):
        return -math.inf if low.startswith("-") else math.inf
    return math.nan if low.endswith(".nan") else float(value)


def _construct_refused(loader: StrictLoader, node: Node) -> None:
    raise _refuse(loader, node, f"the tag {node.tag} has no use in a feedopt file: write the "
                  "value without it")


StrictLoader.add_constructor("tag:yaml.org,2002:bool", _construct_bool)
StrictLoader.add_constructor("tag:yaml.org,2002:int", _construct_int)
StrictLoader.add_constructor("tag:yaml.org,2002:float", _construct_float)
for _tag in ("binary", "timestamp", "set", "omap", "pairs", "value", "yaml"):
    StrictLoader.add_constructor(f"tag:yaml.org,2002:{_tag}", _construct_refused)


def _expanded_size(root: Node, budget: int) -> int:
    """Number of nodes ``root`` expands to with every alias copied (memoised, so cheap).

    InputError for an alias inside its own anchor (a structure that contains itself: no job
    file means that, and readers walking it would never end)."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def size(node: Node) -> int:
        key = id(node)
        if key in open_nodes:
            mark = node.start_mark
            raise InputError(f"line {mark.line + 1}: an alias refers to the anchor it is inside "
                             "(a structure that contains itself): write the values out")
        if key in sizes:
            return sizes[key]
        open_nodes.add(key)
        total = 1
        if isinstance(node, SequenceNode):
            total += sum(size(child) for child in node.value)
        elif isinstance(node, MappingNode):
            total += sum(size(k) + size(v) for k, v in node.value)
        open_nodes.discard(key)
        sizes[key] = min(total, budget + 1)
        return sizes[key]

    return size(root)


def parse_yaml(text: str, source: str) -> Any:
    """Parse one YAML document with :class:`StrictLoader`; InputError naming ``source``."""
    try:
        loader = StrictLoader(text)  # refuses control characters (yaml.reader.ReaderError)
    except yaml.YAMLError as exc:
        raise InputError(f"{source}: not valid YAML: {exc}") from None
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        n = _expanded_size(node, MAX_EXPANDED_NODES)
        if n > MAX_EXPANDED_NODES:
            raise InputError(
                f"{source}: the YAML anchors/aliases expand to more than "
                f"{MAX_EXPANDED_NODES:,} values; a job file needs far fewer: write the values "
                "out or use fewer nested aliases")
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise InputError(f"{source}: not valid YAML{where}: {problem}") from None
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(source) else f"{source}: {msg}") from None
    except RecursionError:
        raise InputError(f"{source}: the YAML is nested too deeply to be a job file") from None
    except (ValueError, TypeError, OverflowError) as exc:  # e.g. !!float abc, a 5000-digit int
        raise InputError(f"{source}: not valid YAML: a value cannot be read "
                         f"({str(exc)[:120]})") from None
    finally:
        loader.dispose()


def read_yaml(path: str | Path, what: str) -> Any:
    """Read and parse the YAML file ``path`` (``what`` names it in messages)."""
    return parse_yaml(read_user_text(path, what), f"{what} {path}")


def read_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """Read a YAML file whose top level must be a mapping; InputError otherwise."""
    data = read_yaml(path, what)
    if not isinstance(data, dict):
        raise InputError(f"{what} {path}: expected a mapping of fields at the top level, got "
                         f"{type(data).__name__}")
    return data


_SHORT = reprlib.Repr()  # Python 3.11: limits are attributes, not constructor arguments
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxdict = 2, 4, 3
_SHORT.maxstring = _SHORT.maxother = 40


def excerpt(value: object, limit: int = 60) -> str:
    """A short ``repr`` of ``value`` (never more than ``limit`` characters) for messages."""
    text = _SHORT.repr(value)
    return text if len(text) <= limit else text[: limit - 4] + " ..."
