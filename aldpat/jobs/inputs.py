"""Inputs as users give them: files, quoted globs, folders (their point files) and ``@list.txt``.

A folder given as an input is a project folder: besides its point files it holds what aldpat
wrote there (``tile_parameter.txt``, job logs, grids, reports, run state, files still being
written). Those are skipped without a word (patterns skip only what is never an input: hidden
files, files still being written, ``tile_parameter.txt``); any other file of a folder that is not
a point file is named in one line per folder and skipped, and the run goes on. A text file (``.txt .xyz .csv .pts``) is a point file when its first line of data -- after
blank, ``#`` and non-numeric header lines, as the text reader skips them -- holds three numbers
or more.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from aldpat.core.paths import expand_home, not_local
from aldpat.errors import SHOWN, AldpatError, InputFormatError, InputMissingError, NoSuchFile, shown
from aldpat.io.atomic import TMP_MARK
from aldpat.io.registry import EXTENSIONS
from aldpat.io.tile_parameters import PARAMETER_FILE
from aldpat.io.toml import read_limited

#: file names aldpat writes beside points that are not points
SIDE_NAMES = frozenset({PARAMETER_FILE})
#: extensions of what aldpat writes beside points (logs, reports, run state, grids, mosaics,
#: previews, shapefiles, parameter files) and of point-cloud index files (LAStools' .lax)
SIDE_SUFFIXES = frozenset({".log", ".html", ".json", ".toml", ".prj", ".vrt", ".tif", ".tiff", ".grd", ".flt",
                           ".hdr", ".asc", ".png", ".shp", ".shx", ".dbf", ".cpg", ".xml", ".lock", ".lax"})
#: bytes of a text file read to tell points from other text
_SNIFF_BYTES = 16384
#: names of skipped files listed in a folder's one line
_NAMED = 5
#: ``@list`` files naming ``@list`` files: at most this deep (a list naming itself, or two naming
#: each other, is refused as a cycle before that)
MAX_LIST_DEPTH = 16
#: the largest ``@list`` file read: ten million paths of a hundred characters
MAX_LIST_BYTES = 1 << 30
#: the most files one pattern may match (a project of a million tiles is far beyond any seen)
MAX_PATTERN_MATCHES = 1_000_000
#: walks of a pattern before giving up when folders vanish under it
PATTERN_ATTEMPTS = 3
_MAGIC = frozenset("*?[")


def never_an_input(path: Path) -> bool:
    """Hidden, still being written, or aldpat's tile index: skipped even where a pattern matches."""
    name = path.name.lower()
    return name.startswith(".") or TMP_MARK in name or name in SIDE_NAMES


def is_side_file(path: Path) -> bool:
    """A file aldpat writes beside points (grids are inputs of some tasks, but not a folder's)."""
    return never_an_input(path) or path.suffix.lower() in SIDE_SUFFIXES


def is_point_file(path: Path) -> bool:
    """A LAS/LAZ file by its extension; a text file by its first line of data."""
    fmt = EXTENSIONS.get(path.suffix.lower())
    if fmt is None:
        return False
    return fmt != "text" or _text_holds_points(path)


