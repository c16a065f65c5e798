"""Interruptions: SIGINT and SIGTERM mid-write, SIGKILL and resume, two writers of one output.

Each runs the real console script and signals it as a shell, a batch scheduler or a second
user would.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import laspy
import numpy as np
import psutil
import pytest

from aldpat import interrupt
from tests.cli.fresh import REPO, aldpat_command, leftovers

sys.path.insert(0, str(REPO / "bench"))
from kill_resume import kill_and_resume, make_project, outputs, run


def big_text(path: Path, n: int, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    rows = np.c_[rng.uniform(0, 500, n), rng.uniform(0, 500, n), rng.uniform(0, 30, n)]
    with open(path, "w") as fh:
        fh.write(("%.2f %.2f %.2f\n" * n) % tuple(rows.ravel()))
    return path


@pytest.fixture(scope="module")
def two_big(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("big")
    return [big_text(folder / "a.txt", 1_000_000, 1), big_text(folder / "b.txt", 1_000_000, 2)]


def start_and_signal(args: list, folder: Path, sig: int) -> tuple[int, str, list[int]]:
    """Start ``aldpat ARGS``, wait until an output is being written, send ``sig``; return the exit
    status, stderr and the processes of the run still alive afterwards."""
    proc = subprocess.Popen(aldpat_command() + [str(a) for a in args], stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL)
    family = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if leftovers(folder):
            break
        time.sleep(0.01)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    family = [p.pid for p in psutil.Process(proc.pid).children(recursive=True)]
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    time.sleep(0.3)
    alive = [pid for pid in family if psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE]
    return proc.returncode, err, alive


@pytest.mark.parametrize("jobs", [1, 2])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_mid_write_leaves_no_temporary_and_says_what_stopped(two_big, tmp_path, sig, jobs):
    out = tmp_path / "out"
    code, err, alive = start_and_signal(["convert", *two_big, "--out-format", "laz", "--odir", out, "-j", jobs],
                                        out, sig)
    name = signal.Signals(sig).name
    assert code == 128 + sig, err
    assert "Traceback" not in err
    line = [ln for ln in err.splitlines() if "interrupted" in ln]
    assert len(line) == 1 and f"interrupted by {name} during convert" in line[0] and "a.txt" in line[0], err
    assert leftovers(out) == [] and alive == []
    for p in out.glob("*.laz"):  # an output finished before the signal is whole
        with laspy.open(p) as fh:
            assert fh.header.point_count == 1_000_000


def test_two_processes_writing_one_output(two_big, tmp_path):
    args = aldpat_command() + ["convert", str(two_big[0]), "--out-format", "laz", "--odir", str(tmp_path)]
    procs = [subprocess.Popen(args, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 1], results
    loser = next(err for code, err in results if code == 1)
    assert "a.laz: output exists" in loser and "Traceback" not in loser
    with laspy.open(tmp_path / "a.laz") as fh:  # the winner's file, whole
        assert fh.header.point_count == 1_000_000
    assert leftovers(tmp_path) == []


def test_killed_at_random_instants_and_resumed_ends_identical(tmp_path):
    """A small version of ``bench/kill_resume.py`` (which runs 20 instants on 3 M points)."""
    # the kills are timed as shares of a clean run: on a fresh installation the first run also
    # compiles numba's loops into its cache, and timed on it the later kills came after the end
    assert run(make_project(tmp_path / "warm", 20_000, jobs=2)).returncode == 0
    clean = tmp_path / "clean"
    ws = make_project(clean, 200_000, jobs=2)
    start = time.perf_counter()
    assert run(ws).returncode == 0
    wall = time.perf_counter() - start
    reference = outputs(clean)
    assert len(reference) > 50
    rng = np.random.default_rng(3)
    landed = 0
    for share in rng.uniform(0.2, 0.9, 3):
        instant = kill_and_resume(clean, reference, tmp_path / "killed", float(share * wall))
        assert instant.ok, instant
        landed += instant.mid_run
    assert landed >= 2  # most kills hit the run while it was going


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_signal_mid_chunk_removes_the_chunks_files(two_big, tmp_path, jobs):
    out = tmp_path / "out"
    # 81 chunks with 20 m buffers (pm's own, 245 m, would copy each point into 84 chunks: a run
    # of half a minute to test the same thing)
    proc = subprocess.Popen(aldpat_command() + ["filter", "pm", str(two_big[0]), "--chunk", "60", "--chunk-buffer", "20",
                                                "-j", str(jobs), "--odir", str(out)],
                            stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None and not list(out.glob(".aldpat-scratch-*/*/chunk_*")):
        time.sleep(0.01)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    family = [p.pid for p in psutil.Process(proc.pid).children(recursive=True)]
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    time.sleep(0.3)
    assert proc.returncode == 128 + signal.SIGINT, err
    assert "Traceback" not in err and "interrupted by SIGINT" in err
    assert list(out.glob(".aldpat-scratch-*")) == [] and leftovers(out) == []
    assert [pid for pid in family if psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE] == []


def family_of(pid: int) -> list[psutil.Process]:
    try:
        return psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


def gone_within(processes: list[psutil.Process], seconds: float) -> list[int]:
    """The pids of ``processes`` still running (not zombies) after up to ``seconds``."""
    _, alive = psutil.wait_procs(processes, timeout=seconds)
    return [p.pid for p in alive if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]


@pytest.mark.parametrize("where", ["processes", "dask"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_to_the_whole_command_reaches_idle_workers_without_a_traceback(two_big, tmp_path, sig, where):
    """As a terminal's Ctrl-C (or a batch scheduler) signals every process of the command: a
    worksheet of -j 2 (or on a local Dask cluster) whose second worker sits idle beside the
    first's big job."""
    tiny = tmp_path / "tiny.txt"
    tiny.write_text("1 2 3\n2 3 4\n3 4 5\n")
    env = dict(os.environ, ALDPAT_SCHEDULER="local:2" if where == "dask" else "none")
    for attempt in range(3):  # on a busy machine the big job may end first: then try again
        out = tmp_path / f"out{attempt}"
        ws = tmp_path / f"ws{attempt}.toml"
        ws.write_text(f'[settings]\njobs = 2\n\n[[job]]\ntask = "convert"\ninputs = ["{two_big[0]}", "{tiny}"]\n'
                      f'out_format = "laz"\nodir = "{out}"\n')
        proc = subprocess.Popen(aldpat_command() + ["run", str(ws)], stderr=subprocess.PIPE, text=True,
                                stdin=subprocess.DEVNULL, start_new_session=True, env=env)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and \
                not ((out / "tiny.laz").exists() and leftovers(out)):
            time.sleep(0.01)
        if proc.poll() is None:
            break
        proc.communicate()
    assert proc.poll() is None, "the run ended before it could be interrupted, three times"
    family = family_of(proc.pid)
    assert len(family) >= 2
    os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + sig, err
    assert "Traceback" not in err and "ForkProcess" not in err, err
    assert sum("interrupted" in line for line in err.splitlines()) == 1, err
    # nor Dask's lines of the jobs it cancelled, or of workers killed as the cluster closed
    assert "CancelledError" not in err and "still alive after" not in err, err
    assert gone_within(family, 10) == [] and leftovers(out) == []


