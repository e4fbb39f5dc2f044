"""Write ``report.md`` (PNG files beside it) and a self-contained ``report.html``.

Both open with the verdict (:mod:`feedopt.report.verdict`): the program to run, where the feed
drops and why, what to check before cutting; then the figures, the tables and the notes.
report.md shows the static PNGs (:mod:`feedopt.report.plots`). report.html shows the
interactive figures (:mod:`feedopt.report.interactive`, plotly.js inlined once in ``<head>``,
each figure an inline script) in place of the static path, feed and deflection figures, one
of which stays as a ``<noscript>`` fallback; the static figures without an interactive
counterpart follow as base64 PNGs. Without plotly the HTML shows every PNG. No external
resource of any kind: the page can be mailed or archived as one file. Everything is rendered
in memory first and written last, each file through a temporary name, so a failure while
drawing leaves no half-written report behind.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from pathlib import Path

from feedopt.report.data import ReportData
from feedopt.report.inputs import input_rows, run_warnings
from feedopt.report.part_table import (
    PART_HEADERS,
    PART_NOTE,
    PART_TITLE,
    other_mode_line,
    part_rows,
    shown_note,
)
from feedopt.report.plots import FIGURES, FigureSpec, caption_of, render_pngs
from feedopt.report.tables import (
    RAMP_NOTE,
    WHERE_HEADERS,
    comparison_table,
    comparison_table_html,
    html_table,
    markdown_table,
    not_exported_lines,
    ramp_table,
    ramp_table_html,
    where_rows,
)
from feedopt.report.verdict import verdict_html, verdict_markdown, write_atomic

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; max-width: 1300px;
  margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.5em; margin-bottom: 0.3em; }
h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ddd; }
.verdict { border-left: 6px solid #2a7d2a; background: #eef7ee; padding: 0.5em 1em;
  margin: 0.8em 0; }
.verdict.none { border-left-color: #b00; background: #fdeeee; }
.verdict-line { font-size: 1.12em; font-weight: bold; margin: 0.2em 0; }
.where { margin: 0.3em 0; }
ul.checks { padding-left: 1.2em; }
ul.checks li { margin: 0.25em 0; }
.kind { display: inline-block; font-size: 0.8em; font-weight: bold; color: #6a3d00;
  background: #f6e6c6; border-radius: 3px; padding: 0 0.4em; margin-right: 0.3em; }
div.scroll { overflow-x: auto; max-width: 100%; margin: 0.5em 0; }
table.comparison { border-collapse: collapse; font-size: 0.82em; }
table.comparison th { background: #f2f2f2; vertical-align: bottom; }
table.comparison th, table.comparison td { border: 1px solid #bbb; padding: 0.25em 0.45em; }
table.comparison td.num { text-align: right; font-variant-numeric: tabular-nums;
  white-space: nowrap; }
td.bad { color: #a00; font-weight: bold; background: #fde2e2; }
td.warn { color: #7a4200; background: #fff1d0; }
td.pick { font-weight: bold; background: #d8f0d8; }
td[title] { cursor: help; }
table.inputs td.txt:first-child { white-space: nowrap; font-weight: bold; }
ul.warnings { color: #8a4b00; }
ul.blockers { font-size: 0.9em; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; height: auto; }
figure.interactive h3 { margin: 0 0 0.3em 0; font-size: 1.05em; }
figcaption { font-size: 0.9em; color: #444; }
@media (max-width: 1000px) {
  body { margin: 0.5em auto; padding: 0 0.5em; }
  table.comparison { font-size: 0.78em; }
  table.comparison th, table.comparison td { padding: 0.2em 0.3em; }
}
"""

_LEGEND = (
    "T: cycle time; T*: lower bound on the cycle time of the law's problem; "
    "T(baseline): cycle time of the baseline, the constant nominal feed (or, for a G-code "
    "program, the programmed law: its own F words); defl./limit: largest predicted "
    "deflection over the limit (<= 1 meets it); verified: the replay shows the law kept "
    "every promise it makes (the constant baseline does not promise the limit, topp does not "
    "promise C2); exported: the trajectory also meets the limit, is C2 and jerk-bounded, so "
    "its RSI CSV was written; min cutting feed, ramps start/stop: see the ramp table below. "
    "Highlighted: the program to run (green), a broken limit or failed verification (red), "
    "a law not exported or not C2 (amber; hover for the reason)."
)
_INPUT_HEADERS = (("input", False), ("value", False))
_WHERE_TITLE = "Where each law deflects most"
_NOT_EXPORTED = "Not exported"
#: Static figures that report.html replaces by interactive ones (when plotly is there).
INTERACTIVE_REPLACES = ("path", "feed", "deflection")
#: The static figure kept in report.html as the ``<noscript>`` fallback.
NOSCRIPT_FIGURE = "feed"


