"""Never lose data: outputs appear complete or not at all.

Every writer writes to a temporary name beside the target and renames it into place only when
the content is complete (``os.replace`` is atomic on one file system). A crash, a bad input or
Ctrl-C leaves the old output (or nothing) -- never half a file.

Without ``--overwrite`` the finished file is put in place with ``os.link``, which fails if the
name exists at that instant, so of two processes writing the same output one wins whole and the
other fails cleanly instead of silently replacing the first one's file.

A write that fails for a reason of the file system (disk full, quota, read-only) is reported
as an :class:`OutputError` naming the output and the reason, not as an internal error.
Temporary files and scratch folders (``--chunk``'s spills) carry the writing process's id and
host, so a later run tells a killed writer's leftovers (SIGKILL, power loss) from a live one's
-- on a shared file system too -- and removes them: the next time the same output is written,
when scratch is made in the same folder, and when a worksheet job runs again.
"""

from __future__ import annotations

import contextlib
import errno
import fnmatch
import hashlib
import itertools
import os
import re
import shutil
import socket
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from aldpat.errors import AldpatError, OutputError, OutputExistsError

TMP_MARK = ".aldpat-tmp"
#: this machine, as temporary names carry it: processes of other hosts (Dask workers on a shared
#: file system) cannot be judged from here
HOST_TAG = hashlib.sha1(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:8]
#: prefixes of scratch folders (``--chunk``'s spills, thin's buckets): ``<prefix><pid>-h<host>-<random>``
SCRATCH_PREFIXES = (".aldpat-scratch-", ".aldpat-spill-")

#: errno values that mean "the file system would not take the output"
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EPERM}
_serial = itertools.count(1)
#: below this many free bytes, a writer that fails without saying why is taken to have hit a full disk
_NEARLY_FULL = 1 << 20


def not_replaceable(path: Path) -> str | None:
    """What takes the name ``path`` when it is not a file or a link -- a folder, a device
    (``/dev/null``), a pipe or a socket -- else None. Renaming a finished output onto one would
    remove it (as root, ``/dev/null`` itself), so no output replaces one, ``--overwrite`` or not."""
    try:
        mode = os.lstat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISLNK(mode):
        return None
    return "a folder" if stat.S_ISDIR(mode) else "a device, a pipe or a socket"


def refuse_unreplaceable(path: Path) -> None:
    """:class:`OutputError` when :func:`not_replaceable` names what ``path`` is."""
    kind = not_replaceable(path)
    if kind is not None:
        raise OutputError(f"is {kind}, not a file: no output replaces one", path=path)


def check_writable(path: Path, *, overwrite: bool) -> None:
    """Refuse an existing output without ``overwrite``, and one whose name a folder, a device,
    a pipe or a socket takes; make sure its folder can be written."""
    path = Path(path)
    refuse_unreplaceable(path)
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
    """A new temporary name for writing ``path``: same folder and suffix, the writing process's
    id and host (so a killed writer's leftovers can be recognised) and a serial number (so two
    writers in one process never share a name)."""
    path = Path(path)
    return path.with_name(f"{path.stem}{TMP_MARK}{os.getpid()}-{next(_serial)}-h{HOST_TAG}{path.suffix}")


def shown_name(path: Path) -> str:
    """The name a user knows a file by: a temporary name (:func:`temp_name`) without its mark."""
    path = Path(path)
    stem, mark, _ = path.stem.partition(TMP_MARK)
    return f"{stem}{path.suffix}" if mark else path.name


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    except (OverflowError, ValueError):
        return False
    return True


def process_started(pid: int) -> int | None:
    """When process ``pid`` started, in the system's clock ticks since boot (Linux), to tell a
    process from a later one that took its id; None where the system does not say."""
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        return int(fields[19])  # field 22 of the line, counted after the command's closing bracket
    except (OSError, IndexError, ValueError):
        return None


_TMP_NAME = re.compile(re.escape(TMP_MARK) + r"(\d+)(?:-\d+)?(?:-h([0-9a-f]{8}))?(?:\.[^.]*)?$")
_SCRATCH_NAME = re.compile("^(?:" + "|".join(map(re.escape, SCRATCH_PREFIXES)) + r")(\d+)-h([0-9a-f]{8})-")


def _owner_gone(pid: int, host: str | None) -> bool:
    """A writer of this host (or of an older name, without one) whose process no longer exists."""
    return (host is None or host == HOST_TAG) and pid != os.getpid() and not process_alive(pid)


def _writer_gone(temporary: Path) -> bool:
    """A temporary output, or a scratch folder, whose writing process no longer exists (it was
    killed)."""
    m = _TMP_NAME.search(temporary.name) or _SCRATCH_NAME.match(temporary.name)
    return m is not None and _owner_gone(int(m.group(1)), m.group(2))


def _remove_if_gone(temporaries: Iterable[Path]) -> None:
    for p in temporaries:
        if not _writer_gone(p):
            continue
        with contextlib.suppress(OSError):
            if stat.S_ISDIR(os.lstat(p).st_mode):
                shutil.rmtree(p)
            else:
                p.unlink()


def scratch_dir(prefix: str, folder: str | Path) -> Path:
    """A new scratch folder ``<prefix><pid>-h<host>-<random>`` in ``folder`` (created if
    missing), after the scratch and temporaries killed writers left there are removed."""
    assert prefix in SCRATCH_PREFIXES
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries_in(folder)
    return Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-h{HOST_TAG}-", dir=folder))


