"""Shared fixtures of the process-stage tests."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from feedopt.process import CuttingCoefficients, Tool, load_coefficients, load_tool

REPO = Path(__file__).resolve().parents[2]
SHARED_DATA = REPO.parent / "shared" / "data"
# The 12 calibration cuts of thesis Table 3.2, shipped in the repository (a copy of
# shared/data/thesis_table_3_2_slot_forces.csv, which test_calibration checks it against when
# shared/ is beside the repository) so the Table 3.3 reproduction never skips.
TABLE_3_2 = REPO / "scenarios" / "materials" / "thesis_table_3_2_slot_forces.csv"
SHARED_TABLE_3_2 = SHARED_DATA / "thesis_table_3_2_slot_forces.csv"
TOOL_YAML = REPO / "scenarios" / "tools" / "hss_2flute_19mm.yaml"
MATERIAL_YAML = REPO / "scenarios" / "materials" / "6061-T6511.yaml"

# thesis Table 3.3 (N/m^2 and N/m)
TABLE_3_3 = {
    1000: CuttingCoefficients(8.21e8, 2.55e8, -0.82e8, 11.91e3, 14.93e3, -3.75e3),
    2000: CuttingCoefficients(8.57e8, 3.19e8, -1.05e8, 7.42e3, 8.45e3, -2.13e3),
    2500: CuttingCoefficients(9.19e8, 4.02e8, -1.19e8, 8.80e3, 6.73e3, -1.05e3),
}


@pytest.fixture
def table_3_2() -> Path:
    assert TABLE_3_2.is_file(), f"thesis Table 3.2 data belongs at {TABLE_3_2}"
    return TABLE_3_2


@pytest.fixture
def thesis_tool() -> Tool:
    return load_tool(TOOL_YAML)


@pytest.fixture
def coeffs_2000() -> CuttingCoefficients:
    return load_coefficients(MATERIAL_YAML).at(2000)


def make_tool(helix_deg: float = 30.0, teeth: int = 2, diameter: float = 19.05e-3) -> Tool:
    return Tool("test", diameter, teeth, math.radians(helix_deg), 23.8125e-3)
