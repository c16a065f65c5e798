"""Reading ahead and writing behind on a thread: the same items in the same order, errors where
they belong, nothing read once the caller has stopped, and no write left under way."""

from __future__ import annotations

import threading
import time

import pytest

from aldpat.errors import InputFormatError
from aldpat.io.prefetch import WriteBehind, read_ahead


def test_the_items_come_in_order_each_read_on_another_thread():
    threads = []

    def source():
        for k in range(50):
            threads.append(threading.current_thread())
            yield k

    assert list(read_ahead(source())) == list(range(50))
    assert threading.current_thread() not in threads


def test_an_error_comes_where_its_item_would_have_with_its_type_and_message():
    def source():
        yield 1
        yield 2
        raise InputFormatError("point 3 is damaged", path="tile.laz")

    got: list[int] = []
    with pytest.raises(InputFormatError, match="point 3 is damaged") as caught:
        got.extend(read_ahead(source()))  # the items before the error stay appended
    assert got == [1, 2] and "tile.laz" in str(caught.value)


def test_a_caller_that_stops_stops_the_reading_and_its_source_is_closed():
    produced = []
    closed = threading.Event()

    def source():
        try:
            for k in range(1000):
                produced.append(k)
                yield k
        finally:
            closed.set()

    for item in read_ahead(source()):
        if item == 3:
            break
    assert closed.wait(5)
    time.sleep(0.3)
    assert len(produced) <= 6  # the items handed over, the one waiting and the one being read


def test_an_error_in_the_caller_stops_the_reading_too():
    closed = threading.Event()

    def source():
        try:
            yield from range(1000)
        finally:
            closed.set()

    with pytest.raises(RuntimeError, match="the caller's own"):
        for item in read_ahead(source()):
            if item == 2:
                raise RuntimeError("the caller's own error")
    assert closed.wait(5)


def test_writes_behind_run_in_order_on_another_thread_one_at_a_time():
    done: list[int] = []
    threads = set()
    running = threading.Lock()

    def write(k: int) -> None:
        assert running.acquire(blocking=False), "two writes at once"
        try:
            threads.add(threading.current_thread())
            time.sleep(0.001 * (k % 3))
            done.append(k)
        finally:
            running.release()

    with WriteBehind() as behind:
        for k in range(30):
            behind.submit(write, k)
            assert len(done) >= k - 1  # at most the one just submitted and the one before under way
    assert done == list(range(30))  # leaving the block waited for the last one
    assert threading.current_thread() not in threads


def test_a_writes_error_comes_at_the_next_submit_with_its_type_and_message():
    def write(k: int) -> None:
        if k == 2:
            raise OSError(28, "No space left on device")

    behind_error = None
    with pytest.raises(OSError, match="No space left") as caught, WriteBehind() as behind:
        for k in range(10):
            behind.submit(write, k)
            behind_error = k
    assert caught.value.errno == 28
    assert behind_error is not None and behind_error <= 3  # no write submitted long after it failed


def test_a_writes_error_at_the_last_chunk_comes_when_the_block_is_left():
    def write(_: int) -> None:
        raise OSError(5, "Input/output error")

    with pytest.raises(OSError, match="Input/output"), WriteBehind() as behind:
        behind.submit(write, 0)


def test_an_error_in_the_caller_waits_for_the_write_under_way_and_is_the_one_raised():
    finished = threading.Event()

    def write(_: int) -> None:
        time.sleep(0.2)
        finished.set()

    with pytest.raises(KeyboardInterrupt), WriteBehind() as behind:
        behind.submit(write, 0)
        raise KeyboardInterrupt
    assert finished.is_set()  # the file written to is closed after its write, never under it
