"""Reading ahead and writing behind: a file's next chunk read, and its last one written, on a
thread while the caller works on this one.

A task's passes over a LAS/LAZ file alternate reading (decompressing, scaling), work on what
was read (gridding, classifying) and writing (packing records, compressing); laspy, lazrs and
numpy let go of the interpreter's lock while they read, pack and write, so reading the next chunk
and writing the last one beside the work on the current one keeps the second core busy. One chunk
is read ahead and one written behind at most, so memory holds two chunks more than it would.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from typing import Self, TypeVar

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


class WriteBehind:
    """Writes done on a thread while the caller prepares the next ones: ``submit(fn, *args)``
    runs ``fn(*args)`` there, in the order submitted, at most one at a time and one waiting; the
    caller's next ``submit`` waits for the one before it. An error raised by a write is raised by
    the next ``submit`` or by leaving the ``with`` block, with its own type and message. Leaving the
    block waits for the write under way, also when an error or an interrupt ends the caller's loop,
    so the files written to are never closed under it.

    For a pass whose writers take what they write as it is (a chunk's rows, the file's fixed
    decimals): what a write reads must not change after its ``submit``.
    """

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="aldpat-write-behind")
        self._pending: Future[None] | None = None

    def submit(self, fn: Callable[..., None], *args: object) -> None:
        self.wait()
        self._pending = self._pool.submit(fn, *args)

    def wait(self) -> None:
        """Wait for the write under way; its error, if it raised one."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, _tb: object) -> None:
        try:
            if kind is None:
                self.wait()
            elif self._pending is not None:
                # the caller's own error is the one raised; the write under way is only finished
                futures_wait([self._pending])
        finally:
            self._pool.shutdown(wait=True)
