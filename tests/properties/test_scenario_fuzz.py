"""Property: a mutated scenario file is either a scenario or one InputError, never a crash;
and ``feedopt run`` on a mutated but cheap scenario exits 0, 2 or 3, never 1, and leaves
nothing behind after 2."""

from __future__ import annotations

import contextlib
import io
import json
import re

import pytest
import yaml
from hypothesis import example, given
from hypothesis import strategies as st

from feedopt.cli import main
from feedopt.errors import InputError
from feedopt.export.rsi import read_rsi_csv
from feedopt.scenario import Scenario, load_scenario

from ._support import (
    ROOT,
    SCENARIO_NAMES,
    SCENARIOS,
    budget,
    garbage,
    mutated,
    text_mutations,
)


def _bundled(name: str, *, cheap: bool = False) -> dict:
    doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    doc["robot"]["directory"] = str(ROOT / "robots" / "kuka_kr500_3")
    doc["tool"] = str(SCENARIOS / doc["tool"])
    doc["material"] = str(SCENARIOS / doc["material"])
    if cheap:
        doc["path"]["spacing_mm"] = 2.0
        doc["schedule"]["laws"] = ["constant", "jerk"]
    return doc


BUNDLED = {name: _bundled(name) for name in SCENARIO_NAMES}
CHEAP = {name: _bundled(name, cheap=True) for name in SCENARIO_NAMES}
TEXTS = {name: (SCENARIOS / f"{name}.yaml").read_text() for name in SCENARIO_NAMES}


def _load_or_input_error(path):
    try:
        scenario, base = load_scenario(path)
    except InputError as exc:
        assert str(exc).strip(), "an InputError must say something"
        return None
    assert isinstance(scenario, Scenario) and base.is_dir()
    return scenario


@st.composite
def mutated_scenarios(draw):
    name = draw(st.sampled_from(SCENARIO_NAMES))
    return draw(mutated(BUNDLED[name]))


def _dump(doc) -> str:
    return yaml.safe_dump(doc, allow_unicode=True, sort_keys=False)


@budget(150)
@given(doc=mutated_scenarios())
def test_mutated_scenario_dict_loads_or_input_error(tmp_path, doc):
    p = tmp_path / "scenario.yaml"
    p.write_text(_dump(doc), encoding="utf-8")
    _load_or_input_error(p)


@budget(40)
@given(name=st.sampled_from(SCENARIO_NAMES), section=st.sampled_from(
    ["robot", "workpiece", "path", "cut", "feed", "deflection", "limits", "schedule", "export"]),
    value=garbage)
def test_whole_section_replaced(tmp_path, name, section, value):
    doc = dict(BUNDLED[name])
    doc[section] = value
    p = tmp_path / "scenario.yaml"
    p.write_text(_dump(doc), encoding="utf-8")
    _load_or_input_error(p)


@budget(60)
@given(top=garbage)
def test_any_yaml_document(tmp_path, top):
    p = tmp_path / "scenario.yaml"
    p.write_text(_dump(top), encoding="utf-8")
    _load_or_input_error(p)


@budget(150)
@given(data=st.data(), name=st.sampled_from(SCENARIO_NAMES))
def test_raw_text_mutations(tmp_path, data, name):
    text = data.draw(text_mutations(TEXTS[name], alphabet=list(":-[]{},#&*!|>'\"%@` \t\n0.")))
    p = tmp_path / "scenario.yaml"
    p.write_text(text, encoding="utf-8", errors="surrogatepass")
    _load_or_input_error(p)


@budget(40)
@given(name=st.sampled_from(SCENARIO_NAMES), data=st.data())
def test_duplicated_lines_and_keys(tmp_path, name, data):
    lines = TEXTS[name].splitlines(keepends=True)
    keyed = [i for i, ln in enumerate(lines) if re.match(r"\s*[a-z_0-9]+:( |$)", ln)]
    picks = data.draw(st.lists(st.sampled_from(keyed), min_size=1, max_size=3, unique=True))
    for i in sorted(picks, reverse=True):
        lines.insert(i + 1, lines[i])
    p = tmp_path / "scenario.yaml"
    p.write_text("".join(lines), encoding="utf-8")
    with pytest.raises(InputError, match="given twice|duplicate|twice"):
        load_scenario(p)


@budget(60)
@given(raw=st.binary(max_size=400), name=st.sampled_from(SCENARIO_NAMES),
       where=st.floats(0, 1))
@example(raw=b"([", name="linear_peripheral", where=0.0)  # an unknown key with a "[" in it
def test_random_bytes(tmp_path, raw, name, where):
    text = TEXTS[name].encode()
    k = int(where * len(text))
    p = tmp_path / "scenario.yaml"
    for content in (raw, text[:k] + raw + text[k:]):
        p.write_bytes(content)
        _load_or_input_error(p)


# --- the whole CLI on cheap mutated scenarios -----------------------------------------------


@st.composite
def cheap_scenarios(draw):
    name = draw(st.sampled_from(SCENARIO_NAMES))
    doc = draw(mutated(CHEAP[name], cheap=True, max_mutations=2))
    path = doc.get("path")
    if isinstance(path, dict):  # keep the run cheap: coarse samples, two fast laws
        spacing = path.get("spacing_mm")
        if isinstance(spacing, int | float) and not isinstance(spacing, bool) and spacing < 2:
            path["spacing_mm"] = 2.0
        for key in ("length_mm", "height_mm", "waves"):
            v = path.get(key)
            if isinstance(v, int | float) and not isinstance(v, bool):
                path[key] = min(v, CHEAP[name]["path"].get(key, v))
    schedule = doc.get("schedule")
    if isinstance(schedule, dict) and isinstance(schedule.get("laws"), list):
        schedule["laws"] = [x for x in schedule["laws"] if x in ("constant", "jerk")] or ["jerk"]
    return doc


def _run(args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    return rc, out.getvalue(), err.getvalue()


def check_run(tmp_path, doc):
    scen = tmp_path / "scen" / "s.yaml"
    scen.parent.mkdir(parents=True, exist_ok=True)
    scen.write_text(_dump(doc), encoding="utf-8")
    out = tmp_path / "results" / "run"
    rc, stdout, stderr = _run(["run", str(scen), "--out", str(out), "--no-report"])
    assert "Traceback" not in stderr and "internal error" not in stderr, stderr
    assert rc in (0, 2, 3), (rc, stderr)
    if rc == 2:
        assert stderr.count("feedopt run: error:") == 1, stderr
        assert not out.exists(), f"exit 2 left {out}"
        assert not (tmp_path / "results").exists() or not any(
            (tmp_path / "results").iterdir()), "exit 2 left a staging folder"
        return rc
    summary = json.loads((out / "summary.json").read_text())
    exported = [law for law, e in summary["laws"].items() if e.get("exported")]
    for law in exported:
        table = read_rsi_csv(out / f"{law}.csv")
        assert len(table) > 1
    if rc == 0:
        assert all(e.get("verified", True) for e in summary["laws"].values()
                   if isinstance(e, dict) and "verified" in e)
    else:
        assert exported, "exit 3 means some laws were exported"
    assert [p.name for p in (tmp_path / "results").iterdir()] == ["run"], "staging left"
    return rc


@budget(5)
@given(doc=cheap_scenarios())
def test_cli_run_on_mutated_cheap_scenario(tmp_path_factory, doc):
    check_run(tmp_path_factory.mktemp("cli"), doc)


def test_cli_run_unmutated_cheap_scenario_exits_0(tmp_path):
    assert check_run(tmp_path, CHEAP["linear_peripheral"]) == 0
