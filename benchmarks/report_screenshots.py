"""Screenshots of the report and its size and drawing time (issue 32).

Runs the bundled scenarios (default triangle_slot and pocket, into a temporary folder), opens
each report.html in headless Chromium (``benchmarks/headless_chromium.py``; ``apt-get install
chromium``) and writes full-page screenshots at 1400 and 900 px to
``docs/img/report_<scenario>_<width>.png`` (256 colours, a few hundred kB). Measures the bytes of
report.html (plotly.js, figure scripts, embedded PNGs, the rest), report.md and its PNGs; the
report's drawing time in the run's report child (``write_run_report``, timed inside the run)
and the profile's ``report`` row (the part of the drawing the exports did not hide); the time
the browser takes from opening the file to every figure drawn. Also for a run of ~1e5 samples
(triangle_slot, spacing chosen from the default run's sample count). Writes the table to
``benchmarks/results/report_size.txt``.

    .venv/bin/python benchmarks/report_screenshots.py            # all, ~1-2 min
    .venv/bin/python benchmarks/report_screenshots.py --large-samples 0 --no-images
"""

from __future__ import annotations

import argparse
import io
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from headless_chromium import (  # noqa: E402
    Chromium,
    find_chromium,
    page_problems,
    plotly_figures,
    sideways_overflow_px,
)

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
IMG = ROOT / "docs" / "img"
RESULTS = ROOT / "benchmarks" / "results" / "report_size.txt"
TIMING_ENV = "FEEDOPT_REPORT_TIMING_FILE"
_TIMED_RUN = "--timed-run"

_untimed_write_run_report = None


def timed_write_run_report(*args, **kwargs):
    """``feedopt.report.run.write_run_report`` that appends its wall time [s] to the file
    named by ``$FEEDOPT_REPORT_TIMING_FILE`` (it runs in the run's report child)."""
    t0 = time.perf_counter()
    try:
        return _untimed_write_run_report(*args, **kwargs)
    finally:
        with open(os.environ[TIMING_ENV], "a") as f:
            f.write(f"{time.perf_counter() - t0:.4f}\n")


def _timed_feedopt(argv: list[str]) -> int:
    """``feedopt argv`` in this process with the report's drawing timed (a module-level
    function of ``__main__``, so the prestarted report child can unpickle it)."""
    global _untimed_write_run_report
    import feedopt.report.run as report_run
    from feedopt.cli import main

    _untimed_write_run_report = report_run.write_run_report
    report_run.write_run_report = timed_write_run_report
    return main(argv)


@dataclass(frozen=True)
class RunNumbers:
    """One ``feedopt run --profile`` and its report: times [s], sizes [bytes]."""

    scenario: str
    samples: int
    total_s: float
    report_row_s: float
    drawing_s: float | None
    html: dict[str, int]
    md_bytes: int
    png_bytes: int
    png_count: int


def parse_profile(text: str) -> tuple[dict[str, float], int]:
    """The ``--profile`` table's rows without a law ({stage: seconds}) and the sample count."""
    rows = {m[1]: float(m[2]) for m in re.finditer(r"^\|\s*(\w+)\s*\|\s*-\s*\|\s*([\d.]+)",
                                                   text, re.M)}
    samples = re.search(r"^(\d+) path samples", text, re.M)
    return rows, int(samples[1]) if samples else 0


def html_parts(page: str) -> dict[str, int]:
    """Bytes of report.html by part: the head's scripts (plotly.js), the body's scripts (the
    figures), ``data:`` URIs (embedded PNGs), the rest, and the total (UTF-8)."""
    size = lambda t: len(t.encode("utf-8"))  # noqa: E731
    head_end = page.find("</head>")
    scripts = [(m.start(), size(m[0])) for m in re.finditer(r"<script\b.*?</script>", page,
                                                            re.S)]
    head = sum(n for at, n in scripts if at < head_end)
    body = sum(n for at, n in scripts if at >= head_end)
    data = sum(size(m[0]) for m in re.finditer(r"data:[\w/+.-]+;base64,[A-Za-z0-9+/=]+", page))
    total = size(page)
    return {"total": total, "plotly_js": head, "figure_scripts": body, "data_uris": data,
            "rest": total - head - body - data}


