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
    pm2d,  # noqa: F401
    pmcircle,  # noqa: F401
    polynomial,  # noqa: F401
    slope,  # noqa: F401
)
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
