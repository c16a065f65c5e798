"""Messages on stderr: ``aldpat: message``, with the level shown from ``-v`` on."""

from __future__ import annotations

import logging
import sys


def setup_logging(verbose: int, quiet: int) -> None:
    level = logging.WARNING - 10 * verbose + 10 * quiet
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("aldpat: %(levelname)s: %(message)s" if verbose else "aldpat: %(message)s"))
    root = logging.getLogger("aldpat")
    root.handlers[:] = [handler]
    root.setLevel(max(logging.DEBUG, min(level, logging.CRITICAL)))
    root.propagate = False
