"""The bad-input corpus: files a user's disk really holds, each with what aldpat must do with it.

A case is either *refused* (the command fails for that input with one line naming the file, the
line where there is one, and what is wrong) or *accepted* (odd but valid: every point is
processed, none dropped, none invented). Point files come in two layouts: ``points`` (x y z
[intensity], read by most commands) and ``altm9`` (the 9-column tapes of split-tape and
separate-returns).
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
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
                for ti, (x, y, z, i) in zip(t, rows, strict=False)]
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
    # tokens Python's float takes and the file's reader does not: the message was pandas' own
    for name, token in (("underscore", "1_000"), ("arabic digits", "\u0661\u0662\u0663")):
        odd = good.copy()
        odd[250] = odd[250].replace(odd[250].split()[2], token, 1)
        file = name.replace(" ", "_") + ".txt"
        cases.append(Case(f"a number with {name}", _write(folder / file, odd),
                          rf"{file}:251: not a number: '{token}'"))
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
        name = f"truncated_{ext[1:]}{ext}"  # its own stem: the outputs of the two have their own names
        (folder / name).write_bytes(whole[: len(whole) // 2])
        (folder / f"whole{ext}").unlink()
        cases.append(Case(f"truncated {ext[1:].upper()}", folder / name, rf"{re.escape(name)}: truncated"))
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


# ------------------------------------------------------------------------------ hostile and careless
#
# Worksheets, parameter files, grids and command lines an attacker would mail, or a careless user
# would type: each with the exit status aldpat must end with (1: refused, 2: usage error, 0:
# accepted as harmless), the one stderr line that says why, and what must hold afterwards
# (nothing connected to, nothing written outside the output folder, no input replaced...).


@dataclass
class Hostile:
    category: str  # security, data loss, resources, LAS header
    name: str
    args: list  # aldpat's arguments
    cwd: Path
    status: int
    message: str | None = None  # regex one stderr line must match
    #: checked after the run: a description of what went wrong, or None
    holds: Callable[[], str | None] | None = None
    limit: float = 60.0  # seconds this case may take
    env: dict = field(default_factory=dict)


def _toml_text(value: str) -> str:
    return json.dumps(value)  # a JSON string is a TOML basic string for these (ASCII) values


def _worksheet(path: Path, jobs: list[dict], settings: dict | None = None) -> Path:
    lines = []
    if settings:
        lines.append("[settings]")
        lines += [f"{k} = {_toml_text(v) if isinstance(v, str) else json.dumps(v)}" for k, v in settings.items()]
    for job in jobs:
        lines.append("[[job]]")
        lines += [f"{k} = {_toml_text(v) if isinstance(v, str) else json.dumps(v)}" for k, v in job.items()]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _tiff(path: Path, values: np.ndarray) -> Path:
    import rasterio
    from rasterio.transform import from_origin

    with rasterio.open(path, "w", driver="GTiff", width=values.shape[1], height=values.shape[0], count=1,
                       dtype="float32", transform=from_origin(0, values.shape[0], 1, 1), nodata=-9999.0) as ds:
        ds.write(values.astype(np.float32), 1)
    return path


def _vrt(path: Path, band: str, size: int = 4) -> Path:
    path.write_text(f'<VRTDataset rasterXSize="{size}" rasterYSize="{size}">\n'
                    '  <GeoTransform>0.0, 1.0, 0.0, 4.0, 0.0, -1.0</GeoTransform>\n'
                    f"{band}\n</VRTDataset>\n", encoding="utf-8")
    return path


def _source(name: str, relative: bool = True) -> str:
    return ('  <VRTRasterBand dataType="Float32" band="1">\n    <ComplexSource>\n'
            f'      <SourceFilename relativeToVRT="{int(relative)}">{name}</SourceFilename>\n'
            "      <SourceBand>1</SourceBand>\n    </ComplexSource>\n  </VRTRasterBand>")


def _none_of(*paths: Path) -> Callable[[], str | None]:
    def check() -> str | None:
        there = [str(p) for p in paths if p.exists()]
        return f"written: {there}" if there else None
    return check


def _no_files(folder: Path) -> Callable[[], str | None]:
    """Nothing written in ``folder`` (a command refusing its input midway may have made it)."""
    def check() -> str | None:
        there = sorted(str(p) for p in folder.rglob("*") if p.is_file()) if folder.exists() else []
        return f"written: {there}" if there else None
    return check


def _no_png(folder: Path) -> Callable[[], str | None]:
    def check() -> str | None:
        pngs = sorted(str(p) for p in folder.rglob("*.png"))
        return f"a picture was written: {pngs}" if pngs else None
    return check


def security_cases(root: Path, port: int) -> list[Hostile]:
    """A worksheet, a parameter file or a grid may not make aldpat connect anywhere or read what
    the user did not name; what reaches HTML or a log reads back as itself. ``port``: a socket
    on this machine that must never be connected to."""
    root.mkdir(parents=True, exist_ok=True)
    points = _write(root / "points.txt", _lines(_points(60), "points"))
    address = f"tcp://127.0.0.1:{port}"
    cases = []
    ws = _worksheet(root / "sched-settings" / "w.toml", [{"task": "info", "inputs": [str(points)]}],
                    {"scheduler": address})
    cases.append(Hostile("security", "worksheet [settings] names a scheduler", ["run", ws], root, 2,
                         r"scheduler: .*comes from the worksheet's \[settings\].*--scheduler"))
    ws = _worksheet(root / "sched-job" / "w.toml", [{"task": "info", "inputs": [str(points)], "scheduler": address}])
    cases.append(Hostile("security", "a worksheet job names a scheduler", ["run", ws], root, 2,
                         r"job 1: scheduler: .*comes from the worksheet"))
    params = root / "sched-params" / "p.toml"
    params.parent.mkdir(parents=True)
    params.write_text(f"scheduler = {_toml_text(address)}\n", encoding="utf-8")
    ws = _worksheet(params.parent / "w.toml", [{"task": "filter", "algorithm": "pm", "inputs": [str(points)],
                                                "params": "p.toml", "odir": "out"}])
    cases.append(Hostile("security", "a worksheet's parameter file names a scheduler", ["run", ws], root, 2,
                         r"scheduler: .*comes from a parameter file", _none_of(params.parent / "out")))
    cases.append(Hostile("security", "a command's --params file names a scheduler",
                         ["filter", "pm", points, "--params", params, "--odir", root / "sched-params" / "cmd"], root, 2,
                         r"scheduler: .*comes from a parameter file", _none_of(root / "sched-params" / "cmd")))
    ws = _worksheet(root / "sched-many" / "w.toml", [{"task": "info", "inputs": [str(points)]}],
                    {"scheduler": "local:100000"})
    cases.append(Hostile("security", "a worksheet asks for 100,000 local workers", ["run", ws], root, 2,
                         r"local:N needs N from 1 to \d+"))
    ws = _worksheet(root / "sched-local" / "w.toml", [{"task": "info", "inputs": [str(points)]}], {"scheduler": "none"})
    cases.append(Hostile("security", "a worksheet's scheduler = none is harmless", ["run", ws], root, 0))

    # GDAL reads only grid files the user named
    grids = root / "grids"
    grids.mkdir()
    secret = grids / "secret.txt"
    secret.write_text("password=hunter2\n" * 8)
    _tiff(grids / "good.tif", np.arange(16.0).reshape(4, 4))
    _vrt(grids / "mosaic.vrt", _source("good.tif"))
    cases.append(Hostile("security", "a VRT mosaic of a local GeoTIFF is read", ["preview", grids / "mosaic.vrt",
                         "--odir", grids / "ok"], root, 0))
    raw = ('  <VRTRasterBand dataType="Byte" band="1" subClass="VRTRawRasterBand">\n'
           '    <SourceFilename relativeToVRT="1">secret.txt</SourceFilename>\n'
           "    <ImageOffset>0</ImageOffset><PixelOffset>1</PixelOffset><LineOffset>4</LineOffset>\n"
           "  </VRTRasterBand>")
    bad_vrts = {
        "raw band over a text file": (_vrt(grids / "raw.vrt", raw), r"raw\.vrt: .*VRTRawRasterBand"),
        "raw band in a file named .tif": (_vrt(grids / "raw-as.tif", raw), r"raw-as\.tif: is not a \.tif grid"),
        "/vsicurl/ source": (_vrt(grids / "curl.vrt", _source(f"/vsicurl/http://127.0.0.1:{port}/x.tif", False)),
                             r"curl\.vrt: VRT source .* is not a local file"),
        "http URL source": (_vrt(grids / "http.vrt", _source(f"http://127.0.0.1:{port}/x.tif", False)),
                            r"http\.vrt: VRT source .* is not a local file"),
        "zip member source": (_vrt(grids / "zip.vrt", _source("/vsizip/grids.zip/good.tif", False)),
                              r"zip\.vrt: VRT source .* is not a local file"),
        "driver connection string": (_vrt(grids / "hdf.vrt", _source(f"HDF5:{grids}/good.tif://x", False)),
                                     r"hdf\.vrt: VRT source .* is not a local file"),
        "nested VRT": (_vrt(grids / "nested.vrt", _source("raw.vrt")), r"nested\.vrt: source 'raw\.vrt' is not a grid"),
        "text file as a source": (_vrt(grids / "text.vrt", _source("secret.txt")), r"text\.vrt: source 'secret\.txt'"),
        "text file named .tif as a source": (_vrt(grids / "named.vrt", _source("secret.tif")),
                                             r"named\.vrt: source 'secret\.tif' is not a \.tif grid"),
        "derived band with a pixel function": (
            _vrt(grids / "derived.vrt", '  <VRTRasterBand dataType="Float32" band="1" subClass="VRTDerivedRasterBand">'
                 "\n    <PixelFunctionType>sum</PixelFunctionType>\n  </VRTRasterBand>"),
            r"derived\.vrt: .*VRTDerivedRasterBand"),
        "Python pixel function": (
            _vrt(grids / "python.vrt", '  <VRTRasterBand dataType="Float32" band="1">\n'
                 "    <PixelFunctionLanguage>Python</PixelFunctionLanguage>\n"
                 "    <PixelFunctionCode>import os</PixelFunctionCode>\n  </VRTRasterBand>"),
            r"python\.vrt: VRT element <PixelFunctionLanguage> is not allowed"),
        "entity expansion": (grids / "entities.vrt", r"entities\.vrt: VRT declares a DOCTYPE or entities"),
        "warped dataset": (grids / "warped.vrt", r"warped\.vrt: .*VRTWarpedDataset"),
    }
    (grids / "secret.tif").write_text("not a tiff\n")
    (grids / "entities.vrt").write_text('<?xml version="1.0"?>\n<!DOCTYPE lol [<!ENTITY a "aaaaaaaaaa">'
                                        '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>\n'
                                        '<VRTDataset rasterXSize="4" rasterYSize="4">&b;</VRTDataset>\n')
    (grids / "warped.vrt").write_text('<VRTDataset rasterXSize="4" rasterYSize="4" subClass="VRTWarpedDataset">'
                                      "<GDALWarpOptions/></VRTDataset>\n")
    for name, (path, message) in bad_vrts.items():
        cases.append(Hostile("security", f"preview of a VRT: {name}", ["preview", path, "--odir", grids / "out"],
                             root, 1, message, _no_png(grids / "out")))
    cases.append(Hostile("security", "a path parameter is a URL", ["grid", points, "--tile-params",
                         f"http://127.0.0.1:{port}/tile_parameter.txt", "--odir", root / "url"], root, 2,
                         r"tile_params: .* is a URL, not a local file", _none_of(root / "url")))
    cases.append(Hostile("security", "a path parameter is a /vsi path", ["ortho-height", points, "--crs", "17N",
                         "--geoid", f"/vsicurl/http://127.0.0.1:{port}/egm.gtx", "--odir", root / "vsi"], root, 2,
                         r"geoid: .* is a GDAL virtual file system path", _none_of(root / "vsi")))
    cases.append(Hostile("security", "an input is a /vsicurl/ path", ["info", f"/vsicurl/http://127.0.0.1:{port}/a.las"],
                         root, 1, r"/vsicurl/http://127\.0\.0\.1:\d+/a\.las: is a GDAL virtual file system path"))

    # names and values that reach HTML, a log or the replayable worksheet log read back as themselves
    odd = root / "names"
    odd.mkdir()
    js = _write(odd / "javascript:alert(document.domain).txt", _lines(_points(60), "points"))
    ws = _worksheet(odd / "report.toml", [{"task": "thin", "inputs": [js.name], "odir": "out", "cell": 2.0}],
                    {"report": True})

    def report_links() -> str | None:
        page = (odd / "report.html").read_text(encoding="utf-8")
        hrefs = re.findall(r'href="([^"]*)"', page)
        bad = [h for h in hrefs if not (h.startswith(("./", "file:")))]
        return f"links that are not plain paths: {bad}" if bad or not hrefs else None
    cases.append(Hostile("security", "an input named javascript:... in the run report", ["run", ws], root, 0,
                         holds=report_links))
    injected = "_x\n[[job]]\ntask = \"info\"\ninputs = [\"a.txt\"]\n"
    for name, suffix in (("a newline and a [[job]]", injected), ("/../../", "/../../escaped"),
                         ("a backslash", "\\..\\x"), ("'..'", "..hidden"), ("an escape sequence", "_\x1b[31mred")):
        cases.append(Hostile("security", f"--suffix holding {name}",
                             ["thin", points, "--suffix", suffix, "--odir", root / "suffix" / "out"], root, 2,
                             r"suffix: .*(path separator or '\.\.'|control character)",
                             _none_of(root / "suffix")))
        ws = _worksheet(root / "suffix-ws" / "w.toml", [{"task": "thin", "inputs": [str(points)], "suffix": suffix,
                                                         "odir": "out"}])
        cases.append(Hostile("security", f"a worksheet's suffix holding {name}", ["run", ws], root, 2,
                             r"job 1: suffix: ", _none_of(root / "suffix-ws" / "out", root / "escaped")))
    newline_name = odd / "two\nlines.txt"
    newline_name.write_text("1 2 3\nnot a point\n")
    cases.append(Hostile("security", "a bad input whose name holds a newline", ["info", newline_name], root, 1,
                         r"two\\nlines\.txt:2: "))
    tricky = _write(odd / 'x"\n[[job]]\ntask = "info".txt', _lines(_points(60), "points"))
    ws = _worksheet(odd / "replay.toml", [{"task": "thin", "inputs": [tricky.name], "odir": "tricky", "cell": 2.0}])

    def log_replays() -> str | None:
        import tomllib

        log = tomllib.loads((odd / "replay.log").read_text(encoding="utf-8"))
        jobs = log.get("job", [])
        if len(jobs) != 1 or jobs[0]["inputs"] != [str(tricky)]:
            return f"the log replays other jobs: {jobs}"
        return None
    cases.append(Hostile("security", "an input name that would inject a job into the worksheet log", ["run", ws],
                         root, 0, holds=log_replays))

    # a CRS may name a grid by URL; with PROJ's network on (PROJ_NETWORK=ON in the user's
    # environment) PROJ would fetch it: aldpat reads local grids only
    geoid = Path(__file__).resolve().parents[1] / "data" / "egm96_15_isprs.gtx"
    grid_url = f"+proj=longlat +ellps=WGS84 +nadgrids=http://127.0.0.1:{port}/g.tif +type=crs"
    cases.append(Hostile("security", "ortho-height --to-crs naming a grid by URL, PROJ_NETWORK=ON",
                         ["ortho-height", points, "--crs", "32632", "--geoid", geoid, "--to-crs", grid_url,
                          "--odir", root / "proj-url"], root, 2, r"--to-crs: no transformation",
                         _none_of(root / "proj-url"), env={"PROJ_NETWORK": "ON"}))
    ws = _worksheet(root / "proj-url-ws" / "w.toml", [{"task": "ortho-height", "inputs": [str(points)], "crs": "32632",
                                                       "geoid": str(geoid), "to_crs": grid_url, "odir": "out"}])
    cases.append(Hostile("security", "a worksheet's to_crs naming a grid by URL, PROJ_NETWORK=ON", ["run", ws], root,
                         1, r"^aldpat: .*--to-crs: no transformation", _none_of(root / "proj-url-ws" / "out"),
                         env={"PROJ_NETWORK": "ON"}))
    return cases


def _digest(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def _unchanged(*paths: Path) -> Callable[[], str | None]:
    """What must hold: the files keep their content (and links stay links to what they were)."""
    before = {p: (_digest(p), os.readlink(p) if p.is_symlink() else None) for p in paths}

    def check() -> str | None:
        changed = [str(p) for p, (digest, link) in before.items()
                   if not p.exists() or _digest(p) != digest or (os.readlink(p) if p.is_symlink() else None) != link]
        return f"changed: {changed}" if changed else None
    return check


def _all(*checks: Callable[[], str | None]) -> Callable[[], str | None]:
    def check() -> str | None:
        return next((broken for broken in (c() for c in checks) if broken), None)
    return check


def _dead_pid() -> int:
    """The id of a process that has ended (of this host)."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def data_loss_cases(root: Path) -> list[Hostile]:
    """No output replaces an input (by name, link or hard link), nor another output of the run;
    logs never follow links nor touch files aldpat did not write; one run per worksheet; a killed
    run's scratch is swept."""
    root.mkdir(parents=True, exist_ok=True)
    rows = _lines(_points(300), "points")
    src = root / "src"
    src.mkdir()
    a = _write(src / "a.txt", rows)
    geoid = root / "geoid.gtx"
    geoid.write_bytes(__import__("struct").pack(">4d2i", -90.0, -180.0, 10.0, 10.0, 19, 37)
                      + np.full(19 * 37, -30.0, dtype=">f4").tobytes())
    polygon = root / "polygon.txt"
    polygon.write_text("499990,3999990\n500070,3999990\n500070,4000070\n499990,4000070\n")
    cases = []
    in_place = {
        "filter pm": ["filter", "pm"], "filter outlier": ["filter", "outlier"], "thin": ["thin"],
        "polygon-extract": ["polygon-extract", "--polygon", polygon],
        "ortho-height": ["ortho-height", "--crs", "17N", "--geoid", geoid], "convert": ["convert"],
        "strip-boundary": ["strip-boundary"],
    }
    for name, command in in_place.items():
        cases.append(Hostile("data loss", f"{name} --suffix '' --overwrite onto its input",
                             [*command, a, "--suffix", "", "--overwrite"], root, 2,
                             r"output .*a\.txt would replace the input .*a\.txt", _unchanged(a)))
    d1, d2 = root / "d1", root / "d2"
    for d in (d1, d2):
        d.mkdir()
        _write(d / "x.txt", rows)
    cases.append(Hostile("data loss", "two inputs of one name into one --odir", ["filter", "pm", d1 / "x.txt", d2 / "x.txt",
                         "--odir", root / "o", "--overwrite"], root, 2,
                         r"d1/x\.txt and .*d2/x\.txt would both write .*o/x_pm\.txt", _none_of(root / "o")))
    linked = root / "linked"
    linked.mkdir()
    (linked / "a_thin.txt").symlink_to(a)
    cases.append(Hostile("data loss", "the output name is a link to the input", ["thin", a, "--odir", linked,
                         "--overwrite"], root, 2, r"would replace the input .*a\.txt", _unchanged(a)))
    hard = root / "hard"
    hard.mkdir()
    os.link(a, hard / "a_thin.txt")
    cases.append(Hostile("data loss", "the output is a hard link of the input", ["thin", a, "--odir", hard,
                         "--overwrite"], root, 2, r"would replace the input .*a\.txt", _unchanged(a)))
    (root / "via").symlink_to(src)
    cases.append(Hostile("data loss", "--odir is a link to the input's folder", ["thin", a, "--odir", root / "via",
                         "--suffix", "", "--overwrite"], root, 2, r"would replace the input", _unchanged(a)))
    tiles = root / "tiles"
    tiles.mkdir()
    tile = _write(tiles / "tile_500000_4000000.txt", rows)
    cases.append(Hostile("data loss", "tile into the folder of the tiles it reads", ["tile", tile, "--width", "100",
                         "--height", "100", "--odir", tiles, "--overwrite"], root, 2, r"would replace the input",
                         _unchanged(tile)))
    # an output named after a device (``-o /dev/null --overwrite``) once renamed the finished file
    # onto it, and as root removed /dev/null; a pipe here stands for every name that is not a file
    specials = root / "specials"
    specials.mkdir()
    pipe, thin_pipe = specials / "pipe.txt", specials / "a_x.txt"  # the second: thin's output name
    for made in (pipe, thin_pipe):
        os.mkfifo(made)

    def still_a_pipe(path: Path) -> Callable[[], str | None]:
        return lambda: None if stat.S_ISFIFO(os.lstat(path).st_mode) else f"{path.name} was replaced"
    for name, command, named in [("merge -o", ["merge", a, "-o", pipe], pipe),
                                 ("grid --mosaic", ["grid", a, "--mosaic", pipe], pipe),
                                 ("thin's output", ["thin", a, "--odir", specials, "--suffix", "_x"], thin_pipe)]:
        cases.append(Hostile("data loss", f"{name} naming a pipe, --overwrite", [*command, "--overwrite"], root, 2,
                             r"is a device, a pipe or a socket, not a file: no output replaces one",
                             still_a_pipe(named)))
    # a mosaic named like an input's own grid once replaced that grid with a VRT of itself (exit 0)
    for command, grid in ((["grid"], "a_linear.grd"), (["dtm"], "a_dtm.tif")):
        into = root / f"mosaic-{command[0]}"
        cases.append(Hostile("data loss", f"{command[0]} --mosaic named like the input's own grid",
                             [*command, a, "--cell", "5", "--odir", into, "--mosaic", into / grid, "--overwrite"],
                             root, 2, rf"a\.txt and the run would both write .*{grid.replace('.', '[.]')}",
                             _no_files(into)))
    older = _write(root / "older.vrt", ["<VRTDataset/>"])
    cases.append(Hostile("data loss", "an existing --mosaic, no --overwrite: refused before any grid is made",
                         ["grid", a, "--cell", "5", "--odir", root / "mosaic-old", "--mosaic", older], root, 1,
                         r"older\.vrt: output exists", _all(_unchanged(older), _no_files(root / "mosaic-old"))))
    (specials / "folder.vrt").mkdir()
    cases.append(Hostile("data loss", "--mosaic naming a folder", ["grid", a, "--mosaic", specials / "folder.vrt",
                         "--overwrite"], root, 2, r"mosaic: .*folder\.vrt' is a folder; name a file"))
    cases.append(Hostile("data loss", "a polygon file that is also the output", ["polygon-extract", a, "--polygon",
                         root / "poly" / "a_poly.txt", "--odir", root / "poly", "--overwrite"], root, 2,
                         r"would replace the input .*a_poly\.txt"))
    (root / "poly").mkdir()
    (root / "poly" / "a_poly.txt").write_text(polygon.read_text())

    # logs: never through a link, never into a file aldpat did not write
    logs = root / "logs"
    logs.mkdir()
    survey = _write(logs / "survey.txt", rows)
    own_log = logs / "survey.log"
    own_log.write_text("the surveyor's own notes\n")
    cases.append(Hostile("data loss", "convert survey.txt beside the user's survey.log", ["convert", survey,
                         "--out-format", "laz"], root, 0, r"survey\.log is not a file aldpat wrote .*survey\.aldpat\.log",
                         _all(_unchanged(own_log), lambda: None if (logs / "survey.aldpat.log").exists() else "no log")))
    outside = root / "outside.txt"
    outside.write_text("not aldpat's\n")
    (logs / "survey_thin.log").symlink_to(outside)
    cases.append(Hostile("data loss", "the job log's name is a link", ["thin", survey], root, 0,
                         r"survey_thin\.log is not a file aldpat wrote \(or is a link\)",
                         _unchanged(outside, logs / "survey_thin.log")))
    sheet = _worksheet(logs / "survey.toml", [{"task": "thin", "inputs": ["survey.txt"], "odir": "ws", "cell": 2.0}],
                       {"report": True})
    own_page = logs / "survey.html"
    own_page.write_text("<html>the surveyor's page</html>\n")
    cases.append(Hostile("data loss", "aldpat run survey.toml beside the user's survey.log and survey.html",
                         ["run", sheet], root, 0, r"survey\.log is not a file aldpat wrote",
                         _unchanged(own_log, own_page)))

    kept = root / "kept"
    kept.mkdir()
    _write(kept / "k.txt", rows)
    sheet = _worksheet(kept / "k.toml", [{"task": "thin", "inputs": ["k.txt"], "odir": "out"}], {"overwrite": True})

    def logs_kept() -> str | None:
        import tomllib

        for name in ("k.log", "k.log.1"):
            if not (kept / name).exists() or len(tomllib.loads((kept / name).read_text())["job"]) != 1:
                return f"{name} missing or not the run's replayable log"
        return None
    cases.append(Hostile("data loss", "a worksheet run twice (first run)", ["run", sheet], root, 0))
    cases.append(Hostile("data loss", "a worksheet run twice keeps the first log", ["run", sheet], root, 0,
                         holds=logs_kept))

    # worksheets: no job replaces what another reads as an original, or another job's output
    ws = root / "ws"
    (ws / "raw").mkdir(parents=True)
    first = _write(ws / "a.txt", rows)
    _write(ws / "raw" / "a.txt", rows[:100])
    sheet = _worksheet(ws / "replace.toml", [{"task": "info", "inputs": ["a.txt"]},
                                             {"task": "thin", "inputs": ["raw/a.txt"], "odir": ".", "suffix": "",
                                              "overwrite": True}])
    cases.append(Hostile("data loss", "a worksheet job replaces what an earlier job reads", ["run", sheet], root, 2,
                         r"job 2: output .*a\.txt would replace .*a\.txt", _unchanged(first)))
    # nor the worksheet being run, nor a parameter file the run reads
    sheet = _worksheet(ws / "itself.toml", [{"task": "merge-boundary", "inputs": ["a.txt"], "output": "itself.toml",
                                             "overwrite": True}])
    cases.append(Hostile("data loss", "a worksheet job writes the worksheet itself", ["run", sheet], root, 2,
                         r"job 1: output .*itself\.toml would replace the worksheet itself", _unchanged(sheet)))
    params = ws / "p.toml"
    params.write_text("cell = 2.0\n")
    sheet = _worksheet(ws / "params.toml", [{"task": "thin", "inputs": ["a.txt"], "params": "p.toml", "odir": "pt"},
                                            {"task": "merge-boundary", "inputs": ["a.txt"], "output": "p.toml",
                                             "overwrite": True}])
    cases.append(Hostile("data loss", "a worksheet job writes another job's parameter file", ["run", sheet], root, 2,
                         r"job 2: output .*p\.toml would replace .*p\.toml, which job 1 reads", _unchanged(params)))
    own = ws / "own.toml"
    own.write_text('delimiter = "space"\n')
    cases.append(Hostile("data loss", "-o names the command's own --params file", ["merge-boundary", a, "-o", own,
                         "--params", own, "--overwrite"], root, 2, r"output .*own\.toml would replace the input",
                         _unchanged(own)))
    sheet = _worksheet(ws / "twice.toml", [{"task": "thin", "inputs": ["a.txt"], "odir": "t", "overwrite": True},
                                           {"task": "thin", "inputs": ["a.txt"], "odir": "t", "cell": 5.0,
                                            "overwrite": True}])
    cases.append(Hostile("data loss", "two worksheet jobs write one output", ["run", sheet], root, 2,
                         r"job 2: output .*t/a_thin\.txt is also written by job 1", _none_of(ws / "t")))
    sheet = _worksheet(ws / "chain.toml", [{"task": "thin", "inputs": ["a.txt"], "odir": "c"},
                                           {"task": "thin", "inputs": ["c/a_thin.txt"], "odir": "c", "cell": 5.0}])
    cases.append(Hostile("data loss", "a worksheet chaining job 2 on job 1's output is normal", ["run", sheet], root, 0))

    # one run per worksheet; a killed run's lock, temporaries and scratch are taken over and swept
    import json
    import socket

    from aldpat.io.atomic import HOST_TAG, process_started

    busy = root / "busy"
    busy.mkdir()
    _write(busy / "b.txt", rows)
    sheet = _worksheet(busy / "b.toml", [{"task": "thin", "inputs": ["b.txt"], "odir": "out"}])
    (busy / "b.lock").write_text(json.dumps({"aldpat": "worksheet lock", "pid": os.getpid(),
                                             "started": process_started(os.getpid()), "host": socket.gethostname(),
                                             "since": "now", "token": "x"}) + "\n")
    cases.append(Hostile("data loss", "a worksheet another run holds", ["run", sheet, "--resume"], root, 1,
                         rf"b\.toml: is being run by process {os.getpid()}", _none_of(busy / "out")))
    dead = root / "dead"
    dead.mkdir()
    _write(dead / "d.txt", rows)
    pid = _dead_pid()
    sheet = _worksheet(dead / "d.toml", [{"task": "grid", "inputs": ["d.txt"], "odir": "out", "cell": 5.0,
                                          "chunk": 20.0}])
    (dead / "d.lock").write_text(json.dumps({"aldpat": "worksheet lock", "pid": pid, "started": None,
                                             "host": socket.gethostname(), "since": "then", "token": "y"}) + "\n")
    (dead / "out").mkdir()
    scratch = dead / "out" / f".aldpat-scratch-{pid}-h{HOST_TAG}-abc123"
    (scratch / "aldpat-chunks-x").mkdir(parents=True)
    (scratch / "aldpat-chunks-x" / "chunk_0_0.bin").write_bytes(b"\0" * 4096)
    stale = dead / "out" / f"d.aldpat-tmp{pid}-1-h{HOST_TAG}.grd"
    stale.write_bytes(b"half")

    def swept() -> str | None:
        left = [p.name for p in (dead / "out").iterdir() if p.name.startswith(".aldpat") or "aldpat-tmp" in p.name]
        if left or (dead / "d.lock").exists() or not (dead / "out" / "d_linear.grd").exists():
            return f"left: {left}, lock {(dead / 'd.lock').exists()}"
        return None
    cases.append(Hostile("data loss", "a killed run's lock, temporaries and scratch", ["run", sheet, "--resume"], root,
                         0, holds=swept))
    return cases


