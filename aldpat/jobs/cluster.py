"""Where jobs run when they leave this machine: a Dask distributed cluster.

``--scheduler tcp://host:8786`` (or the environment variable ``ALDPAT_SCHEDULER``) sends every
job -- one input, one tile with its neighbours -- to the workers of a running Dask scheduler;
``--scheduler local:N`` starts a ``LocalCluster`` of N single-threaded worker processes on this
machine for the run (and keeps it for the next jobs of a worksheet). ``dask[distributed]`` is the
optional extra ``aldpat[dask]``, imported only here.

Trust: Dask's protocol is pickle, so the scheduler and its workers can run any code in this
process (and this process's jobs run on them). Which scheduler to trust is therefore the user's
choice alone, made on the command line or in the environment: a worksheet or a parameter file
(data, possibly mailed by someone else) may name ``local``, ``local:N`` or ``none`` -- they
connect nowhere and start only this machine's own aldpat -- but an address there is refused
unless the same address was given on the command line or in ``$ALDPAT_SCHEDULER``
(:func:`scheduler_for`). Connections use the TLS security of Dask's configuration
(``distributed.comm.tls.*``: a ``tls://`` address needs it), as ``dask worker`` does; a local
cluster listens on the loopback interface only.

The workers must see the inputs and outputs under the same paths as this process (a shared file
system: the usual deployment); each job runs in the folder the command was started from, so
relative paths mean the same on every worker. Results come back in input order, as with ``-j``,
so outputs and logs are those of ``-j 1``. A worker lost mid-job: the scheduler gives the job to
another worker (Dask reschedules the tasks of a lost worker); the lost writer's temporary file is
removed at the end of the run, and no output is ever half-written (``aldpat.io.atomic``).
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import logging
import os
import threading
import uuid
from pathlib import Path
from typing import Any

from aldpat import interrupt
from aldpat.core.threads import ENV as THREADS_ENV
from aldpat.core.threads import share_for
from aldpat.core.units import TOPIC as UNITS_TOPIC
from aldpat.errors import ParamError, UsageError
from aldpat.io.atomic import remove_stale_temporaries_in
from aldpat.jobs.context import JobResult
from aldpat.jobs.execute import Progress, doing, execute, job_name, report_result
from aldpat.jobs.resolve import ResolvedRun
from aldpat.jobs.task import Task
from aldpat.options import LOCAL_SCHEDULER, NO_SCHEDULER, check_scheduler

log = logging.getLogger(__name__)

ENV = "ALDPAT_SCHEDULER"


#: where a run's parameters may come from without the user having typed them -- a worksheet and
#: the parameter files it or a command names (:data:`aldpat.params.SOURCES`) -- as a message says them
UNTRUSTED_SOURCES = {"settings": "the worksheet's [settings]", "params file": "a parameter file",
                     "worksheet": "the worksheet"}


def scheduler_for(given: str | None, source: str = "cli") -> str | None:
    """The scheduler a run uses: the option's, else ``$ALDPAT_SCHEDULER``; ``none`` means none.

    ``source`` says where ``given`` came from: an address from a worksheet or a parameter file
    (:data:`UNTRUSTED_SOURCES`) is refused unless the user gave the same address on the command
    line or in ``$ALDPAT_SCHEDULER``: whoever runs the scheduler can run code in this process."""
    from_env = os.environ.get(ENV) or None
    value = given if given is not None else from_env
    if value is None or value.lower() in NO_SCHEDULER:
        return None
    try:
        check_scheduler(value)
    except ParamError as exc:
        raise UsageError(f"{exc} (from ${ENV})" if given is None else str(exc)) from None
    if given is not None and source in UNTRUSTED_SOURCES and not LOCAL_SCHEDULER.match(value) \
            and value != from_env:
        raise UsageError(f"scheduler: {value!r} comes from {UNTRUSTED_SOURCES[source]}; "
                         "a Dask scheduler and its workers can run code in this process, so only the command "
                         f"line (--scheduler {value}) or ${ENV} may choose one")
    return value
def _distributed() -> Any:
    try:
        return importlib.import_module("distributed")
    except ImportError:
        raise UsageError("--scheduler needs Dask's distributed scheduler: pip install 'aldpat[dask]'") from None


#: Dask's own log lines below this level are not shown: its INFO lines (workers joining and
#: leaving, a connection closed as a stopped run's workers end, with its traceback) are not news
#: to the user, who reads aldpat's own lines; its warnings (a worker over its memory) are.
DASK_LOG_LEVEL = logging.WARNING

_clients: dict[str, Any] = {}
_clients_lock = threading.Lock()


def client_for(scheduler: str) -> Any:
    """A client of ``scheduler``, made once per process and closed at exit (a worksheet's jobs
    share it, and a ``local:N`` cluster is started once)."""
    with _clients_lock:
        client = _clients.get(scheduler)
        if client is not None and client.status == "running":
            return client
        distributed = _distributed()
        logging.getLogger("distributed").setLevel(DASK_LOG_LEVEL)
        # Dask closes its clusters at exit too, with its logging as it was: ours must run first
        # (exit functions run last registered first), lest an interrupted run's workers, busy in
        # compiled code, be killed with a line each ("still alive after 4.0 seconds, killing")
        atexit.unregister(_close_clients)
        atexit.register(_close_clients)
        m = LOCAL_SCHEDULER.match(scheduler)
        if m:
            workers = int(m.group(1) or os.cpu_count() or 1)
            # the worker processes inherit the environment: each takes its part of the cores
            _worker_environment()
            before = os.environ.get(THREADS_ENV)
            os.environ[THREADS_ENV] = str(share_for(workers))
            try:
                # loopback only: the workers of a local cluster take jobs from this process alone;
                # Ctrl-C reaches every process of the command: the workers leave it to this one
                with interrupt.ignored_by_new_processes():
                    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                       host="127.0.0.1", dashboard_address="127.0.0.1:0")
            finally:
                if before is None:
                    os.environ.pop(THREADS_ENV, None)
                else:
                    os.environ[THREADS_ENV] = before
            client = distributed.Client(cluster)
            from aldpat.jobs.worker_logging import LocalWorkerLogging

            client.register_plugin(LocalWorkerLogging())  # the scheduler's going away at the end is not news
        else:
            security = _security(distributed, scheduler)
            try:
                client = distributed.Client(scheduler, timeout="20s", security=security)
            except OSError as exc:
                raise UsageError(f"scheduler {scheduler}: cannot connect: {exc}") from None
        _clients[scheduler] = client
        log.info("dask scheduler %s: dashboard %s", scheduler, client.dashboard_link)
        return client


def _security(distributed: Any, scheduler: str) -> Any:
    """The TLS settings of Dask's configuration (``distributed.comm.tls.*``, as ``dask worker``
    reads them); a ``tls://`` address without them is refused before connecting."""
    security = distributed.Security()  # from dask.config
    if scheduler.startswith("tls://") and not security.tls_ca_file:
        raise UsageError(f"scheduler {scheduler}: tls:// needs Dask's TLS settings: distributed.comm.tls.ca-file "
                         "(the authority that signed the scheduler's certificate), and .client.cert and .client.key, "
                         "in the Dask configuration or DASK_DISTRIBUTED__COMM__TLS__* variables")
    return security


