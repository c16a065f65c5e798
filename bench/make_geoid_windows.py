"""Cut small windows of the EGM96 GTX grid around the NGA test points into tests/data/.

    python bench/make_geoid_windows.py [EGM96_15.gtx]   # default: data_paths.EGM96

Tests may only read files inside the repository, so each NGA EGM96 test point checked by the tests gets a
4 x 4 node window (0.75 degree a side) of the real 15-minute grid: a few hundred bytes each; so does
the middle of the ISPRS sites of the LAZ slices in tests/data (``egm96_15_isprs.gtx``, UTM 32N).
GTX layout: big-endian float64 lower-left latitude, lower-left longitude, dlat, dlon, big-endian
int32 rows, cols, then big-endian float32 rows from the south.
"""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from data_paths import EGM96

REPO = Path(__file__).resolve().parents[1]
SOURCE = EGM96
#: (latitude, longitude 0..360, N in metres): the NGA's EGM96 test values, shared with the tests
NGA_POINTS = [tuple(row) for row in np.loadtxt(REPO / "tests" / "data" / "egm96_nga_values.txt")]
#: window name -> (latitude, longitude) of its middle: CSite1 (48.785 N, 9.17 E) and FSite5
#: (48.937 N, 8.92 E), both inside one window
SITE_WINDOWS = {"isprs": (48.86, 9.04)}


def read_gtx(path: Path) -> tuple[tuple[float, float, float, float], np.ndarray]:
    raw = Path(path).read_bytes()
    lat0, lon0, dlat, dlon, rows, cols = struct.unpack(">4d2i", raw[:40])
    values = np.frombuffer(raw, dtype=">f4", count=rows * cols, offset=40).reshape(rows, cols)
    return (lat0, lon0, dlat, dlon), values


def write_gtx(path: Path, lat0: float, lon0: float, dlat: float, dlon: float, values: np.ndarray) -> None:
    rows, cols = values.shape
    path.write_bytes(struct.pack(">4d2i", lat0, lon0, dlat, dlon, rows, cols)
                     + np.ascontiguousarray(values, dtype=">f4").tobytes())


def cut(head, values: np.ndarray, lat: float, lon: float, size: int = 4):
    """The ``size`` x ``size`` window whose centre cell holds (lat, lon); longitudes wrap."""
    lat0, lon0, dlat, dlon = head
    lon = (lon - lon0) % 360.0 + lon0
    r = int(np.floor((lat - lat0) / dlat)) - size // 2 + 1
    c = int(np.floor((lon - lon0) / dlon)) - size // 2 + 1
    rows = np.arange(r, r + size)
    cols = np.arange(c, c + size) % values.shape[1]
    window = values[np.ix_(rows, cols)]
    wlon0 = lon0 + c * dlon
    wlon0 = (wlon0 + 180.0) % 360.0 - 180.0  # -180..180 so the window never straddles 360
    return lat0 + r * dlat, wlon0, window


def main(source: Path = SOURCE) -> None:
    head, values = read_gtx(source)
    out = REPO / "tests" / "data"
    out.mkdir(parents=True, exist_ok=True)
    for k, (lat, lon, _) in enumerate(NGA_POINTS, start=1):
        lat0, lon0, window = cut(head, values, lat, lon)
        target = out / f"egm96_15_nga{k}.gtx"
        write_gtx(target, lat0, lon0, head[2], head[3], window)
        print(target.relative_to(REPO), f"{target.stat().st_size} bytes", f"lower-left {lat0:g}, {lon0:g}")
    for name, (lat, lon) in SITE_WINDOWS.items():
        lat0, lon0, window = cut(head, values, lat, lon)
        target = out / f"egm96_15_{name}.gtx"
        write_gtx(target, lat0, lon0, head[2], head[3], window)
        print(target.relative_to(REPO), f"{target.stat().st_size} bytes", f"lower-left {lat0:g}, {lon0:g}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else SOURCE)
