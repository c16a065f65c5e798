"""aldpat: batch airborne LiDAR processing, the ALDPAT tasks and research filters.

From Python (``docs/api.md``)::

    import aldpat
    is_ground = aldpat.ground("site.laz")            # numpy bool per point, True = ground
    dem = aldpat.dtm("site.laz", cell=1.0)           # a Raster: .array, .transform, .crs, .nodata
    dem.write("site_dtm.tif")
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

__all__ = ["AldpatError", "ParamError", "Raster", "__version__", "dtm", "ground"]

#: public name -> the module it lives in
_HOMES = {"ground": "aldpat.api", "dtm": "aldpat.api", "Raster": "aldpat.api",
          "AldpatError": "aldpat.errors", "ParamError": "aldpat.errors"}

if TYPE_CHECKING:
    from aldpat.api import Raster, dtm, ground
    from aldpat.errors import AldpatError, ParamError


def __getattr__(name: str) -> Any:
    # Loaded on first use: importing any module of the package runs this file first, and the
    # API imports the filters and tasks, which import much of the package (some of it this file,
    # for the version); loading it here at once would start every import of ``aldpat.core.x``
    # with the whole library, half-initialised modules importing each other.
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'aldpat' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    # what a user may call, without the helpers this file imports
    return sorted(set(__all__) | {name for name in globals() if name.startswith("__")})
