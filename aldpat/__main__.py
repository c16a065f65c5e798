"""``python -m aldpat`` is the ``aldpat`` command."""

from aldpat.cli.main import main

main()
