"""The verdict on top of the report: the program to run and what to check before cutting,
from summaries written by hand."""

from __future__ import annotations

import pytest

from feedopt.errors import InputError
from feedopt.report.verdict import (
    BEGIN,
    END,
    CheckKind,
    checks_before_cutting,
    program_files,
    refresh_report_verdict,
    verdict,
    verdict_html,
    verdict_line,
    verdict_markdown,
    where_line,
)

KRL = {"rsi_csv": "{law}.csv", "rsi_corrections": "{law}_rsi.csv",
       "rsi_host_program": "{law}_rsi.src", "rsi_ethernet_config": "feedopt_rsi_ethernet.xml",
       "gcode_program": "{law}.nc", "urscript_program": None,
       "urscript_not_written": "no URScript: robot has controller 'kuka'"}


def _law(t: float, *, verified: bool = True, exported: bool | None = True, c2: bool = True,
         defl: float = 0.25, files: bool | None = None, **extra) -> dict:
    """One law's summary entry; ``files``: its exporters' entries (default: when exported)."""
    row = {"cycle_time_s": t, "lower_bound_s": 626.4, "max_deflection_mm": defl,
           "max_feed_mm_s": 4.2, "min_feed_mm_s": 2.3, "max_accel_mm_s2": 500.0,
           "max_jerk_mm_s3": 5000.0, "c2": c2, "verified": verified, "planning_time_s": 0.1,
           "problems": [], "export_blockers": []}
    if exported is not None:
        row["exported"] = exported
    return {**row, **extra}


def _with_files(law: str, row: dict) -> dict:
    return {**row, **{k: (v.format(law=law) if isinstance(v, str) else v)
                      for k, v in KRL.items()}}


def _summary(**laws) -> dict:
    return {"scenario": {"name": "pocket", "deflection_limit_mm": 0.25, "lower_bound_s": 626.4,
                         "fits": []},
            "warnings": [], "laws": laws}


def test_the_fastest_exported_law_wins_over_a_faster_unexported_one() -> None:
    s = _summary(
        programmed=_law(517.2, exported=False, defl=0.4019,
                        export_blockers=["deflection reaches 0.4019 mm, 1.6077 x the limit"]),
        topp=_law(628.7, exported=False, c2=False, export_blockers=["not C2"]),
        convex=_with_files("convex", _law(636.9)),
        jerk=_with_files("jerk", _law(630.1)),
        # faster still, exported on request (--export-unverified) but not verified
        hurried=_with_files("hurried", _law(600.0, verified=False, problems=["jerk too high"])),
    )
    v = verdict(s)
    assert v.law == "jerk" and v.reason is None
    assert v.files == ("jerk_rsi.src", "jerk.csv", "jerk.nc")  # controller files only
    assert v.cycle_time_s == 630.1 and v.lower_bound_s == 626.4 and v.c2 is True
    assert v.baseline.law == "programmed" and v.baseline.breaks_limit
    assert v.saving == pytest.approx(1 - 630.1 / 517.2)
    line = verdict_line(v)
    slower = (630.1 / 517.2 - 1) * 100  # independent: 21.8 % longer
    assert line == (f"Run jerk (jerk_rsi.src, jerk.csv, jerk.nc): verified, C2, 630.1 s = "
                    f"{630.1 / 626.4:.3f} T*, {slower:.1f} % longer than the programmed feed "
                    f"(517.2 s, over the deflection limit: {0.4019 / 0.25:.2f} x).")


def test_faster_than_a_baseline_that_meets_the_limit_and_ties_go_to_file_order() -> None:
    s = _summary(constant=_law(183.0, exported=False, defl=0.2),
                 convex=_law(146.0), jerk=_law(146.0))
    s["scenario"]["lower_bound_s"] = 145.85
    for row in s["laws"].values():
        row.pop("lower_bound_s")  # T* from the scenario then
    v = verdict(s)
    assert v.law == "convex" and v.files == ()  # exporters not done yet: no file named
    assert verdict_line(v) == (f"Run convex: verified, C2, 146.0 s = {146.0 / 145.85:.3f} T*, "
                               f"{(1 - 146.0 / 183.0) * 100:.1f} % faster than the constant "
                               "feed (183.0 s).")


def test_no_exported_law_gives_each_reason() -> None:
    s = _summary(constant=_law(116.6, exported=False, defl=0.405,
                               export_blockers=["deflection reaches 0.405 mm"]),
                 topp=_law(146.0, exported=False, c2=False,
                           export_blockers=["not C2: the acceleration jumps"]),
                 convex=_law(146.0, verified=False, problems=["the solver failed"]),
                 old=_law(150.0, exported=None))
    v = verdict(s)
    assert v.law is None and v.files == ()
    assert v.reason == ("no law is both verified and exported (constant: not exported: "
                        "deflection reaches 0.405 mm; topp: not exported: not C2: the "
                        "acceleration jumps; convex: not verified: the solver failed; old: no "
                        "export verdict in summary.json (written by an older feedopt))")
    assert verdict_line(v) == f"No program to run: {v.reason}."
    assert 'class="verdict none"' in verdict_html(s)


def test_bad_summaries_are_refused_by_name() -> None:
    for bad in ({}, {"laws": {}}, {"laws": []}, []):
        with pytest.raises(InputError, match="needs a non-empty 'laws' object"):
            verdict(bad)


