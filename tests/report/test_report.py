"""Report: every figure is drawn, embedded in a self-contained HTML and referenced by the md."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest

from feedopt.report.data import LawSeries, ReportData
from feedopt.report.html import INTERACTIVE_REPLACES, Interactive, render_report, write_report
from feedopt.report.plots import FIGURES, plot_deflection, plot_path_feed

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def written(tmp_path_factory, report_data):
    out = tmp_path_factory.mktemp("report") / "out"  # created by write_report
    return out, write_report(out, report_data)


def _static_shown() -> list:
    """The static figures of the synthetic run (the engagement, redundancy and part figures
    need a stock / robot.redundancy: optimise / a predicted part: tests/process/
    test_material.py, tests/robot, tests/report/test_part_table.py)."""
    return [spec for spec in FIGURES if spec.key not in ("engagement", "redundancy", "part")]


def test_html_layout_verdict_then_figures_then_tables_then_notes(written):
    _, (md_path, html_path) = written
    page = html_path.read_text()
    head, body = page.split("</head>", 1)
    # the verdict first: thesis is the only exported law of the fake summary (none has an
    # "exported" key: no law is exported, so the line says so and why)
    order = [body.index(x) for x in ("<h1>", 'class="verdict', "<h2>Figures</h2>",
                                     "<h2>Comparison of timing laws</h2>",
                                     "<h2>Verification and notes</h2>")]
    assert order == sorted(order)
    assert "No program to run: no law is both verified and exported" in body
    # interactive figures (plotly.js once, in <head>, inline) replace the static path, feed
    # and deflection figures; the feed PNG stays as the fallback for a page without scripts
    assert head.count("<script>") == 1 and "<script src" not in page
    live = re.findall(r'<figure id="ifig-([^"]+)" class="interactive">', body)
    assert live == ["path3d", "feed", "deflection"]
    noscript = re.findall(r"<noscript>(.*?)</noscript>", body, flags=re.S)
    assert len(noscript) == 1 and 'id="fig-feed"' in noscript[0]
    images = re.findall(r'<img [^>]*src="([^"]*)"', body)
    kept = [s.key for s in _static_shown() if s.key not in INTERACTIVE_REPLACES]
    assert kept == ["accel_jerk", "joints"]
    assert len(images) == 1 + len(kept)
    for key in kept:
        assert f'id="fig-{key}"' in body
    for k, key in enumerate(kept, start=4):  # after the three interactive ones
        assert re.search(rf'id="fig-{key}".*?<figcaption>Figure {k}: ', body)
    for src in images:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(PNG_MAGIC)
    # self-contained: no script, stylesheet, link, frame or image from anywhere (outside
    # the inline scripts: plotly.js itself is tests/report/test_browser.py's)
    outside = re.sub(r"<script\b.*?</script>", "", page, flags=re.S)
    for needle in ("<link", "<iframe", "url(", "<script src", "http://", "https://"):
        assert needle not in outside
    assert all(src.startswith("data:") for src in re.findall(r'src="([^"]*)"', outside))
    # escaped scenario name, comparison table in its scrolling box, verification status
    assert "triangle_slot &lt;test&gt;" in page and "<test>" not in outside
    assert '<div class="scroll"><table class="comparison">' in page
    assert "NOT verified" in page


def test_html_without_plotly_shows_every_static_figure(report_data, monkeypatch):
    monkeypatch.setattr("feedopt.report.html.interactive_part", lambda data: Interactive())
    _, page, pngs = render_report(report_data)
    assert "<script" not in page and "<noscript>" not in page
    images = re.findall(r'<img [^>]*src="data:image/png;base64,([^"]*)"', page)
    shown = _static_shown()
    assert len(images) == len(shown) == 5
    for b64, spec in zip(images, shown, strict=True):
        assert base64.b64decode(b64) == pngs[f"report_{spec.key}.png"]


def test_markdown_references_png_files_of_every_static_figure(written):
    tmp_path, (md_path, html_path) = written
    assert md_path == tmp_path / "report.md" and html_path == tmp_path / "report.html"
    md = md_path.read_text()
    page = html_path.read_text()
    refs = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert refs == [f"report_{spec.key}.png" for spec in _static_shown()]
    for ref in refs:
        payload = (tmp_path / ref).read_bytes()
        assert payload.startswith(PNG_MAGIC)
        # at 150 dpi: the pixel width is 150 x the figure's width in inches
        width = int.from_bytes(payload[16:20], "big")
        assert width >= 150 * 8
    for key in ("feed", "accel_jerk", "joints"):  # in the HTML too (the feed one: noscript)
        assert base64.b64encode((tmp_path / f"report_{key}.png").read_bytes()).decode() in page
    assert md.index("<!-- verdict -->") < md.index("## Figures") < md.index("| thesis")
    assert "| thesis" in md and "defl./limit" in md
    assert "**topp**: NOT verified" in md and "thesis note" in md
    assert not list(tmp_path.glob(".*.tmp"))


def test_deflection_figure_has_the_limit_and_constant_in_each_panel(report_data):
    fig = plot_deflection(report_data)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 2  # thesis and topp, each against constant
    for ax in axes:
        ys = [np.asarray(ln.get_ydata(), dtype=float) for ln in ax.get_lines()]
        assert any(np.all(y == 0.29) for y in ys)  # the limit line
        labels = [ln.get_label() for ln in ax.get_lines()]
        assert "constant" in labels
    const = report_data.laws[0]
    line = next(ln for ln in axes[0].get_lines() if ln.get_label() == "constant")
    np.testing.assert_array_equal(line.get_ydata(), const.deflection_mm)


def test_path_figure_colours_segments_by_feed(report_data):
    fig = plot_path_feed(report_data)
    from matplotlib.collections import LineCollection

    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["constant", "thesis", "topp (NOT verified)"]
    thesis = report_data.laws[1]
    colls = [c for c in panels[1].collections
             if isinstance(c, LineCollection) and c.get_array() is not None]
    np.testing.assert_allclose(colls[0].get_array(),
                               0.5 * (thesis.feed_mm_s[:-1] + thesis.feed_mm_s[1:]))
    # blends underlaid: one grey segment per pair of consecutive blend samples
    blend = report_data.segment_kind != "line"
    grey = [c for c in panels[1].collections if c.get_label() == "blend"]
    assert len(grey[0].get_segments()) == int(np.sum(blend[:-1] & blend[1:]))


def test_report_data_checks_shapes(report_data):
    law = report_data.laws[0]
    short = LawSeries(law.law, law.s_mm[:-1], law.feed_mm_s[:-1], law.deflection_mm[:-1],
                      law.t_s, law.feed_t_mm_s, law.accel_mm_s2, law.jerk_mm_s3,
                      law.joint_velocity_deg_s)
    with pytest.raises(ValueError, match="path samples"):
        ReportData("x", report_data.summary, report_data.path_xyz_mm,
                   report_data.segment_kind, (short,), np.ones(6), 0.29)
    with pytest.raises(ValueError, match="joint_velocity_deg_s"):  # one column per joint
        LawSeries("x", law.s_mm, law.feed_mm_s, law.deflection_mm, law.t_s, law.feed_t_mm_s,
                  law.accel_mm_s2, law.jerk_mm_s3, law.joint_velocity_deg_s[:, 0])
    five = LawSeries("x", law.s_mm, law.feed_mm_s, law.deflection_mm, law.t_s,
                     law.feed_t_mm_s, law.accel_mm_s2, law.jerk_mm_s3,
                     law.joint_velocity_deg_s[:, :5])
    with pytest.raises(ValueError, match="5 joint_velocity_deg_s columns, the robot 6"):
        ReportData("x", report_data.summary, report_data.path_xyz_mm,
                   report_data.segment_kind, (five,), np.ones(6), 0.29)
    with pytest.raises(ValueError, match="feed_t_mm_s"):
        LawSeries("x", law.s_mm, law.feed_mm_s, law.deflection_mm, law.t_s,
                  law.feed_t_mm_s[1:], law.accel_mm_s2, law.jerk_mm_s3,
                  law.joint_velocity_deg_s)


def test_law_series_from_si_converts_units(report_data):
    thesis = report_data.laws[1]
    assert thesis.feed_mm_s.max() == pytest.approx(4.02)
    assert thesis.deflection_mm.max() == pytest.approx(0.285)
    # joint velocities were built as 0.1 * j * sin(t) deg/s in radians
    np.testing.assert_allclose(thesis.joint_velocity_deg_s[:, 5], 0.6 * np.sin(thesis.t_s))
