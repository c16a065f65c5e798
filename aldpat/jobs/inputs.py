"""Inputs as users give them: files, quoted globs, folders (their point files) and ``@list.txt``."""

from __future__ import annotations

import glob
from collections.abc import Iterable
from pathlib import Path

from aldpat.errors import AldpatError, InputMissingError
from aldpat.io.registry import EXTENSIONS


def _is_point_file(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in EXTENSIONS


def expand_inputs(items: Iterable[str | Path], base: Path | None = None) -> tuple[list[Path], list[AldpatError]]:
    """Files, quoted globs, folders (their point files) and ``@list.txt`` -> paths, errors.

    Relative items are taken from ``base`` (the worksheet's folder) when given. A pattern that
    matches nothing is an error for that item only; the others are still returned.
    """
    out: list[Path] = []
    errors: list[AldpatError] = []
    for raw in items:
        item = str(raw)
        if item.startswith("@"):
            listfile = _rooted(item[1:], base)
            try:
                lines = listfile.read_text(encoding="utf-8").splitlines()
            except OSError:
                errors.append(InputMissingError("cannot read input list", path=listfile))
                continue
            sub = [ln.strip() for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
            got, errs = expand_inputs(sub, listfile.parent)
            out += got
            errors += errs
            continue
        path = _rooted(item, base)
        if any(ch in item for ch in "*?["):
            matches = sorted(Path(p) for p in glob.glob(str(path), recursive=True))
            matches = [m for m in matches if m.is_file()]
            if not matches:
                errors.append(InputMissingError("no file matches this pattern", path=item))
            out += matches
        elif path.is_dir():
            files = sorted(p for p in path.iterdir() if _is_point_file(p))
            if not files:
                errors.append(InputMissingError("folder holds no point files", path=path))
            out += files
        elif path.exists():
            out.append(path)
        else:
            errors.append(InputMissingError("no such file", path=path))
    seen: set[Path] = set()
    unique = []
    for p in out:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique, errors


def _rooted(item: str, base: Path | None) -> Path:
    p = Path(item).expanduser()
    return p if p.is_absolute() or base is None else base / p
