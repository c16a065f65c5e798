"""Messages on stderr: ``aldpat: message``, with the level shown from ``-v`` on."""

from __future__ import annotations

import logging
import sys

from aldpat.errors import one_line


class OneLineFormatter(logging.Formatter):
    """Every message one line (:func:`aldpat.errors.one_line`): a file name holding a newline or
    a terminal escape is shown escaped, never as a second message or a coloured screen. Debug
    records (``-vv``: tracebacks) keep their lines."""

    def formatMessage(self, record: logging.LogRecord) -> str:
        if record.levelno > logging.DEBUG:
            record.message = one_line(record.message)
        return super().formatMessage(record)


def setup_logging(verbose: int, quiet: int) -> None:
    level = logging.WARNING - 10 * verbose + 10 * quiet
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(OneLineFormatter("aldpat: %(levelname)s: %(message)s" if verbose else "aldpat: %(message)s"))
    root = logging.getLogger("aldpat")
    root.handlers[:] = [handler]
    root.setLevel(max(logging.DEBUG, min(level, logging.CRITICAL)))
    root.propagate = False
