"""``<law>_compensation.csv``: the nominal and the commanded (compensated) path per cycle.

With ``deflection.mode: residual`` the pose columns of ``<law>.csv`` are the commanded path,
``nominal - mean deflection`` (:mod:`feedopt.schedule.compensation`); this companion file,
one row per controller cycle like ``<law>.csv``, carries both paths and the offset between
them, so the cell can be checked against the part geometry. Not written without compensation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feedopt.export.job import Exporter, ExportJob, status_line
from feedopt.floattext import refuse_non_finite, write_float_rows
from feedopt.units import MM_PER_M

COLUMNS = ("t_s", "s_mm", "nominal_x_mm", "nominal_y_mm", "nominal_z_mm", "commanded_x_mm",
           "commanded_y_mm", "commanded_z_mm", "offset_x_mm", "offset_y_mm", "offset_z_mm")


def export_compensation(job: ExportJob, out_dir: Path) -> dict:
    """Write ``<law>_compensation.csv`` (nothing without compensation)."""
    if job.compensation is None:
        return {}
    motion = job.samples.motion
    s = np.clip(motion.s, job.problem.s[0], job.problem.s[-1])
    nominal, commanded = job.compensation.at(s)
    m = np.column_stack([motion.t, s * MM_PER_M, nominal * MM_PER_M, commanded * MM_PER_M,
                         (commanded - nominal) * MM_PER_M])
    name = f"{job.law}_compensation.csv"
    refuse_non_finite(m, COLUMNS, "compensation table", out_dir / name)
    with (out_dir / name).open("w", encoding="ascii", newline="\n") as f:
        f.write(f"# {status_line(job)}\n"
                "# compensation: commanded = nominal - predicted mean deflection of a cutter "
                "revolution at the planned feed (deflection.mode residual); base frame, mm; "
                f"{job.law}.csv carries the commanded pose\n" + ",".join(COLUMNS) + "\n")
        write_float_rows(f, m)
    offset = np.linalg.norm(commanded - nominal, axis=1)
    return {"compensation_csv": name,
            "max_compensation_offset_mm": float(offset.max() * MM_PER_M) if offset.size else 0.0}


EXPORTER = Exporter(
    name="compensation", file_pattern="{law}_compensation.csv", export=export_compensation,
    description="nominal and commanded (compensated) TCP path per controller cycle, with the "
                "offset between them (deflection.mode residual only)")
