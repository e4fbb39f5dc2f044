"""report stage of feedopt (see shared/design.md): comparison table, plots, markdown/HTML."""

from feedopt.report.data import LawSeries, ReportData, law_series_from_si, load_summary
from feedopt.report.html import write_report
from feedopt.report.tables import comparison_table

__all__ = [
    "LawSeries",
    "ReportData",
    "comparison_table",
    "law_series_from_si",
    "load_summary",
    "write_report",
]
