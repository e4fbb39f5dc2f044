"""The blend registry: the one place a corner-blend kind is declared.

A :class:`BlendKind` bundles everything the rest of feedopt needs to know about one kind of
corner blend of linear interpolation with polynomial blends (LIPB, thesis 3.3): the name of
its size parameter (a radius or a tolerance, with its meaning for users), its tangent
distance (how much of each adjoining line it uses), the largest size that fits a corner,
the builder that turns corners into segment parameters, the evaluator of those segments by
arc length, and its plot colour. :func:`~feedopt.geometry.path.build_lipb_path`,
``feedopt path`` and the path figure take all of it from here, so a new kind is one
:func:`register_blend` call::

    register_blend(BlendKind(name="my_blend", size=TOLERANCE, tangent_distance=...,
                             largest_size=..., build=..., evaluator=..., colour="tab:cyan"))

The built-in kinds (circle, bezier4, bezier5, varying_radius) are registered by
:mod:`feedopt.geometry.blend_kinds` when :mod:`feedopt.geometry` is imported. ``"none"``
(:data:`NO_BLEND`: sharp corners, no blend) is not a kind but is always accepted where a
blend is chosen; ``"line"`` (:data:`LINE`) is the segment kind of the lines between blends.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from feedopt.errors import InputError

if TYPE_CHECKING:  # pragma: no cover - typing only (blends/path import this module)
    from feedopt.geometry.corners import Corners

LINE = "line"  #: segment kind of the lines of an LIPB path (not a blend)
NO_BLEND = "none"  #: blend choice that leaves every corner sharp
_RESERVED = (LINE, NO_BLEND)
_NAME = re.compile(r"[a-z][a-z0-9_]*")


@dataclass(frozen=True)
class SizeParameter:
    """The one number that sizes a blend kind.

    Attributes
    ----------
    name : lower-case identifier, e.g. ``"radius"``; ``feedopt path`` takes it as
        ``--<name> MM`` and messages call the size by it
    meaning : what the number is, for users (help texts)
    """

    name: str
    meaning: str


RADIUS = SizeParameter("radius", "blend radius [mm] (circle: its radius; varying_radius: "
                       "r0, the radius where it meets the lines)")
TOLERANCE = SizeParameter("tolerance", "blend tolerance delta [mm]: distance from the corner "
                          "along each line to where the blend starts (Eq. 3.1)")


class SegmentEvaluator(Protocol):
    """Evaluator of all segments of one kind of a path (built once per path).

    ``eval(j, sl)`` takes (n,) indices ``j`` into the segments it was built from and (n,)
    local arc lengths ``sl`` in [0, length of segment j] [m] and returns position (n, 3) [m],
    unit tangent dp/ds (n, 3), curvature vector d2p/ds2 (n, 3) [1/m] and its derivative
    d3p/ds3 (n, 3) [1/m^2], vectorised over n.
    """

    def eval(self, j: np.ndarray, sl: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class BuiltBlends:
    """Output of a :attr:`BlendKind.build`: one blend per corner given to it.

    Attributes
    ----------
    params : arrays with leading axis m (one row per corner); row k becomes the ``params``
        dict of the k-th blend's :class:`~feedopt.geometry.path.Segment`
    length : (m,) arc length of each blend [m]
    """

    params: dict[str, np.ndarray]
    length: np.ndarray


@dataclass(frozen=True)
class BlendKind:
    """Everything feedopt knows about one kind of corner blend.

    Attributes
    ----------
    name : identifier used in scenarios, ``--blend`` and segment kinds (not "line"/"none")
    size : its size parameter (:data:`RADIUS`, :data:`TOLERANCE` or another)
    tangent_distance : ``(turn (m,), size) -> (m,)``: distance from the corner point along
        each line to where the blend meets it [m], for corners turning by ``turn`` [rad]
    largest_size : ``(turn (m,), room (m,)) -> (m,)``: the largest size whose tangent
        distance is at most ``room`` [m] (inverse of ``tangent_distance``, for the "does not
        fit" messages)
    build : ``(corners, size) -> BuiltBlends``: the blends of the given
        :class:`~feedopt.geometry.blends.Corners` (all turning by at least the collinear
        tolerance and fitting their lines), vectorised over the corners
    evaluator : ``(segments) -> SegmentEvaluator``: built once per path from all its
        segments of this kind (their ``params`` are what ``build`` returned)
    colour : matplotlib colour of this kind in path figures
    max_turn : corners turning more than this [rad] are refused for this kind (besides the
        reversal limit every kind has); ``pi``: no extra limit
    max_turn_reason : why, for that message (e.g. "Eq. 3.3 gives an almost zero alpha")
    description : one line for users (help texts)
    """

    name: str
    size: SizeParameter
    tangent_distance: Callable[[np.ndarray, float], np.ndarray]
    largest_size: Callable[[np.ndarray, np.ndarray], np.ndarray]
    build: Callable[[Corners, float], BuiltBlends]
    evaluator: Callable[[Sequence[Any]], SegmentEvaluator]
    colour: str
    max_turn: float = np.pi
    max_turn_reason: str = ""
    description: str = field(default="", compare=False)


_REGISTRY: dict[str, BlendKind] = {}


@dataclass(frozen=True)
class SegmentKind:
    """A kind of path segment that is not a corner blend: programmed arcs, G2 transitions,
    smoothed point chains (:mod:`feedopt.geometry.program_path` builds them).

    Attributes
    ----------
    name : identifier used as the segment kind (not "line", "none" or a blend's name)
    evaluator : ``(segments) -> SegmentEvaluator``, as for blends
    colour : matplotlib colour of this kind in path figures
    description : one line for users
    """

    name: str
    evaluator: Callable[[Sequence[Any]], SegmentEvaluator]
    colour: str
    description: str = field(default="", compare=False)


_SEGMENT_KINDS: dict[str, SegmentKind] = {}


def register_segment_kind(kind: SegmentKind) -> SegmentKind:
    """Add a non-blend segment kind (ValueError for a name taken by a blend or a kind)."""
    if not _NAME.fullmatch(kind.name) or kind.name in _RESERVED:
        raise ValueError(f"segment kind name {kind.name!r} must be a lower-case identifier "
                         f"other than {' and '.join(map(repr, _RESERVED))}")
    if kind.name in _REGISTRY or kind.name in _SEGMENT_KINDS:
        raise ValueError(f"a segment or blend kind named {kind.name!r} is already registered")
    _SEGMENT_KINDS[kind.name] = kind
    return kind


def segment_kinds() -> tuple[SegmentKind, ...]:
    """The registered non-blend segment kinds, in registration order."""
    return tuple(_SEGMENT_KINDS.values())


def register_blend(kind: BlendKind) -> BlendKind:
    """Add ``kind`` to the registry (after the kinds already there) and return it.

    Raises ``ValueError`` for a name that is taken, reserved ("line", "none") or not a
    lower-case identifier, and for a size parameter whose name another kind already uses
    with a different meaning (``feedopt path`` has one ``--<name>`` option per size name).
    """
    if not isinstance(kind, BlendKind):
        raise TypeError(f"register_blend takes a BlendKind, got {type(kind).__name__}")
    if not _NAME.fullmatch(kind.name) or kind.name in _RESERVED:
        raise ValueError(f"blend name {kind.name!r} must be a lower-case identifier other than "
                         f"{' and '.join(map(repr, _RESERVED))}")
    if kind.name in _REGISTRY or kind.name in _SEGMENT_KINDS:
        raise ValueError(f"a blend kind named {kind.name!r} is already registered")
    if not _NAME.fullmatch(kind.size.name):
        raise ValueError(f"size parameter name {kind.size.name!r} of blend {kind.name!r} must "
                         "be a lower-case identifier")
    for other in _REGISTRY.values():
        if other.size.name == kind.size.name and other.size != kind.size:
            raise ValueError(
                f"blend {kind.name!r} gives size parameter {kind.size.name!r} a different "
                f"meaning than blend {other.name!r} does; reuse {other.name}'s SizeParameter "
                "or choose another name")
    if not 0.0 < kind.max_turn <= np.pi:
        raise ValueError(f"max_turn of blend {kind.name!r} must lie in (0, pi], got "
                         f"{kind.max_turn}")
    _REGISTRY[kind.name] = kind
    return kind


def unregister_blend(name: str) -> BlendKind:
    """Remove a registered kind and return it (paths already built keep working)."""
    try:
        return _REGISTRY.pop(name)
    except KeyError:
        raise ValueError(f"no blend kind named {name!r} is registered") from None


def blend_names() -> tuple[str, ...]:
    """Every accepted blend choice: the registered kinds in order, then ``"none"``."""
    return (*_REGISTRY, NO_BLEND)


def blend_kinds() -> tuple[BlendKind, ...]:
    """The registered kinds, in registration order."""
    return tuple(_REGISTRY.values())


def get_blend(name: str) -> BlendKind | None:
    """The registered kind called ``name``; ``None`` for ``"none"``.

    Raises :class:`~feedopt.errors.InputError` naming the choices for any other name.
    """
    if name == NO_BLEND:
        return None
    kind = _REGISTRY.get(name) if isinstance(name, str) else None
    if kind is None:
        raise InputError(f"unknown blend {name!r}; choose one of {', '.join(blend_names())}")
    return kind


def size_parameters() -> dict[str, tuple[SizeParameter, tuple[str, ...]]]:
    """Every size parameter name in use: its :class:`SizeParameter` and the kinds using it."""
    out: dict[str, tuple[SizeParameter, tuple[str, ...]]] = {}
    for kind in _REGISTRY.values():
        size, names = out.get(kind.size.name, (kind.size, ()))
        out[kind.size.name] = (size, (*names, kind.name))
    return out