def _text_holds_points(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            sample = fh.read(_SNIFF_BYTES)
            more = bool(fh.read(1))
    except OSError:
        return True  # the reader will say why it cannot be read
    lines = sample.decode("utf-8", errors="replace").splitlines()
    if more:
        lines = lines[:-1]  # the last line may be cut short
    for line in lines:
        text = line.strip().lstrip("\ufeff")
        if not text or text.startswith("#"):
            continue
        fields = text.replace(",", " ").replace(";", " ").split()
        try:
            [float(f) for f in fields]
        except ValueError:
            continue  # a header line
        return len(fields) >= 3
    return more  # nothing but header lines so far: let the reader look further


def expand_inputs(items: Iterable[str | Path], base: Path | None = None,
                  skipped: list[str] | None = None,
                  gathered: set[Path] | None = None) -> tuple[list[Path], list[AldpatError]]:
    """Files, quoted globs, folders (their point files) and ``@list.txt`` -> paths, errors.

    Relative items are taken from ``base`` (the worksheet's folder) when given. A pattern that
    matches nothing is an error for that item only; the others are still returned. Files of a
    folder that are neither points nor aldpat's own side files are named in ``skipped`` (one
    line per folder), when given; the files found in folders and by patterns, not named one by
    one, are added to ``gathered``, when given.
    """
    out: list[Path] = []
    errors: list[AldpatError] = []
    _expand(items, base, skipped, out, errors, (), gathered)
    seen: set[Path] = set()
    unique = []
    for p in out:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique, errors


def _expand(items: Iterable[str | Path], base: Path | None, skipped: list[str] | None, out: list[Path],
            errors: list[AldpatError], lists: tuple[Path, ...], gathered: set[Path] | None) -> None:
    """:func:`expand_inputs` of ``items``, read from the ``@list`` files ``lists`` (outermost first)."""
    for raw in items:
        item = str(raw)
        why = not_local(item.removeprefix("@"))
        if why is not None:
            if len(item) > SHOWN or not item.strip():  # an empty or endless name is quoted, shortly
                errors.append(InputMissingError(f"input {shown(item)} is {why}"))
            else:
                errors.append(InputMissingError(f"is {why}", path=item))
            continue
        if item.startswith("@"):
            listfile = _rooted(item[1:], base)
            try:
                key = listfile.resolve()
            except (OSError, RuntimeError):  # a symlink loop
                key = listfile
            if key in lists:
                errors.append(InputFormatError("input list names itself (through "
                                               f"{' -> '.join(p.name for p in lists)})", path=listfile))
                continue
            if len(lists) >= MAX_LIST_DEPTH:
                errors.append(InputFormatError(f"input lists nested more than {MAX_LIST_DEPTH} deep", path=listfile))
                continue
            try:
                text = read_limited(listfile, MAX_LIST_BYTES, what="input list")
            except InputFormatError as exc:
                errors.append(exc)
                continue
            except OSError:
                errors.append(NoSuchFile("cannot read input list", path=listfile))
                continue
            sub = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
            _expand(sub, listfile.parent, skipped, out, errors, (*lists, key), gathered)
            continue
        path = _rooted(item, base)
        if any(ch in item for ch in "*?[") and not path.is_file():  # a file named "x[1].txt" is that file
            try:
                matches = sorted(m for m in pattern_files(path) if not never_an_input(m))
            except InputFormatError as exc:
                errors.append(exc)
                continue
            if not matches:
                errors.append(InputMissingError("no file matches this pattern", path=item))
            out += matches
            if gathered is not None:
                gathered.update(matches)
        elif path.is_dir():
            files, others = _folder_files(path)
            if others and skipped is not None:
                named = ", ".join(p.name for p in others[:_NAMED])
                more = f" and {len(others) - _NAMED} more" if len(others) > _NAMED else ""
                skipped.append(f"{path}: skipped {len(others)} file{'s' if len(others) > 1 else ''} that "
                               f"{'are' if len(others) > 1 else 'is'} not point data: {named}{more}")
            if not files:
                errors.append(InputMissingError("folder holds no point files", path=path))
            out += files
            if gathered is not None:
                gathered.update(files)
        elif path.is_file():
            out.append(path)
        elif path.exists():  # a pipe would block the batch until something writes to it
            errors.append(InputFormatError("is not a regular file (a pipe, a device or a socket)", path=path))
        else:
            errors.append(NoSuchFile("no such file", path=path))


def pattern_files(pattern: Path) -> list[Path]:
    """The files a pattern matches, as the shell's ``globstar`` finds them: ``**`` is any number of
    folders but never enters a linked folder (a link to a parent would make the walk endless),
    ``*`` and ``?`` skip hidden names unless the pattern's part starts with a dot. More than
    :data:`MAX_PATTERN_MATCHES` files is refused (:class:`InputFormatError`) as they are found."""
    parts = pattern.parts
    fixed = next((i for i, part in enumerate(parts) if _MAGIC & set(part)), len(parts))
    anchor, rest = Path(*parts[:fixed]) if fixed else Path("."), parts[fixed:]
    if not rest:
        return [pattern] if pattern.is_file() else []
    if not anchor.is_dir():
        return []
    if rest[-1] == "**":  # every file below, as glob's recursive "**" (a path's "**" lists folders)
        rest = (*rest, "*")
    hidden_asked = any(part.startswith(".") for part in rest)
    for _ in range(PATTERN_ATTEMPTS):
        found: list[Path] = []
        try:
            for match in anchor.glob("/".join(rest)):
                relative = match.parts[len(anchor.parts):] if fixed else match.parts
                if not hidden_asked and any(part.startswith(".") for part in relative):
                    continue
                if not match.is_file():
                    continue
                found.append(match)
                if len(found) > MAX_PATTERN_MATCHES:
                    raise InputFormatError(f"pattern matches more than {MAX_PATTERN_MATCHES:,} files; "
                                           "name fewer (a folder, or a narrower pattern)", path=pattern)
            return found
        except FileNotFoundError:
            # a folder removed while the walk went through it (another run's scratch folder
            # beside its outputs): the walk (pathlib's) stops there; walk again
            continue
        except OSError as exc:
            raise InputFormatError(f"cannot search for this pattern: {(exc.strerror or str(exc)).lower()}",
                                   path=pattern) from None
    raise InputFormatError(f"cannot search for this pattern: its folders kept changing while searched "
                           f"({PATTERN_ATTEMPTS} tries)", path=pattern)


def _folder_files(folder: Path) -> tuple[list[Path], list[Path]]:
    """A folder's point files, and its files that are neither points nor side files."""
    points: list[Path] = []
    others: list[Path] = []
    for p in sorted(folder.iterdir()):
        if not p.is_file() or is_side_file(p):
            continue
        (points if is_point_file(p) else others).append(p)
    return points, others


def _rooted(item: str, base: Path | None) -> Path:
    """``item`` with a leading ``~`` the home folder (:func:`aldpat.core.paths.expand_home`), from
    ``base`` when relative."""
    p = Path(expand_home(item))
    return p if p.is_absolute() or base is None else base / p
