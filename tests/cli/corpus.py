"""The bad-input corpus: files a user's disk really holds, each with what aldpat must do with it.

A case is either *refused* (the command fails for that input with one line naming the file, the
line where there is one, and what is wrong) or *accepted* (odd but valid: every point is
processed, none dropped, none invented). Point files come in two layouts: ``points`` (x y z
[intensity], read by most commands) and ``altm9`` (the 9-column tapes of split-tape and
separate-returns).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import laspy
import numpy as np
import pyproj

DEEP = 120_000  # data lines before the bad line of the "deep" cases: several reader chunks' worth


@dataclass
class Case:
    name: str
    path: Path
    refused: str | None = None  # regex the one stderr line must match; None: accepted
    count: int | None = None  # points in an accepted file


def _points(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = 500000 + rng.uniform(0, 60, n)
    y = 4000000 + rng.uniform(0, 60, n)
    z = 100 + 0.05 * (x - 500000) + rng.normal(0, 0.05, n)
    return np.c_[x, y, z, rng.integers(0, 255, n)]


def _lines(rows: np.ndarray, layout: str) -> list[str]:
    if layout == "altm9":
        t = np.arange(len(rows)) * 0.01 + 318000.0
        return [f"{ti:.2f} {x:.2f} {y:.2f} {z:.2f} {int(i)} {x:.2f} {y:.2f} {z + 0.4:.2f} {int(i)}"
                for ti, (x, y, z, i) in zip(t, rows)]
    return [f"{x:.2f} {y:.2f} {z:.2f} {int(i)}" for x, y, z, i in rows]


def _write(path: Path, lines: list[str], *, head: bytes = b"", newline: str = "\n") -> Path:
    path.write_bytes(head + newline.join(lines).encode("utf-8") + newline.encode())
    return path


def text_cases(folder: Path, layout: str = "points") -> list[Case]:
    """The text cases of the corpus, written into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = _points(400)
    good = _lines(rows, layout)
    ncols = 9 if layout == "altm9" else 4
    cases = [
        Case("empty file", _write(folder / "empty.txt", []), r"empty\.txt: file is empty"),
        Case("header only", _write(folder / "header only.txt", ["x y z intensity"]),
             r"header only\.txt: no numeric point lines"),
    ]
    deep = _lines(_points(DEEP + 10, seed=1), layout)
    ragged = deep.copy()
    ragged[DEEP] = " ".join(ragged[DEEP].split()[:-1])
    cases.append(Case("ragged line deep in a large file", _write(folder / "ragged.txt", ragged),
                      rf"ragged\.txt:{DEEP + 1}: expected {ncols} columns, found {ncols - 1}"))
    word = deep.copy()
    word[DEEP] = word[DEEP].replace(word[DEEP].split()[2], "12O.5", 1)
    cases.append(Case("non-numeric token deep in a large file", _write(folder / "token.txt", word),
                      rf"token\.txt:{DEEP + 1}: not a number: '12O\.5'"))
    nan = good.copy()
    nan[200] = nan[200].replace(nan[200].split()[3], "nan", 1)
    cases.append(Case("NaN coordinate", _write(folder / "nan.txt", nan), r"nan\.txt:201: non-finite value 'nan'"))
    inf = good.copy()
    inf[300] = inf[300].replace(inf[300].split()[2], "inf", 1)
    cases.append(Case("infinite coordinate", _write(folder / "inf.txt", inf), r"inf\.txt:301: non-finite value 'inf'"))
    huge = good.copy()
    huge[100] = huge[100].replace(huge[100].split()[2], "1e300", 1)
    cases.append(Case("1e300", _write(folder / "huge.txt", huge), r"huge\.txt:101: \w+ = 1e300 is not a plausible"))
    (folder / "binary.txt").write_bytes(bytes(range(256)) * 64)
    cases.append(Case("binary file named .txt", folder / "binary.txt", r"binary\.txt: not a text file"))
    latin_bad = good.copy()
    latin_bad[50] = latin_bad[50].replace(" ", " \xe9", 1)
    (folder / "latin1 value.txt").write_bytes("\n".join(latin_bad).encode("latin-1") + b"\n")
    cases.append(Case("Latin-1 byte inside a value", folder / "latin1 value.txt",
                      r"latin1 value\.txt:51: not a number"))
    # accepted: odd but valid
    cases.append(Case("byte-order mark", _write(folder / "bom.txt", good, head=b"\xef\xbb\xbf"), count=len(good)))
    (folder / "latin1 header.txt").write_bytes("# relevé 2007, hauteur en mètres\n".encode("latin-1")
                                               + "\n".join(good).encode() + b"\n")
    cases.append(Case("Latin-1 header line", folder / "latin1 header.txt", count=len(good)))
    mixed = [ln.replace(" ", "\t", 1).replace(" ", "  ", 1) if k % 3 == 0 else ln for k, ln in enumerate(good)]
    cases.append(Case("tabs mixed with spaces", _write(folder / "tabs.txt", mixed), count=len(good)))
    cases.append(Case("CRLF line ends", _write(folder / "crlf.txt", good, newline="\r\n"), count=len(good)))
    cases.append(Case("path with spaces and non-ASCII", _write(folder / "relevé été 2007.txt", good),
                      count=len(good)))
    return cases


