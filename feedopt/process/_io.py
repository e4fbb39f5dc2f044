"""Small helpers shared by the process-stage file readers (YAML/CSV at the user's edge)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from feedopt.errors import InputError


def read_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """Read a YAML file whose top level must be a mapping; InputError otherwise."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what} file {str(p)!r} does not exist")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise InputError(f"{what} file {str(p)!r} is not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise InputError(f"{what} file {str(p)!r}: expected a mapping of fields at the top level")
    return data


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
