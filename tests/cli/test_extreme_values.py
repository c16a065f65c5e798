"""Every numeric option of every registered task at extreme values, through the real CLI.

As ``tests/test_registry.py`` walks the tasks, this walks the parameter registry: each numeric
option of each task (its own, the shared ones, the run's) at 1e308, 1e-300, -1e308, 2**31 and
1e20, on tiny real-looking data. Each run must end as a user can read it -- exit 0 (a harmless
value), 1 (the input refused, one line naming it) or 2 (a usage error, one line) -- never with a
traceback, an internal error or a hang. The runs share one fresh process
(:func:`tests.cli.fresh.aldpat_batch`), each with its own time limit, so the whole registry costs
tens of seconds, and a hang fails the test instead of stalling the suite.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path

import numpy as np

from aldpat.io.surfer import write_surfer
from aldpat.tasks import TASKS
from tests.cli.fresh import aldpat_batch

VALUES = ("1e308", "1e-300", "-1e308", str(2**31), "1e20")
#: the longest a run on this tiny data may take, whatever the value, once its code is compiled
LIMIT = 20.0
#: each task's first run, with its defaults, compiles its numba kernels (no cache in a clean
#: clone): tens of seconds on a loaded machine, which the hang limit above must not count
FIRST_RUN_LIMIT = 300.0
NUMERIC = ("float", "int", "floats", "ints")


def _data(root: Path) -> dict[str, Path]:
    rng = np.random.default_rng(7)
    n = 80
    x, y = 500000 + rng.uniform(0, 60, n), 4000000 + rng.uniform(0, 60, n)
    z = 100 + 0.05 * (x - 500000) + rng.normal(0, 0.1, n)
    z[:8] += 6.0  # a few objects
    points = root / "points.txt"
    np.savetxt(points, np.c_[x, y, z, rng.integers(0, 255, n)], fmt=["%.2f", "%.2f", "%.2f", "%d"])
    reference = root / "reference.txt"
    np.savetxt(reference, np.c_[x, y, z, (np.arange(n) < 8).astype(int)], fmt=["%.2f", "%.2f", "%.2f", "%d"])
    t = 318000.0 + np.arange(n) * 0.01
    t[n // 2:] += 120.0  # two strips
    tape = root / "tape.txt"
    np.savetxt(tape, np.c_[t, x, y, z, np.full(n, 10), x, y, z + 0.5, np.full(n, 12)],
               fmt=["%.2f"] + ["%.2f", "%.2f", "%.2f", "%d"] * 2)
    polygon = root / "polygon.txt"
    polygon.write_text("499990,3999990\n500070,3999990\n500070,4000070\n499990,4000070\n")
    geoid = root / "geoid.gtx"
    geoid.write_bytes(struct.pack(">4d2i", -90.0, -180.0, 10.0, 10.0, 19, 37)
                      + np.full(19 * 37, -30.0, dtype=">f4").tobytes())
    merged = root / "merged.txt"
    ring = [(500000, 4000000), (500060, 4000000), (500060, 4000060), (500000, 4000060), (500000, 4000000)]
    merged.write_text("".join(f"{a} {b} 100.0 1 points.txt\n" for a, b in ring))
    from aldpat.core.grid_extent import GridSpec

    grid = root / "grid.grd"
    write_surfer(grid, rng.normal(100, 1, (12, 12)), GridSpec(500000, 4000000, 5, 5, 12, 12))
    return {"points": points, "reference": reference, "tape": tape, "polygon": polygon, "geoid": geoid,
            "merged": merged, "grid": grid}


def _base_args(key: str, data: dict[str, Path], out: Path) -> list:
    """Inputs and required options of task ``key``: each task on data it reads."""
    task = TASKS[key]
    inputs = {"split-tape": ["tape"], "separate-returns": ["tape"], "grd2bin": ["grid"], "shapefile": ["merged"],
              "merge-boundary": ["points"]}.get(key, ["points"])
    args: list = [*key.split(), *(data[i] for i in inputs)]
    required = {"reference": data["reference"], "polygon": data["polygon"], "geoid": data["geoid"],
                "output": out / "merged_out.txt"}
    names = {s.name for s in task.all_specs()}
    for name, value in required.items():
        spec = next((s for s in task.all_specs() if s.name == name), None)
        if spec is not None and spec.required:
            args += [spec.option, value]
    if key == "ortho-height":
        args += ["--crs", "17N"]
    if "odir" in names:
        args += ["--odir", out]
    if "overwrite" in names:
        args.append("--overwrite")
    return args


def _cases(data: dict[str, Path], root: Path, values: tuple[str, ...], wanted) -> list[dict]:
    """Each task with its defaults, then each of its options that ``wanted`` picks at each of
    ``values``."""
    cases = []
    for key in sorted(TASKS):
        out = root / "out" / key.replace(" ", "-")
        cases.append({"args": _base_args(key, data, out), "cwd": root, "limit": FIRST_RUN_LIMIT,
                      "name": f"{key} (its defaults, compiling its kernels)"})
        for spec in TASKS[key].all_specs():
            if not wanted(spec):
                continue
            for value in values:
                option = [spec.option, *[value] * (spec.length or 1)]
                cases.append({"args": _base_args(key, data, out) + option, "cwd": root, "limit": LIMIT,
                              "name": f"{key} {spec.option} {value[:12]!r}"})
    return cases


def _faults(cases: list[dict], results: list[dict]) -> list[str]:
    """The runs that did not end as a user can read it: exit 0, 1 with a word, or 2 in one line."""
    bad = []
    for case, got in zip(cases, results, strict=False):
        stderr = got["stderr"]
        lines = [ln for ln in stderr.splitlines() if ln.strip()]
        if got["status"] not in (0, 1, 2):
            bad.append(f"{case['name']}: {got['status']} after {got['seconds']:.1f} s")
        elif "Traceback" in stderr or "internal error" in stderr:
            bad.append(f"{case['name']}: {lines[-1] if lines else ''}")
        elif got["status"] == 2 and len(lines) != 1:
            bad.append(f"{case['name']}: a usage error in {len(lines)} lines: {stderr[-300:]!r}")
        elif got["status"] == 1 and not lines:
            bad.append(f"{case['name']}: exit 1 without a word")
    return bad


def test_every_numeric_option_at_extreme_values(tmp_path):
    cases = _cases(_data(tmp_path), tmp_path, VALUES, lambda spec: spec.kind in NUMERIC)
    assert len(cases) > 1000  # the registry's every task and option: none left out
    start = time.perf_counter()
    results = aldpat_batch(cases, total=900)
    seconds = time.perf_counter() - start
    statuses = [r["status"] for r in results]
    print(f"{len(cases)} runs in {seconds:.1f} s: {statuses.count(0)} exit 0, {statuses.count(1)} exit 1, "
          f"{statuses.count(2)} exit 2")
    bad = _faults(cases, results)
    assert not bad, f"{len(bad)} of {len(cases)} runs:\n" + "\n".join(bad)


#: what a careless script passes as text: an empty value (an unset shell variable), a name no file
#: system takes, a superscript digit (a digit to ``str.isdigit``, not to ``int``)
TEXTS = ("", "9" * 400, "\u00b2")


def test_every_path_and_list_option_at_careless_texts(tmp_path):
    cases = _cases(_data(tmp_path), tmp_path, TEXTS, lambda spec: spec.path or spec.kind in ("floats", "ints"))
    assert len(cases) > 150
    bad = _faults(cases, aldpat_batch(cases, total=900))
    assert not bad, f"{len(bad)} of {len(cases)} runs:\n" + "\n".join(bad)
