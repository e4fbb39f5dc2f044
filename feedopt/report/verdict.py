"""The report's first lines: which program to run, and what to check before cutting.

Built from the content of ``summary.json`` alone, so the same answer comes from a run and from
a summary read back. :func:`verdict` picks the program: the fastest law that is verified AND
exported (its files are its exporters' entries in ``summary["laws"][law]``);
:func:`checks_before_cutting` lists what the numbers rest on that a person must confirm
(placeholder inputs, fitted inputs, extrapolated coefficients, moves the model does not
cover, laws that failed verification). :func:`verdict_markdown` / :func:`verdict_html` render
both between :data:`BEGIN` and :data:`END` markers; the report is drawn while the exporters
still write, so :func:`refresh_report_verdict` renders the block again once the files are
known (no matplotlib is imported here).
"""

from __future__ import annotations

import html
import os
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from feedopt.errors import InputError

#: The baseline laws (the constant nominal feed, a G-code program's own feeds), first found.
BASELINE_LAWS = ("constant", "programmed")
#: What each baseline is called in a sentence.
BASELINE_NAMES = {"constant": "the constant feed", "programmed": "the programmed feed"}
#: summary entries naming the files a controller runs, in the order the verdict names them
#: (a native program first, then the RSI host program and its stream, then G-code).
PROGRAM_KEYS = ("krl_program", "rapid_module", "fanuc_program", "urscript_program",
                "rsi_host_program", "rsi_csv", "gcode_program")
#: Markers around the verdict block in report.md and report.html.
BEGIN, END = "<!-- verdict -->", "<!-- /verdict -->"
#: A deflection ratio above this breaks the limit (the replay's relative tolerance).
RATIO_TOL = 1e-6


class CheckKind(Enum):
    """What kind of thing a person must confirm before cutting (the value is its label)."""

    PLACEHOLDER = "placeholder input"
    FIT = "fitted input"
    EXTRAPOLATED = "extrapolated"
    UNMODELLED = "not modelled"
    UNVERIFIED = "failed verification"


@dataclass(frozen=True)
class Check:
    """One item of "check before cutting": its kind and the sentence from the summary."""

    kind: CheckKind
    text: str


@dataclass(frozen=True)
class Baseline:
    """The run's baseline law: its cycle time [s] and largest deflection over the limit."""

    law: str
    cycle_time_s: float
    deflection_ratio: float | None = None

    @property
    def name(self) -> str:
        return BASELINE_NAMES.get(self.law, f"the {self.law} law")

    @property
    def breaks_limit(self) -> bool:
        return self.deflection_ratio is not None and self.deflection_ratio > 1 + RATIO_TOL


@dataclass(frozen=True)
class Verdict:
    """The program to run (``law`` None, with ``reason``, when no law is exported).

    files : the controller files of the law (its exporters' summary entries), in
        :data:`PROGRAM_KEYS` order; empty while the exporters have not written them yet
    cycle_time_s, lower_bound_s : T and T* [s]; c2 : whether the law is C2
    baseline : the baseline law, None when the run has none
    """

    law: str | None
    files: tuple[str, ...] = ()
    cycle_time_s: float | None = None
    lower_bound_s: float | None = None
    c2: bool | None = None
    baseline: Baseline | None = None
    reason: str | None = None

    @property
    def time_over_lower_bound(self) -> float | None:
        """T / T*, None when either is unknown."""
        if self.cycle_time_s is None or not self.lower_bound_s:
            return None
        return self.cycle_time_s / self.lower_bound_s

    @property
    def saving(self) -> float | None:
        """(T(baseline) - T) / T(baseline): > 0 when the law is faster than the baseline."""
        if self.cycle_time_s is None or self.baseline is None or not self.baseline.cycle_time_s:
            return None
        return 1.0 - self.cycle_time_s / self.baseline.cycle_time_s


def _laws(summary: Mapping) -> Mapping:
    laws = summary.get("laws") if isinstance(summary, Mapping) else None
    if not isinstance(laws, Mapping) or not laws:
        raise InputError("summary: a verdict needs a non-empty 'laws' object (one entry per "
                         "timing law, as `feedopt run` writes summary.json)")
    return laws


def _number(value) -> float | None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    return float(value) if ok else None


