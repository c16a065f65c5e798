"""Ground filters on a grid of lowest points, registered by name in FILTERS.

Importing this package imports every filter module so that :data:`FILTERS` is complete.
"""

# one import per filter module; each registers itself
from aldpat.filters import (
    atin,  # noqa: F401
    cluster_pm,  # noqa: F401
    etew,  # noqa: F401
    gapm,  # noqa: F401
    multipass,  # noqa: F401
    outlier,  # noqa: F401
    pm,  # noqa: F401
    polynomial,  # noqa: F401
    slope,  # noqa: F401
)
from aldpat.filters.classify import FilterResult  # noqa: F401
from aldpat.filters.driver import ground_filter  # noqa: F401
from aldpat.filters.marks import MARK_GROUND, MARK_INTERPOLATED  # noqa: F401
from aldpat.filters.options import GroundParams, PointFilterParams  # noqa: F401
from aldpat.filters.registry import FILTERS, FilterSpec, get_filter, register_filter  # noqa: F401
