"""Import heavy libraries when first used, not when ``aldpat`` starts.

Every command imports every task module to build its command line; the scientific libraries
those modules compute with (scipy, pyproj) would otherwise add most of a second to each
``aldpat`` invocation, even ``aldpat info`` on one small file. A module returned here is loaded
on its first attribute access (``importlib.util.LazyLoader``).
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType


def lazy_import(name: str) -> ModuleType:
    """``name`` as a module that is loaded when an attribute of it is first used."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    loader.exec_module(module)
    return module
