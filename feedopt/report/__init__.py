"""report stage of feedopt (see shared/design.md): comparison table, plots, markdown/HTML.

The names below are loaded on first use (PEP 562): importing a submodule such as
``feedopt.report.data`` must not pull in matplotlib, which only the report drawing needs (a run
draws it in a forked child, so the parent never pays the import).
"""

from __future__ import annotations

import importlib

_WHERE = {
    "LawSeries": "feedopt.report.data",
    "PathCurvesSI": "feedopt.report.data",
    "ReportData": "feedopt.report.data",
    "TimeCurvesSI": "feedopt.report.data",
    "law_series_from_si": "feedopt.report.data",
    "load_summary": "feedopt.report.data",
    "write_report": "feedopt.report.html",
    "comparison_table": "feedopt.report.tables",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'feedopt.report' has no attribute {name!r}")
