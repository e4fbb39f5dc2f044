"""Grid specifications of ``feedopt sweep --grid``: which numeric fields vary, over which values.

One ``--grid`` option names one field by its dotted path in the scenario
(``workpiece.position_mm``, ``cut.axial_depth_mm``, ``schedule.law_options.convex.<field>``)
or in the robot's ``robot.yaml`` (prefix ``robot_yaml.``, e.g. ``robot_yaml.tool.tcp_xyz_mm``
for the TCP offset), and its values::

    cut.spindle_rpm=2000:3000:250          lo:hi:step, both ends included
    deflection.limit_mm=0.2;0.25;0.29      a list
    workpiece.position_mm=x:1500:1900:50,y:-400:400:50,z:800   components of a vector

A vector's components are named ``x``, ``y``, ``z`` (3-vectors) or by index ``0``..``n-1``;
each varied component is one axis of the grid, unnamed components keep the scenario's value.
Values are decimal: ``0:0.3:0.1`` gives 0, 0.1, 0.2, 0.3 exactly as written. The grid is the
Cartesian product of all axes. Overrides are applied to the scenario's raw YAML data before
validation, so each point is checked exactly as if the user had written it in the file. A
``fits:`` note on a swept field is dropped at every point: there the value is the sweep's
choice, not a value fitted to reproduce a reference.
"""

from __future__ import annotations

import copy
import difflib
import itertools
import types
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from feedopt.errors import InputError

#: Prefix of fields of the robot directory's robot.yaml (TCP offset, joint stiffness, ...).
ROBOT_PREFIX = "robot_yaml."
#: Names of the components of 3-vectors (positions, angles, axes).
XYZ = ("x", "y", "z")
#: Largest number of values of one axis, and of points of a grid.
MAX_AXIS_VALUES = 10_000
MAX_POINTS = 100_000

Number = float | int


@dataclass(frozen=True)
class Axis:
    """One varied number: a scalar field, or one component of a vector field.

    Attributes
    ----------
    field : str
        Dotted path as the user wrote it (``robot_yaml.`` prefix included).
    component : int or None
        Index in the vector field; None for a scalar field.
    label : str or None
        Component name as written (``x``, ``2``).
    values : tuple of float or int
        The values, in the order written (int for integer fields).
    base : tuple or None
        The whole vector as the scenario (or the schema's default) gives it, for a component.
    """

    field: str
    component: int | None
    label: str | None
    values: tuple[Number, ...]
    base: tuple[Number, ...] | None = None

    @property
    def name(self) -> str:
        """Column name in the table: the field, plus ``.<component>`` for a vector."""
        return self.field if self.label is None else f"{self.field}.{self.label}"

    @property
    def fit_name(self) -> str:
        """How a scenario's ``fits:`` note names this field (``stock.box_mm[5]``)."""
        return self.field if self.component is None else f"{self.field}[{self.component}]"

    @property
    def in_robot(self) -> bool:
        """True for a robot.yaml field."""
        return self.field.startswith(ROBOT_PREFIX)

    @property
    def keys(self) -> tuple[str, ...]:
        """Path of keys in the YAML data it changes."""
        return tuple(self.field.removeprefix(ROBOT_PREFIX).split("."))


@dataclass(frozen=True)
class Grid:
    """The axes of a sweep; its points are the Cartesian product of their values."""

    axes: tuple[Axis, ...]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.axes)

    @property
    def size(self) -> int:
        n = 1
        for k in self.shape:
            n *= k
        return n

    def points(self) -> Iterator[tuple[Number, ...]]:
        """Every point, the last axis varying fastest."""
        return itertools.product(*(a.values for a in self.axes))


def point_key(values: Sequence[Number | str]) -> tuple[float, ...]:
    """The identity of a point (its values as floats), for resuming from a table."""
    return tuple(float(v) for v in values)


# --- field types --------------------------------------------------------------------------

