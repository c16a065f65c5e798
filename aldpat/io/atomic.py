"""Never lose data: outputs appear complete or not at all.

Every writer writes to a temporary name beside the target and renames it into place only when
the content is complete (``os.replace`` is atomic on one file system). A crash, a bad input or
Ctrl-C leaves the old output (or nothing) -- never half a file.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from aldpat.errors import OutputError, OutputExistsError

TMP_MARK = ".aldpat-tmp"


def check_writable(path: Path, *, overwrite: bool) -> None:
    """Refuse an existing output without ``overwrite``; make sure its folder can be written."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise OutputExistsError("output exists (use --overwrite to replace it)", path=path)
    parent = path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create output folder: {exc.strerror or exc}", path=parent) from None
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError("output folder is not writable", path=parent)


def temp_name(path: Path) -> Path:
    """The temporary name used while ``path`` is being written (same folder, same suffix)."""
    path = Path(path)
    return path.with_name(f"{path.stem}{TMP_MARK}{os.getpid()}{path.suffix}")


@contextlib.contextmanager
def atomic_output(path: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; rename it to ``path`` when the block succeeds.

    The existence check is repeated at rename time so that a file created meanwhile by another
    process is not clobbered without ``overwrite``.
    """
    path = Path(path)
    check_writable(path, overwrite=overwrite)
    tmp = temp_name(path)
    try:
        yield tmp
        if path.exists() and not overwrite:
            raise OutputExistsError("output exists (use --overwrite to replace it)", path=path)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


@contextlib.contextmanager
def atomic_outputs(paths: list[Path], *, overwrite: bool = False) -> Iterator[list[Path]]:
    """Like :func:`atomic_output` for a set of files that belong together (.shp/.shx/.dbf).

    All are renamed only after the block succeeds.
    """
    paths = [Path(p) for p in paths]
    for p in paths:
        check_writable(p, overwrite=overwrite)
    tmps = [temp_name(p) for p in paths]
    try:
        yield tmps
        for t, p in zip(tmps, paths):
            if t.exists():
                os.replace(t, p)
    except BaseException:
        for t in tmps:
            with contextlib.suppress(OSError):
                t.unlink()
        raise
