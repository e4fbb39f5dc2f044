"""The comparison table of timing laws (one or several runs), as markdown or HTML.

One row per (run, law) from ``summary.json``; the same text is printed by ``feedopt compare``
and put in ``report.md``. Missing values (``null``) show as ``-``. :func:`ramp_table` details
the start and stop ramps (:data:`RAMP_NOTE` defines them).
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
    ("T/T(baseline)", True),
    ("max defl. [mm]", True),
    ("defl./limit", True),
    ("max feed [mm/s]", True),
    ("min cutting feed [mm/s]", True),
    ("ramps start/stop [mm]", True),
    ("max acc. [mm/s^2]", True),
    ("max jerk [mm/s^3]", True),
    ("C2", False),
    ("planning [s]", True),
)
_DASH = "-"

#: What "min cutting feed" and the ramps mean (footnote of both tables).
RAMP_NOTE = (
    "min cutting feed: the smallest feed between the start and stop ramps (exact, on the "
    "trajectory, not on the samples, so it does not depend on the sample spacing). Start "
    "ramp: from s = 0 to the first point where the feed stops increasing or reaches the feed "
    "bound v_max(s) (within 0.1 %, to the end of that polynomial piece); the constant "
    "baseline ignores the bound, so its ramps end where its feed levels off. Stop ramp: the "
    "same seen backwards from the end of the path."
)
# (header, right-aligned) of the ramp table.
RAMP_HEADERS: tuple[tuple[str, bool], ...] = (
    ("law", False),
    ("start ramp [mm]", True),
    ("start ramp [s]", True),
    ("reaches [mm/s]", True),
    ("ends where", False),
    ("stop ramp [mm]", True),
    ("stop ramp [s]", True),
    ("from [mm/s]", True),
    ("starts where", False),
)
# Why a ramp ends (summary.json "ends_by", schedule/checks.py Ramp.reason), in words.
_START_WHY = {"flat": "feed levels off", "bound": "feed meets v_max", "path": "path ends"}
_STOP_WHY = {"flat": "feed starts falling", "bound": "feed leaves v_max", "path": "path starts"}


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


def _ramp(row: Mapping, which: str) -> Mapping:
    ramp = row.get(which)
    return ramp if isinstance(ramp, Mapping) else {}


def _ramp_pair(row: Mapping) -> str:
    """``start / stop`` ramp lengths [mm], or ``-`` when the summary has none."""
    a = _ramp(row, "start_ramp").get("length_mm")
    b = _ramp(row, "stop_ramp").get("length_mm")
    if a is None and b is None:
        return _DASH
    return f"{_num(a)} / {_num(b)}"


def ramp_rows(summary: Mapping) -> list[list[str]]:
    """Formatted cells (see :data:`RAMP_HEADERS`) of the ramps of one run, one row per law."""
    rows = []
    for law, r in summary["laws"].items():
        up, dn = _ramp(r, "start_ramp"), _ramp(r, "stop_ramp")
        rows.append([
            str(law),
            _num(up.get("length_mm")), _num(up.get("duration_s")), _num(up.get("feed_mm_s")),
            _START_WHY.get(str(up.get("ends_by")), _DASH),
            _num(dn.get("length_mm")), _num(dn.get("duration_s")), _num(dn.get("feed_mm_s")),
            _STOP_WHY.get(str(dn.get("ends_by")), _DASH),
        ])
    return rows


def comparison_rows(summary: Mapping) -> list[list[str]]:
    """Formatted cells (see :data:`HEADERS`) of one run, one row per law in file order."""
    laws = summary["laws"]
    # the baseline: the constant nominal feed, or a G-code program's own feeds
    base = next((laws[b] for b in ("constant", "programmed") if b in laws), {})
    t_const = base.get("cycle_time_s")
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
                _ramp_pair(r),
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
    return markdown_table(*_table(summaries, names))


def ramp_table(summary: Mapping) -> str:
    """Markdown table of the start and stop ramps of each law of one run (see RAMP_NOTE)."""
    return markdown_table(list(RAMP_HEADERS), ramp_rows(summary))


def ramp_table_html(summary: Mapping) -> str:
    """The same table as :func:`ramp_table` as an HTML ``<table>``."""
    return html_table(list(RAMP_HEADERS), ramp_rows(summary))


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown_table(headers: Sequence[tuple[str, bool]], rows: Sequence[Sequence[str]]) -> str:
    """A padded markdown pipe table; ``headers`` are ``(text, right-aligned)`` pairs."""
    cells = [[_md_cell(h) for h, _ in headers], *([_md_cell(c) for c in r] for r in rows)]
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
    return "\n".join([line(cells[0]), sep, *(line(r) for r in cells[1:])])


def comparison_table_html(
    summaries: Sequence[Mapping], names: Sequence[str] | None = None
) -> str:
    """The same table as :func:`comparison_table` as an HTML ``<table>``."""
    return html_table(*_table(summaries, names))


def html_table(headers: Sequence[tuple[str, bool]], rows: Sequence[Sequence[str]],
               css_class: str = "comparison") -> str:
    """An HTML ``<table class="comparison">``; cells reading ``NO`` are marked bad."""
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
        f'<table class="{html.escape(css_class)}">\n<thead><tr>' + head + "</tr></thead>\n<tbody>\n"
        + "\n".join(body) + "\n</tbody>\n</table>"
    )