@dataclass(frozen=True)
class _Leaf:
    kind: Literal["float", "int"]
    vector: bool
    default: Any  # the schema's default (PydanticUndefined if required)


def _unwrap(ann: Any) -> list[Any]:
    """The alternatives of an annotation, Annotated and Optional removed."""
    origin = get_origin(ann)
    if origin is Annotated:
        return _unwrap(get_args(ann)[0])
    if origin is Union or origin is types.UnionType:
        return [a for arg in get_args(ann) if arg is not type(None) for a in _unwrap(arg)]
    return [ann]


def _number_kind(ann: Any) -> Literal["float", "int"] | None:
    alts = _unwrap(ann)
    if len(alts) != 1:
        return None
    if alts[0] is float:
        return "float"
    if alts[0] is int:
        return "int"
    return None


def _classify(ann: Any) -> tuple[Literal["float", "int"] | None, bool]:
    """(number kind, is a list) of a leaf annotation; kind None when it is not numeric."""
    alts = _unwrap(ann)
    if len(alts) == 1 and get_origin(alts[0]) is list:
        args = get_args(alts[0])
        return (_number_kind(args[0]) if args else None), True
    return _number_kind(ann), False


def _submodel(ann: Any) -> type[BaseModel] | None:
    return next((a for a in _unwrap(ann) if isinstance(a, type) and issubclass(a, BaseModel)),
                None)


def _unknown(name: str, where: str, valid: Sequence[str]) -> InputError:
    close = difflib.get_close_matches(name, list(valid), n=1)
    hint = f"did you mean '{close[0]}'?" if close else f"valid: {', '.join(valid)}"
    return InputError(f"--grid {where}: no field '{name}' there; {hint}")


def _scenario_leaf(keys: tuple[str, ...], field: str) -> _Leaf:
    """Type of the scenario field at ``keys``; InputError naming ``field`` if not numeric."""
    from feedopt.scenario import Scenario
    from feedopt.schedule.laws import LAWS

    model: type[BaseModel] = Scenario
    i = 0
    while i < len(keys):
        part = keys[i]
        where = ".".join(keys[:i]) or "(top level)"
        if part not in model.model_fields:
            raise _unknown(part, f"{field}: {where}", list(model.model_fields))
        info = model.model_fields[part]
        rest = keys[i + 1:]
        if model.__name__ == "ScheduleSection" and part == "law_options":
            if not rest:
                break
            if rest[0] not in LAWS:
                raise _unknown(rest[0], f"{field}: schedule.law_options", list(LAWS))
            model, i = LAWS[rest[0]].options_model(), i + 2
            continue
        sub = _submodel(info.annotation)
        if sub is not None and rest:
            model, i = sub, i + 1
            continue
        if sub is not None or rest:
            what = "a section" if sub is not None else "not a section"
            raise InputError(f"--grid {field}: {'.'.join(keys[:i + 1])} is {what}; a sweep "
                             "varies one numeric field (e.g. workpiece.position_mm, "
                             "cut.axial_depth_mm; `feedopt validate --schema` lists them)")
        kind, vector = _classify(info.annotation)
        if kind is None:
            raise InputError(f"--grid {field}: not a numeric field (text, yes/no or a choice); "
                             "a sweep varies numbers: run one sweep per value of such a field")
        return _Leaf(kind, vector, info.default)
    raise InputError(f"--grid {field}: name a numeric field inside it (e.g. "
                     "schedule.law_options.convex.<field>; `feedopt validate --schema` lists "
                     "them)")


