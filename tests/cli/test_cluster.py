"""``--scheduler``: jobs on a real Dask cluster give the files ``-j 1`` gives.

A ``LocalCluster`` (``--scheduler local:2``), and a ``dask scheduler`` with two ``dask worker``
processes on loopback started here, one of them killed while a worksheet runs.
"""

from __future__ import annotations

import contextlib
import filecmp
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.cli.fresh import DATA, aldpat, aldpat_command, leftovers

pytest.importorskip("distributed")  # the test extra installs it; aldpat[dask] for users


def outputs(folder: Path) -> list[str]:
    """The files the jobs wrote (the worksheet, its state and the logs, which hold times and
    paths, aside)."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if p.is_file() and p.suffix != ".log" and not p.name.startswith("project."))


def same_files(one: Path, two: Path) -> list[str]:
    names = outputs(one)
    assert names == outputs(two)
    for name in names:
        assert filecmp.cmp(one / name, two / name, shallow=False), name
    return names


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> list[Path]:
    """Sample 24 in four quarters (real points; dtm reads each quarter's neighbours)."""
    root = tmp_path_factory.mktemp("cluster")
    rows = np.loadtxt(DATA / "samp24.txt")
    xm, ym = (rows[:, :2].min(axis=0) + rows[:, :2].max(axis=0)) / 2
    paths = []
    for i, west in enumerate((True, False)):
        for j, south in enumerate((True, False)):
            keep = ((rows[:, 0] < xm) == west) & ((rows[:, 1] < ym) == south)
            paths.append(root / f"q{i}{j}.txt")
            np.savetxt(paths[-1], rows[keep], fmt=["%.2f", "%.2f", "%.2f", "%d"])
    return paths


@pytest.mark.parametrize("command", [["filter", "gapm", "--result", "classified"],
                                     ["dtm", "--cell", "2", "--crs", "EPSG:32632"]])
def test_local_cluster_writes_what_one_process_writes(parts, tmp_path, command):
    aldpat(*command, *parts, "--odir", tmp_path / "one").ok()
    done = aldpat(*command, *parts, "--odir", tmp_path / "dask", "--scheduler", "local:2", "-v").ok()
    assert "dashboard http://" in done.stderr
    assert len(same_files(tmp_path / "one", tmp_path / "dask")) == 4
    assert leftovers(tmp_path) == []


def test_scheduler_from_the_environment_and_bad_values(parts, tmp_path):
    aldpat("info", parts[0], env={"ALDPAT_SCHEDULER": "local:1"}).ok()
    bad = aldpat("info", parts[0], "--scheduler", "host:8786")
    assert bad.returncode == 2 and "tcp://host:8786" in bad.stderr
    bad = aldpat("info", parts[0], env={"ALDPAT_SCHEDULER": "local:0"})
    assert bad.returncode == 2 and "ALDPAT_SCHEDULER" in bad.stderr


def test_without_dask_the_command_says_how_to_install_it(parts, tmp_path):
    shadow = tmp_path / "shadow"
    shadow.mkdir()
    (shadow / "distributed.py").write_text("raise ImportError('not installed')\n")  # as if absent
    done = aldpat("info", parts[0], "--scheduler", "local:2", env={"PYTHONPATH": str(shadow)})
    assert done.returncode == 2 and "pip install 'aldpat[dask]'" in done.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args: str) -> subprocess.Popen:
    script = Path(sys.executable).with_name("dask")
    return subprocess.Popen([str(script), *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)  # its own group: a kill takes the nanny and its worker


def _kill(proc: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


@pytest.fixture
def cluster():
    """A scheduler and two single-threaded workers on loopback."""
    from distributed import Client

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")]
    workers = [_dask("worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard") for _ in range(2)]
    procs += workers
    try:
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for p in procs:
            _kill(p)


def worksheet(folder: Path, inputs: list[Path], scheduler: str | None) -> Path:
    settings = f'scheduler = "{scheduler}"\n' if scheduler else ""
    names = ", ".join(f'"{p}"' for p in inputs)
    path = folder / "project.toml"
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(f"[settings]\noverwrite = true\n{settings}\n"
                    f'[[job]]\ntask = "filter"\nalgorithm = "gapm"\ninputs = [{names}]\nodir = "ground"\n\n'
                    f'[[job]]\ntask = "grid"\ninputs = ["ground/*.txt"]\nodir = "grids"\ncell = 2.0\n')
    return path


def test_worksheet_on_a_scheduler_and_two_workers(parts, tmp_path, cluster):
    address, _ = cluster
    aldpat("run", worksheet(tmp_path / "one", parts, None)).ok()
    sheet = worksheet(tmp_path / "dask", parts, address)
    # the worksheet alone may not choose a scheduler: the user names the same one
    refused = aldpat("run", sheet)
    assert refused.returncode == 2 and "comes from the worksheet's [settings]" in refused.stderr
    assert not (tmp_path / "dask" / "ground").exists()
    aldpat("run", sheet, env={"ALDPAT_SCHEDULER": address}).ok()
    assert len(same_files(tmp_path / "one", tmp_path / "dask")) == 8
    again = aldpat("run", sheet, "--resume", "--scheduler", address).ok()  # resume is the runner's: the same on a cluster
    assert again.stderr.count("Skipped") == 2


def test_a_worker_killed_mid_run_changes_nothing(tmp_path, cluster):
    address, workers = cluster
    # eight inputs of 250,000 points, most of a second of filtering each: the kill lands mid-run
    rng = np.random.default_rng(5)
    inputs = []
    for k in range(8):
        x, y = rng.uniform(0, 500, 250_000), rng.uniform(0, 500, 250_000)
        z = 100 + 0.05 * x + np.sin(y / 40) * 3 + rng.normal(0, 0.05, x.size)
        z[(x % 100 < 20) & (y % 100 < 20)] += 8.0  # buildings
        inputs.append(tmp_path / f"t{k:02d}.txt")
        rows = np.c_[x + 1000 * k, y, z]
        inputs[-1].write_text(("%.2f %.2f %.2f\n" * len(rows)) % tuple(rows.ravel()))
    aldpat("run", worksheet(tmp_path / "one", inputs, None)).ok()
    sheet = worksheet(tmp_path / "dask", inputs, address)
    run = subprocess.Popen([*aldpat_command(), "run", str(sheet), "--scheduler", address], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    ground = tmp_path / "dask" / "ground"
    deadline = time.time() + 120
    while not (ground.exists() and any(ground.glob("*.txt"))) and time.time() < deadline:
        time.sleep(0.05)
    assert run.poll() is None, "the run ended before a worker could be killed"
    _kill(workers[0])
    _, err = run.communicate(timeout=600)
    assert run.returncode == 0, err
    assert len(same_files(tmp_path / "one", tmp_path / "dask")) == 16
    assert leftovers(tmp_path) == []


def test_chunks_of_one_file_are_units_of_the_cluster(tmp_path):
    sample = DATA / "samp24.txt"
    # small windows and a short low-outlier reach: 20 m chunks within the bound on copies per point
    small = ["--window-series", "1,2,4,8", "--low-outlier-reach", "4", "--result", "classified"]
    aldpat("filter", "pm", sample, *small, "--odir", tmp_path / "one").ok()
    aldpat("filter", "pm", sample, *small, "--chunk", "20", "--scheduler", "local:2", "--odir", tmp_path / "dask").ok()
    assert filecmp.cmp(tmp_path / "one" / "samp24_pm.txt", tmp_path / "dask" / "samp24_pm.txt", shallow=False)
    assert "28 chunks of 20 m" in (tmp_path / "dask" / "samp24_pm.log").read_text()
    assert "on the Dask cluster" in (tmp_path / "dask" / "samp24_pm.log").read_text()
    assert not list(tmp_path.rglob(".aldpat-scratch-*")) and leftovers(tmp_path) == []


def test_the_progress_counts_the_chunks_finished_on_the_cluster(tmp_path):
    from aldpat.jobs.registry import get_task
    from aldpat.jobs.run import run_task
    from tests.filters.test_chunked import Recorder

    progress = Recorder()
    options = {"odir": str(tmp_path), "chunk": 20.0, "window_series": (1, 2, 4, 8), "low_outlier_reach": 4.0,
               "scheduler": "local:2"}
    report = run_task(get_task("filter", "pm"), [DATA / "samp24.txt"], [("python", options)], progress=progress)
    assert report.exit_code == 0
    assert (progress.jobs, progress.done) == (1, 1)
    assert progress.planned == progress.finished == 28  # told by the worker, heard by this client


WORKER_SETTINGS = """
import json, logging, os
from aldpat.jobs.cluster import client_for

def settings():
    return logging.getLogger("distributed.batched").getEffectiveLevel(), os.environ.get("MALLOC_TRIM_THRESHOLD_")

if __name__ == "__main__":
    client = client_for("local:1")
    print(json.dumps({"here": settings()[0], "workers": list(client.run(settings).values())}))
"""


def test_local_workers_start_with_dask_logging_at_warnings_and_the_c_librarys_trim(tmp_path):
    """A stopped run's workers end with Dask's INFO lines ("Batched Comm Closed", with a traceback)
    in this process and in each worker, which reads its logging settings as it imports Dask: both
    start at warnings. The workers keep glibc's trim threshold (Dask sets 64 kB)."""
    import json

    script = tmp_path / "settings.py"
    script.write_text(WORKER_SETTINGS)
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, env=env,
                         cwd=tmp_path, check=False)
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout.splitlines()[-1])
    assert got == {"here": 30, "workers": [[30, None]]}


def test_local_workers_drop_only_the_records_of_the_runs_own_ending():
    """Dask logs a heartbeat meeting the closing scheduler of a local cluster as an ERROR with a
    traceback, after the run's own lines, and each job an interrupted run cancels as a WARNING:
    aldpat's local workers drop those records and no other; a local cluster's workers have the
    filter installed on both loggers."""
    import logging

    from aldpat.jobs.cluster import client_for
    from aldpat.jobs.worker_logging import LOGGERS, RunEndingRecords

    def record(message: str) -> logging.LogRecord:
        return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, message, None, None)

    quiet = RunEndingRecords()
    assert not quiet.filter(record("Failed to communicate with scheduler during heartbeat."))
    assert not quiet.filter(record("Async instruction for <Task cancelled name=\"execute('aldpat-filter-gapm-5')\" "
                                   "coro=<Worker.execute() done>> ended with CancelledError"))
    assert quiet.filter(record("Unexpected exception during heartbeat. Closing worker."))
    assert quiet.filter(record("Worker is at 95% memory usage."))
    assert quiet.filter(record("Async instruction for <Task finished coro=<Worker.gather_dep()>> ended with OSError"))
    client = client_for("local:1")

    def installed() -> bool:
        return all(any(type(f).__name__ == "RunEndingRecords" for f in logging.getLogger(name).filters)
                   for name in LOGGERS)

    assert all(client.run(installed).values())
