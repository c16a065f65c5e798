"""Where jobs run: one after the other in this process, or in a pool of worker processes.

Each executor takes the planned jobs and returns their results in input order, so outputs and
logs do not depend on how the jobs ran. Other executors (a cluster of machines) take the same
arguments.
"""

from __future__ import annotations

from aldpat import interrupt
from aldpat.core.workers import WorkerPool
from aldpat.jobs.context import JobResult
from aldpat.jobs.execute import Progress, doing, execute, job_name, report_result
from aldpat.jobs.resolve import ResolvedRun
from aldpat.jobs.task import Task


def run_in_this_process(task: Task, jobs: list[list[str]], run: ResolvedRun, command: str,
                        results: list[JobResult], progress: Progress | None) -> None:
    """Run ``jobs`` one after the other here."""
    start = len(results)  # the run's results may hold a first pass's failures
    for job in jobs:
        with interrupt.doing(doing(task, run, len(results) - start, len(jobs))):
            results.append(execute(task, job, run, command))
        report_result(results[-1], progress)


def run_in_processes(task: Task, jobs: list[list[str]], run: ResolvedRun, command: str, workers: int,
                     results: list[JobResult], progress: Progress | None) -> None:
    """Run ``jobs`` in ``workers`` processes, collecting results in input order.

    On an interruption the queued jobs are cancelled and the running ones are ended with
    SIGTERM, which each worker turns into a clean exit that removes its temporary files
    (:mod:`aldpat.core.workers`).
    """
    pool = WorkerPool(workers)
    try:
        futures = pool.submit_all(execute, [(task, job, run, command) for job in jobs])
        start = len(results)  # the run's results may hold a first pass's failures
        for job, fut in zip(jobs, futures, strict=False):  # in input order, so output and logs do not depend on -j
            def state(done: int = len(results) - start) -> str:
                # the pool counts as running the jobs it has queued for its workers too; they take
                # them in order, so the first ``workers`` are those at work
                running = [job_name(task, j) for j, f in zip(jobs, futures, strict=False) if f.running()][:workers]
                return doing(task, run, done, len(jobs), f"; running: {', '.join(running)}")

            with interrupt.doing(state):
                try:
                    results.append(fut.result())
                except Exception as exc:  # noqa: BLE001  (a worker died, killed or out of memory: that job failed)
                    results.append(JobResult(inputs=job, error=f"{job_name(task, job)}: worker process "
                                                               f"failed: {type(exc).__name__}: {exc}"))
            report_result(results[-1], progress)
    except BaseException:
        pool.stop()
        raise
    pool.close()
