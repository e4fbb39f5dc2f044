"""The reader's warnings: single notes in order, and notes that gather the lines of one kind."""

from __future__ import annotations

from dataclasses import dataclass, field

#: Grouped notes: key -> text before the line list (the count is put in front).
_GROUPED = {
    "deleted": "line(s) starting with '/' skipped (block delete)",
    "omitted": "rapid(s) from a position the reader does not know are not in the move list",
    "approach": ("feed move(s) from a position the reader does not know (program start, after "
                 "M6, G28 or G53): their unknown start coordinates are taken from their end "
                 "and the path approaches them through the air (an approach that has no "
                 "length then is dropped and the next move carries the approach)"),
    "g53": ("G53 rapid(s) to machine coordinates: treated as a retract to a safe height the "
            "reader does not know; the path links through the air at the program's clearance "
            "height"),
    "zero_length": "zero-length move(s) dropped",
    "spindle_off": ("feed move(s) with the spindle never started (no M3/M4 before them) or "
                    "plunging/retracting after M5"),
    "dwell_large": ("G4 P of 100 or more read as seconds (path.dwell_p_units: s, the RS-274/NGC "
                    "and LinuxCNC unit); Fanuc posts write milliseconds (P1000 = 1 s): if this "
                    "one does, set path.dwell_p_units: ms"),
    "g64_q": "G64 Q (naive CAM tolerance) read but not used: only P sets the path tolerance",
    "turn": ("tool vector turned in place (a block with only a tool vector, or a zero-length "
             "move with a new one): the next move starts from the turned vector"),
    "plus_z": ("move(s) under G43.5/TRAORI before any tool vector was given: read with the "
               "tool along +Z"),
}


def line_list(lines: list[int]) -> str:
    """``"3, 5, 9"``, the first ten and ``"and k more"``."""
    shown = ", ".join(str(n) for n in lines[:10])
    return shown + (f" and {len(lines) - 10} more" if len(lines) > 10 else "")


@dataclass
class Notes:
    """Warnings collected while reading: ``items`` in order, then one per group."""

    items: list[str] = field(default_factory=list)
    groups: dict[str, list[int]] = field(default_factory=dict)

    def add(self, kind: str, line: int) -> None:
        """Record ``line`` under the grouped note ``kind``."""
        lines = self.groups.setdefault(kind, [])
        if not lines or lines[-1] != line:
            lines.append(line)

    def finish(self) -> tuple[str, ...]:
        """Every note, the grouped ones last."""
        out = list(self.items)
        for kind, text in _GROUPED.items():
            lines = self.groups.get(kind)
            if lines:
                out.append(f"{len(lines)} {text} (lines {line_list(lines)})")
        return tuple(out)
