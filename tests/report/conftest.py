"""A synthetic report: a two-wave triangle path with blends and three laws (no planning)."""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.report.data import (
    LawSeries,
    PathCurvesSI,
    ReportData,
    TimeCurvesSI,
    law_series_from_si,
)


def fake_summary(name: str = "triangle_slot", scale: float = 1.0) -> dict:
    def row(t, tl, d, fmax, fmin, verified=True):
        return {"cycle_time_s": t * scale, "lower_bound_s": tl, "max_deflection_mm": d,
                "max_feed_mm_s": fmax, "min_feed_mm_s": fmin, "max_accel_mm_s2": 5.0,
                "max_jerk_mm_s3": 80.0, "c2": True, "verified": verified,
                "planning_time_s": 0.12}

    return {
        "scenario": {"name": name, "deflection_limit_mm": 0.29},
        "laws": {
            "constant": row(100.0, None, 0.41, 4.23, 4.23),
            "thesis": {**row(125.0, 110.0, 0.29, 4.02, 2.75),
                       "start_ramp": {"length_mm": 0.16, "duration_s": 0.1153, "feed_mm_s": 2.771,
                                      "s_from_mm": 0.0, "s_to_mm": 0.16, "ends_by": "flat"},
                       "stop_ramp": {"length_mm": 0.2866, "duration_s": 0.1401,
                                     "feed_mm_s": 4.091, "s_from_mm": 492.63,
                                     "s_to_mm": 492.917, "ends_by": "bound"}},
            "topp": {**row(115.0, 110.0, 0.2899, 4.1, 2.6), "deflection_ratio": 0.9997},
        },
    }


def _law(name, s, xyz_kind, t_end, verified=True):
    k = s.size
    up = xyz_kind  # +1 on up lines, -1 on down lines, 0 in blends
    if name == "constant":
        feed = np.full(k, 4.23e-3)
        defl = 0.29e-3 * (1.0 + 0.4 * (up > 0) + 0.2 * (up == 0))
    else:
        feed = np.where(up > 0, 2.75e-3, np.where(up < 0, 4.02e-3, 2.2e-3))
        defl = np.full(k, 0.285e-3)
    m = 200
    t = np.linspace(0.0, t_end, m)
    ft = np.interp(t, np.linspace(0, t_end, k), feed)
    qd = np.deg2rad(np.outer(np.sin(t), [1, 2, 3, 4, 5, 6]) * 0.1)
    timed = TimeCurvesSI(t, ft, np.gradient(ft, t), np.gradient(np.gradient(ft, t), t), qd)
    return law_series_from_si(name, PathCurvesSI(s, feed, defl), timed, verified,
                              notes=(f"{name} note",))


@pytest.fixture(scope="session")
def report_data() -> ReportData:
    # key points of a triangle wave (mm), densely sampled; corners stand for blends
    kx = np.array([0, 38.1, 76.2, 114.3, 152.4])
    ky = np.array([0, 76.2, 0, 76.2, 0])
    k = 401
    u = np.linspace(0, 4, k)
    x = np.interp(u, np.arange(5), kx)
    y = np.interp(u, np.arange(5), ky)
    frac = u - np.floor(u)
    near_corner = (frac < 0.08) | (frac > 0.92)
    kind = np.where(near_corner, "blend", "line")
    direction = np.where(near_corner, 0, np.where(np.floor(u) % 2 == 0, 1, -1))
    xyz = np.column_stack([x + 1200, y - 40, np.full(k, 650.0)])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]) * 1e-3
    laws: tuple[LawSeries, ...] = (
        _law("constant", s, direction, 100.0),
        _law("thesis", s, direction, 125.0),
        _law("topp", s, direction, 115.0, verified=False),
    )
    return ReportData(
        scenario="triangle_slot <test>",
        summary=fake_summary(),
        path_xyz_mm=xyz,
        segment_kind=kind,
        laws=laws,
        joint_velocity_limit_deg_s=np.array([45, 45, 45, 50, 50, 60.0]),
        deflection_limit_mm=0.29,
        notes=("workpiece at x=1200 mm",),
    )