@pytest.mark.parametrize("pool", ["jobs", "chunks"])
def test_sigkill_of_the_parent_leaves_no_worker_busy_or_idle(two_big, tmp_path, pool):
    tiny = tmp_path / "tiny.txt"
    tiny.write_text("1 2 3\n2 3 4\n3 4 5\n")
    if pool == "jobs":  # one worker converting a big file, the other idle once the tiny one is done
        args = ["convert", two_big[0], tiny, "--out-format", "laz"]

        def started(proc, out) -> bool:
            return (out / "tiny.laz").exists() and bool(leftovers(out))
    else:  # the chunks of one file in two worker processes
        args = ["filter", "pm", big_text(tmp_path / "c.txt", 200_000, 3), "--chunk", "100"]

        def started(proc, out) -> bool:
            return len(family_of(proc.pid)) >= 2
    # the state sought (a worker busy, the other idle) depends on how the processes are
    # scheduled: on a busy machine the big job may end before the tiny one; then try again
    for attempt in range(3):
        out = tmp_path / f"out{attempt}"
        proc = subprocess.Popen(aldpat_command() + [str(a) for a in args] + ["--odir", str(out), "-j", "2"],
                                stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None and not started(proc, out):
            time.sleep(0.01)
        if proc.poll() is None:
            break
    assert proc.poll() is None, "the run ended before it could be killed, three times"
    family = family_of(proc.pid)
    proc.kill()
    proc.wait()
    assert gone_within(family, 10) == []
    assert leftovers(out) == []  # the busy worker removed the output it was writing


BLOCKED_SENDER = """
import ctypes, os, signal, sys, time
from aldpat import interrupt
from aldpat.core.workers import WorkerPool

def big(n, how):
    if how == "no-pdeathsig":  # as where the kernel has no such signal: the watchdog alone
        ctypes.CDLL(None).prctl(1, 0, 0, 0, 0)  # PR_SET_PDEATHSIG, none
    time.sleep(0.5)
    return b"x" * n

if __name__ == "__main__":  # the workers import this script
    with interrupt.doing("a worksheet job"):  # what the parent was doing when its workers started
        pool = WorkerPool(2)
        futures = pool.submit_all(big, [(64 << 20, sys.argv[1]), (1, sys.argv[1])])
        while len(pool._pool._processes) < 2:
            time.sleep(0.01)
        print(" ".join(str(p.pid) for p in pool._pool._processes.values()), flush=True)
        os.kill(os.getpid(), signal.SIGSTOP)  # the parent stops reading: the first worker blocks on the pipe
"""


@pytest.mark.parametrize("how", ["pdeathsig", "no-pdeathsig"])
def test_a_worker_blocked_sending_its_result_ends_with_its_killed_parent(tmp_path, how):
    """The orphan once seen: a worker sending a large result down a pipe nobody reads any more."""
    script = tmp_path / "blocked.py"
    script.write_text(BLOCKED_SENDER)
    proc = subprocess.Popen([sys.executable, str(script), how], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=REPO)
    workers = [psutil.Process(int(pid)) for pid in proc.stdout.readline().split()]
    assert len(workers) == 2
    deadline = time.monotonic() + 30
    while psutil.Process(proc.pid).status() != psutil.STATUS_STOPPED and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.5)  # the result is being sent: 64 MiB into a pipe of 64 KiB
    proc.kill()
    proc.wait()
    assert gone_within(workers, 10) == []
    assert "Traceback" not in proc.stderr.read()


