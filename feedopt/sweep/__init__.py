"""Parameter and placement sweeps (``feedopt sweep``): the pipeline at every point of a grid.

- :mod:`~feedopt.sweep.grid`: ``--grid FIELD=VALUES`` specs, applied to the raw scenario data
- :mod:`~feedopt.sweep.bundle`: the scenario and its files, shipped to the workers
- :mod:`~feedopt.sweep.point`: one point = ``prepare`` + ``plan_and_verify``, as typed numbers
- :mod:`~feedopt.sweep.execute`: this process, a local Dask cluster or a running one
- :mod:`~feedopt.sweep.table`: the CSV table, appended as points finish, read to resume
- :mod:`~feedopt.sweep.rowcheck`: every row read back checked as feedopt writes it
- :mod:`~feedopt.sweep.folder`: the output folder (outdir's rules, plus resuming)
- :mod:`~feedopt.sweep.objective`, :mod:`~feedopt.sweep.plots`: best point, heat maps
- :mod:`~feedopt.sweep.run`: :func:`run_sweep`, which ties them together
"""

from feedopt.sweep.run import (
    Execution,
    SweepInterrupted,
    SweepResult,
    SweepSettings,
    run_sweep,
)

__all__ = ["Execution", "SweepInterrupted", "SweepResult", "SweepSettings", "run_sweep"]
