"""One grid point of a sweep: the pipeline without its exports, reduced to typed numbers.

:func:`evaluate_point` runs :func:`feedopt.runner.prepare` and
:func:`feedopt.runner.plan_and_verify` on the point's scenario and keeps what a placement or
parameter study compares: T*, each law's cycle time, verdict and replayed max deflection, the
max and mean deflection at the nominal feed, the worst Jacobian condition number and the
lowest feed bound. It never raises for a point: bad input at the point (an unreachable
placement, a joint limit, a value the schema refuses in combination) is a ``refused`` row
with the message, anything else an ``error`` row with the exception, so no point loses the
sweep.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from feedopt.errors import InputError
from feedopt.sweep.bundle import Bundle, materialise, scenario_at
from feedopt.sweep.grid import Axis, Number
from feedopt.units import MM
from feedopt.verify import Verdict

#: ``f(prepared, results) -> float``: an extra number per point (a column of the table).
Metric = Callable[..., float]


class Status(Enum):
    """What became of a point."""

    OK = "ok"  # planned (its laws may still have failed their verification: see feasible)
    REFUSED = "refused"  # bad input at this point: unreachable, joint limit, invalid value
    ERROR = "error"  # an internal error or a lost worker (retried when the sweep resumes)


#: Verdict of each law in the table: a verification verdict, or declined / not run.
VERDICT_TOKENS = {Verdict.EXPORTABLE: "exportable", Verdict.VERIFIED: "verified",
                  Verdict.FAILED: "failed"}
DECLINED = "declined"


@dataclass(frozen=True)
class LawOutcome:
    """One law at one point."""

    verdict: str  # a value of VERDICT_TOKENS or DECLINED
    cycle_time_s: float | None = None
    max_deflection_mm: float | None = None


@dataclass(frozen=True)
class PointSettings:
    """What every point runs: the laws, a sample spacing override and extra metrics."""

    laws: tuple[str, ...]
    spacing_mm: float | None = None
    extra: tuple[tuple[str, Metric], ...] = ()


@dataclass(frozen=True)
class PointResult:
    """The numbers of one point (SI-free: the units are in the names)."""

    values: tuple[Number, ...]
    status: Status
    reason: str = ""
    t_star_s: float | None = None
    max_deflection_nominal_mm: float | None = None
    mean_deflection_nominal_mm: float | None = None
    max_condition_number: float | None = None
    min_bound_mm_s: float | None = None
    samples: int | None = None
    laws: dict[str, LawOutcome] = field(default_factory=dict)
    extra: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def feasible(self) -> bool:
        """Planned, and no law broke a promise it makes."""
        return self.status is Status.OK and all(
            o.verdict != VERDICT_TOKENS[Verdict.FAILED] for o in self.laws.values())


def _quiet(_message: str) -> None:
    pass


def _one_line(text: str) -> str:
    return "; ".join(line.strip() for line in text.splitlines() if line.strip())


def nominal_feed(problem) -> np.ndarray:
    """The nominal feed at every sample [m/s]: a program's own feeds (0 on rapids, which do
    not cut), else the scenario's one nominal feed."""
    if problem.programmed_feed is not None:
        pf = problem.programmed_feed
        return np.where(np.isfinite(pf), pf, 0.0)
    return np.full(problem.n, problem.nominal_feed)


def _measure(values: tuple[Number, ...], prepared, results: dict, settings: PointSettings,
             t0: float) -> PointResult:
    problem = prepared.problem
    deflection = prepared.model.deflection(nominal_feed(problem))
    cutting = deflection[deflection > 0]
    laws: dict[str, LawOutcome] = {}
    for law in settings.laws:
        if law in results:
            ver = results[law].verification
            laws[law] = LawOutcome(VERDICT_TOKENS[ver.verdict], results[law].trajectory.duration,
                                   ver.max_deflection / MM)
        elif law in prepared.declined:
            laws[law] = LawOutcome(DECLINED)
    failed = [f"{law} failed its verification: {results[law].verification.problems[0]}"
              for law, o in laws.items() if o.verdict == VERDICT_TOKENS[Verdict.FAILED]
              and results[law].verification.problems]
    declined = [f"{law} declined: {why}" for law, why in prepared.declined.items()]
    extra = {name: float(metric(prepared, results)) for name, metric in settings.extra}
    return PointResult(
        values=values, status=Status.OK, reason=_one_line("; ".join(failed + declined)),
        t_star_s=problem.lower_bound_time(),
        max_deflection_nominal_mm=float(deflection.max()) / MM,
        mean_deflection_nominal_mm=float(cutting.mean()) / MM if cutting.size else 0.0,
        max_condition_number=prepared.along.max_condition_number,
        min_bound_mm_s=float(problem.v_max.min()) / MM, samples=problem.n, laws=laws,
        extra=extra, seconds=time.perf_counter() - t0)


def evaluate_point(bundle: Bundle, axes: Sequence[Axis], values: Sequence[Number],
                   settings: PointSettings) -> PointResult:
    """Plan and verify one grid point; never raises (a failure is a row with its reason).

    Parameters
    ----------
    bundle
        The scenario and its files (:func:`feedopt.sweep.bundle.build_bundle`).
    axes, values
        The grid's axes and this point's value on each.
    settings
        Laws to run, spacing override, extra metrics.
    """
    from feedopt.parallel import single_threaded_blas
    from feedopt.runner import plan_and_verify, prepare

    values = tuple(values)
    t0 = time.perf_counter()
    try:
        scenario, base = scenario_at(bundle, axes, values)
        with single_threaded_blas():  # the sweep's workers use the cores (feedopt.parallel)
            prepared = prepare(scenario, base, _quiet, spacing_mm=settings.spacing_mm)
            results = plan_and_verify(prepared, list(settings.laws), _quiet)
        if not results:
            raise InputError("no timing law planned this point: "
                             + "; ".join(prepared.declined.values()))
        return _measure(values, prepared, results, settings, t0)
    except InputError as exc:
        reason = bundle.readable(str(exc), materialise(bundle))
        return PointResult(values, Status.REFUSED, _one_line(reason),
                           seconds=time.perf_counter() - t0)
    except Exception as exc:  # noqa: BLE001 - a point's failure is a row, never a lost sweep
        return error_result(values, exc, time.perf_counter() - t0)


def error_result(values: Sequence[Number], exc: BaseException, seconds: float = 0.0
                 ) -> PointResult:
    """The row of a point whose evaluation crashed (or whose worker was lost)."""
    return PointResult(tuple(values), Status.ERROR,
                       _one_line(f"internal error: {type(exc).__name__}: {exc}"),
                       seconds=seconds)
