"""One ``aldpat run`` per worksheet at a time.

Two runs of one worksheet at once -- a ``--resume`` started while the first still runs -- took
each other's running jobs for killed ones and ran them again over each other's outputs. A run
therefore holds ``<worksheet-stem>.lock`` beside the worksheet while it runs: created atomically
(``O_CREAT | O_EXCL``, never through a link), holding the holder's process id, its start time as
the system keeps it, the host and when the run began. A second run is refused with one line
naming the holder. A lock whose holder is gone (killed, the machine rebooted) is taken over: on
the same host a process that no longer exists -- or a process id now reused by another process,
told apart by its start time -- is no holder. A lock held from another host cannot be judged
from here: it is refused, saying which host holds it (remove the file if that run is over).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import socket
import time
import uuid
from pathlib import Path
from typing import Self

from aldpat.errors import AldpatError, OutputError
from aldpat.io.atomic import process_alive, process_started
from aldpat.io.sidefiles import own_place


class WorksheetBusy(AldpatError):
    """Another run holds the worksheet (exit status 1: nothing was run)."""


#: what a lock aldpat wrote begins with
MARK = re.compile(rb'\A\{"aldpat": "worksheet lock"')


def lock_path(worksheet: Path) -> Path:
    return own_place(worksheet.with_name(worksheet.stem + ".lock"), MARK)[0]


class WorksheetLock:
    """``with WorksheetLock(worksheet_path):`` -- held for the block, released however it ends."""

    def __init__(self, worksheet: Path, command: str = "aldpat run"):
        self.worksheet = Path(worksheet)
        self.path = lock_path(self.worksheet)
        self.token = uuid.uuid4().hex
        self.record = {"aldpat": "worksheet lock", "pid": os.getpid(), "started": process_started(os.getpid()),
                       "host": socket.gethostname(), "since": time.strftime("%Y-%m-%d %H:%M:%S"),
                       "command": command, "token": self.token}

    def __enter__(self) -> Self:
        for _ in range(8):  # a lock taken over between two tries: try again
            if self._create():
                return self
            holder = self._holder()
            if holder is None:
                continue  # gone between the two looks
            if self._holder_alive(holder):
                raise WorksheetBusy(f"is being run by process {holder.get('pid')} on {holder.get('host')} since "
                                    f"{holder.get('since')} ({self.path.name}); wait for that run to end, or remove "
                                    f"{self.path.name} if it has", path=self.worksheet)
            self._take_over(holder)
        raise WorksheetBusy(f"cannot take the lock {self.path.name}: other runs keep taking it", path=self.worksheet)

    def __exit__(self, *exc: object) -> None:
        holder = self._holder()
        if holder is not None and holder.get("token") == self.token:
            with contextlib.suppress(OSError):
                os.unlink(self.path)

    def _create(self) -> bool:
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
        try:
            fd = os.open(self.path, flags, 0o644)
        except FileExistsError:
            return False
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                return False
            raise OutputError(f"cannot create the lock {self.path.name}: {(exc.strerror or str(exc)).lower()}",
                             path=self.worksheet.parent) from None
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(json.dumps(self.record) + "\n")
        return True

    def _holder(self) -> dict | None:
        try:
            with open(self.path, encoding="utf-8") as fh:
                return json.loads(fh.read(4096))
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}  # unreadable or half-written: its holder is judged gone only by its age below

    def _holder_alive(self, holder: dict) -> bool:
        if not holder:  # a lock being written this very instant, or garbage: alive unless old
            try:
                return time.time() - os.lstat(self.path).st_mtime < 60
            except OSError:
                return False
        if holder.get("host") != socket.gethostname():
            return True  # another machine's process: cannot be judged from here
        pid = holder.get("pid")
        if not isinstance(pid, int) or not process_alive(pid):
            return False
        started = holder.get("started")
        return started is None or process_started(pid) in (None, started)  # same pid, not a reused one

    def _take_over(self, dead: dict) -> None:
        """Move the dead holder's lock aside (of two takers one wins the rename) and remove it;
        a lock that turns out to be another's, made after the dead one was judged, goes back."""
        stale = self.path.with_name(f"{self.path.name}.stale-{self.token}")
        try:
            os.rename(self.path, stale)
        except OSError:
            return
        try:
            with open(stale, encoding="utf-8") as fh:
                moved = json.loads(fh.read(4096))
        except (OSError, ValueError):
            moved = {}
        if moved != dead and moved:
            with contextlib.suppress(OSError):
                os.link(stale, self.path)  # back in place, unless yet another lock is there now
        with contextlib.suppress(OSError):
            os.unlink(stale)
