"""report.html in a real browser (issue 32): it loads with no console error, asks for nothing
outside itself, and every interactive figure draws (the 3D view's WebGL canvas included).

Needs Chromium (``apt-get install chromium``, see docs/running.md); skipped without it. The
browser is driven over the DevTools protocol by ``benchmarks/headless_chromium.py``. The
checker itself is tested on pages broken on purpose.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from feedopt.cli import main
from tests.conftest import load_benchmark

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"


hc = load_benchmark("headless_chromium")
CHROMIUM = hc.find_chromium()
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no chromium on PATH (apt-get install chromium; docs/performance.md)")

#: Small runs of two bundled scenarios: a slot with three laws, a G-code pocket with rapids.
RUNS = {
    "triangle_slot": ["--spacing-mm", "1", "--laws", "constant,thesis,topp"],
    "pocket": ["--spacing-mm", "1", "--laws", "programmed,topp"],
}
#: Share of a 3D view's pixels its WebGL canvas must change (a blank canvas changes none).
MIN_DRAWN_SHARE = 0.01


def figure_scripts(page_html: str) -> int:
    """Figures the page means to draw: inline scripts after ``</head>`` calling
    ``Plotly.newPlot`` (plotly.js itself sits in the head), counted in the file's text."""
    body = page_html.split("</head>", 1)[-1]
    return body.count("Plotly.newPlot(")


def figure_problems(figures: list[dict], scripts: int) -> list[str]:
    """What the browser's plotly graphs (``headless_chromium.plotly_figures``) lack against
    ``scripts`` figure scripts of the file: figures not drawn, 3D views with no WebGL."""
    problems = [] if scripts else ["no interactive figure: no Plotly.newPlot script"]
    if len(figures) != scripts:
        problems.append(f"{scripts} figure scripts, {len(figures)} plotly graphs drawn")
    for k, g in enumerate(figures):
        if not g["laid_out"] or g["svg"] == 0:
            problems.append(f"figure {k} ({g['id']}): not drawn (no layout or no SVG)")
        if g["gl3d"] and (g["canvases"] == 0 or g["no_webgl"]):
            problems.append(f"figure {k} ({g['id']}): 3D view without WebGL")
    return problems


def drawn_share(with_canvas: bytes, without_canvas: bytes) -> float:
    """Share of the pixels two PNGs of one region differ in (the canvas shown / hidden)."""
    from PIL import Image

    a, b = (np.asarray(Image.open(io.BytesIO(p)).convert("RGB"), dtype=np.int16)
            for p in (with_canvas, without_canvas))
    if a.shape != b.shape or a.size == 0:
        return 0.0
    return float(np.mean(np.abs(a - b).max(axis=2) > 8))


def webgl_drawn(browser, page, k: int, box: list[float]) -> float:
    """:func:`drawn_share` of graph ``k``'s largest canvas: a clip with its canvases shown,
    one with them hidden."""
    canvases = f"document.querySelectorAll('.js-plotly-plot')[{k}].querySelectorAll('canvas')"
    shown = browser.clip(page, box)
    browser.evaluate(page, f"{canvases}.forEach(c => c.style.visibility = 'hidden')")
    browser.settle(page)
    hidden = browser.clip(page, box)
    browser.evaluate(page, f"{canvases}.forEach(c => c.style.visibility = '')")
    return drawn_share(shown, hidden)


@pytest.fixture(scope="module")
def browser():
    with hc.Chromium(CHROMIUM) as b:
        yield b


