"""path.dwell_p_units: strict in the scenario, passed to the reader by the geometry stage."""

import pytest
from pydantic import ValidationError

from feedopt.errors import InputError
from feedopt.gcode import StopKind
from feedopt.geometry import stage
from feedopt.scenario import PathSection

PROGRAM = "G21 G90\nG0 X0 Y0 Z5\nM3 S1000\nG1 X10 F600\nG4 P1500\nG1 X20\nM30\n"


def test_dwell_p_units_field_is_strict_and_described():
    assert PathSection(generator="gcode", file="p.nc").dwell_p_units == "s"
    assert PathSection(generator="gcode", file="p.nc", dwell_p_units="ms").dwell_p_units == "ms"
    with pytest.raises(ValidationError, match="dwell_p_units"):
        PathSection(generator="gcode", file="p.nc", dwell_p_units="seconds")
    assert "Fanuc" in PathSection.model_fields["dwell_p_units"].description


@pytest.mark.parametrize(("units", "hold"), [("s", 1500.0), ("ms", 1.5)])
def test_geometry_stage_reads_the_program_with_the_field(tmp_path, monkeypatch, units, hold):
    (tmp_path / "p.nc").write_text(PROGRAM)
    section = PathSection(generator="gcode", file="p.nc", dwell_p_units=units)
    seen = {}

    def stop_after_reading(program, *_):
        seen["program"] = program
        raise InputError("stopped after the reader (test)")

    monkeypatch.setattr(stage, "check_tools", stop_after_reading)
    with pytest.raises(InputError, match="stopped after the reader"):
        stage.program_from_section(section, tmp_path)
    (dwell,) = [s for s in seen["program"].stops if s.kind is StopKind.DWELL]
    assert dwell.hold_s == pytest.approx(hold)