def deflection_ratio(summary: Mapping, law: str) -> float | None:
    """``laws[law].deflection_ratio`` if given, else max deflection / scenario limit."""
    row = _laws(summary)[law]
    if _number(row.get("deflection_ratio")) is not None:
        return float(row["deflection_ratio"])
    limit = _number((summary.get("scenario") or {}).get("deflection_limit_mm"))
    peak = _number(row.get("max_deflection_mm"))
    return None if peak is None or not limit else peak / limit


def baseline_law(summary: Mapping) -> str | None:
    """The run's baseline law (:data:`BASELINE_LAWS`, first present), or None."""
    return next((b for b in BASELINE_LAWS if b in _laws(summary)), None)


def baseline(summary: Mapping) -> Baseline | None:
    """The :class:`Baseline` of the run, None without one (or without its cycle time)."""
    law = baseline_law(summary)
    time = None if law is None else _number(_laws(summary)[law].get("cycle_time_s"))
    return None if time is None else Baseline(law, time, deflection_ratio(summary, law))


def program_files(row: Mapping) -> tuple[str, ...]:
    """The controller files a law's exporters wrote (:data:`PROGRAM_KEYS`, then any other
    ``*_program`` entry), without repeats."""
    keys = [*PROGRAM_KEYS, *(k for k in row if k.endswith("_program") and k not in PROGRAM_KEYS)]
    files = [row[k] for k in keys if isinstance(row.get(k), str) and row[k]]
    return tuple(dict.fromkeys(files))


def program_law(summary: Mapping) -> str | None:
    """The fastest law that is verified and exported (file order breaks ties), or None."""
    laws = _laws(summary)
    ready = [(t, i, law) for i, (law, row) in enumerate(laws.items())
             if isinstance(row, Mapping) and row.get("verified") is True
             and row.get("exported") is True
             and (t := _number(row.get("cycle_time_s"))) is not None]
    return min(ready)[2] if ready else None


def _why_not(row) -> str:
    """Why one law is not the program to run."""
    if not isinstance(row, Mapping):
        return "no entry"
    if row.get("verified") is not True:
        problems = [str(p) for p in row.get("problems") or []]
        return "not verified" + (f": {'; '.join(problems)}" if problems else "")
    if row.get("exported") is None:
        return "no export verdict in summary.json (written by an older feedopt)"
    if row.get("exported") is False:
        blockers = [str(b) for b in row.get("export_blockers") or []]
        return "not exported" + (f": {'; '.join(blockers)}" if blockers else "")
    return "no cycle time"


def no_program_reason(summary: Mapping) -> str:
    """Why no law is the program to run: each law's reason."""
    reasons = "; ".join(f"{law}: {_why_not(row)}" for law, row in _laws(summary).items())
    return f"no law is both verified and exported ({reasons})"


def verdict(summary: Mapping) -> Verdict:
    """The :class:`Verdict` of a run from its ``summary.json`` content.

    Raises :class:`~feedopt.errors.InputError` when ``summary`` has no ``laws``.
    """
    law = program_law(summary)
    base = baseline(summary)
    if law is None:
        return Verdict(None, baseline=base, reason=no_program_reason(summary))
    row = _laws(summary)[law]
    bound = _number(row.get("lower_bound_s"))
    if bound is None:
        bound = _number((summary.get("scenario") or {}).get("lower_bound_s"))
    c2 = row.get("c2") if isinstance(row.get("c2"), bool) else None
    return Verdict(law, program_files(row), _number(row["cycle_time_s"]), bound, c2, base)


def _seconds(t: float) -> str:
    return f"{t:.1f} s" if t >= 10 else f"{t:.3g} s"


def _against_baseline(v: Verdict) -> str:
    """``20.2 % faster than the programmed feed (183.0 s)``, and whether that one breaks
    the limit; empty without a baseline."""
    base, saving = v.baseline, v.saving
    if base is None or saving is None:
        return ""
    if base.law == v.law:
        return f"it is {base.name} itself"
    if abs(saving) < 5e-4:
        out = f"as fast as {base.name}"
    else:
        word = "faster" if saving > 0 else "longer"
        out = f"{abs(saving) * 100:.1f} % {word} than {base.name}"
    if base.breaks_limit:  # said inside the parentheses: it is the baseline that breaks it
        return out + (f" ({_seconds(base.cycle_time_s)}, over the deflection limit: "
                      f"{base.deflection_ratio:.2f} x)")
    return out + f" ({_seconds(base.cycle_time_s)})"