def _far_points(path: Path, apart: float) -> Path:
    """Three points ``apart`` metres from each other: a grid of their extent at 1 m cells has
    (apart + 1)**2 nodes."""
    path.write_text(f"0 0 1\n{apart:.0f} 0 2\n0 {apart:.0f} 3\n", encoding="ascii")
    return path


def resources_cases(root: Path) -> list[Hostile]:
    """Every allocation that follows from the data or a parameter is checked before it is made
    (grid nodes, chunk copies, line length, file sizes, windows, counts in headers) and refused
    in one line naming the input and what to change; parameters at extremes are refused."""
    root.mkdir(parents=True, exist_ok=True)
    rows = _lines(_points(300), "points")
    a = _write(root / "a.txt", rows)
    far = _far_points(root / "far.txt", 2_000_000)  # 4e12 nodes at 1 m: no machine holds them
    out = root / "out"
    cases = [
        Hostile("resources", "grid on 3 points 2,000 km apart at 1 m cells", ["grid", far, "--cell", "1",
                "--grid-format", "geotiff", "--odir", out], root, 1,
                r"far\.txt: a 2000001 x 2000001 grid \(4\.0e\+12 nodes\) of 1 m cells needs 256\.0 TB of memory",
                _none_of(out), limit=30),
        Hostile("resources", "grid to Surfer 7 past its 2 GiB data section", ["grid", far, "--cell", "1", "--odir", out],
                root, 1, r"far\.txt: a grid of 2000001 x 2000001 nodes is too large for one Surfer 7 data section",
                _none_of(out), limit=30),
        Hostile("resources", "dtm on 3 points 2,000 km apart", ["dtm", far, "--cell", "1", "--odir", out], root, 1,
                r"far\.txt: a 2000001 x 2000001 grid .* needs .* of memory", _none_of(out), limit=30),
        Hostile("resources", "a filter's grid of 3 points 2,000 km apart names the file", ["filter", "pm", far,
                "--cell", "0.01", "--odir", out], root, 1, r"far\.txt: a \d+ x \d+ grid of 0\.01 m cells is too large",
                _none_of(out), limit=30),
        Hostile("resources", "grid --cell 1e-300", ["grid", a, "--cell", "1e-300", "--odir", out], root, 1,
                r"a\.txt: x .* at 1e-300 m cells would take .* nodes a side", _none_of(out), limit=30),
        Hostile("resources", "thin --cell 1e-15: columns past int64", ["thin", a, "--cell", "1e-15", "--odir",
                root / "thin-out"], root, 1, r"a\.txt: a point lies 5(\.\d+)?e\+20 cells of 1e-15 m from the origin in x",
                _no_files(root / "thin-out")),
        Hostile("resources", "grid --chunk 1 with a 40 m buffer", ["grid", a, "--chunk", "1", "--chunk-buffer", "40",
                "--odir", out], root, 2, r"--chunk 1 m with a 40 m buffer copies every point into 6,561 chunks",
                _none_of(out), limit=30),
        Hostile("resources", "filter --chunk 1 with its windows' buffer", ["filter", "pm", a, "--chunk", "1",
                "--odir", out], root, 2, r"error: --chunk 1 m with a \d+ m buffer copies every point", _none_of(out),
                limit=30),
        Hostile("resources", "grid --chunk at the cell: a chunk a node", ["grid", a, "--cell", "0.01", "--chunk", "0.01",
                "--chunk-buffer", "0", "--grid-format", "geotiff", "--odir", out], root, 2,
                r"cuts the input into [\d,]+ chunks or more \(at most 1,000,000\)", _none_of(out), limit=30),
        Hostile("resources", "filter slope --search-radius 1e9: a list of 4e18 cells", ["filter", "slope", a,
                "--search-radius", "1e9", "--odir", out], root, 2,
                r"search_radius: 1e\+09 m is 1e\+09 cells of 1 m; at most 1,000 cells", _none_of(out), limit=30),
        Hostile("resources", "--window-series-length 3000", ["filter", "pm", a, "--window-series-length", "3000",
                "--odir", out], root, 2, r"window_series_length: 3000 is out of range", _none_of(out)),
        Hostile("resources", "--window-series-length 200 past the widest window", ["filter", "pm", a,
                "--window-series-length", "200", "--odir", out], root, 2,
                r"window_series_length: 200 windows .* grow past 100,000 cells", _none_of(out)),
        Hostile("resources", "a half window of 2**31 cells", ["filter", "gapm", a, "--window-series", "1,2,2147483648",
                "--odir", out], root, 2, r"window_series: 2147483648 is out of range", _none_of(out)),
        Hostile("resources", "--params /dev/zero", ["filter", "pm", a, "--params", "/dev/zero", "--odir", out], root, 2,
                r"/dev/zero: TOML file larger than \d+ MB", _none_of(out), limit=30),
        Hostile("resources", "--polygon /dev/zero", ["polygon-extract", a, "--polygon", "/dev/zero", "--odir", out],
                root, 1, r"/dev/zero: polygon file larger than \d+ MB", _none_of(out), limit=30),
        Hostile("resources", "an option of a megabyte", ["thin", a, "--cell", "1" * 1_000_000], root, 2,
                r"cell: expected a finite number, got '1+\.\.\. \(1,000,002 characters\)"),
    ]
    # a tape split at an interval below its pulse spacing: a strip a shot, a file each
    tape = root / "every_shot.txt"
    t = 318000.0 + np.arange(10_001) * 0.01
    tape.write_text("".join(f"{ti:.2f} 500000.00 4000000.00 100.00 10 500000.00 4000000.00 100.40 12\n" for ti in t))
    cases.append(Hostile("resources", "split-tape --interval 1e-9: a strip a shot", ["split-tape", tape, "--interval",
                         "1e-9", "--odir", root / "strips"], root, 1,
                         r"every_shot\.txt: more than 10,000 strips at --interval 1e-09 s", _no_files(root / "strips")))
    # a file of one 4 MB line, a megabyte token on a later line, ten thousand columns
    one_line = root / "one_line.txt"
    one_line.write_text(" ".join(["1.5"] * 1_000_000) + "\n", encoding="ascii")
    cases.append(Hostile("resources", "a 4 MB file of one line", ["thin", one_line, "--odir", out], root, 1,
                         r"one_line\.txt: line 1 is longer than 65,536 bytes", _none_of(out)))
    token = _write(root / "token.txt", rows[:5] + ["7" * 1_000_000 + " 1 2 3"] + rows[5:])
    cases.append(Hostile("resources", "a megabyte token on line 6", ["thin", token, "--odir", root / "streamed"], root,
                         1, r"token\.txt:6: longer than 65,536 characters", _none_of(root / "streamed" / "token_thin.txt")))
    wide = _write(root / "wide.txt", [" ".join(["1.5"] * 10_000)] * 3)
    cases.append(Hostile("resources", "ten thousand columns", ["thin", wide, "--odir", out], root, 1,
                         r"wide\.txt:1: 10,000 columns", _none_of(out)))
    bad = _write(root / "bad_token.txt", ["x" * 50_000 + " 1 2"] + rows)
    cases.append(Hostile("resources", "a 50 kB header token is not echoed whole", ["thin", bad, "--odir", root / "kept"],
                         root, 0))
    # sizes in headers: a grid of 2**60 nodes, tile rows that are no numbers
    import struct

    huge = root / "huge.grd"
    with open(huge, "wb") as fh:
        fh.write(struct.pack("<iii", 0x42525344, 4, 1) + struct.pack("<ii", 0x44495247, 72)
                 + struct.pack("<ii8d", 2**30, 2**30, 0, 0, 1, 1, 0, 1, 0, 1.70141e38)
                 + struct.pack("<ii", 0x41544144, 32) + b"\0" * 32)
    cases.append(Hostile("resources", "a Surfer grid header of 2**60 nodes", ["grd2bin", huge, "--odir", out], root, 1,
                         r"huge\.grd: expected [\d,]+ node values, the file holds 4", _none_of(out)))
    tp = root / "tp_nan.txt"
    tp.write_text(f"{a} 500000 500100 4000000 4000100 100 100 10\nb.txt nan 500200 4000000 4000100 100 100 10\n")
    cases.append(Hostile("resources", "a NaN in a tile_parameter.txt row", ["grid", a, "--tile-params", tp,
                         "--odir", out], root, 1, r"tp_nan\.txt:2: a number of the row is not a coordinate",
                         _none_of(out)))
    # a list naming itself, and a worksheet of 3,000 jobs checked in linear time
    listed = root / "self.lst"
    listed.write_text(f"{a}\n@{listed}\n")
    cases.append(Hostile("resources", "an @list naming itself", ["info", f"@{listed}"], root, 1, r"self\.lst"))
    sheet = root / "many" / "w.toml"
    sheet.parent.mkdir()
    _write(sheet.parent / "in.txt", rows)
    sheet.write_text("".join(f'[[job]]\ntask = "thin"\ninputs = ["in.txt"]\nsuffix = "_t{i}"\n\n' for i in range(3000)))
    cases.append(Hostile("resources", "checking a worksheet of 3,000 jobs", ["run", sheet, "--dry-run", "-q"], root, 0,
                         limit=60))
    return cases