def degenerate_cases(folder: Path, layout: str = "points") -> list[Case]:
    """Valid files with too little in them for some tasks: one point, every point the same."""
    folder.mkdir(parents=True, exist_ok=True)
    one = _lines(_points(1), layout)
    same = _lines(np.repeat(_points(1), 50, axis=0), layout)
    return [Case("one point", _write(folder / "one.txt", one), count=1),
            Case("all points identical", _write(folder / "same.txt", same), count=50)]


def _las(path: Path, n: int, *, point_format: int = 3, version: str = "1.2") -> Path:
    rows = _points(max(n, 1))[:n]
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([0.01, 0.01, 0.01])
    header.offsets = np.array([500000.0, 4000000.0, 0.0])
    header.add_crs(pyproj.CRS.from_epsg(32617))
    las = laspy.LasData(header)
    las.x, las.y, las.z = rows[:, 0], rows[:, 1], rows[:, 2]
    las.intensity = rows[:, 3].astype(np.uint16)
    las.classification = np.ones(n, np.uint8)
    if "gps_time" in las.point_format.dimension_names:
        las.gps_time = np.arange(n, dtype=float)
    las.write(path)
    return path


def las_cases(folder: Path) -> list[Case]:
    """The LAS/LAZ cases of the corpus (they apply to commands reading x y z points)."""
    folder.mkdir(parents=True, exist_ok=True)
    cases = []
    for ext in (".las", ".laz"):
        whole = _las(folder / f"whole{ext}", 3000).read_bytes()
        (folder / f"truncated{ext}").write_bytes(whole[: len(whole) // 2])
        (folder / f"whole{ext}").unlink()
        cases.append(Case(f"truncated {ext[1:].upper()}", folder / f"truncated{ext}",
                          rf"truncated{re.escape(ext)}: truncated"))
    path = _las(folder / "miscounted.las", 400)
    data = bytearray(path.read_bytes())
    data[107:111] = (300).to_bytes(4, "little")  # legacy point count: says 300 of 400
    path.write_bytes(bytes(data))
    cases.append(Case("LAS header counts fewer points than it holds", path,
                      r"miscounted\.las: header says 300 points, the file holds 400"))
    cases.append(Case("0-point LAS", _las(folder / "nopoints.las", 0), r"nopoints\.las: no points in file"))
    for fmt in (6, 7, 8, 9, 10):
        ext = ".laz" if fmt % 2 else ".las"
        cases.append(Case(f"LAS 1.4 point format {fmt}", _las(folder / f"format{fmt}{ext}", 400, point_format=fmt,
                                                                version="1.4"), count=400))
    return cases
