"""Small helpers shared by the process-stage file readers (YAML/CSV at the user's edge)."""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from typing import Any

from feedopt.errors import InputError
from feedopt.yamlio import read_yaml_mapping  # noqa: F401 - re-exported for the readers


def number(data: dict[str, Any], key: str, where: str) -> float:
    """Return ``data[key]`` as a finite float; InputError naming ``where.key`` otherwise."""
    if key not in data:
        raise InputError(f"{where}: missing field {key!r}")
    value = data[key]
    if isinstance(value, bool):
        raise InputError(f"{where}.{key}: expected a number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}.{key}: expected a number, got {value!r}") from exc
    if not math.isfinite(out):
        raise InputError(f"{where}.{key}: must be finite, got {value!r}")
    return out


def check_keys(data: dict[Any, Any], known: Sequence[str], where: str,
               hints: Mapping[str, str] | None = None) -> None:
    """InputError naming ``where``, the first unknown key of ``data`` (with a close match
    from ``known`` when there is one, or the ``hints`` text of a word in it) and the known keys.
    """
    unknown = [k for k in data if k not in known]
    if not unknown:
        return
    key = str(unknown[0])
    close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.75)
    note = next((text for word, text in (hints or {}).items() if word in key.lower()), "")
    if close:
        note = f"did you mean {close[0]!r}?"
    others = f" (and {len(unknown) - 1} more unknown)" if len(unknown) > 1 else ""
    raise InputError(f"{where}: unknown key {key!r}{others}{': ' + note if note else ''}; "
                     f"known keys: {', '.join(known)}")


def text(data: dict[str, Any], key: str, where: str, default: str = "") -> str:
    """``data[key]`` as text (a number is written as text); ``default`` when missing or null;
    InputError for a mapping or list."""
    value = data.get(key)
    if value is None:
        return default
    if isinstance(value, (dict, list)):
        raise InputError(f"{where}.{key}: expected text, got a {type(value).__name__}")
    return str(value)
