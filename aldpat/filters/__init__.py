"""Ground filters on a grid of lowest points, registered by name in FILTERS.

Importing this package imports every filter module so that :data:`FILTERS` is complete.
"""

# one import per filter module; each registers itself
from aldpat.filters import (
    atin,  # noqa: E402,F401
    cluster_pm,  # noqa: E402,F401
    etew,  # noqa: E402,F401
    gapm,  # noqa: E402,F401
    multipass,  # noqa: E402,F401
    outlier,  # noqa: E402,F401
    pm,  # noqa: E402,F401
    pm2d,  # noqa: E402,F401
    pmcircle,  # noqa: E402,F401
    polynomial,  # noqa: E402,F401
    slope,  # noqa: E402,F401
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
