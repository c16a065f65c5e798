"""What a path aldpat opens may be: a file of this machine's file systems, never a URL nor one of
GDAL's virtual file systems (``/vsicurl/``, ``/vsizip/``...), whoever gave it -- a command line,
a worksheet, a parameter file or a VRT's source list. A worksheet someone mails is data: opening
what it names may not reach the network or read through archives and raw-file drivers."""

from __future__ import annotations

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
