"""The one rule every registry of feedopt follows (laws, blends, bound constraints,
exporters): names are unique, entries keep their registration order."""

from __future__ import annotations

from typing import TypeVar

T = TypeVar("T")


def add_unique(registry: dict[str, T], name: str, entry: T, what: str) -> T:
    """Add ``entry`` under ``name``; ValueError naming ``what`` if the name is taken."""
    if name in registry:
        raise ValueError(f"{what} {name!r} is already registered")
    registry[name] = entry
    return entry
