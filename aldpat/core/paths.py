"""What a path aldpat opens may be: a file of this machine's file systems, never a URL nor one of
GDAL's virtual file systems (``/vsicurl/``, ``/vsizip/``...), whoever gave it -- a command line,
a worksheet, a parameter file or a VRT's source list. A worksheet someone mails is data: opening
what it names may not reach the network or read through archives and raw-file drivers."""

from __future__ import annotations

import functools
import os
import re

#: ``http://``, ``s3://``, ``file://``...: a scheme
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")
#: ``/vsicurl/``, ``/vsizip/``, ``/vsimem/``... (``\\vsi...\\`` on Windows)
_VSI = re.compile(r"^[/\\]vsi[a-z0-9_]*([/\\]|$)", re.IGNORECASE)


#: the longest name of one file or folder the usual file systems take (bytes), and of a whole path
LONGEST_NAME = 255
LONGEST_PATH = 4096


def not_local(text: str) -> str | None:
    """Why ``text`` is not a local file path (``None`` when it is one): also an empty one (an
    unset shell variable: ``--odir "$OUT"``) and one no file system takes, which the system would
    refuse only when it is opened, in the middle of a run."""
    text = str(text).strip()
    if not text:
        return "empty, not a file name (an unset variable?)"
    if "\x00" in text:
        return "a name holding a NUL character, which no file name holds"
    encoded = os.fsencode(text)
    if len(encoded) > LONGEST_PATH or any(len(part) > LONGEST_NAME for part in encoded.split(b"/")):
        return f"longer than a file name can be ({LONGEST_NAME} bytes a name, {LONGEST_PATH} a path)"
    if _VSI.match(text):
        return "a GDAL virtual file system path (/vsi...), not a local file"
    if _URL.match(text):
        return "a URL, not a local file"
    return None


def names_folder(text: str) -> bool:
    """Whether ``text``, given where a file is wanted (``--mosaic``, ``-o``, ``--polygon``), names
    a folder: one that exists, or a name ending in a separator, ``.`` or ``..``."""
    text = str(text).strip()
    return text.endswith(("/", "\\")) or os.path.basename(text) in (".", "..") or os.path.isdir(text)


def expand_home(text: str) -> str:
    """``text`` with a leading ``~`` or ``~user`` the home folder, as a shell expands it on a command
    line; a ``~user`` this machine does not know stays as written, as a shell leaves it
    (``Path.expanduser`` raises RuntimeError for one: a traceback for a typo). ``$VAR`` is left as
    it is: what a worksheet or a parameter file names may not depend on the environment of whoever
    runs it."""
    return os.path.expanduser(text)


@functools.lru_cache(maxsize=1024)
def folds_case(folder: str) -> bool:
    """Whether names differing only in case name one file in ``folder`` (macOS's APFS and HFS+ and
    Windows' NTFS and FAT by default; Linux file systems do not), found without writing anything:
    a name with letters in the nearest folder that exists -- one of its entries, or else its own
    name in its parent -- is looked up with its case swapped. False where nothing tells (no name
    with letters, or nothing readable)."""
    at = os.path.abspath(folder)
    while not os.path.isdir(at) and os.path.dirname(at) != at:
        at = os.path.dirname(at)
    try:
        with os.scandir(at) as entries:
            for k, entry in enumerate(entries):
                if k >= 64:
                    break
                if entry.name.swapcase() != entry.name:
                    return _same_file(entry.path, os.path.join(at, entry.name.swapcase()))
    except OSError:
        pass
    while os.path.dirname(at) != at:
        name = os.path.basename(at)
        if name.swapcase() != name:
            return _same_file(at, os.path.join(os.path.dirname(at), name.swapcase()))
        at = os.path.dirname(at)
    return False


def _same_file(path: str, other: str) -> bool:
    try:
        return os.path.samefile(path, other)
    except OSError:
        return False
