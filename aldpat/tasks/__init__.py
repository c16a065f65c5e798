"""Every task module in this package registers itself on import.

Modules are discovered, not listed, so adding a task is adding one module (see
docs/ARCHITECTURE.md).
"""

import importlib
import pkgutil

from aldpat.tasks.base import TASKS, Task, get_task, register_task, run_task

for _info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if _info.name != "base" and not _info.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_info.name}")

__all__ = ["TASKS", "Task", "get_task", "register_task", "run_task"]