@pytest.fixture(scope="module", params=sorted(RUNS))
def report(request, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp(request.param) / "run"
    args = ["run", str(SCENARIOS / f"{request.param}.yaml"), *RUNS[request.param]]
    assert main([*args, "--out", str(out)]) == 0
    return out / "report.html"


@pytest.fixture(scope="module")
def opened(browser, report):
    """The report loaded at 1400 px with every figure drawn: (page, plotly graphs)."""
    page = browser.load(report, width_px=1400)
    return page, hc.plotly_figures(browser, page)


def test_report_loads_quietly_and_self_contained(browser, report, opened) -> None:
    page, _ = opened
    assert hc.page_problems(page) == []  # while loading and drawing
    assert page.requests[0] == report.resolve().as_uri()
    assert browser.evaluate(page, "document.querySelectorAll('script[src], link[href], "
                                  "iframe, img:not([src^=\"data:\"])').length") == 0


def test_interactive_figures_draw(browser, report, opened) -> None:
    page, figures = opened
    scripts = figure_scripts(report.read_text(encoding="utf-8"))
    assert figure_problems(figures, scripts) == []
    assert browser.evaluate(page, "typeof Plotly") == "object"
    assert any(g["gl3d"] for g in figures), "no 3D view of the path"
    for k, g in enumerate(figures):
        if g["gl3d"]:
            share = webgl_drawn(browser, page, k, g["canvas_box"])
            assert share > MIN_DRAWN_SHARE, f"3D figure {k}: WebGL drew {share:.2%} of it"


def test_report_fits_1400_px(browser, opened) -> None:
    page, _ = opened
    overflow = hc.sideways_overflow_px(browser, page)
    assert overflow <= 0, f"the page scrolls sideways by {overflow} px at 1400 px"


def test_full_page_screenshot(browser, opened, tmp_path) -> None:
    page, _ = opened
    height = browser.evaluate(page, "document.documentElement.scrollHeight")
    width, shot_height = browser.screenshot(page, tmp_path / "report.png")
    png = (tmp_path / "report.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert int.from_bytes(png[16:20], "big") == width == 1400  # the IHDR chunk
    assert int.from_bytes(png[20:24], "big") == shot_height == min(height, 16000) > 1000
    browser.resize(page, 1400, 1000)


# --- the checker against pages broken on purpose ---------------------------------------------

def _page(tmp_path: Path, body: str, head: str = "") -> Path:
    p = tmp_path / "broken.html"
    p.write_text(f'<!DOCTYPE html><html><head><meta charset="utf-8">{head}</head>'
                 f"<body><p>text</p>{body}</body></html>", encoding="utf-8")
    return p


def test_checker_finds_a_script_error(browser, tmp_path) -> None:
    page = browser.load(_page(tmp_path, "<script>undefinedFn()</script>"))
    problems = hc.page_problems(page)
    assert len(problems) == 1 and "undefinedFn is not defined" in problems[0]


def test_checker_finds_console_error_and_rejected_promise(browser, tmp_path) -> None:
    body = ("<script>console.log('fine'); console.warn('fine too'); console.error('bad')"
            "</script><script>Promise.reject(new Error('nobody caught me'))</script>")
    problems = hc.page_problems(browser.load(_page(tmp_path, body)))
    assert problems[0] == "console error: bad"
    assert len(problems) == 2 and "nobody caught me" in problems[1]


def test_checker_finds_an_external_request(browser, tmp_path) -> None:
    page = browser.load(_page(tmp_path, '<img src="http://example.com/x.png">'))
    problems = hc.page_problems(page)
    assert "external request: http://example.com/x.png" in problems
    assert all("example.com" in p or "ERR_NAME_NOT_RESOLVED" in p for p in problems)


def test_checker_finds_a_second_local_file(browser, tmp_path) -> None:
    (tmp_path / "plotly.min.js").write_text("var Plotly = {};")
    page = browser.load(_page(tmp_path, "", head='<script src="plotly.min.js"></script>'))
    assert hc.page_problems(page) == [
        f"loads another file: {(tmp_path / 'plotly.min.js').resolve().as_uri()}"]


def test_checker_finds_a_page_wider_than_the_window(browser, tmp_path) -> None:
    page = browser.load(_page(tmp_path, '<div style="width: 1000px">wide</div>'), width_px=900)
    assert hc.sideways_overflow_px(browser, page) == 8 + 1000 - 900  # body margin 8 px
    browser.resize(page, 1400, 1000)
    assert hc.sideways_overflow_px(browser, page) == 0


def test_checker_finds_figures_that_did_not_draw(browser, tmp_path) -> None:
    body = ('<div id="g"></div><script>Plotly.newPlot("g", [{"x": [1, 2], "y": [3, 4]}])'
            "</script>")  # plotly.js is missing
    path = _page(tmp_path, body)
    page = browser.load(path)
    figures = hc.plotly_figures(browser, page, timeout_s=1.0)
    assert figures == []
    assert figure_problems(figures, figure_scripts(path.read_text())) == [
        "1 figure scripts, 0 plotly graphs drawn"]
    assert "Plotly is not defined" in hc.page_problems(page)[0]


_SCENE = ('<div id="g" style="width:600px;height:400px"></div><script>Plotly.newPlot("g", '
          '[{"type": "scatter3d", "mode": "lines", "x": [0, 1, 2], "y": [0, 1, 0], '
          '"z": [0, 0, 1]}], {"showlegend": false})</script>')
#: Run before plotly.js: WebGL contexts draw nothing / cannot be had.
_NO_DRAWING = ("<script>for (const C of [WebGLRenderingContext, WebGL2RenderingContext]) "
               "for (const f of ['drawArrays', 'drawElements']) C.prototype[f] = () => {};"
               "</script>")
_NO_WEBGL = ("<script>const getContext = HTMLCanvasElement.prototype.getContext;"
             "HTMLCanvasElement.prototype.getContext = function (kind, ...rest) {"
             "return kind.includes('webgl') ? null : getContext.call(this, kind, ...rest); };"
             "</script>")


@pytest.mark.parametrize("sabotage", ["", _NO_DRAWING, _NO_WEBGL],
                         ids=["drawn", "blank", "no webgl"])
def test_checker_finds_a_3d_view_that_did_not_draw(browser, tmp_path, sabotage) -> None:
    from plotly.offline import get_plotlyjs

    head = f"{sabotage}<script>{get_plotlyjs()}</script>"
    page = browser.load(_page(tmp_path, _SCENE, head=head))
    figures = hc.plotly_figures(browser, page, timeout_s=3.0)
    print(figures, hc.page_problems(page))
    if sabotage == _NO_WEBGL:
        assert figure_problems(figures, 1) != []
        return
    (g,) = figures
    assert figure_problems([g], 1) == [] and g["gl3d"]
    share = webgl_drawn(browser, page, 0, g["canvas_box"])
    assert (share > MIN_DRAWN_SHARE) == (sabotage == "")