#: the temporaries found in each folder at a job's first look (:func:`remove_stale_temporaries`)
_temporaries: dict[str, list[Path]] = {}


def forget_temporaries() -> None:
    """Look at the folders afresh: each job starts here, so that a writer killed before it is seen."""
    _temporaries.clear()


def remove_stale_temporaries(path: Path) -> None:
    """Remove temporaries of ``path`` whose writing process no longer exists (it was killed).

    A folder is listed once a job (:func:`forget_temporaries`), not once an output: the 30,000
    strips of a split tape, or a tile run's 20,000 tiles, listed their growing folder each."""
    path = Path(path)
    with contextlib.suppress(OSError):
        folder = os.path.abspath(path.parent)
        if folder not in _temporaries:
            _temporaries[folder] = list(path.parent.glob(f"*{TMP_MARK}*"))
        pattern = f"{glob_escape(path.stem)}{TMP_MARK}*{glob_escape(path.suffix)}"
        mine = [p for p in _temporaries[folder] if fnmatch.fnmatchcase(p.name, pattern)]
        _remove_if_gone(mine)


def remove_stale_temporaries_in(folder: Path) -> None:
    """Remove every temporary and scratch folder in ``folder`` whose writing process no longer
    exists; those of a process still writing are left to it."""
    with contextlib.suppress(OSError):
        found = list(Path(folder).glob(f"*{TMP_MARK}*"))
        for prefix in SCRATCH_PREFIXES:
            found += Path(folder).glob(f"{prefix}*")
        _remove_if_gone(found)


def glob_escape(text: str) -> str:
    return re.sub(r"([*?[])", r"[\1]", text)


def publish(tmp: Path, path: Path, *, overwrite: bool) -> None:
    """Put the finished ``tmp`` in place as ``path``; without ``overwrite`` never replace a file,
    and never what is not a file (:func:`not_replaceable`)."""
    refuse_unreplaceable(path)
    if overwrite:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)  # fails if ``path`` exists at this instant: no check-then-replace race
    except FileExistsError:
        raise OutputExistsError("output exists (use --overwrite to replace it; another process may "
                                "have written it meanwhile)", path=path) from None
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EXDEV, errno.EMLINK):
            raise
        # a file system without hard links: the best it allows
        if path.exists():
            raise OutputExistsError("output exists (use --overwrite to replace it)", path=path) from None
        os.replace(tmp, path)
        return
    os.unlink(tmp)


def as_output_error(exc: BaseException, path: Path) -> OutputError | None:
    """The one-line error for a write of ``path`` that failed with ``exc``, if the file system
    (not the data, not a bug) is why; ``None`` otherwise."""
    if isinstance(exc, AldpatError) or not isinstance(exc, Exception):
        return None
    reason = None
    if isinstance(exc, OSError) and exc.errno in _WRITE_ERRNOS:
        reason = os.strerror(exc.errno).lower()
    elif isinstance(exc, OSError) or type(exc).__name__ in ("LazrsError", "LaspyException"):
        # numpy ("Not enough free space to write ...") and the LAZ compressor ("Failed to call
        # write") do not always carry an errno
        if _free_bytes(path.parent) < _NEARLY_FULL or "free space" in str(exc).lower():
            reason = "no space left on device"
        elif isinstance(exc, OSError) and exc.filename is not None and Path(exc.filename).parent == path.parent:
            reason = (exc.strerror or str(exc)).lower()
    if reason is None:
        return None
    return OutputError(f"cannot write this output: {reason} (nothing was left behind)", path=path)


def _free_bytes(folder: Path) -> int:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return 1 << 62


@contextlib.contextmanager
def atomic_output(path: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; put it in place as ``path`` when the block succeeds.

    The existence check is made again when the file is put in place, atomically, so that a file
    created meanwhile by another process is not clobbered without ``overwrite``.
    """
    path = Path(path)
    check_writable(path, overwrite=overwrite)
    remove_stale_temporaries(path)
    tmp = temp_name(path)
    try:
        yield tmp
        publish(tmp, path, overwrite=overwrite)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        error = as_output_error(exc, path)
        if error is not None:
            raise error from None
        raise


@contextlib.contextmanager
def atomic_outputs(paths: list[Path], *, overwrite: bool = False) -> Iterator[list[Path]]:
    """Like :func:`atomic_output` for a set of files that belong together (.shp/.shx/.dbf).

    All are put in place only after the block succeeds; if one of them cannot be (another
    process wrote it meanwhile), those already placed are taken back, so the set stays whole.
    """
    paths = [Path(p) for p in paths]
    for p in paths:
        check_writable(p, overwrite=overwrite)
        remove_stale_temporaries(p)
    tmps = [temp_name(p) for p in paths]
    placed: list[Path] = []
    try:
        yield tmps
        for t, p in zip(tmps, paths, strict=False):
            if t.exists():
                publish(t, p, overwrite=overwrite)
                placed.append(p)
    except BaseException as exc:
        if not overwrite:
            for p in placed:  # ours: created by the link above an instant ago
                with contextlib.suppress(OSError):
                    p.unlink()
        for t in tmps:
            with contextlib.suppress(OSError):
                t.unlink()
        error = as_output_error(exc, paths[0])
        if error is not None:
            raise error from None
        raise
