"""What the workers of aldpat's own local Dask cluster log: not the run's own ending.

When a ``local:N`` cluster closes at the end of a run, a worker's heartbeat already on its way
to the scheduler can find the connection closed; Dask then logs "Failed to communicate with
scheduler during heartbeat" at ERROR with a traceback, on the user's terminal, after the run's
own closing lines (an open race in Dask's local clusters). And when a run is interrupted, aldpat
cancels the jobs still on the workers, each of which then logs "Async instruction for <Task
cancelled ...> ended with CancelledError" at WARNING, after the one line aldpat prints. On a
cluster aldpat started itself the scheduler lives in aldpat's own process, so the scheduler's
going away means the run is over, and a cancelled job means aldpat has already said why it
stopped: those records are dropped, and every other worker message (a worker over its memory)
passes as before. Imported only when a local cluster starts, since it needs Dask.
"""

from __future__ import annotations

import logging
from typing import Any

from distributed import WorkerPlugin

#: The start of a record dropped (``distributed.worker.Worker.heartbeat``'s message).
HEARTBEAT_LOST = "Failed to communicate with scheduler during heartbeat"
#: The start and end of the other (the worker state machine's, of a job aldpat cancelled).
CANCELLED_START, CANCELLED_END = "Async instruction for <Task cancelled", "ended with CancelledError"
#: The loggers they come from: a filter acts on the records of its own logger only.
LOGGERS = ("distributed.worker", "distributed.worker.state_machine")


class RunEndingRecords(logging.Filter):
    """Drops a worker's records of the run's own ending -- a heartbeat that met the closed
    scheduler, a job aldpat cancelled -- and only those."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message.startswith(HEARTBEAT_LOST):
            return False
        return not (message.startswith(CANCELLED_START) and message.endswith(CANCELLED_END))


class LocalWorkerLogging(WorkerPlugin):
    """Installs :class:`RunEndingRecords` on the worker's loggers in each worker process."""

    name = "aldpat-local-worker-logging"

    def setup(self, worker: Any) -> None:
        for name in LOGGERS:
            logger = logging.getLogger(name)
            if not any(isinstance(f, RunEndingRecords) for f in logger.filters):
                logger.addFilter(RunEndingRecords())
