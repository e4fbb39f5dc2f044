"""The planning stage of a run: every timing law planned on the prepared problem, then all of
them replayed in one pass (:func:`plan_and_verify`), and the law worker children that plan a
law with slow imports on another core (:func:`law_workers`)."""

from __future__ import annotations

import importlib
import time
from functools import partial

import numpy as np

from feedopt import background, outputs
from feedopt.errors import LawNotApplicable
from feedopt.profiling import Progress, progress_bar, stderr_progress
from feedopt.run_data import LawResult, Prepared
from feedopt.schedule.laws import LAWS, plan_law, planning_order
from feedopt.schedule.trajectory import Trajectory
from feedopt.units import MM
from feedopt.verify import Verdict, replay_all

__all__ = ["law_workers", "plan_and_verify", "plan_laws", "replay_laws"]

Workers = dict[str, background.Prestarted]


def plan_and_verify(
    prepared: Prepared, laws: list[str], progress: Progress = stderr_progress,
    workers: Workers | None = None,
) -> dict[str, LawResult]:
    """Run each timing law (registry order), then replay-verify all of them in one pass.

    A law with a child in ``workers`` (:func:`law_workers`, its slow imports done) is sent
    there and planned beside the laws planned here; its planning time is the child's own, so
    it overlaps theirs.
    """
    planned, planning_time = plan_laws(prepared, laws, progress, workers)
    results = replay_laws(prepared, planned, planning_time, progress)
    return {law: results[law] for law in laws if law in results}


def _declined(prepared: Prepared, law: str, exc: LawNotApplicable, progress: Progress) -> None:
    prepared.declined[law] = str(exc)
    progress(f"[5/5] {law}: declined: {exc}")


def plan_laws(prepared: Prepared, laws: list[str], progress: Progress,
              workers: Workers | None) -> tuple[dict[str, Trajectory], dict[str, float]]:
    """Each law's trajectory (registry order; a declined law is recorded in
    ``prepared.declined``) and its planning time [s]; a law with a worker is planned there."""
    context: dict[str, Trajectory] = {}
    planned: dict[str, Trajectory] = {}
    planning_time: dict[str, float] = {}
    options = prepared.scenario.schedule
    sent: Workers = {}
    order = planning_order(laws)
    workers = dict(workers or {})
    if prepared.problem.n > outputs.CHILD_COPY_MAX_SAMPLES:  # a copy would cost more than saved
        for worker in workers.values():
            worker.join(cancel=True)
        workers = {}
    with progress_bar(progress, "[5/5] planning", " laws", False) as bar:
        done = 0
        for law in order:
            worker = workers.pop(law, None)
            if worker is not None:
                worker.submit(_plan_law_timed, law, prepared.problem,
                              {k: context[k] for k in LAWS[law].uses_context if k in context},
                              options.options_for(law))
                sent[law] = worker
                continue
            t0 = time.perf_counter()
            try:
                planned[law] = plan_law(law, prepared.problem, context,
                                        options=options.options_for(law))
            except LawNotApplicable as exc:
                _declined(prepared, law, exc, progress)
            else:
                planning_time[law] = time.perf_counter() - t0
            done += 1
            if bar is not None:
                bar(done, len(order))
        for law, worker in sent.items():
            try:
                planned[law], planning_time[law] = worker.join(reraise=True)
            except LawNotApplicable as exc:
                _declined(prepared, law, exc, progress)
            else:
                context[law] = planned[law]
            done += 1
            if bar is not None:
                bar(done, len(order))
    return {law: planned[law] for law in order if law in planned}, planning_time


def replay_laws(prepared: Prepared, planned: dict[str, Trajectory],
                planning_time: dict[str, float], progress: Progress) -> dict[str, LawResult]:
    """Every planned trajectory replayed in one pass (:func:`feedopt.verify.replay_all`), its
    verdict reported."""
    results: dict[str, LawResult] = {}
    t_star = prepared.problem.lower_bound_time()
    with progress_bar(progress, "[5/5] replay") as bar:
        replayed = replay_all(planned, prepared.problem, prepared.model, prepared.limit, bar,
                              tolerances=(prepared.schedule.wall_limit,
                                          prepared.schedule.floor_limit))
    for law, (ver, dt_verify) in replayed.items():
        traj, dt = planned[law], planning_time[law]
        results[law] = LawResult(trajectory=traj, verification=ver, planning_time=dt,
                                 verification_time=dt_verify)
        status = ver.verdict.value
        if ver.verdict is Verdict.VERIFIED:
            status += ": " + "; ".join(ver.export_blockers)
        progress(f"[5/5] {law}: {traj.duration:.2f} s cycle ({traj.duration / t_star:.4f} T*), "
                 f"max deflection {ver.max_deflection / MM:.4f} mm ({ver.deflection_ratio:.4f} "
                 f"of limit), {status} ({dt:.2f} s)")
        if ver.surface is not None and np.isfinite(ver.tolerances).any():
            progress(f"      {law}: {ver.surface.describe()}")
        for problem in ver.problems:
            progress(f"      ! {law}: {problem}")
    return results


def _plan_law_timed(law: str, problem, context: dict[str, Trajectory], options
                    ) -> tuple[Trajectory, float]:
    """:func:`plan_law` in a law worker: the trajectory and the time it took [s]."""
    t0 = time.perf_counter()
    trajectory = plan_law(law, problem, dict(context), options=options)
    return trajectory, time.perf_counter() - t0


def _import_law(law: str) -> None:
    for name in (*LAWS[law].slow_imports, LAWS[law].module):
        importlib.import_module(name)


def law_workers(laws: list[str]) -> Workers:
    """A child per requested law with slow imports (:attr:`LawSpec.slow_imports`: cvxpy for
    ``convex``), forked now so that the imports happen on the other core while this one
    prepares; :func:`plan_and_verify` sends each its law. Empty where fork is unavailable."""
    if not background.fork_available():
        return {}
    return {law: background.prestart(partial(_import_law, law), f"planning {law}")
            for law in dict.fromkeys(laws) if law in LAWS and LAWS[law].slow_imports}