def scenario_spacing_mm(scenario: str) -> float:
    """The bundled scenario's own sample spacing [mm]."""
    import yaml

    return float(yaml.safe_load((SCENARIOS / f"{scenario}.yaml").read_text())["path"]
                 ["spacing_mm"])


def _key(r: RunNumbers) -> str:
    return f"{r.scenario} ({r.samples} samples)"


def run_scenario(scenario: str, out: Path, extra: list[str]) -> RunNumbers:
    """``feedopt run`` of a bundled scenario into ``out`` with ``--profile`` (a new
    process, the drawing timed inside it)."""
    timing = out.with_name(out.name + "_drawing.txt")
    timing.unlink(missing_ok=True)
    cmd = [sys.executable, str(Path(__file__).resolve()), _TIMED_RUN, "run",
           str(SCENARIOS / f"{scenario}.yaml"), "--out", str(out), "--profile", *extra]
    done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ,
                                                                    TIMING_ENV: str(timing)})
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{done.stderr[-3000:]}")
    rows, samples = parse_profile(done.stdout)
    drawing = [float(x) for x in timing.read_text().split()] if timing.exists() else []
    pngs = sorted(out.glob("report_*.png"))
    return RunNumbers(
        scenario=scenario, samples=samples, total_s=rows.get("total", float("nan")),
        report_row_s=rows.get("report", float("nan")), drawing_s=drawing[0] if drawing else None,
        html=html_parts((out / "report.html").read_text(encoding="utf-8")),
        md_bytes=(out / "report.md").stat().st_size,
        png_bytes=sum(p.stat().st_size for p in pngs), png_count=len(pngs))


#: Height of the top of a report (verdict, checks, the 3D view) saved for the README [px].
TOP_PX = 1250


def small_png(png: bytes, colours: int = 256, crop_height_px: int | None = None) -> bytes:
    """The PNG with an adaptive palette of ``colours`` (about 3-5x smaller; no optipng),
    cut to its top ``crop_height_px`` if given."""
    from PIL import Image

    img = Image.open(io.BytesIO(png)).convert("RGB")
    if crop_height_px is not None:
        img = img.crop((0, 0, img.width, min(crop_height_px, img.height)))
    buf = io.BytesIO()
    img.quantize(colors=colours, method=Image.Quantize.MEDIANCUT).save(buf, "PNG",
                                                                       optimize=True)
    return buf.getvalue()


@dataclass(frozen=True)
class View:
    """One report opened at one width: open-to-drawn time, figures, problems, overflow."""

    width_px: int
    height_px: int
    open_s: float
    figures: int
    problems: tuple[str, ...]
    overflow_px: int
    image: Path | None = None
    image_bytes: int = 0


def view(browser: Chromium, html: Path, width_px: int, image: Path | None,
         max_height_px: int) -> View:
    """Open ``html`` at ``width_px``, wait for every figure, and (``image``) write a small
    full-page screenshot there."""
    t0 = time.perf_counter()
    page = browser.load(html, width_px=width_px)
    figures = plotly_figures(browser, page)
    open_s = time.perf_counter() - t0
    overflow = sideways_overflow_px(browser, page)
    height, size = int(browser.evaluate(page, "document.documentElement.scrollHeight")), 0
    if image is not None:
        with tempfile.TemporaryDirectory() as tmp:
            raw = Path(tmp) / "shot.png"
            _, height = browser.screenshot(page, raw, max_height_px=max_height_px)
            image.parent.mkdir(parents=True, exist_ok=True)
            image.write_bytes(small_png(raw.read_bytes()))
            size = image.stat().st_size
            top = image.with_name(f"{image.stem}_top.png")  # what the README shows
            top.write_bytes(small_png(raw.read_bytes(), crop_height_px=TOP_PX))
    return View(width_px, height, open_s, len(figures), tuple(page_problems(page)), overflow,
                image, size)


def _shown(path: Path) -> str:
    return str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)


def _kb(n: int) -> str:
    return f"{n / 1024:,.0f}"


