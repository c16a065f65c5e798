"""What the machine has to give, and the check every allocation that follows from the data or a
parameter passes before it is made.

A grid's size follows from the data's extent and the cell (three points 20 km apart at 1 m cells
ask for 400 million nodes); a chunked run's scratch from the chunks and their buffers. Asking the
system first and failing after minutes of swapping -- or after filling the disk -- is what a
user must never see: :func:`check_memory` and :func:`check_disk` compare the bytes a step will
hold with the memory available now (``MemAvailable`` of ``/proc/meminfo``, else what the system
reports free) and the free space of the folder it writes to, and refuse with one line saying how
much is asked, how much there is, and what to change.
"""

from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

from aldpat.errors import DataError


class ResourceError(DataError):
    """A step would need more memory or disk than the machine has (exit status 1)."""


def available_memory() -> int:
    """Bytes of memory a process may take now without the system swapping: ``MemAvailable``
    (Linux), else the free physical pages, within a cgroup's (container's) limit and the
    process's own (``ulimit -v``) where one is set."""
    available = _meminfo_available()
    if available is None:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):  # not on this system: assume a workstation's
            available = 8 << 30
    for room in (_cgroup_room(), _address_space_room()):
        if room is not None:
            available = min(available, room)
    return available


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_room() -> int | None:
    """What a cgroup v2 memory limit leaves (``memory.max`` less ``memory.current``)."""
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as fh:
            limit = fh.read().strip()
        if limit == "max":
            return None
        with open("/sys/fs/cgroup/memory.current", encoding="ascii") as fh:
            used = int(fh.read().strip())
        return max(0, int(limit) - used)
    except (OSError, ValueError):
        return None


def _address_space_room() -> int | None:
    """What ``ulimit -v`` or ``ulimit -d`` (RLIMIT_AS, RLIMIT_DATA) leaves this process, where one
    is set: past it every allocation fails whatever the machine has free."""
    try:
        import resource
    except ImportError:  # not on this system
        return None
    limits = []
    for which in (resource.RLIMIT_AS, getattr(resource, "RLIMIT_DATA", resource.RLIMIT_AS)):
        try:
            soft = resource.getrlimit(which)[0]
        except (OSError, ValueError):
            continue
        if soft != resource.RLIM_INFINITY and soft >= 0:
            limits.append(soft)
    if not limits:
        return None
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        used = 0
    return max(0, min(limits) - used)


def free_disk(folder: str | Path) -> int:
    """Free bytes of the file system ``folder`` (or its nearest existing parent) is on."""
    place = Path(folder).absolute()
    while not place.exists() and place.parent != place:
        place = place.parent
    try:
        return shutil.disk_usage(place).free
    except OSError:
        return 1 << 62  # cannot tell: let the writer report a full disk if it comes to that


def size_text(nbytes: float) -> str:
    """``2.1 GB``, ``640 MB``, ``12 kB``; astronomical sizes as powers of ten."""
    if not math.isfinite(nbytes) or nbytes >= 1e18:
        return f"{nbytes:.1e} bytes"
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.1f} {unit}"
    return f"{int(nbytes)} bytes"


def count_text(n: float) -> str:
    """``400 million``, ``3.2e+15``: a count as a person reads it."""
    if n >= 1e12 or not math.isfinite(n):
        return f"{n:.1e}"
    for word, scale in (("billion", 1e9), ("million", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {word}"
    return f"{int(n):,}"


#: The share of the memory available now one step may plan to take: the rest is for what the
#: estimate leaves out and for the other processes of a shared machine.
MEMORY_SHARE = 0.8


def check_memory(nbytes: float, what: str, change: str, *, path: str | Path | None = None) -> None:
    """Refuse a step that would hold ``nbytes`` when the memory available now is less (less
    :data:`MEMORY_SHARE` of it). ``what`` says what is allocated (``a 20001 x 20001 grid``),
    ``change`` what the user may change (``use a larger --cell``); ``path`` is the input, when
    known here (a job names its own otherwise)."""
    available = available_memory()
    if nbytes > available * MEMORY_SHARE:
        raise ResourceError(f"{what} needs {size_text(nbytes)} of memory and {size_text(available)} is available "
                            f"(one step takes at most {MEMORY_SHARE:.0%} of it); {change}", path=path)


def check_disk(nbytes: float, folder: str | Path, what: str, change: str, *, path: str | Path | None = None) -> None:
    """Refuse a step that would write ``nbytes`` into ``folder`` when its disk has less free."""
    free = free_disk(folder)
    if nbytes > free:
        raise ResourceError(f"{what} needs {size_text(nbytes)} of disk in {folder} and {size_text(free)} is free; "
                            f"{change}", path=path)
