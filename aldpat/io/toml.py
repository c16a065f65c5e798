"""Reading TOML (worksheets and ``--params`` files) with one-line errors."""

from __future__ import annotations

import tomllib
from pathlib import Path

from aldpat.errors import InputMissingError, UsageError


def load_toml(path: str | Path) -> dict:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputMissingError("no such file", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"cannot read: {exc}", path=path) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        # tomllib says "... (at line 3, column 7)": keep the line as ours
        message = str(exc)
        line = None
        if "(at line " in message:
            try:
                line = int(message.split("(at line ", 1)[1].split(",", 1)[0])
                message = message.split(" (at line ", 1)[0]
            except ValueError:
                pass
        elif "(at end of document)" in message:
            line = max(1, len(text.splitlines()))
            message = message.replace(" (at end of document)", " at the end of the file")
        raise UsageError(f"TOML syntax error: {message}", path=path, line=line) from None
