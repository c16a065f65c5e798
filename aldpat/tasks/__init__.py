"""Every task module in this package registers itself on import.

Modules are discovered, not listed, so adding a task is adding one module (see
docs/ARCHITECTURE.md).
"""

import importlib
import pkgutil

from aldpat.jobs.registry import TASKS, Task, get_task, register_task
from aldpat.jobs.run import run_task

for _info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")

__all__ = ["TASKS", "Task", "get_task", "register_task", "run_task"]
