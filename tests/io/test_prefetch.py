"""Reading ahead on a thread: the same items in the same order, errors where they belong, and
nothing read once the caller has stopped."""

from __future__ import annotations

import threading
import time

import pytest

from aldpat.errors import InputFormatError
from aldpat.io.prefetch import read_ahead


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