def _robot_leaf(keys: tuple[str, ...], field: str, robot_doc: dict) -> _Leaf:
    """Type of the robot.yaml field at ``keys``, from the value the file holds."""
    node: Any = robot_doc
    for i, part in enumerate(keys):
        if not isinstance(node, dict) or part not in node:
            where = ".".join(keys[:i]) or "the top level"
            valid = list(node) if isinstance(node, dict) else []
            raise _unknown(part, f"{field}: robot.yaml {where}", valid or ["(none)"])
        node = node[part]
    numbers = node if isinstance(node, list) else [node]
    if not numbers or any(isinstance(v, bool) or not isinstance(v, int | float)
                          for v in numbers):
        raise InputError(f"--grid {field}: robot.yaml holds {node!r} there, not a number or a "
                         "list of numbers; a sweep varies numbers")
    return _Leaf("float", isinstance(node, list), PydanticUndefined)


def _get(data: dict, keys: Sequence[str]) -> Any:
    node: Any = data
    for k in keys:
        if not isinstance(node, dict) or k not in node:
            return PydanticUndefined
        node = node[k]
    return node


# --- values -------------------------------------------------------------------------------

def _decimal(text: str, field: str) -> Decimal:
    try:
        d = Decimal(text.strip())
    except InvalidOperation:
        d = None
    if d is None or not d.is_finite():
        raise InputError(f"--grid {field}: '{text}' is not a decimal number (write values as "
                         "lo:hi:step, v1;v2;... or one number)")
    return d