def format_results(runs: list[RunNumbers], views: dict[str, list[View]], header: str) -> str:
    """The results file: one row per run, then one per screenshot, then any problems."""
    out = [header, "",
           "| run | samples | report.html [kB] | plotly.js | figure scripts | data: URIs | "
           "rest | report.md [kB] | PNGs [kB] (n) | drawing [s] | report row [s] | "
           "run total [s] | browser open->drawn [s] | figures |",
           "|---|" + "---:|" * 13]
    for r in runs:
        h, v = r.html, views[_key(r)][0]
        drawing = "-" if r.drawing_s is None else f"{r.drawing_s:.2f}"
        out.append(f"| {r.scenario} | {r.samples} | {_kb(h['total'])} | {_kb(h['plotly_js'])} | "
                   f"{_kb(h['figure_scripts'])} | {_kb(h['data_uris'])} | {_kb(h['rest'])} | "
                   f"{_kb(r.md_bytes)} | {_kb(r.png_bytes)} ({r.png_count}) | {drawing} | "
                   f"{r.report_row_s:.2f} | {r.total_s:.2f} | {v.open_s:.2f} | {v.figures} |")
    out += ["", "| screenshot | width x height [px] | file [kB] | open->drawn [s] | "
                "sideways overflow [px] |", "|---|---:|---:|---:|---:|"]
    problems = []
    for key, vs in views.items():
        for v in vs:
            name = _shown(v.image) if v.image else f"{key} (not saved)"
            out.append(f"| {name} | {v.width_px} x {v.height_px} | {_kb(v.image_bytes)} | "
                       f"{v.open_s:.2f} | {v.overflow_px} |")
            problems += [f"- {key} at {v.width_px} px: {p}" for p in v.problems]
    out += ["", "Browser problems (console errors, exceptions, requests): "
            + ("none" if not problems else "")] + problems
    return "\n".join(out) + "\n"


def _header(browser_binary: str) -> str:
    def sh(*cmd: str) -> str:
        done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
        return done.stdout.strip()

    commit = sh("git", "rev-parse", "--short", "HEAD")
    dirty = " + uncommitted changes" if sh("git", "status", "--porcelain", "feedopt") else ""
    return (f"# report size, drawing time, screenshots (benchmarks/report_screenshots.py)\n"
            f"{time.strftime('%Y-%m-%d %H:%M')}, commit {commit}{dirty}, {os.cpu_count()} "
            f"cores, {sh(browser_binary, '--version')}\n"
            "drawing: write_run_report in the run's report child; report row: the --profile "
            "row (the drawing the exports did not hide); browser open->drawn: load + every "
            "plotly figure drawn, headless, software WebGL. kB = 1024 bytes.")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == [_TIMED_RUN]:
        return _timed_feedopt(argv[1:])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="triangle_slot,pocket")
    ap.add_argument("--widths", default="1400,900", help="screenshot widths [px]")
    ap.add_argument("--large-samples", type=float, default=1e5,
                    help="also a triangle_slot run of about this many samples (0: none)")
    ap.add_argument("--max-height-px", type=int, default=12000)
    ap.add_argument("--no-images", action="store_true", help="measure only, write no PNG")
    ap.add_argument("--img-dir", type=Path, default=IMG)
    ap.add_argument("--results", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    binary = find_chromium()
    if binary is None:
        raise SystemExit("no chromium on PATH: apt-get install chromium")
    runs, views = [], {}
    with tempfile.TemporaryDirectory(prefix="report_screenshots_") as tmp, \
            Chromium(binary) as browser:
        for name in args.scenarios.split(","):
            runs.append(run_scenario(name, Path(tmp) / name, []))
            views[_key(runs[-1])] = [
                view(browser, Path(tmp) / name / "report.html", int(w),
                     None if args.no_images else args.img_dir / f"report_{name}_{w}.png",
                     args.max_height_px) for w in args.widths.split(",")]
        if args.large_samples > 0:
            base = next((r for r in runs if r.scenario == "triangle_slot"), None) \
                or run_scenario("triangle_slot", Path(tmp) / "triangle_slot", [])
            spacing = scenario_spacing_mm("triangle_slot") * base.samples / args.large_samples
            out = Path(tmp) / "triangle_slot_large"
            runs.append(run_scenario("triangle_slot", out, ["--spacing-mm", f"{spacing:.6g}"]))
            views[_key(runs[-1])] = [
                view(browser, out / "report.html", 1400, None, args.max_height_px)]
        text = format_results(runs, views, _header(binary))
    args.results.write_text(text)
    print(text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
