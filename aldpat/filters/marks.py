"""The marks of the mark matrix (dissertation §5.2.2, Table 5-1) and the marks of points the
filters' own tests set aside: 0 for ground, else the (half) window size in cells at which a cell
was removed, or one of these values.
"""

from __future__ import annotations

#: Mark of a real cell kept as ground (dissertation Table 5-1).
MARK_GROUND = 0
#: Mark of an interpolated (empty) cell (dissertation Table 5-1); never written out as a point.
MARK_INTERPOLATED = -7777
#: Mark of a point that is not ground though no window removed it, so it gets the smallest window
#: a filter can use: every non-ground point of a point filter (``slope``, ``ipf``, ``poly2``,
#: ``atin``: they have no windows), a cell outside ``etew``'s [Min Z, Max Z], and a point of a
#: grid filter's ground cell that the final tests (``ground_tolerance``, the surface test) find
#: off the ground surface.
MARK_NON_GROUND = 1

#: Mark of a cell removed by the raised-segment test (an object larger than any window).
MARK_RAISED_SEGMENT = 9000
#: Mark of a point set aside as a low outlier before filtering.
MARK_LOW_OUTLIER = -9000
