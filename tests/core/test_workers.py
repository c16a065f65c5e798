"""Worker processes: as many as asked, within what the memory available holds."""

from __future__ import annotations

import logging

from aldpat.core import workers


def test_workers_are_as_many_as_the_memory_holds(monkeypatch):
    monkeypatch.setattr(workers, "available_memory", lambda: 1 << 30)  # 1 GiB: 0.8 GiB for 256 MiB each
    assert workers.affordable_workers(8) == 3
    assert workers.affordable_workers(2) == 2
    monkeypatch.setattr(workers, "available_memory", lambda: 100 << 20)
    assert workers.affordable_workers(4) == 1  # one at least: the run still runs
    monkeypatch.setattr(workers, "available_memory", lambda: 1 << 50)
    assert workers.affordable_workers(1024) == workers.MOST_WORKERS  # four per core


def test_a_run_asking_more_workers_than_memory_holds_says_so_and_runs(tmp_path, monkeypatch, caplog):
    """``-j 1024`` from a worksheet over a thousand tiles started a thousand processes."""
    from aldpat.jobs.registry import get_task
    from aldpat.jobs.run import run_task

    inputs = []
    for k in range(3):
        inputs.append(tmp_path / f"t{k}.txt")
        inputs[-1].write_text(f"{k} 0 1\n{k} 1 2\n{k + 0.5} 0.5 3\n")
    monkeypatch.setattr(workers, "available_memory", lambda: 400 << 20)  # room for one
    with caplog.at_level(logging.WARNING):
        report = run_task(get_task("thin"), inputs, [("python", {"jobs": 1024, "odir": str(tmp_path / "out"),
                                                                 "cell": 1.0})])
    assert all(r.ok for r in report.results) and len(list((tmp_path / "out").glob("*_thin.txt"))) == 3
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("-j 1024")]
    assert said == [said[0]] and said[0].startswith("-j 1024: 1 worker processes: at most ")
    assert "and as many as the memory available holds" in said[0]
