"""Files aldpat writes beside the user's -- job logs, worksheet logs, run state, run reports, the
worksheet lock: recognised as aldpat's by what their first bytes say, never written through a
symbolic link, never appended to or replacing a file aldpat did not write.

A name is a guess: ``convert survey.txt`` writes ``survey.log``, and the user may already keep a
``survey.log`` of their own (or a link of that name pointing anywhere). Such a file is left as it
is and aldpat writes under the next free name of its own -- ``survey.aldpat.log``, then
``survey.aldpat-2.log``... -- saying so in a warning (:func:`own_place`). A worksheet log is kept
when the next run writes one: the earlier ones are rotated to ``.log.1`` ... ``.log.5``
(:func:`rotate`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
from pathlib import Path

#: what aldpat reads of a file to tell whether it wrote it
HEAD_BYTES = 4096
#: names tried after the first: ``stem.aldpat.ext``, ``stem.aldpat-2.ext`` ... ``stem.aldpat-9.ext``
OTHER_NAMES = 9
#: earlier worksheet logs kept (``.log.1`` the last)
KEEP = 5


def _head(path: Path) -> bytes | None:
    """The first bytes of a regular file that is not a link; None for a link, a folder, a device,
    or a file that cannot be read."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        return os.read(fd, HEAD_BYTES)
    finally:
        os.close(fd)


def is_ours(path: Path, marker: re.Pattern[bytes]) -> bool:
    """Whether ``path`` is a regular file (not a link) whose first bytes carry ``marker``."""
    head = _head(path)
    return head is not None and marker.search(head) is not None


def free_or_ours(path: Path, marker: re.Pattern[bytes]) -> bool:
    """Whether aldpat may write ``path``: nothing is there (not even a dangling link), or a file of
    its own."""
    try:
        os.lstat(path)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return is_ours(path, marker)


def other_names(path: Path) -> list[Path]:
    """``path`` and the names aldpat takes instead when it is the user's."""
    path = Path(path)
    stem, suffix = path.stem, path.suffix
    if path.name.endswith(".state.json"):
        stem, suffix = path.name[: -len(".state.json")], ".state.json"
    return [path] + [path.with_name(f"{stem}.aldpat{'' if k == 1 else f'-{k}'}{suffix}")
                     for k in range(1, OTHER_NAMES + 1)]


def own_place(path: Path, marker: re.Pattern[bytes]) -> tuple[Path, str | None]:
    """Where aldpat writes the side file meant for ``path``: there, when it is free or aldpat's;
    else the first of :func:`other_names` that is, with a warning saying so."""
    for candidate in other_names(path):
        if free_or_ours(candidate, marker):
            if candidate == Path(path):
                return candidate, None
            return candidate, (f"{path} is not a file aldpat wrote (or is a link): left as it is, "
                               f"written {candidate.name} instead")
    raise FileExistsError(errno.EEXIST, f"{path} and the names aldpat would use instead are other files", str(path))


def append(path: Path, text: str, marker: re.Pattern[bytes]) -> tuple[Path, str | None]:
    """Append ``text`` (which begins with ``marker`` when it starts a file) to aldpat's side file
    meant for ``path``; return where it went and a warning when that is not ``path``. The file
    is opened without following links and checked again once open, so a file put there meanwhile
    is not written to."""
    warning = None
    for candidate in other_names(path):
        if not free_or_ours(candidate, marker):
            continue
        try:
            fd = os.open(candidate, os.O_RDWR | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
        except OSError as exc:
            if exc.errno in (errno.ELOOP, errno.EISDIR):  # a link or a folder put there meanwhile
                continue
            raise
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode) or (st.st_size and not marker.search(os.pread(fd, HEAD_BYTES, 0))):
                continue  # closed below: someone else's file, put there after the check
            os.write(fd, (("\n" if st.st_size else "") + text).encode("utf-8"))
        finally:
            os.close(fd)
        if candidate != Path(path):
            warning = (f"{path} is not a file aldpat wrote (or is a link): left as it is, "
                       f"written {candidate.name} instead")
        return candidate, warning
    raise FileExistsError(errno.EEXIST, f"{path} and the names aldpat would use instead are other files", str(path))


def rotate(path: Path, marker: re.Pattern[bytes], keep: int = KEEP) -> None:
    """Keep aldpat's ``path`` as ``path.1`` (``path.1`` as ``path.2``... the oldest of ``keep``
    dropped) before a new one is written. Files that are not aldpat's are never moved nor
    removed: the rotation stops short of them."""
    path = Path(path)
    if not is_ours(path, marker):
        return
    slots = [path] + [path.with_name(f"{path.name}.{k}") for k in range(1, keep + 1)]
    if is_ours(slots[-1], marker):
        with contextlib.suppress(OSError):
            os.unlink(slots[-1])
    for k in range(keep - 1, -1, -1):
        if is_ours(slots[k], marker) and not os.path.lexists(slots[k + 1]):
            with contextlib.suppress(OSError):
                os.rename(slots[k], slots[k + 1])
