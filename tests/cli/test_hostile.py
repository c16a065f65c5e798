"""The hostile and careless corpus (:mod:`tests.cli.corpus`) through the real CLI.

Every case runs through the console script's entry point in a fresh process (the cases of a
category share one: :func:`tests.cli.fresh.aldpat_batch`), and must end with its exit status,
its one stderr line saying why, no traceback and no internal error, and whatever it says must
hold afterwards (nothing connected to, nothing written, the input untouched...).
"""

from __future__ import annotations

import re
import socket

import pytest

from tests.cli.corpus import Hostile, data_loss_cases, las_header_cases, resources_cases, security_cases
from tests.cli.fresh import aldpat_batch


def check(cases: list[Hostile]) -> None:
    results = aldpat_batch([{"args": c.args, "cwd": c.cwd, "limit": c.limit, "env": c.env} for c in cases])
    problems = []
    for case, got in zip(cases, results, strict=False):
        lines = [ln for ln in got["stderr"].splitlines() if ln.strip()]
        why = []
        if got["status"] != case.status:
            why.append(f"exit {got['status']}, expected {case.status}")
        if "Traceback" in got["stderr"] or "internal error" in got["stderr"]:
            why.append("a traceback or an internal error")
        if case.message is not None and sum(bool(re.search(case.message, ln)) for ln in lines) != 1:
            why.append(f"no one line matching {case.message!r}")
        if case.status == 2 and len(lines) != 1:
            why.append(f"{len(lines)} lines for a usage error")
        if any(len(ln) > 2000 for ln in lines):  # a megabyte token is not echoed whole
            why.append(f"a line of {max(map(len, lines)):,} characters")
        if case.holds is not None:
            try:
                broken = case.holds()
            except OSError as exc:
                broken = f"what must hold could not be read: {exc}"
            if broken:
                why.append(broken)
        if why:
            problems.append(f"[{case.category}] {case.name}: {'; '.join(why)}\n    stderr: {got['stderr'][-600:]!r}")
        print(f"{got['seconds']:6.2f} s  exit {got['status']}  [{case.category}] {case.name}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


@pytest.fixture
def listener():
    """A socket on loopback that no case may connect to."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(8)
        sock.setblocking(False)
        yield sock
        try:
            conn, _ = sock.accept()
        except BlockingIOError:
            return
        conn.close()
        pytest.fail("a case connected to the listening socket")


def test_security(tmp_path, listener):
    check(security_cases(tmp_path, listener.getsockname()[1]))


def test_data_loss(tmp_path):
    check(data_loss_cases(tmp_path))


def test_resources(tmp_path):
    check(resources_cases(tmp_path))


def test_las_header(tmp_path):
    check(las_header_cases(tmp_path))
