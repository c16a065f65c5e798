"""Many ``aldpat`` command lines in one fresh process, each through the real CLI entry point.

A fresh process per command costs most of a second of start-up; a corpus of hundreds of cases
that each end in a usage error or a refusal is run here instead: ``python -m tests.cli.batch
CASES.json RESULTS.json`` runs each case's arguments through :func:`aldpat.cli.main.run` (the
console script's command: its exit statuses, its messages; the script's ``main`` ends its process
after one) in this one process, in the case's
folder, with its own time limit. A case that overruns ends with ``"hang"``; one stuck where no
signal reaches it is found by the caller from the ``START n`` lines on stdout when the whole
batch overruns.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import sys
import time
import traceback


class Overran(BaseException):
    """A case ran past its time limit (a BaseException, so no ``except Exception`` swallows it)."""


def _alarm(signum, frame):
    raise Overran()


def run_case(args: list[str], cwd: str, limit: float, env: dict[str, str]) -> dict:
    from aldpat.cli.leave import status_of
    from aldpat.cli.main import run

    out, err = io.StringIO(), io.StringIO()
    status: int | str = 0
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    here = os.getcwd()
    start = time.perf_counter()
    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, limit)
    try:
        os.chdir(cwd)
        sys.argv = ["aldpat", *args]
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            run()
    except SystemExit as exc:
        status = status_of(exc)
    except Overran:
        status = "hang"
    except BaseException:  # noqa: BLE001  (reported as what it is: the CLI let an exception out)
        status = "escaped"
        err.write(traceback.format_exc())
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        os.chdir(here)
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return {"args": args, "status": status, "stdout": out.getvalue(), "stderr": err.getvalue(),
            "seconds": time.perf_counter() - start}


def main() -> None:
    spec, out = sys.argv[1], sys.argv[2]  # before the cases set sys.argv
    with open(spec, encoding="utf-8") as fh:
        cases = json.load(fh)
    results = []
    for n, case in enumerate(cases):
        print(f"START {n}", flush=True)
        results.append(run_case(case["args"], case["cwd"], case.get("limit", 30.0), case.get("env", {})))
        # what is done so far, should the next hang: whole, or not at all (the process may be
        # ended in the middle of a write)
        with open(out + ".part", "w", encoding="utf-8") as fh:
            json.dump(results, fh)
        os.replace(out + ".part", out)


if __name__ == "__main__":
    main()