@dataclass(frozen=True)
class Interactive:
    """The interactive figures of report.html and plotly.js (empty: the static PNGs are
    shown instead)."""

    figures: tuple = ()
    script: str = ""


def interactive_part(data: ReportData) -> Interactive:
    """The figures of :mod:`feedopt.report.interactive` and plotly.js (a dependency: a
    missing plotly is an install error, not a report without its figures)."""
    from feedopt.report.interactive import interactive_figures, plotly_script

    figures = tuple(interactive_figures(data))
    return Interactive(figures, plotly_script() if figures else "")


def _notes_lines(data: ReportData) -> list[tuple[str, str]]:
    """(law, text) pairs: verification status and the law's notes."""
    out = [("", n) for n in data.notes]
    for ls in data.laws:
        status = "verified" if ls.verified else "NOT verified: not exported as RSI CSV"
        out.append((ls.law, status))
        out.extend((ls.law, n) for n in ls.notes)
    return out


def _markdown(data: ReportData, figures: list[FigureSpec], title: str) -> str:
    """report.md: verdict, figures, tables, notes."""
    summary = data.summary
    md = [f"# {title}", "", verdict_markdown(summary), ""]
    if figures:
        md += ["## Figures", ""]
    for k, spec in enumerate(figures, start=1):
        caption = caption_of(spec, data)
        md += [f"![{caption}](report_{spec.key}.png)", "", f"*Figure {k}: {caption}*", ""]
    md += ["## Comparison of timing laws", "", comparison_table([summary]), ""]
    blocked = not_exported_lines(summary)
    if blocked:
        md += [f"{_NOT_EXPORTED}:", "", *(f"- {b}" for b in blocked), ""]
    md += [f"Deflection limit: {data.deflection_limit_mm:g} mm.", "", _LEGEND, ""]
    where, _ = where_rows(summary)
    if where:
        md += [f"### {_WHERE_TITLE}", "", markdown_table(WHERE_HEADERS, where), ""]
    part = part_rows(summary)
    if part:
        other = other_mode_line(summary)
        note = " ".join(x for x in (shown_note(summary), PART_NOTE) if x)
        md += [f"### {PART_TITLE}", "", markdown_table(PART_HEADERS, part), "", note, ""]
        md += [other, ""] if other else []
    md += ["### Start and stop ramps", "", ramp_table(summary), "", RAMP_NOTE, ""]
    inputs = input_rows(summary)
    if inputs:
        md += ["## Inputs", "", markdown_table(_INPUT_HEADERS, inputs), ""]
    warnings = run_warnings(summary)
    if warnings:
        md += ["## Warnings", "", *(f"- {w}" for w in warnings), ""]
    md += ["## Verification and notes", ""]
    md += [f"- **{law}**: {text}" if law else f"- {text}" for law, text in _notes_lines(data)]
    return "\n".join(md) + "\n"


def _boxed(table: str) -> str:
    """A table in its own horizontally scrolling box (narrow windows)."""
    return f'<div class="scroll">{table}</div>'


def _img(spec: FigureSpec, data: ReportData, png: bytes, number: int | None) -> str:
    """A static figure as an ``<img>`` with a base64 ``data:`` URI."""
    esc = html.escape
    caption = caption_of(spec, data)
    b64 = base64.b64encode(png).decode("ascii")
    label = f"Figure {number}: " if number is not None else ""
    return (f'<figure id="fig-{spec.key}"><img alt="{esc(caption)}" '
            f'src="data:image/png;base64,{b64}">'
            f"<figcaption>{label}{esc(caption)}</figcaption></figure>")


def _html_figures(data: ReportData, figures: list[FigureSpec], pngs: dict[str, bytes],
                  live: Interactive) -> list[str]:
    """The figures of report.html: interactive ones (with a ``<noscript>`` PNG), then the
    static figures they do not replace; every static one when there is no interactive."""
    esc = html.escape
    out = ["<h2>Figures</h2>"]
    number = 0
    for fig in live.figures:
        number += 1
        out.append(f'<figure id="ifig-{esc(fig.key)}" class="interactive">'
                   f"<h3>{esc(fig.title)}</h3>{fig.html}"
                   f"<figcaption>Figure {number}: {esc(fig.caption)}</figcaption></figure>")
    replaced = INTERACTIVE_REPLACES if live.figures else ()
    fallback = [s for s in figures if s.key == NOSCRIPT_FIGURE and s.key in replaced]
    for spec in fallback:
        out.append("<noscript>" + _img(spec, data, pngs[f"report_{spec.key}.png"], None)
                   + "</noscript>")
    for spec in figures:
        if spec.key not in replaced:
            number += 1
            out.append(_img(spec, data, pngs[f"report_{spec.key}.png"], number))
    return out


