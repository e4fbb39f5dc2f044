"""What every strict YAML file of feedopt shares: the strict pydantic base, one readable
message for all validation problems (field path, problem, the nearest valid name of an
unknown field) and a Markdown field reference generated from a model.

Used by the scenario (:mod:`feedopt.scenario`) and robot.yaml (:mod:`feedopt.robot.robot_file`).
"""

from __future__ import annotations

import difflib
from typing import Annotated, Literal, get_args, get_origin

from pydantic import BaseModel, ConfigDict, ValidationError

from feedopt.yamlio import excerpt


class Strict(BaseModel):
    """Unknown keys refused; a number field takes a number written as a number (no "true"
    -> 1.0, no strings parsed as numbers; the YAML reader keeps 0x1D, yes/no, 1:30 as
    strings)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


def sub_model(annotation: object) -> type[BaseModel] | None:
    """The model class inside a field's annotation (``X``, ``X | None``, ...), else None."""
    return next((a for a in getattr(annotation, "__args__", (annotation,))
                 if isinstance(a, type) and issubclass(a, BaseModel)), None)


def field_names(model: type[BaseModel], loc: tuple) -> list[str]:
    """Valid field names of ``model`` at location ``loc`` (for suggestions)."""
    current: type[BaseModel] | None = model
    for part in loc:
        if current is None or not isinstance(part, str) or part not in current.model_fields:
            break
        current = sub_model(current.model_fields[part].annotation)
    return list(current.model_fields) if current is not None else []


def format_validation_error(exc: ValidationError, source: str, model: type[BaseModel],
                            what: str) -> str:
    """One readable message for all pydantic errors of a ``what`` (e.g. "scenario") file
    ``source`` validated against ``model``: field path, problem, suggestion."""
    lines = [f"{source}: invalid {what} ({exc.error_count()} problem(s)):"]
    for err in exc.errors():
        loc = tuple(p for p in err["loc"] if not _is_union_tag(p))
        if err["type"] == "extra_forbidden" and err["loc"]:  # the unknown key itself, as is
            loc = tuple(p for p in err["loc"][:-1] if not _is_union_tag(p)) + err["loc"][-1:]
        path = ".".join(str(p) for p in loc) or "(top level)"
        if err["type"] == "extra_forbidden":
            names = field_names(model, loc[:-1])
            close = difflib.get_close_matches(str(loc[-1]), names, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else f"; valid: {', '.join(names)}"
            lines.append(f"  - {path}: unknown field{hint}")
        elif err["type"] == "missing":
            lines.append(f"  - {path}: required field is missing")
        else:
            got = err.get("input")
            got_s = "" if isinstance(got, dict) else f" (got {excerpt(got)})"
            lines.append(f"  - {path}: {err['msg']}{got_s}")
    return "\n".join(lines)


def _is_union_tag(part: object) -> bool:
    """pydantic's location entries naming a union member (``list[float]``, ``function-
    before[...]``), which are not field names."""
    return isinstance(part, str) and ("[" in part or part in ("str", "float", "int"))


def type_name(ann: object) -> str:
    """Readable type of a field: allowed values of a Literal, list of numbers, ..."""
    origin, args = get_origin(ann), get_args(ann)
    if origin is Literal:
        return " | ".join(repr(a) for a in args)
    if origin is dict:
        return "mapping"
    if origin is list:
        return "list of numbers" if args and get_args(args[0])[:1] == (float,) else "list"
    if origin is Annotated:
        return type_name(args[0])
    if args:  # a union such as float | None
        return " | ".join("null" if a is type(None) else type_name(a) for a in args)
    return getattr(ann, "__name__", str(ann))


def reference_lines(model: type[BaseModel], prefix: str = "",
                    leaves: tuple[type[BaseModel], ...] = ()) -> list[str]:
    """Markdown bullets of every field of ``model`` and its sections, recursively (a model in
    ``leaves`` is listed as one field, not as a section)."""
    out = []
    for name, f in model.model_fields.items():
        ann = f.annotation
        sub = sub_model(ann)
        default = "required" if f.is_required() else f"default `{f.default!r}`"
        if sub is not None and sub not in leaves:
            note = f": {f.description}" if f.description else ""
            out.append(f"- **{prefix}{name}** (section){note}")
            out += reference_lines(sub, f"{prefix}{name}.", leaves)
        else:
            out.append(f"- **{prefix}{name}** — {f.description or ''} ({default}; "
                       f"{type_name(ann)})")
    return out
