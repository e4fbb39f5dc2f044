"""Timings of the export and report stages on synthetic data.

Run: ``.venv/bin/python benchmarks/bench_export.py [--quick]``. ``main(quick)`` returns the
timings (seconds) as a dict so a combined benchmark can call it.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from feedopt.export.frames import cell_frames
from feedopt.export.krl import KeyPoints, parse_krl_spline, write_krl_program
from feedopt.export.rsi import RsiTable, read_rsi_csv, write_rsi_csv
from feedopt.report.data import PathCurvesSI, ReportData, TimeCurvesSI, law_series_from_si
from feedopt.report.html import write_report
from feedopt.robot.model import load_robot


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _report_data(k: int, m: int) -> ReportData:
    u = np.linspace(0, 6, k)
    xyz = np.column_stack([1200 + 25 * u, 40 * np.abs((u % 2) - 1), np.full(k, 650.0)])
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]) * 1e-3
    kind = np.where(np.abs((u % 1) - 0.5) > 0.45, "blend", "line")
    laws = []
    for law, f in (("constant", 1.0), ("thesis", 0.8), ("topp", 0.85), ("convex", 0.86),
                   ("jerk", 0.84)):
        feed = 4.23e-3 * f * (1 + 0.1 * np.sin(u * 3))
        t = np.linspace(0, 80 / f, m)
        laws.append(law_series_from_si(
            law, PathCurvesSI(s, feed, 0.28e-3 * (1 + 0.1 * np.cos(u))),
            TimeCurvesSI(t, np.interp(t, t[[0, -1]], feed[[0, -1]]), np.sin(t) * 1e-3,
                         np.cos(t) * 1e-2, np.outer(np.sin(t), np.arange(1, 7)) * 1e-3)))
    summary = {"scenario": {"deflection_limit_mm": 0.29}, "laws": {
        ls.law: {"cycle_time_s": float(ls.t_s[-1]), "lower_bound_s": 60.0,
                 "max_deflection_mm": 0.3, "max_feed_mm_s": 4.6, "min_feed_mm_s": 3.0,
                 "max_accel_mm_s2": 1.0, "max_jerk_mm_s3": 10.0, "c2": True,
                 "verified": True, "planning_time_s": 0.1} for ls in laws}}
    return ReportData("bench", summary, xyz, kind, tuple(laws), np.full(6, 60.0), 0.29)


def main(quick: bool = False) -> dict[str, float]:
    """Time RSI write/read, KRL write/parse and the report; returns seconds per step."""
    n = 5_000 if quick else 75_000  # rows: 20 s / 300 s at the 4 ms RSI cycle
    rng = np.random.default_rng(0)
    m = rng.normal(size=(n, 18)) * 1e3
    m[:, 0] = np.arange(n) * 0.004
    table = RsiTable.from_matrix(m)
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        out[f"rsi_write_{n}_rows"], _ = _timed(lambda: write_rsi_csv(tmp / "a.csv", table))
        out[f"rsi_read_{n}_rows"], back = _timed(lambda: read_rsi_csv(tmp / "a.csv"))
        assert back.equals(table)
        pts = np.column_stack([np.linspace(1000, 1300, 1001), np.zeros((1001, 2)) + 500,
                               np.zeros((1001, 3)) + [0, 90, 0]])
        motion = ["SLIN" if i % 2 else "SPL" for i in range(1000)]
        vel = np.full(1000, 0.004)
        frames = cell_frames(load_robot(Path(__file__).parents[1] / "robots" / "kuka_kr500_3"))
        out["krl_write_1000_segments"], (path, _) = _timed(
            lambda: write_krl_program(tmp / "k.src", None, KeyPoints(pts, motion, vel, np.zeros(6)),
                                      frames=frames))
        out["krl_parse_1000_segments"], _ = _timed(lambda: parse_krl_spline(path.read_text()))
        k, mm = (2_000, 5_000) if quick else (20_000, 75_000)
        data = _report_data(k, mm)
        out[f"report_5_laws_{k}_samples_{mm}_cycles"], _ = _timed(
            lambda: write_report(tmp / "rep", data))
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    for key, sec in main(ap.parse_args().quick).items():
        print(f"{key:45s} {sec:8.3f} s")
