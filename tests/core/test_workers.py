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


def test_a_chunked_run_asking_more_workers_than_memory_holds_says_so_and_runs(tmp_path, monkeypatch, caplog):
    """The chunk workers of one big input were capped without a word."""
    import numpy as np

    from aldpat.jobs.registry import get_task
    from aldpat.jobs.run import run_task

    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 300, (3000, 2))
    src = tmp_path / "big.txt"
    np.savetxt(src, np.column_stack([xy, 100 + 0.01 * xy[:, 0]]), fmt="%.2f")
    monkeypatch.setattr(workers, "available_memory", lambda: 400 << 20)  # room for one
    with caplog.at_level(logging.WARNING):
        report = run_task(get_task("filter", "pm"), [src], [("python", {
            "jobs": 64, "odir": str(tmp_path / "out"), "chunk": 100.0, "chunk_buffer": 10.0})])
    assert all(r.ok for r in report.results), report.results[0].error
    said = [r.getMessage() for r in caplog.records if "worker processes: at most" in r.getMessage()]
    assert len(said) == 1 and said[0].startswith("-j 64 for the chunks: 1 worker processes")
