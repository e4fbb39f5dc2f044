"""Small helpers shared by the process-stage file readers (YAML/CSV at the user's edge)."""

from __future__ import annotations

import math
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
