"""Run profiling: where a run's time goes (``feedopt run --profile``, benchmarks/bench_scale.py)
and progress bars for long stages."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Protocol

Progress = Callable[[str], None]


def stderr_progress(message: str) -> None:
    """The runner's console progress: each message on its own line of stderr."""
    print(message, file=sys.stderr, flush=True)


def is_console(progress: Progress) -> bool:
    """True for the runner's own console progress (bars are drawn only for it)."""
    return progress is stderr_progress


# A stage that runs longer than this [s] shows a progress bar (console runs on a terminal).
_BAR_DELAY_S = 2.0


@contextmanager
def progress_bar(progress: Progress, what: str, unit: str = " samples",
                 unit_scale: bool = True) -> Iterator[Callable[[int, int], None] | None]:
    """``update(done, total)`` drawing a tqdm bar on stderr for a long stage, or None.

    Only for the console's own progress (:func:`stderr_progress`) on a terminal: a caller
    with its own ``progress`` (tests, sweeps, benchmarks) or a redirected stderr gets no bar.
    The bar appears after :data:`_BAR_DELAY_S` and is removed when the stage ends (the
    stage's summary line follows).
    """
    if not is_console(progress) or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    bars = []

    def update(done: int, total: int) -> None:
        if not bars:
            bars.append(tqdm(total=total, desc=what, unit=unit, unit_scale=unit_scale,
                             file=sys.stderr, delay=_BAR_DELAY_S, leave=False,
                             dynamic_ncols=True))
        bar = bars[0]
        if bar.total != total:
            bar.total = total
            bar.refresh()
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        for bar in bars:
            bar.close()


@dataclass(frozen=True)
class StageTiming:
    """Wall time [s] of one stage of a run; ``law`` names the timing law for per-law stages
    (plan, verify, export), empty otherwise."""

    stage: str
    seconds: float
    law: str = ""


@dataclass(frozen=True)
class RunProfile:
    """Where a run's time went (``feedopt run --profile``, benchmarks/bench_scale.py).

    Attributes
    ----------
    rows : tuple of StageTiming
        Geometry, process, robot, bounds; plan, verify and export per law; report; other
        (loading the scenario, checking and moving the outputs).
    total_s : float
        Wall time of the whole run (:func:`run_scenario`) [s].
    peak_memory_bytes : int
        Peak resident memory of the process so far (``getrusage``).
    child_peak_memory_bytes : int
        Peak resident memory of the largest finished child process (the report's), which
        shares the parent's pages until it writes them, so the two overlap.
    samples : int
        Number of path samples.
    """

    rows: tuple[StageTiming, ...]
    total_s: float
    peak_memory_bytes: int
    samples: int
    child_peak_memory_bytes: int = 0

    def table(self) -> str:
        """The rows as a markdown table with each one's share of the total, then the total
        and the peak memory."""
        from feedopt.report.tables import markdown_table

        body = [[r.stage, r.law or "-", f"{r.seconds:.3f}",
                 f"{r.seconds / self.total_s:.1%}" if self.total_s > 0 else "-"]
                for r in self.rows]
        body.append(["total", "-", f"{self.total_s:.3f}", "100.0%"])
        headers = (("stage", False), ("law", False), ("time [s]", True), ("share", True))
        return (markdown_table(headers, body) + f"\n\n{self.samples} path samples; peak "
                f"memory {self.peak_memory_bytes / 2**20:.0f} MiB"
                + (f" (largest child process {self.child_peak_memory_bytes / 2**20:.0f} MiB)"
                   if self.child_peak_memory_bytes else ""))


def peak_memory_bytes(children: bool = False) -> int:
    """Peak resident memory of this process so far [bytes] (0 where unknown); with
    ``children``, of its largest finished child."""
    try:
        import resource
    except ImportError:  # not on this platform
        return 0
    who = resource.RUSAGE_CHILDREN if children else resource.RUSAGE_SELF
    peak = resource.getrusage(who).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)


class LawTimes(Protocol):
    """What :func:`run_profile` reads of a law's result (:class:`feedopt.run_data.LawResult`)."""

    planning_time: float
    verification_time: float


def run_profile(stage_times: Mapping[str, float], results: Mapping[str, LawTimes],
                output_times: Mapping[tuple[str, str], float], total: float,
                samples: int) -> RunProfile:
    """A run's stage and per-law times in pipeline order: the prepared stages, plan, verify
    and export per law, the report, and the rest of ``total`` [s] as "other"."""
    rows = [StageTiming(stage, t) for stage, t in stage_times.items()]
    for law, res in results.items():
        rows += [StageTiming("plan", res.planning_time, law),
                 StageTiming("verify", res.verification_time, law)]
        if ("export", law) in output_times:
            rows.append(StageTiming("export", output_times[("export", law)], law))
    if ("part", "") in output_times:  # the predicted part of every law
        rows.append(StageTiming("part", output_times[("part", "")]))
    if ("report", "") in output_times:
        rows.append(StageTiming("report", output_times[("report", "")]))
    rows.append(StageTiming("other", max(0.0, total - sum(r.seconds for r in rows))))
    return RunProfile(rows=tuple(rows), total_s=total, peak_memory_bytes=peak_memory_bytes(),
                      child_peak_memory_bytes=peak_memory_bytes(children=True),
                      samples=samples)