def verdict_line(v: Verdict) -> str:
    """The one line on top of the report, e.g. ``Run convex (convex.csv): verified, C2,
    146.0 s = 1.001 T*, 20.2 % faster than the programmed feed (183.0 s).``"""
    if v.law is None:
        return f"No program to run: {v.reason}."
    files = f" ({', '.join(v.files)})" if v.files else ""
    parts = ["verified"]
    if v.c2 is not None:
        parts.append("C2" if v.c2 else "not C2")
    if v.cycle_time_s is not None:
        ratio = v.time_over_lower_bound
        parts.append(_seconds(v.cycle_time_s) + ("" if ratio is None else f" = {ratio:.3f} T*"))
    against = _against_baseline(v)
    if against:
        parts.append(against)
    return f"Run {v.law}{files}: {', '.join(parts)}."


def _place(place) -> str | None:
    """``line 118 (N1030), s = 1794.9 mm`` from a summary place (``worst_deflection``,
    ``program.lowest_bound``), or None."""
    if not isinstance(place, Mapping) or _number(place.get("s_mm")) is None:
        return None
    label = place.get("label")
    return (f"{label}, " if label else "") + f"s = {float(place['s_mm']):.1f} mm"


def _active(scenario: Mapping) -> str:
    """``deflection on 67 % of the path, max feed on 33 %`` from ``active_constraints``."""
    active = scenario.get("active_constraints")
    if not isinstance(active, Mapping):
        return ""
    shares = sorted(((float(f), str(k)) for k, f in active.items()
                     if _number(f) is not None and float(f) >= 0.005), reverse=True)
    named = [f"{k.replace('_', ' ')} on {f * 100:.0f} %" for f, k in shares]
    return (named[0] + " of the path" + "".join(f", {n}" for n in named[1:])) if named else ""


def where_line(summary: Mapping, law: str | None) -> str | None:
    """Where the feed drops and why: what bounds the feed along the path, where the bound
    is lowest (program line) and where ``law`` deflects most; None when nothing is known."""
    sc = summary.get("scenario") if isinstance(summary.get("scenario"), Mapping) else {}
    parts = []
    active = _active(sc)
    if active:
        parts.append(f"The feed bound is set by {active}")
    low = (sc.get("program") or {}).get("lowest_bound") if isinstance(
        sc.get("program"), Mapping) else None
    at = _place(low)
    if at is not None and _number(low.get("v_max_mm_s")) is not None:
        parts.append(f"it is lowest at {at} ({float(low['v_max_mm_s']):.3g} mm/s)")
    row = _laws(summary).get(law) if law is not None else None
    worst = _place(row.get("worst_deflection")) if isinstance(row, Mapping) else None
    peak = None if row is None else _number(row.get("max_deflection_mm"))
    if worst is not None and peak is not None:
        parts.append(f"{law} deflects most ({peak:.3f} mm) at {worst}")
    if not parts:
        return None
    return "; ".join(parts) + "."


_PLACEHOLDER = ("placeholder",)
_UNMODELLED = ("no force model", "not deflection-limited", "not in the move list",
               "does not describe", "feeds there are approximate", "is not modelled")
_EXTRAPOLATED = ("extrapolat",)


def classify_warning(text: str) -> CheckKind | None:
    """The :class:`CheckKind` of a run warning, None when it is not a check before cutting."""
    low = text.lower()
    for kind, needles in ((CheckKind.PLACEHOLDER, _PLACEHOLDER),
                          (CheckKind.UNMODELLED, _UNMODELLED),
                          (CheckKind.EXTRAPOLATED, _EXTRAPOLATED)):
        if any(n in low for n in needles):
            return kind
    return None


def _strings(value) -> list[str]:
    if isinstance(value, str):
        return [value] if value.strip() else []
    if not isinstance(value, (list, tuple)):
        return []
    return [str(x) for x in value if str(x).strip()]


def _scenario_checks(sc: Mapping, warned: list[Check]) -> list[Check]:
    """Checks the scenario section states outside the warnings: extrapolated coefficients,
    plunges without a force model (when no warning already says so)."""
    out = []
    material = sc.get("material") if isinstance(sc.get("material"), Mapping) else {}
    if material.get("coefficients_at_rpm") == "extrapolated":
        rpm = (sc.get("cut") or {}).get("rpm") if isinstance(sc.get("cut"), Mapping) else None
        speeds = ", ".join(f"{float(r):g}" for r in material.get("calibrated_rpm") or [])
        out.append(Check(CheckKind.EXTRAPOLATED, f"cutting coefficients at {rpm} rpm are "
                         f"extrapolated (calibrated at {speeds or 'unknown'} rpm)"))
    program = sc.get("program") if isinstance(sc.get("program"), Mapping) else {}
    plunges = [p.get("label") for p in program.get("unmodelled_plunges") or []
               if isinstance(p, Mapping)]
    said = any("plunge" in c.text for c in warned if c.kind is CheckKind.UNMODELLED)
    if plunges and not said:
        out.append(Check(CheckKind.UNMODELLED, f"{len(plunges)} plunge(s) into material have "
                         f"no force model ({', '.join(map(str, plunges[:10]))})"))
    return out