def test_a_stop_a_library_reported_as_its_own_error_still_stops(monkeypatch):
    """lazrs writes a LAZ file through the file object's ``write``: a signal handled there raises
    in the callback, and the library may hand the job an error of its own instead. The job must
    stop (the run with it), not pass for a job that failed while the run goes on."""
    from aldpat.jobs.execute import _guarded
    from aldpat.jobs.resolve import resolve_run
    from aldpat.tasks import get_task

    task = get_task("convert")
    run = resolve_run(task, [])
    monkeypatch.setattr(interrupt, "_requested", None)

    def broken_write(ctx):
        raise OSError(5, "Input/output error")

    failed = _guarded(task, ["a.txt"], run, "aldpat convert a.txt", broken_write)
    assert failed.error == "a.txt: input/output error"  # no signal: the job's own error

    def interrupted_write(ctx):
        with contextlib.suppress(interrupt.Interrupted):  # what the library made of it
            interrupt._raise(signal.SIGTERM, None)
        raise OSError(5, "Input/output error")

    with pytest.raises(interrupt.Interrupted):
        _guarded(task, ["a.txt"], run, "aldpat convert a.txt", interrupted_write)


def test_workers_after_the_run_read_laz_itself(tmp_path):
    """A worksheet whose first job reads a LAZ file in the run's process (one input: no pool),
    then runs -j 2 over LAZ files. lazrs reads LAZ on a thread pool; workers forked from a process
    holding one waited for ever on their first LAZ read. Workers come from a fork server now."""
    slice_laz = REPO / "tests" / "data" / "csite1_slice.laz"
    for name in ("a.laz", "b.laz"):
        (tmp_path / name).write_bytes(slice_laz.read_bytes())
    ws = tmp_path / "ws.toml"
    ws.write_text('[settings]\njobs = 2\n\n'
                  '[[job]]\ntask = "convert"\ninputs = ["a.laz"]\nout_format = "text"\nodir = "text"\n\n'
                  '[[job]]\ntask = "filter"\nalgorithm = "pm"\ninputs = ["a.laz", "b.laz"]\nodir = "ground"\n')
    done = subprocess.run(aldpat_command() + ["run", str(ws)], check=False, capture_output=True, text=True,
                          timeout=240, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "ground").glob("*.laz")) == ["a_pm.laz", "b_pm.laz"]
    assert "Traceback" not in done.stderr


