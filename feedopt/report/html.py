"""Write ``report.md`` (PNG files beside it) and a self-contained ``report.html``.

The HTML embeds every figure as a base64 ``data:`` URI and has inline CSS only: no scripts,
links or other external resources, so it can be mailed or archived as one file. Everything is
rendered in memory first and written last, each file through a temporary name, so a failure
while drawing leaves no half-written report behind.
"""

from __future__ import annotations

import base64
import html
import os
from pathlib import Path

from feedopt.report.data import ReportData
from feedopt.report.inputs import input_rows, run_warnings
from feedopt.report.plots import FIGURES, render_pngs
from feedopt.report.tables import (
    RAMP_NOTE,
    comparison_table,
    comparison_table_html,
    html_table,
    markdown_table,
    ramp_table,
    ramp_table_html,
)

_CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
table.comparison { border-collapse: collapse; font-size: 0.85em; }
table.comparison th, table.comparison td { border: 1px solid #bbb; padding: 0.25em 0.5em; }
table.comparison td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.bad { color: #b00; font-weight: bold; }
table.inputs td.txt:first-child { white-space: nowrap; font-weight: bold; }
ul.warnings { color: #8a4b00; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; }
figcaption { font-size: 0.9em; color: #444; }
"""

_LEGEND = (
    "T: cycle time; T*: lower bound on the cycle time of the law's problem; "
    "T(baseline): cycle time of the baseline, the constant nominal feed (or, for a G-code "
    "program, the programmed law: its own F words); defl./limit: largest predicted "
    "deflection over the limit (<= 1 meets it); verified: the replay shows the law kept "
    "every promise it makes (the constant baseline does not promise the limit, topp does not "
    "promise C2); exported: the trajectory also meets the limit, is C2 and jerk-bounded, so "
    "its RSI CSV was written; min cutting feed, ramps start/stop: see the ramp table below."
)
_INPUT_HEADERS = (("input", False), ("value", False))


def _notes_lines(data: ReportData) -> list[tuple[str, str]]:
    """(law, text) pairs: verification status and the law's notes."""
    out = [("", n) for n in data.notes]
    for ls in data.laws:
        status = "verified" if ls.verified else "NOT verified: not exported as RSI CSV"
        out.append((ls.law, status))
        out.extend((ls.law, n) for n in ls.notes)
    return out


_FITS_TITLE = "Fitted inputs: these results reproduce a reference by construction"


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
    table_md = comparison_table([data.summary])
    title = f"feedopt report: {data.scenario}"
    limit = f"Deflection limit: {data.deflection_limit_mm:g} mm."
    warnings = run_warnings(data.summary)
    inputs = input_rows(data.summary)

    fits = list(data.summary.get("scenario", {}).get("fits", []))
    md = [f"# {title}", ""]
    if fits:
        md += [f"## {_FITS_TITLE}", "", *(f"- {f}" for f in fits), ""]
    if warnings:
        md += ["## Warnings", "", *(f"- {w}" for w in warnings), ""]
    if inputs:
        md += ["## Inputs", "", markdown_table(_INPUT_HEADERS, inputs), ""]
    md += ["## Comparison of timing laws", "", table_md, "", limit, "", _LEGEND, "",
           "### Start and stop ramps", "", ramp_table(data.summary), "", RAMP_NOTE, "",
           "## Verification and notes", ""]
    for law, text in _notes_lines(data):
        md.append(f"- **{law}**: {text}" if law else f"- {text}")
    md += ["", "## Figures", ""]
    for k, spec in enumerate(figures, start=1):
        md += [f"![{spec.caption}](report_{spec.key}.png)", "",
               f"*Figure {k}: {spec.caption}*", ""]

    esc = html.escape
    h = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(title)}</title>",
        f"<style>{_CSS}</style>",
        "</head><body>",
        f"<h1>{esc(title)}</h1>",
    ]
    if fits:
        h += [f"<h2>{_FITS_TITLE}</h2>", '<ul class="warnings">',
              *(f"<li>{esc(f)}</li>" for f in fits), "</ul>"]
    if warnings:
        h += ["<h2>Warnings</h2>", '<ul class="warnings">',
              *(f"<li>{esc(w)}</li>" for w in warnings), "</ul>"]
    if inputs:
        h += ["<h2>Inputs</h2>",
              html_table(_INPUT_HEADERS, inputs, css_class="comparison inputs")]
    h += [
        "<h2>Comparison of timing laws</h2>",
        comparison_table_html([data.summary]),
        f"<p>{esc(limit)}</p>",
        f"<p>{esc(_LEGEND)}</p>",
        "<h3>Start and stop ramps</h3>",
        ramp_table_html(data.summary),
        f"<p>{esc(RAMP_NOTE)}</p>",
        "<h2>Verification and notes</h2>",
        "<ul>",
    ]
    for law, text in _notes_lines(data):
        h.append(f"<li><b>{esc(law)}</b>: {esc(text)}</li>" if law else f"<li>{esc(text)}</li>")
    h += ["</ul>", "<h2>Figures</h2>"]
    for k, spec in enumerate(figures, start=1):
        b64 = base64.b64encode(pngs[f"report_{spec.key}.png"]).decode("ascii")
        h.append(
            f'<figure id="fig-{spec.key}"><img alt="{esc(spec.caption)}" '
            f'src="data:image/png;base64,{b64}">'
            f"<figcaption>Figure {k}: {esc(spec.caption)}</figcaption></figure>"
        )
    h.append("</body></html>")
    return "\n".join(md) + "\n", "\n".join(h) + "\n", pngs


def _write_atomic(path: Path, payload: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(payload)
    os.replace(tmp, path)


def write_report(out_dir: str | Path, data: ReportData) -> tuple[Path, Path]:
    """Write ``report.md``, its ``report_*.png`` figures and ``report.html`` into ``out_dir``.

    Returns ``(md_path, html_path)``. The directory is created if needed.
    """
    out = Path(out_dir)
    md, page, pngs = render_report(data)
    out.mkdir(parents=True, exist_ok=True)
    for name, payload in pngs.items():
        _write_atomic(out / name, payload)
    md_path, html_path = out / "report.md", out / "report.html"
    _write_atomic(md_path, md.encode("utf-8"))
    _write_atomic(html_path, page.encode("utf-8"))
    return md_path, html_path