def checks_before_cutting(summary: Mapping) -> list[Check]:
    """What to confirm before cutting, from ``summary.json``'s content: placeholder inputs,
    fitted inputs, extrapolated coefficients, moves the model does not cover, and laws that
    failed verification, in that order (each kind in summary order)."""
    sc = summary.get("scenario") if isinstance(summary.get("scenario"), Mapping) else {}
    warned = [Check(kind, w) for w in _strings(summary.get("warnings"))
              if (kind := classify_warning(w)) is not None]
    found = [*warned, *(Check(CheckKind.FIT, f) for f in _strings(sc.get("fits"))),
             *_scenario_checks(sc, warned)]
    for law, row in _laws(summary).items():
        if isinstance(row, Mapping) and row.get("verified") is False:
            found.append(Check(CheckKind.UNVERIFIED, f"{law}: {_why_not(row)}"))
    order = list(CheckKind)
    return sorted(found, key=lambda c: order.index(c.kind))  # stable: summary order kept


CHECKS_TITLE = "Check before cutting"


def _md(text: str) -> str:
    """Summary text for report.md: an HTML comment opener cannot end the verdict block."""
    return text.replace("<!--", "&lt;!--")


def verdict_markdown(summary: Mapping) -> str:
    """The verdict block of report.md (between :data:`BEGIN` and :data:`END`)."""
    v = verdict(summary)
    lines = [BEGIN, f"**{_md(verdict_line(v))}**", ""]
    where = where_line(summary, v.law)
    if where:
        lines += [_md(where), ""]
    checks = checks_before_cutting(summary)
    if checks:
        lines += [f"**{CHECKS_TITLE}:**", "",
                  *(f"- *{c.kind.value}*: {_md(c.text)}" for c in checks), ""]
    return "\n".join([*lines, END])


def verdict_html(summary: Mapping) -> str:
    """The verdict block of report.html (between :data:`BEGIN` and :data:`END`)."""
    esc = html.escape
    v = verdict(summary)
    state = "none" if v.law is None else "ok"
    out = [BEGIN, f'<section id="verdict" class="verdict {state}">',
           f'<p class="verdict-line">{esc(verdict_line(v))}</p>']
    where = where_line(summary, v.law)
    if where:
        out.append(f'<p class="where">{esc(where)}</p>')
    out.append("</section>")
    checks = checks_before_cutting(summary)
    if checks:
        out += [f'<section id="checks"><h2>{CHECKS_TITLE}</h2>', '<ul class="checks">',
                *(f'<li><span class="kind">{esc(c.kind.value)}</span> {esc(c.text)}</li>'
                  for c in checks), "</ul></section>"]
    return "\n".join([*out, END])


def write_atomic(path: Path, payload: bytes) -> None:
    """Write ``payload`` to ``path`` through a temporary name (no half-written file)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(payload)
    os.replace(tmp, path)


def _replace_block(text: str, block: str) -> str | None:
    """``text`` with its verdict block replaced by ``block``; None when it has none."""
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < i:
        return None
    return text[:i] + block + text[j + len(END):]


def refresh_report_verdict(out_dir: str | Path, summary: Mapping) -> list[Path]:
    """Render the verdict block of ``report.md`` / ``report.html`` in ``out_dir`` again from
    ``summary`` (the report is drawn while the exporters write: their file names come
    after). Files without the block, or missing, are left alone; returns those rewritten."""
    out = Path(out_dir)
    done = []
    for name, render in (("report.md", verdict_markdown), ("report.html", verdict_html)):
        path = out / name
        if not path.is_file():
            continue
        text = path.read_text(encoding="utf-8")
        new = _replace_block(text, render(summary))
        if new is not None and new != text:
            write_atomic(path, new.encode("utf-8"))
            done.append(path)
    return done
