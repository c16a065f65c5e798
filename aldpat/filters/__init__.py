"""Ground filters on a grid of lowest points, registered by name in FILTERS.

Importing this package imports every filter module so that :data:`FILTERS` is complete.
"""

from aldpat.filters.base import (  # noqa: F401
    FILTERS,
    MARK_GROUND,
    MARK_INTERPOLATED,
    FilterResult,
    FilterSpec,
    GroundParams,
    PointFilterParams,
    get_filter,
    ground_filter,
    register_filter,
)

# one import per filter module; each registers itself
from aldpat.filters import etew  # noqa: E402,F401
from aldpat.filters import pm  # noqa: E402,F401
from aldpat.filters import pm2d  # noqa: E402,F401
from aldpat.filters import pmcircle  # noqa: E402,F401
from aldpat.filters import outlier  # noqa: E402,F401
from aldpat.filters import cluster_pm  # noqa: E402,F401
from aldpat.filters import gapm  # noqa: E402,F401
from aldpat.filters import multipass  # noqa: E402,F401
from aldpat.filters import slope  # noqa: E402,F401
from aldpat.filters import polynomial  # noqa: E402,F401
from aldpat.filters import atin  # noqa: E402,F401
