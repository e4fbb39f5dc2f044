"""The report child of a run: forked before planning so that matplotlib and the figures are
imported on the other core while this one plans (:func:`report_worker`); the output stage
sends it the run's data (:func:`feedopt.outputs.write_outputs`). Importing this module
imports no plotting library."""

from __future__ import annotations

from feedopt import background

__all__ = ["report_worker"]


def _import_report() -> None:
    import feedopt.report.html  # noqa: F401 - matplotlib and the figures, ~0.5 s
    import feedopt.report.run  # noqa: F401
    from feedopt.report.interactive import warm_up

    warm_up()  # plotly's import and its first figure, ~0.5 s


def report_worker() -> background.Prestarted:
    """A forked child that imports the report's plotting libraries now and draws the report
    when :func:`feedopt.outputs.write_outputs` sends it the run's data."""
    return background.prestart(_import_report, "drawing the report")
