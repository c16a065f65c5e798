"""The process's thread budget and the one way steps split their work over it."""

from __future__ import annotations

import threading

import pytest

from aldpat.core.threads import ENV, on_threads, share_for, thread_budget


def test_budget_reads_the_environment_and_ignores_nonsense(monkeypatch):
    monkeypatch.setenv(ENV, "3")
    assert thread_budget() == 3
    monkeypatch.setenv(ENV, "0")
    assert thread_budget() == 1
    monkeypatch.setenv(ENV, "many")
    assert thread_budget() >= 1
    assert share_for(10_000) == 1


@pytest.mark.parametrize("workers", [None, 1, 2, 5])
def test_results_come_back_in_the_pieces_order(workers, monkeypatch):
    monkeypatch.setenv(ENV, "4")
    assert on_threads(lambda a: a * a, range(0, 50, 7), workers) == [a * a for a in range(0, 50, 7)]
    assert on_threads(lambda ab: ab[1] - ab[0], [(0, 3), (3, 10)], workers) == [3, 7]


def test_one_thread_runs_here_in_order(monkeypatch):
    monkeypatch.setenv(ENV, "1")
    seen: list[tuple[int, str]] = []
    on_threads(lambda a: seen.append((a, threading.current_thread().name)), range(4))
    assert seen == [(a, threading.current_thread().name) for a in range(4)]


def test_several_threads_run_the_pieces_on_a_pool(monkeypatch):
    monkeypatch.setenv(ENV, "2")
    names = on_threads(lambda _: threading.current_thread().name, range(8))
    assert threading.current_thread().name not in names


def test_an_error_in_a_piece_reaches_the_caller(monkeypatch):
    monkeypatch.setenv(ENV, "2")

    def work(a: int) -> int:
        if a == 3:
            raise ValueError("piece 3")
        return a

    with pytest.raises(ValueError, match="piece 3"):
        on_threads(work, range(6))


def test_a_failed_call_returns_only_once_its_running_pieces_are_done(monkeypatch):
    monkeypatch.setenv(ENV, "2")
    finished: list[int] = []
    started = threading.Event()

    def work(a: int) -> int:
        if a == 0:
            started.wait(5)
            raise ValueError("piece 0")
        started.set()
        threading.Event().wait(0.2)
        finished.append(a)
        return a

    with pytest.raises(ValueError, match="piece 0"):
        on_threads(work, range(2))
    assert finished == [1], "the call returned while a piece was still writing into its outputs"
