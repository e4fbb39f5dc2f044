"""The comparison table of timing laws (one or several runs), as markdown or HTML.

One row per (run, law) from ``summary.json``; the same text is printed by ``feedopt compare``
and put in ``report.md``. Missing values (``null``) show as ``-``. :func:`ramp_table` details
the start and stop ramps (:data:`RAMP_NOTE` defines them), :func:`where_rows` where each law
deflects most (by program line). In HTML, cells are marked (:func:`comparison_marks`): ``bad``
for a broken limit or a failed verification, ``warn`` for a law not exported (the reason in
its tooltip) or not C2, ``pick`` for the program to run.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence

from feedopt.report.verdict import RATIO_TOL, baseline_law, deflection_ratio, program_law

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


#: (header, right-aligned) of the table of where each law deflects most.
WHERE_HEADERS: tuple[tuple[str, bool], ...] = (
    ("law", False),
    ("max defl. [mm]", True),
    ("defl./limit", True),
    ("program line", False),
    ("s [mm]", True),
    ("sample", True),
)


def where_rows(summary: Mapping) -> tuple[list[list[str]], list[list[str]]]:
    """Rows of :data:`WHERE_HEADERS` (laws whose entry has ``worst_deflection``) and their
    marks (``bad`` where the limit is broken); no rows for an older summary."""
    rows, marks = [], []
    for law, r in summary["laws"].items():
        place = r.get("worst_deflection")
        if not isinstance(place, Mapping):
            continue
        ratio = deflection_ratio(summary, law)
        label = place.get("label")
        rows.append([str(law), _num(r.get("max_deflection_mm")),
                     _DASH if ratio is None else f"{ratio:.3f}",
                     str(label) if label else _DASH, _num(place.get("s_mm"), ".2f"),
                     _DASH if place.get("sample") is None else str(int(place["sample"]))])
        bad = ratio is not None and ratio > 1 + RATIO_TOL
        marks.append(["", "", "bad" if bad else "", "", "", ""])
    return rows, marks


def comparison_rows(summary: Mapping) -> list[list[str]]:
    """Formatted cells (see :data:`HEADERS`) of one run, one row per law in file order."""
    laws = summary["laws"]
    # the baseline: the constant nominal feed, or a G-code program's own feeds
    base = laws.get(baseline_law(summary), {})
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


_COL = {h: j for j, (h, _) in enumerate(HEADERS)}


def _blockers(row: Mapping) -> str:
    why = [str(b) for b in row.get("export_blockers") or []]
    if row.get("verified") is False:
        why = [*(str(p) for p in row.get("problems") or []), *why] or ["not verified"]
    return "; ".join(why)


def comparison_marks(summary: Mapping) -> list[tuple[list[str], list[str]]]:
    """Per row of :func:`comparison_rows`: the CSS mark of each cell (``""``, ``bad``,
    ``warn``, ``pick``) and its tooltip (``""`` for none)."""
    pick = program_law(summary)
    out = []
    for law, r in summary["laws"].items():
        marks, titles = [""] * len(HEADERS), [""] * len(HEADERS)
        if law == pick:
            marks[_COL["law"]], titles[_COL["law"]] = "pick", "the program to run"
        if r.get("verified") is False:
            marks[_COL["verified"]], titles[_COL["verified"]] = "bad", _blockers(r)
        if r.get("exported") is False:
            marks[_COL["exported"]], titles[_COL["exported"]] = "warn", _blockers(r)
        ratio = deflection_ratio(summary, law)
        if ratio is not None and ratio > 1 + RATIO_TOL:
            marks[_COL["defl./limit"]] = "bad"
            titles[_COL["defl./limit"]] = f"the predicted deflection breaks the limit {ratio:.3f} x"
        if r.get("c2") is False:
            marks[_COL["C2"]] = "warn"
        out.append((marks, titles))
    return out


def not_exported_lines(summary: Mapping) -> list[str]:
    """``law: reason`` for every law that was not exported (or failed verification)."""
    return [f"{law}: {_blockers(r) or 'not exported'}" for law, r in summary["laws"].items()
            if r.get("exported") is False or r.get("verified") is False]


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
    rows, marks, titles = [], [], []
    for i, s in enumerate(summaries):
        for r, (m, tip) in zip(comparison_rows(s), comparison_marks(s), strict=True):
            rows.append([str(names[i]), *r] if multi else r)
            marks.append(["", *m] if multi else m)
            titles.append(["", *tip] if multi else tip)
    return headers, rows, marks, titles


def comparison_table(summaries: Sequence[Mapping], names: Sequence[str] | None = None) -> str:
    """Markdown (pipe) table comparing the laws of one or several runs, padded for terminals.

    With several summaries (or explicit ``names``) a first column ``run`` names the run of
    each row (``names``, else ``scenario.name``, else ``run i``).
    """
    headers, rows, _, _ = _table(summaries, names)
    return markdown_table(headers, rows)


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
    """The same table as :func:`comparison_table` as an HTML ``<table>``, its cells marked
    (:func:`comparison_marks`)."""
    headers, rows, marks, titles = _table(summaries, names)
    return html_table(headers, rows, marks=marks, titles=titles)


def _td(text: str, right: bool, mark: str, title: str) -> str:
    cls = ("num" if right else "txt") + (f" {mark}" if mark else "")
    tip = f' title="{html.escape(title)}"' if title else ""
    return f'<td class="{cls}"{tip}>{html.escape(text)}</td>'


def html_table(headers: Sequence[tuple[str, bool]], rows: Sequence[Sequence[str]],
               css_class: str = "comparison", marks: Sequence[Sequence[str]] | None = None,
               titles: Sequence[Sequence[str]] | None = None) -> str:
    """An HTML ``<table class="comparison">``. ``marks[i][j]`` is an extra CSS class of a
    cell (``bad``, ``warn``, ``pick``) and ``titles[i][j]`` its tooltip; without marks, cells
    reading ``NO`` are marked bad."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h, _ in headers)
    body = []
    for i, r in enumerate(rows):
        tds = "".join(
            _td(c, headers[j][1],
                marks[i][j] if marks is not None else ("bad" if c == "NO" else ""),
                titles[i][j] if titles is not None else "")
            for j, c in enumerate(r))
        body.append(f"<tr>{tds}</tr>")
    return (
        f'<table class="{html.escape(css_class)}">\n<thead><tr>' + head + "</tr></thead>\n<tbody>\n"
        + "\n".join(body) + "\n</tbody>\n</table>"
    )