def _worker_environment() -> None:
    """What Dask's local workers find in their environment as they start.

    Dask starts them with glibc's trim threshold at 64 kB, so that they hand memory back at once;
    the filters allocate and free large arrays all the time, and at that setting a worksheet of 16
    tiles took 1.56 times its ``-j 1`` time on ``local:2``, and 1.07 times without it
    (``bench/bench_chunks.py tiles``): the workers keep the C library's own threshold. And their
    Dask logging starts at warnings (:data:`DASK_LOG_LEVEL`): a worker reads its logging settings
    as it imports Dask, before the cluster's configuration reaches it."""
    import dask

    environ = dask.config.get("distributed.nanny.pre-spawn-environ", default={})
    environ = {k: v for k, v in environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    environ["DASK_LOGGING__DISTRIBUTED"] = logging.getLevelName(DASK_LOG_LEVEL).lower()
    dask.config.set({"distributed.nanny.pre-spawn-environ": environ})


@atexit.register
def _close_clients() -> None:
    # the run is over: what the scheduler says of workers leaving is not news to the user
    logging.getLogger("distributed").setLevel(logging.ERROR)
    try:
        for client in list(_clients.values()):
            with contextlib.suppress(Exception):
                cluster = client.cluster
                client.close()
                if cluster is not None:
                    cluster.close()
    except interrupt.Interrupted:
        # a signal while the cluster closes, the run's own lines said: no traceback of the closing;
        # the local workers, this process's daemonic children, end with it
        pass
    _clients.clear()
    # the local workers are gone now, with them any writer an interruption left mid-write
    for folder in _output_folders:
        with contextlib.suppress(OSError, interrupt.Interrupted):
            remove_stale_temporaries_in(folder)


def _execute_in_folder(folder: str, task: Task, sources: list[str], run: ResolvedRun, command: str) -> JobResult:
    """:func:`execute` on a worker, in the folder the command was started from."""
    if os.getcwd() != folder:
        os.chdir(folder)
    return execute(task, sources, run, command)


def run_on_cluster(task: Task, jobs: list[list[str]], run: ResolvedRun, command: str, scheduler: str,
                   results: list[JobResult], progress: Progress | None) -> None:
    """Run ``jobs`` on the cluster, collecting results in input order."""
    client = client_for(scheduler)
    folder = os.getcwd()
    tag = uuid.uuid4().hex[:8]
    keys = [f"aldpat-{task.key.replace(' ', '-')}-{k}-{tag}" for k in range(len(jobs))]
    heard = _hear_units(client, set(keys), progress) if progress is not None else None
    futures = [client.submit(_execute_in_folder, folder, task, job, run, command, pure=False, key=key)
               for key, job in zip(keys, jobs, strict=False)]
    start = len(results)  # the run's results may hold a first pass's failures
    try:
        for job, fut in zip(jobs, futures, strict=False):
            def state(done: int = len(results) - start) -> str:
                return doing(task, run, done, len(jobs), f" on {scheduler}")

            with interrupt.doing(state):
                try:
                    results.append(fut.result())
                except Exception as exc:  # noqa: BLE001  (the unit failed on every worker it was given to)
                    results.append(JobResult(inputs=job, error=f"{job_name(task, job)}: cluster worker failed: "
                                                               f"{type(exc).__name__}: {exc}"))
            report_result(results[-1], progress)
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        raise
    finally:
        if heard is not None:
            heard.close(client)
        for fut in futures:  # the results are here: the cluster need not keep them
            fut.release()
        _remove_lost_writers_files(results, run)


class _Units:
    """Counts on ``progress`` the units (chunks) the jobs ``keys`` of this run tell of from the
    workers (:mod:`aldpat.core.units`); other runs on the same cluster are not counted."""

    def __init__(self, keys: set[str], progress: Progress):
        self.keys, self.progress = keys, progress
        self.open = 0  # units planned and not yet finished
        self.changed = threading.Condition()

    def __call__(self, event: tuple[float, dict]) -> None:
        message = event[1]
        if message.get("job") not in self.keys:
            return
        n = int(message["n"])
        self.progress.units(message["kind"], n)
        with self.changed:
            self.open += n if message["kind"] == "planned" else -n
            self.changed.notify_all()

    def close(self, client: Any, wait: float = 2.0) -> None:
        """Stop listening, once the events still on their way (they travel apart from the jobs'
        results) have come, or after ``wait`` seconds."""
        with self.changed:
            self.changed.wait_for(lambda: self.open <= 0, timeout=wait)
        with contextlib.suppress(Exception):
            client.unsubscribe_topic(UNITS_TOPIC)


def _hear_units(client: Any, keys: set[str], progress: Progress) -> _Units:
    heard = _Units(keys, progress)
    client.subscribe_topic(UNITS_TOPIC, heard)
    return heard


#: output folders of the runs on a cluster, swept again when its local workers have been closed
_output_folders: set[Path] = set()


def _remove_lost_writers_files(results: list[JobResult], run: ResolvedRun) -> None:
    """Temporary files of writers that are gone (a worker killed mid-write) in the output folders."""
    folders = {Path(w.path).parent for r in results for w in r.outputs}
    odir = getattr(run.output.values, "odir", None) if run.output is not None else None
    if odir:
        folders.add(Path(odir))
    _output_folders.update(folders)
    for folder in folders:
        with contextlib.suppress(OSError):
            remove_stale_temporaries_in(folder)
