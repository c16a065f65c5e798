"""The ``aldpat`` process ends without the interpreter's teardown, losing nothing an exit must do."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from aldpat.cli.leave import status_of
from tests.cli.fresh import TEST_DATA, aldpat


def _python(code: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, capture_output=True, text=True,
                          timeout=120, check=False)


@pytest.mark.parametrize("code, status", [(None, 0), (0, 0), (3, 3), ("no way", 1)])
def test_an_exit_status_is_the_interpreters(code, status):
    assert status_of(SystemExit(code)) == status


def test_an_exit_with_a_text_prints_it_and_ends_with_status_1(tmp_path):
    done = _python("""
        from aldpat.cli.leave import leave_after
        leave_after(SystemExit("no way"))
        """, tmp_path)
    assert done.returncode == 1 and done.stderr.strip() == "no way"


def test_exit_handlers_run_and_the_status_is_kept(tmp_path):
    done = _python(f"""
        import atexit, sys
        atexit.register(lambda: open({str(tmp_path / 'handler-ran')!r}, 'w').close())
        sys.argv = ['aldpat', 'filter', 'gapm', 'missing.laz']
        from aldpat.cli.main import main
        main()
        """, tmp_path)
    assert done.returncode != 0 and "missing.laz" in done.stderr
    assert (tmp_path / "handler-ran").exists(), "an atexit handler did not run"


def test_a_thread_still_running_is_waited_for(tmp_path):
    done = _python(f"""
        import sys, threading, time
        def late():
            time.sleep(0.5)
            open({str(tmp_path / 'thread-done')!r}, 'w').close()
        threading.Thread(target=late).start()
        sys.argv = ['aldpat', '--version']
        from aldpat.cli.main import main
        main()
        """, tmp_path)
    assert done.returncode == 0 and "aldpat" in done.stdout
    assert (tmp_path / "thread-done").exists(), "the process ended under a running thread"


def test_a_worksheet_writes_its_output_log_and_state_whole(tmp_path):
    import json

    import laspy

    (tmp_path / "strip.laz").write_bytes((TEST_DATA / "fsite5_strip.laz").read_bytes())
    (tmp_path / "ws.toml").write_text(
        '[[job]]\ntask = "filter"\nalgorithm = "gapm"\ninputs = ["strip.laz"]\nodir = "out"\n'
        'result = "classified"\n', encoding="utf-8")
    done = aldpat("run", "ws.toml", cwd=tmp_path).ok()
    las = laspy.read(tmp_path / "out" / "strip_gapm.laz")
    assert len(las.points) == 20_643 and (las.classification == 2).sum() > 10_000
    log = (tmp_path / "ws.log").read_text(encoding="utf-8")
    assert "[[job]]" in log and "strip.laz" in log, f"the run log is not whole:\n{log}\n{done.stderr}"
    state = json.loads((tmp_path / "ws.state.json").read_text(encoding="utf-8"))
    assert state, "the run's state is empty"
