"""Reading ahead: the next chunk of a file read on a thread while the caller works on this one.

A task's passes over a LAS/LAZ file alternate reading (decompressing, scaling) and work on what
was read (gridding, classifying, writing); laspy and lazrs let go of the interpreter's lock while
they read, so reading the next chunk beside the work on the current one keeps the second core
busy. One chunk is read ahead at most, so memory holds one chunk more than it would.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from typing import TypeVar

T = TypeVar("T")

#: How long the reading thread waits for room before it looks again whether the reader left.
_WAIT = 0.1


class _Done:
    """What the reading thread puts last: the end of the chunks, or the error that ended them."""

    def __init__(self, error: BaseException | None = None) -> None:
        self.error = error


def read_ahead(chunks: Iterator[T]) -> Iterator[T]:
    """The items of ``chunks``, each produced on a thread while the one before is in use.

    An error raised while producing is raised here, where the item would have come, with its own
    type and message (a damaged chunk's line names its file as before). When the caller stops
    early -- it broke off, or an error or an interrupt ended its loop -- the thread finishes the
    item it is reading and stops: nothing is read after that, and the source is closed on the
    thread that read it.
    """
    handoff: queue.Queue[T | _Done] = queue.Queue(maxsize=1)
    left = threading.Event()

    def hand_over(item: T | _Done) -> bool:
        """Put ``item`` where the caller takes it; False when the caller has left instead."""
        while not left.is_set():
            try:
                handoff.put(item, timeout=_WAIT)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        end = _Done()
        try:
            for item in chunks:
                if not hand_over(item):
                    break
        except BaseException as exc:  # noqa: BLE001  (handed over whole to the caller's thread)
            end = _Done(exc)
        finally:
            close = getattr(chunks, "close", None)
            if close is not None:
                close()  # the source's own clean-up (its open file), on this thread
        hand_over(end)

    thread = threading.Thread(target=produce, name="aldpat-read-ahead", daemon=True)
    thread.start()
    try:
        while True:
            item = handoff.get()
            if isinstance(item, _Done):
                if item.error is not None:
                    raise item.error
                return
            yield item
    finally:
        left.set()
        thread.join()
