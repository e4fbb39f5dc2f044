"""What "best" means in a sweep: the feasible point with the smallest objective.

``t_star`` (default: the lower bound on the cycle time of any law under the feed bound, so
the placement where the robot is stiffest along this path), ``cycle_time:<law>`` (that law's
cycle time; the law must have planned and kept its promises at the point),
``max_deflection`` / ``mean_deflection`` (at the nominal feed; the mean is the criterion
Schnoes and Zach chose placements by).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from feedopt.errors import InputError
from feedopt.sweep.table import Row

_SIMPLE = {
    "t_star": ("t_star_s", "T* [s]"),
    "max_deflection": ("max_deflection_nominal_mm", "max deflection at the nominal feed [mm]"),
    "mean_deflection": ("mean_deflection_nominal_mm",
                        "mean deflection at the nominal feed [mm]"),
}
_CYCLE = "cycle_time"
_KEPT_PROMISES = ("exportable", "verified")


@dataclass(frozen=True)
class Objective:
    """A column to minimise over the feasible points."""

    name: str
    column: str
    label: str
    law: str | None = None

    def value(self, row: Row) -> float | None:
        """The objective of ``row``; None when the point is not a candidate."""
        if row.get("feasible") != "yes":
            return None
        if self.law is not None and row.get(f"{self.law}.verdict") not in _KEPT_PROMISES:
            return None
        text = row.get(self.column, "")
        return float(text) if text else None


def choices(laws: Sequence[str]) -> list[str]:
    """Every objective a sweep of ``laws`` offers."""
    return list(_SIMPLE) + [f"{_CYCLE}:{law}" for law in laws]


def parse_objective(text: str, laws: Sequence[str]) -> Objective:
    """The objective ``text`` names; InputError listing the choices otherwise."""
    if text in _SIMPLE:
        column, label = _SIMPLE[text]
        return Objective(text, column, label)
    kind, _, law = text.partition(":")
    if kind == _CYCLE and law in laws:
        return Objective(text, f"{law}.cycle_time_s", f"{law} cycle time [s]", law)
    raise InputError(f"--objective {text}: choose one of {', '.join(choices(laws))} (a "
                     "cycle_time law must be one the sweep runs)")


def best(rows: Iterable[Row], objective: Objective) -> tuple[Row, float] | None:
    """The first row with the smallest objective, and that objective; None if none is
    feasible."""
    found: tuple[Row, float] | None = None
    for row in rows:
        v = objective.value(row)
        if v is not None and (found is None or v < found[1]):
            found = (row, v)
    return found