def _values(text: str, field: str, kind: str) -> tuple[Number, ...]:
    """Values of ``lo:hi:step``, ``v1;v2;...`` or ``v``, exact as decimals."""
    if not text.strip():
        raise InputError(f"--grid {field}: no values given (write lo:hi:step, v1;v2;... or v)")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError(f"--grid {field}: '{text}' is not lo:hi:step (three numbers)")
        lo, hi, step = (_decimal(p, field) for p in parts)
        if step <= 0:
            raise InputError(f"--grid {field}: step {step} must be positive")
        if hi < lo:
            raise InputError(f"--grid {field}: hi {hi} is below lo {lo}; write lo:hi:step with "
                             "lo <= hi")
        count = int((hi - lo) // step) + 1
        if count > MAX_AXIS_VALUES:
            raise InputError(f"--grid {field}: {lo}:{hi}:{step} gives {count} values, more than "
                             f"{MAX_AXIS_VALUES}; use a larger step")
        decimals = [lo + k * step for k in range(count)]
    else:
        decimals = [_decimal(p, field) for p in text.split(";")]
    if kind == "int":
        if any(d != d.to_integral_value() for d in decimals):
            raise InputError(f"--grid {field}: an integer field; '{text}' gives non-integer "
                             "values")
        out: tuple[Number, ...] = tuple(int(d) for d in decimals)
    else:
        out = tuple(float(d) for d in decimals)
    if len(set(out)) != len(out):
        raise InputError(f"--grid {field}: '{text}' repeats a value")
    return out


def _component(label: str, length: int, field: str) -> int:
    names = XYZ if length == 3 else ()
    if label in names:
        return names.index(label)
    if label.isdigit() and int(label) < length:
        return int(label)
    valid = ", ".join(list(names) + [str(i) for i in range(length)])
    raise InputError(f"--grid {field}: no component '{label}' in a vector of {length}; "
                     f"name one of {valid}")


def parse_axes(spec: str, raw: dict, robot_doc: dict) -> list[Axis]:
    """The axes of one ``--grid FIELD=VALUES`` option (several for a vector field).

    Parameters
    ----------
    spec
        The option's text.
    raw
        The scenario's YAML data (for the current value of a vector field).
    robot_doc
        The robot's robot.yaml data (for ``robot_yaml.`` fields).

    Raises
    ------
    InputError
        Naming the field: unknown or non-numeric field, malformed values, bad component.
    """
    field, sep, text = spec.partition("=")
    field = field.strip()
    if not sep or not field:
        raise InputError(f"--grid {spec}: write FIELD=VALUES, e.g. cut.spindle_rpm=2000:3000:500 "
                         "or workpiece.position_mm=x:1600:1900:100,z:800")
    keys = tuple(field.removeprefix(ROBOT_PREFIX).split("."))
    if any(not k for k in keys):
        raise InputError(f"--grid {field}: empty name between dots")
    if field.startswith(ROBOT_PREFIX):
        leaf = _robot_leaf(keys, field, robot_doc)
        current = _get(robot_doc, keys)
    else:
        leaf = _scenario_leaf(keys, field)
        current = _get(raw, keys)
        if current is PydanticUndefined:
            current = leaf.default
    if not leaf.vector:
        return [Axis(field, None, None, _values(text, field, leaf.kind))]
    if not isinstance(current, list):
        raise InputError(f"--grid {field}: the scenario gives no value for this vector field; "
                         "write it in the scenario first, then sweep its components")
    axes = []
    for part in text.split(","):
        label, colon, values = part.partition(":")
        label = label.strip()
        valid = [*(XYZ if len(current) == 3 else ()), *map(str, range(len(current)))]
        if not colon or (label not in valid and _is_number(label)):
            raise InputError(f"--grid {field}: a vector field: name the component of each "
                             f"range, e.g. {field}=x:1600:1900:100,z:800 (got '{part}')")
        index = _component(label, len(current), field)
        if any(a.component == index for a in axes):
            raise InputError(f"--grid {field}: component {label} is given twice")
        axes.append(Axis(field, index, label, _values(values, f"{field}.{label}", leaf.kind),
                         base=tuple(current)))
    return axes


def _is_number(text: str) -> bool:
    try:
        Decimal(text)
    except InvalidOperation:
        return False
    return True


def parse_grid(specs: Sequence[str], raw: dict, robot_doc: dict) -> Grid:
    """The grid of every ``--grid`` option; InputError naming the field for any problem."""
    if not specs:
        raise InputError("--grid: give at least one, e.g. --grid "
                         "workpiece.position_mm=x:1600:1900:100,z:800")
    axes: list[Axis] = []
    for spec in specs:
        for axis in parse_axes(spec, raw, robot_doc):
            if any((a.field, a.component) == (axis.field, axis.component) for a in axes):
                raise InputError(f"--grid {axis.name}: given twice; give each field once")
            axes.append(axis)
    grid = Grid(tuple(axes))
    if grid.size > MAX_POINTS:
        sizes = " x ".join(f"{len(a.values)} ({a.name})" for a in axes)
        raise InputError(f"--grid: {sizes} = {grid.size} points, more than {MAX_POINTS}; use "
                         "larger steps or fewer fields")
    return grid


def _set(data: dict, axis: Axis, value: Number) -> None:
    node = data
    keys = axis.keys
    for k in keys[:-1]:
        child = node.get(k)
        if not isinstance(child, dict):
            child = {}
            node[k] = child
        node = child
    if axis.component is None:
        node[keys[-1]] = value
        return
    vector = list(node.get(keys[-1], axis.base))
    vector[axis.component] = value
    node[keys[-1]] = vector


def apply_point(raw: dict, robot_doc: dict, axes: Sequence[Axis],
                values: Sequence[Number]) -> tuple[dict, dict | None]:
    """The scenario data and robot.yaml data (None when unchanged) of one grid point.

    ``raw`` and ``robot_doc`` are not modified.
    """
    new_raw = copy.deepcopy(raw)
    new_robot = copy.deepcopy(robot_doc) if any(a.in_robot for a in axes) else None
    for axis, value in zip(axes, values, strict=True):
        _set(new_robot if axis.in_robot else new_raw, axis, value)
    swept = {a.fit_name for a in axes if not a.in_robot}
    fits = new_raw.get("fits")
    if isinstance(fits, list):  # a swept value is the sweep's, no longer a fit (FitNote)
        new_raw["fits"] = [f for f in fits if not (isinstance(f, dict)
                                                   and f.get("field") in swept)]
    return new_raw, new_robot
