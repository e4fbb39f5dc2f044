"""Fixtures of the RSI tests: the bundled default run's trajectory (once per session) and
short stretches of it written as RSI CSVs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from feedopt.export.rsi import RsiTable, read_rsi_csv, write_rsi_csv

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def default_run(tmp_path_factory) -> Path:
    """``feedopt run scenarios/triangle_slot.yaml --laws jerk`` (no report figures): its
    output folder, with jerk.csv and the RSI host files."""
    from feedopt.runner import run_scenario

    out = tmp_path_factory.mktemp("rsi") / "triangle_slot"
    run_scenario(ROOT / "scenarios" / "triangle_slot.yaml", out_dir=out, laws=["jerk"],
                 report=False, progress=lambda _m: None)
    return out


@pytest.fixture(scope="session")
def default_table(default_run) -> RsiTable:
    return read_rsi_csv(default_run / "jerk.csv")


@pytest.fixture
def stretch(default_table, tmp_path):
    """``stretch(rows, step=1)``: the first ``rows`` rows of the default trajectory (every
    ``step``-th) written as an RSI CSV; returns its path."""

    def write(rows: int, step: int = 1, name: str = "stretch.csv") -> Path:
        m = default_table.as_matrix()[: rows * step : step].copy()
        path = tmp_path / name
        write_rsi_csv(path, RsiTable.from_matrix(m))
        return path

    return write


def poses(table: RsiTable) -> np.ndarray:
    """(n, 6) X, Y, Z, A, B, C of a table, straight from its columns."""
    return np.column_stack([table.x_mm, table.y_mm, table.z_mm, table.a_deg, table.b_deg,
                            table.c_deg])
