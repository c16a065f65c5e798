"""What the workers of aldpat's own local Dask cluster log: not the scheduler's going away.

When a ``local:N`` cluster closes at the end of a run, a worker's heartbeat already on its way
to the scheduler can find the connection closed; Dask then logs "Failed to communicate with
scheduler during heartbeat" at ERROR with a traceback, on the user's terminal, after the run's
own closing lines (an open race in Dask's local clusters). On a cluster aldpat started itself
the scheduler lives in aldpat's own process, so its going away means the run is over or aldpat
has already said why it stopped: that one record is dropped, and every other worker message
passes as before. Imported only when a local cluster starts, since it needs Dask.
"""

from __future__ import annotations

import logging
from typing import Any

from distributed import WorkerPlugin

#: The start of the record dropped (``distributed.worker.Worker.heartbeat``'s message).
HEARTBEAT_LOST = "Failed to communicate with scheduler during heartbeat"


class NoHeartbeatLostRecord(logging.Filter):
    """Drops the worker's record of a heartbeat that met a closed scheduler, and only that."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(HEARTBEAT_LOST)


class LocalWorkerLogging(WorkerPlugin):
    """Installs :class:`NoHeartbeatLostRecord` on the worker's logger in each worker process."""

    name = "aldpat-local-worker-logging"

    def setup(self, worker: Any) -> None:
        logger = logging.getLogger("distributed.worker")
        if not any(isinstance(f, NoHeartbeatLostRecord) for f in logger.filters):
            logger.addFilter(NoHeartbeatLostRecord())
