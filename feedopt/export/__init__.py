"""export stage of feedopt: one module per output format, registered in
:data:`feedopt.export.job.EXPORTERS` (see :mod:`feedopt.export.job`)."""

from feedopt.export import (
    compensation,
    fanuc,
    gcode_out,
    krl,
    rapid,
    rsi,
    rsi_program,
    urscript,
)
from feedopt.export.job import EXPORTERS, register_exporter

# The built-in exporters, in the order they write (a new format: its module + one line here).
for _exporter in (rsi.EXPORTER, krl.EXPORTER, rsi_program.EXPORTER, gcode_out.EXPORTER,
                  urscript.EXPORTER, rapid.EXPORTER, fanuc.EXPORTER, compensation.EXPORTER):
    if _exporter.name not in EXPORTERS:
        register_exporter(_exporter)
