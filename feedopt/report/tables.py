"""The comparison table of timing laws (one or several runs), as markdown or HTML.

One row per (run, law) from ``summary.json``; the same text is printed by ``feedopt compare``
and put in ``report.md``. Missing values (``null``) show as ``-``.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence

# (header, right-aligned)
HEADERS: tuple[tuple[str, bool], ...] = (
    ("law", False),
    ("verified", False),
    ("exported", False),
    ("T [s]", True),
    ("T* [s]", True),
    ("T/T*", True),
    ("T/T(constant)", True),
    ("max defl. [mm]", True),
    ("defl./limit", True),
    ("max feed [mm/s]", True),
    ("min feed [mm/s]", True),
    ("max acc. [mm/s^2]", True),
    ("max jerk [mm/s^3]", True),
    ("C2", False),
    ("planning [s]", True),
)
_DASH = "-"


def _num(v, fmt: str = ".4g") -> str:
    return _DASH if v is None else format(float(v), fmt)


def _bool(v, yes: str = "yes", no: str = "NO") -> str:
    return _DASH if v is None else (yes if v else no)


def _ratio(a, b) -> str:
    if a is None or b is None or b == 0:
        return _DASH
    return f"{float(a) / float(b):.3f}"


def deflection_ratio(summary: Mapping, law: str) -> float | None:
    """``laws[law].deflection_ratio`` if given, else max deflection / scenario limit."""
    row = summary["laws"][law]
    if row.get("deflection_ratio") is not None:
        return float(row["deflection_ratio"])
    limit = summary.get("scenario", {}).get("deflection_limit_mm")
    if row.get("max_deflection_mm") is None or not limit:
        return None
    return float(row["max_deflection_mm"]) / float(limit)


def comparison_rows(summary: Mapping) -> list[list[str]]:
    """Formatted cells (see :data:`HEADERS`) of one run, one row per law in file order."""
    laws = summary["laws"]
    t_const = laws.get("constant", {}).get("cycle_time_s")
    rows = []
    for law, r in laws.items():
        ratio = deflection_ratio(summary, law)
        rows.append(
            [
                str(law),
                _bool(r.get("verified")),
                _DASH if r.get("exported") is None else _bool(r.get("exported"), no="no"),
                _num(r.get("cycle_time_s")),
                _num(r.get("lower_bound_s")),
                _ratio(r.get("cycle_time_s"), r.get("lower_bound_s")),
                _ratio(r.get("cycle_time_s"), t_const),
                _num(r.get("max_deflection_mm")),
                _DASH if ratio is None else f"{ratio:.3f}",
                _num(r.get("max_feed_mm_s")),
                _num(r.get("min_feed_mm_s")),
                _num(r.get("max_accel_mm_s2")),
                _num(r.get("max_jerk_mm_s3")),
                _bool(r.get("c2"), no="no"),
                _num(r.get("planning_time_s"), ".3g"),
            ]
        )
    return rows


def _table(summaries: Sequence[Mapping], names: Sequence[str] | None):
    if not summaries:
        raise ValueError("comparison_table needs at least one summary")
    headers = list(HEADERS)
    multi = len(summaries) > 1 or names is not None
    if names is not None and len(names) != len(summaries):
        raise ValueError(f"{len(names)} names for {len(summaries)} summaries")
    if multi:
        if names is None:
            names = [
                str(s.get("scenario", {}).get("name", f"run {i + 1}"))
                for i, s in enumerate(summaries)
            ]
        headers = [("run", False), *headers]
    rows = []
    for i, s in enumerate(summaries):
        for r in comparison_rows(s):
            rows.append([str(names[i]), *r] if multi else r)
    return headers, rows


def comparison_table(summaries: Sequence[Mapping], names: Sequence[str] | None = None) -> str:
    """Markdown (pipe) table comparing the laws of one or several runs, padded for terminals.

    With several summaries (or explicit ``names``) a first column ``run`` names the run of
    each row (``names``, else ``scenario.name``, else ``run i``).
    """
    headers, rows = _table(summaries, names)
    cells = [[h for h, _ in headers], *rows]
    widths = [max(len(r[j]) for r in cells) for j in range(len(headers))]

    def line(r):
        out = []
        for j, c in enumerate(r):
            out.append(c.rjust(widths[j]) if headers[j][1] else c.ljust(widths[j]))
        return "| " + " | ".join(out) + " |"

    sep = "|" + "|".join(
        ("-" * (widths[j] + 1) + ":") if right else (":" + "-" * (widths[j] + 1))
        for j, (_, right) in enumerate(headers)
    ) + "|"
    return "\n".join([line(cells[0]), sep, *(line(r) for r in rows)])


def comparison_table_html(
    summaries: Sequence[Mapping], names: Sequence[str] | None = None
) -> str:
    """The same table as :func:`comparison_table` as an HTML ``<table>``."""
    headers, rows = _table(summaries, names)
    head = "".join(f"<th>{html.escape(h)}</th>" for h, _ in headers)
    body = []
    for r in rows:
        tds = "".join(
            f'<td class="{"num" if headers[j][1] else "txt"}'
            f'{" bad" if c in ("NO",) else ""}">{html.escape(c)}</td>'
            for j, c in enumerate(r)
        )
        body.append(f"<tr>{tds}</tr>")
    return (
        '<table class="comparison">\n<thead><tr>' + head + "</tr></thead>\n<tbody>\n"
        + "\n".join(body) + "\n</tbody>\n</table>"
    )