def _patched(source: Path, path: Path, offset: int, fmt: str, value) -> Path:
    """``source`` with the bytes at ``offset`` replaced by ``value`` packed as ``fmt``."""
    import struct

    data = bytearray(source.read_bytes())
    struct.pack_into(fmt, data, offset, value)
    path.write_bytes(bytes(data))
    return path


def las_header_cases(root: Path) -> list[Hostile]:
    """A LAS header is data: one that contradicts itself or the points is refused in one line;
    LAS 1.0 and 1.1 files are written as 1.2."""
    root.mkdir(parents=True, exist_ok=True)
    good = _las(root / "good.las", 400, point_format=1)
    out = root / "out"
    # LAS 1.2 header: x y z scales at 131, offsets at 155, max x at 179, min x at 187, the
    # legacy point count at 107, the minor version at 25
    broken = [
        ("x scale 0", "scale0.las", 131, "<d", 0.0, r"x scale 0 is not a positive number"),
        ("a negative y scale", "scaleneg.las", 139, "<d", -0.01, r"y scale -0\.01 is not a positive number"),
        ("a NaN x offset", "offnan.las", 155, "<d", float("nan"), r"x offset nan is not a coordinate"),
        ("a 1e300 y offset", "off1e300.las", 163, "<d", 1e300, r"y offset 1e\+300 is not a coordinate"),
        ("an extent of 2e12 m", "extent.las", 179, "<d", 2e12, r"x bounds .* are not coordinates"),
        ("an extent wider than the Earth", "earth.las", 179, "<d", 9e7, r"x bounds .* span more than the Earth"),
        ("the minimum above the maximum", "minmax.las", 187, "<d", 600000.0, r"x minimum 600000 is above its maximum"),
        ("four billion points in 20 kB", "count.las", 107, "<I", 2**32 - 1, r"truncated: header says 4294967295 points"),
        ("points outside the header's bounds", "tight.las", 179, "<d", 500010.0,
         r"point \d+ has x = .* outside the header's bounds"),
        # the header size at 94, the offset to the points at 96, the number of records at 100,
        # the point format at 104 (laspy read 2^32 - 1 records past the end: 24 GB)
        ("four billion variable length records", "vlrs.las", 100, "<I", 2**32 - 1,
         r"4,294,967,295 variable length records cannot fit in the \d+ bytes before the points"),
        ("the points past the end of the file", "offset.las", 96, "<I", 2**32 - 256,
         r"the points start at byte 4,294,967,040, outside"),
        ("a header of 65535 bytes", "hsize.las", 94, "<H", 65535, r"outside the header's 65535 bytes"),
        ("point format 99", "pf99.las", 104, "<B", 99, r"point format 99 is not one of LAS's 0-10"),
    ]
    cases = []
    for name, file, offset, fmt, value, message in broken:
        path = _patched(good, root / file, offset, fmt, value)
        for command in (["info"], ["filter", "pm"], ["grid", "--chunk", "20"]):
            cases.append(Hostile("LAS header", f"{' '.join(command)}: {name}", [*command, path, "--odir", out]
                                 if command != ["info"] else [*command, path], root, 1,
                                 rf"{re.escape(file)}: .*{message}", _no_files(out)))
    laz = root / "count.laz"
    laz.write_bytes(_las(root / "whole.laz", 400, point_format=1).read_bytes())
    _patched(laz, laz, 107, "<I", 2**32 - 1)
    cases.append(Hostile("LAS header", "a LAZ header counting 4 billion points", ["info", laz], root, 1,
                         r"count\.laz: truncated or a corrupt header: header says 4,294,967,295 points"))
    for minor in (0, 1):
        old = _patched(good, root / f"v1{minor}.las", 25, "<B", minor)

        def written_as_12(minor: int = minor) -> str | None:
            made = root / "written" / f"v1{minor}_thin.las"
            if not made.exists():
                return f"{made.name} not written"
            with laspy.open(made) as fh:
                version = str(fh.header.version)
            return None if version == "1.2" else f"{made.name} is LAS {version}"
        cases.append(Hostile("LAS header", f"LAS 1.{minor} is written as 1.2", ["thin", old, "--odir", root / "written"],
                             root, 0,
                             holds=written_as_12))
    return cases
