"""Where the benchmarks find the public data sets they read (one home for the locations).

The data are not in the repository (hundreds of MB); each is public:

* ``isprs/`` -- the ISPRS filter-test reference samples (Sithole & Vosselman 2004), one
  ``sampNN.txt`` each with ``x y z label`` per line (label 0 bare earth, 1 object);
* ``isprs-sites/`` -- the ISPRS test sites with first and last pulse, as LAZ
  (``FSite5_orig-utm.laz`` is used);
* ``geoid/egm96_15.gtx`` -- the NGA EGM96 geoid on a 15' grid.

They are looked for in ``$ALDPAT_DATA`` (default: a folder ``shared/data`` beside the
repository clone); ``$ALDPAT_ISPRS`` may point at the samples alone.
"""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("ALDPAT_DATA", REPO.parent / "shared" / "data"))
ISPRS_SAMPLES = Path(os.environ.get("ALDPAT_ISPRS", DATA / "isprs"))
ISPRS_SITES = DATA / "isprs-sites"
FSITE5 = ISPRS_SITES / "FSite5_orig-utm.laz"
EGM96 = DATA / "geoid" / "egm96_15.gtx"