def _html_tables(data: ReportData) -> list[str]:
    """The tables of report.html: comparison (marked), why not exported, where each law
    deflects most, ramps, inputs."""
    esc = html.escape
    summary = data.summary
    out = ["<h2>Comparison of timing laws</h2>", _boxed(comparison_table_html([summary]))]
    blocked = not_exported_lines(summary)
    if blocked:
        out += [f"<p>{_NOT_EXPORTED}:</p>", '<ul class="blockers">',
                *(f"<li>{esc(b)}</li>" for b in blocked), "</ul>"]
    out += [f"<p>Deflection limit: {data.deflection_limit_mm:g} mm.</p>",
            f"<p>{esc(_LEGEND)}</p>"]
    where, marks = where_rows(summary)
    if where:
        out += [f"<h3>{_WHERE_TITLE}</h3>", _boxed(html_table(WHERE_HEADERS, where,
                                                              marks=marks))]
    part = part_rows(summary)
    if part:
        other = other_mode_line(summary)
        note = " ".join(x for x in (shown_note(summary), PART_NOTE) if x)
        out += [f"<h3>{PART_TITLE}</h3>", _boxed(html_table(PART_HEADERS, part)),
                f"<p>{esc(note)}</p>"] + ([f"<p>{esc(other)}</p>"] if other else [])
    out += ["<h3>Start and stop ramps</h3>", _boxed(ramp_table_html(summary)),
            f"<p>{esc(RAMP_NOTE)}</p>"]
    inputs = input_rows(summary)
    if inputs:
        out += ["<h2>Inputs</h2>",
                _boxed(html_table(_INPUT_HEADERS, inputs, css_class="comparison inputs"))]
    return out


def _html_notes(data: ReportData) -> list[str]:
    """The notes of report.html: the run's warnings and each law's verification notes."""
    esc = html.escape
    out = []
    warnings = run_warnings(data.summary)
    if warnings:
        out += ["<h2>Warnings</h2>", '<ul class="warnings">',
                *(f"<li>{esc(w)}</li>" for w in warnings), "</ul>"]
    out += ["<h2>Verification and notes</h2>", "<ul>"]
    out += [f"<li><b>{esc(law)}</b>: {esc(text)}</li>" if law else f"<li>{esc(text)}</li>"
            for law, text in _notes_lines(data)]
    return [*out, "</ul>"]


def _html(data: ReportData, figures: list[FigureSpec], pngs: dict[str, bytes],
          live: Interactive, title: str) -> str:
    """report.html: verdict and checks, figures, tables, notes."""
    esc = html.escape
    head = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{esc(title)}</title>", f"<style>{_CSS}</style>"]
    if live.script:
        head.append(f"<script>{live.script}</script>")
    body = ["</head><body>", f"<h1>{esc(title)}</h1>", verdict_html(data.summary),
            *_html_figures(data, figures, pngs, live), *_html_tables(data), *_html_notes(data),
            "</body></html>"]
    return "\n".join([*head, *body]) + "\n"


def render_report(data: ReportData) -> tuple[str, str, dict[str, bytes]]:
    """Markdown text, HTML text and ``{png file name: bytes}`` of the report (nothing written)."""
    drawn = {}
    figures = []
    for spec in FIGURES:
        fig = spec.draw(data)
        if fig is None:  # a figure that does not apply to this run (no stock, ...)
            continue
        figures.append(spec)
        drawn[f"report_{spec.key}.png"] = fig
    pngs = render_pngs(drawn)
    title = f"feedopt report: {data.scenario}"
    live = interactive_part(data)
    return _markdown(data, figures, title), _html(data, figures, pngs, live, title), pngs


def write_report(out_dir: str | Path, data: ReportData) -> tuple[Path, Path]:
    """Write ``report.md``, its ``report_*.png`` figures and ``report.html`` into ``out_dir``.

    Returns ``(md_path, html_path)``. The directory is created if needed.
    """
    out = Path(out_dir)
    md, page, pngs = render_report(data)
    out.mkdir(parents=True, exist_ok=True)
    for name, payload in pngs.items():
        write_atomic(out / name, payload)
    md_path, html_path = out / "report.md", out / "report.html"
    write_atomic(md_path, md.encode("utf-8"))
    write_atomic(html_path, page.encode("utf-8"))
    return md_path, html_path