def test_checks_find_placeholders_fits_unmodelled_moves_and_failed_laws() -> None:
    s = _summary(constant=_law(116.6, exported=False),
                 convex=_law(146.0, verified=False, problems=["jerk 6000 exceeds 5000"]))
    s["warnings"] = [
        "pocket.nc: line 20: G43 H1 tool length offset recorded, no geometric effect",
        "pocket.nc: line 135: G28 returns Z to machine home: that part of the move is not in "
        "the move list",
        "robot ur10: UR10 joint stiffness is an ILLUSTRATIVE PLACEHOLDER, not a calibration",
        "the tightest path radius is 0.0257 mm (41 place(s) tighter than the cutter): feeds "
        "there are approximate",
        "feed.nominal_mm_s (9 mm/s): feed per tooth 0.1 mm is above the range the cutting "
        "coefficients were calibrated for; the linear force model is extrapolated there",
    ]
    s["scenario"]["fits"] = ["cut.axial_depth_mm = 1.5 is a FIT: not stated in the thesis"]
    s["scenario"]["material"] = {"coefficients_at_rpm": "extrapolated",
                                 "calibrated_rpm": [1000, 2000]}
    s["scenario"]["cut"] = {"rpm": 3000}
    s["scenario"]["program"] = {"unmodelled_plunges": [{"label": "line 40 (N400)", "line": 40}]}
    got = [(c.kind, c.text) for c in checks_before_cutting(s)]
    w = s["warnings"]
    assert got == [
        (CheckKind.PLACEHOLDER, w[2]),
        (CheckKind.FIT, s["scenario"]["fits"][0]),
        (CheckKind.EXTRAPOLATED, w[4]),
        (CheckKind.EXTRAPOLATED, "cutting coefficients at 3000 rpm are extrapolated "
                                 "(calibrated at 1000, 2000 rpm)"),
        (CheckKind.UNMODELLED, w[1]),
        (CheckKind.UNMODELLED, w[3]),
        (CheckKind.UNMODELLED, "1 plunge(s) into material have no force model "
                               "(line 40 (N400))"),
        (CheckKind.UNVERIFIED, "convex: not verified: jerk 6000 exceeds 5000"),
    ]
    # the G43 note is not a check (it stays in the warnings); a plunge warning is not
    # repeated from the program section
    s["warnings"].append("the plunges straight down into material at line 40 (N400) (12 "
                         "samples) have no force model: no plunge coefficients")
    texts = [c.text for c in checks_before_cutting(s)]
    assert not any("G43" in t for t in texts)
    assert sum("plunge" in t for t in texts) == 1
    assert checks_before_cutting(_summary(jerk=_law(1.0))) == []


def test_where_line_names_the_program_line_and_the_constraints() -> None:
    s = _summary(jerk=_law(630.1, worst_deflection={"sample": 15610, "s_mm": 1561.04,
                                                     "line": 110, "label": "line 110 (N950)"}))
    s["scenario"]["active_constraints"] = {"deflection": 0.6704, "max_feed": 0.3296,
                                           "spindle_power": 0.0}
    s["scenario"]["program"] = {"lowest_bound": {"line": 118, "label": "line 118 (N1030)",
                                                 "s_mm": 1794.823, "v_max_mm_s": 2.29323}}
    assert where_line(s, "jerk") == (
        "The feed bound is set by deflection on 67 % of the path, max feed on 33 %; it is "
        "lowest at line 118 (N1030), s = 1794.8 mm (2.29 mm/s); jerk deflects most (0.250 mm) "
        "at line 110 (N950), s = 1561.0 mm.")
    assert where_line(_summary(jerk=_law(1.0)), None) is None


def test_program_files_keep_the_controller_files_in_order() -> None:
    row = {"rsi_csv": "a.csv", "krl_program": "a.src", "krl_data": "a.dat", "gcode_program":
           "a.nc", "fanuc_program": None, "custom_program": "a.xyz", "rsi_corrections": "x.csv"}
    assert program_files(row) == ("a.src", "a.csv", "a.nc", "a.xyz")


def test_refresh_rewrites_only_the_verdict_block(tmp_path) -> None:
    s = _summary(constant=_law(183.0, exported=False), jerk=_law(146.0))
    md = f"# title\n\n{verdict_markdown(s)}\n\n## Rest <!-- keep -->\n"
    page = f"<h1>t</h1>\n{verdict_html(s)}\n<p>rest</p>\n"
    (tmp_path / "report.md").write_text(md)
    (tmp_path / "report.html").write_text(page)
    assert "Run jerk:" in md  # drawn before the exporters wrote: no files yet
    done = _with_files("jerk", s["laws"]["jerk"])
    s["laws"]["jerk"] = done
    s["warnings"] = ["a <!-- /verdict --> placeholder in a warning"]  # cannot end the block
    assert refresh_report_verdict(tmp_path, s) == [tmp_path / "report.md",
                                                   tmp_path / "report.html"]
    md2, page2 = (tmp_path / "report.md").read_text(), (tmp_path / "report.html").read_text()
    assert md2 == f"# title\n\n{verdict_markdown(s)}\n\n## Rest <!-- keep -->\n"
    assert page2 == f"<h1>t</h1>\n{verdict_html(s)}\n<p>rest</p>\n"
    assert "Run jerk (jerk_rsi.src, jerk.csv, jerk.nc)" in md2 and md2.count(END) == 1
    assert page2.count(BEGIN) == page2.count(END) == 1
    assert refresh_report_verdict(tmp_path, s) == []  # nothing changed: nothing written
    (tmp_path / "report.md").unlink()
    assert refresh_report_verdict(tmp_path / "none", s) == []
