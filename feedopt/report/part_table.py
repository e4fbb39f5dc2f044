"""The report's predicted-part section from summary.json alone: per segment, the walls and the
floor of the program to run next to the baseline's (as the thesis's CMM tables), and what the
other limit mode would give at the same tolerance (``part.other_mode``)."""

from __future__ import annotations

from collections.abc import Mapping

from feedopt.report.verdict import baseline_law, program_law

PART_TITLE = "The predicted part, per segment"
PART_HEADERS = (("segment", True), ("kind", False), ("law", False),
                ("left wall: mean distance [mm]", True), ("left wall: flatness [mm]", True),
                ("right wall: mean distance [mm]", True), ("right wall: flatness [mm]", True),
                ("floor: depth mean [mm]", True), ("floor: depth std [mm]", True))
def shown_note(summary: Mapping) -> str | None:
    """Which segments the table shows when it does not show them all."""
    laws = part_laws(summary)
    if not laws:
        return None
    entry = summary["part"]["laws"][laws[0]]
    total, shown = entry.get("segments_measured"), len(entry.get("segments") or [])
    if isinstance(total, int) and total > shown:
        return (f"{shown} of the {total} segments measured: those with the most dexels "
                "(the longest cuts).")
    return None


PART_NOTE = ("Material left > 0, overcut < 0; walls: left = +y of the feed (up-milling side), "
             "right = -y; mean distance to the nominal plane (thesis Eq. 3.28), flatness "
             "between two parallel planes (lines only); floor depth below the top (Table 3.6). "
             "The deflected cutting edges' envelope (feedopt.part); part_<law>.csv has every "
             "dexel.")
_DASH = "-"


def _cell(value, fmt: str = ".4f") -> str:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    return format(value, fmt) if ok else _DASH


def _wall(row: Mapping, side: str) -> list[str]:
    wall = row.get(f"{side}_wall")
    if not isinstance(wall, Mapping):
        return [_DASH, _DASH]
    return [_cell(wall.get("mean_distance_mm")), _cell(wall.get("flatness_mm"))]


def part_laws(summary: Mapping) -> list[str]:
    """The laws shown: the program to run, then the baseline (those with a part)."""
    part = summary.get("part")
    laws = part.get("laws") if isinstance(part, Mapping) else None
    if not isinstance(laws, Mapping):
        return []
    chosen = [program_law(summary), baseline_law(summary)]
    return [law for law in dict.fromkeys(chosen) if law is not None and law in laws]


def part_rows(summary: Mapping) -> list[list[str]]:
    """Rows of :data:`PART_HEADERS`: each segment, the shown laws one after the other."""
    laws = part_laws(summary)
    if not laws:
        return []
    tables = {law: summary["part"]["laws"][law].get("segments") or [] for law in laws}
    rows = []
    for k, first in enumerate(tables[laws[0]]):
        for law in laws:
            if k >= len(tables[law]):
                continue
            row = tables[law][k]
            floor = row.get("floor") if isinstance(row.get("floor"), Mapping) else {}
            rows.append([str(first.get("segment", k + 1)), str(row.get("kind", "")), law,
                         *_wall(row, "left"), *_wall(row, "right"),
                         _cell(floor.get("depth_mean_mm")), _cell(floor.get("depth_std_mm"))])
    return rows


def other_mode_line(summary: Mapping) -> str | None:
    """What planning for the part would give at the tolerance this run's deflection limit
    reaches (``part.other_mode`` of a norm-mode run), or None."""
    part = summary.get("part")
    other = part.get("other_mode") if isinstance(part, Mapping) else None
    if not isinstance(other, Mapping):
        return None
    t_this, t_other = other.get("lower_bound_s"), other.get("other_lower_bound_s")
    if not isinstance(t_this, (int, float)) or not isinstance(t_other, (int, float)):
        return None
    held = [f"{what} within {other[key]:.4f} mm" for what, key in
            (("walls", "wall_limit_mm"), ("floor", "floor_limit_mm"))
            if isinstance(other.get(key), (int, float))]
    return (f"The part this deflection limit gives ({other.get('law')}: "
            f"{', '.join(held)}), planned for instead (deflection.mode: surface with these "
            f"tolerances): T* = {t_other:.2f} s against {t_this:.2f} s here "
            f"({t_other / t_this - 1.0:+.1%}).")