def test_an_interrupted_first_pass_says_no_output_was_written():
    """``dtm`` over tiles first finds every tile's ground classes, writing no output: an
    interruption then said "(4 of 16 inputs done)" of a folder still empty. The line now says
    which pass it stopped in; the main pass counts its own jobs, not a first pass's failures."""
    from types import SimpleNamespace

    from aldpat.jobs.execute import doing

    task = SimpleNamespace(key="dtm")
    assert doing(task, SimpleNamespace(stage="first"), 4, 16) == (
        "dtm, first pass (4 of 16 inputs' ground classes found, no output written yet)")
    assert doing(task, SimpleNamespace(stage="main"), 4, 16, " on local:2") == "dtm (4 of 16 inputs done on local:2)"


def test_an_interrupted_run_names_the_inputs_at_work_once_each(tmp_path):
    """``dtm`` over overlapping strips: each job reads every other strip as its buffer. An
    interruption listed, for every job the pool had queued (three to five with ``-j 2``), all the
    inputs it reads -- a line of up to 1,900 characters naming each strip several times. It names
    the inputs whose outputs were being made now, as many as the workers."""
    strips = tmp_path / "strips"
    strips.mkdir()
    for k in range(24):
        os.link(REPO / "tests" / "data" / "fsite5_strip.laz", strips / f"s{k:02d}.laz")
    code, err, _ = start_and_signal(["dtm", strips, "--cell", "2", "-j", "2", "--odir", tmp_path / "dtm"],
                                    tmp_path / "dtm", signal.SIGTERM)
    line = next(ln for ln in err.splitlines() if "interrupted by SIGTERM" in ln)
    assert code == 128 + signal.SIGTERM and "Traceback" not in err
    running = line.split("running: ")[1].split(")")[0].split(", ")
    assert 1 <= len(running) <= 2 and len(set(running)) == len(running), line
    assert all(name.startswith(str(strips)) and name.endswith(".laz") for name in running), line
    assert len(line) < 400, line


@pytest.mark.parametrize("where", ["run", "worker"])
def test_an_interruption_inside_a_callback_from_c_is_raised_again_without_a_word(where):
    """A signal's handler may raise inside a callback from C (LLVM's, compiling a numba loop of a
    fresh installation): C cannot take the exception, and Python printed "Exception ignored in"
    with a traceback and dropped it, so the run went on. The interruption is raised again once the
    callback returns, and nothing is printed for it."""
    code = (
        "import ctypes, os, signal, sys, time\n"
        "from aldpat import interrupt\n"
        + ("interrupt.install()\n" if where == "run" else
           "interrupt.install_in_worker(os.getppid())\ninterrupt._activity.append('a job')\n")
        + "@ctypes.CFUNCTYPE(None)\n"
        "def callback():\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    time.sleep(1)  # the handler raises in here, inside the callback\n"
        "try:\n"
        "    callback()\n"
        "    time.sleep(5)\n"
        "    print('went on')\n"
        "except interrupt.Interrupted as exc:\n"
        "    print('interrupted by', exc.signal_name)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=60,
                          cwd=REPO)
    assert done.stdout.strip() == "interrupted by SIGTERM", (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
