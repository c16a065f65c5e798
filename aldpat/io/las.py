"""LAS and LAZ through laspy (LAZ with the lazrs backend).

Reading streams with laspy's ``chunk_iterator``. Each chunk carries its laspy point record, so a
task that keeps, drops or reclassifies points writes every other attribute back untouched, with
the source's point format, scale, offset and VLRs (CRS included).

A CRS goes into a header as the LAS 1.4 specification (R15, section 2.5 and 2.6) has it: OGC WKT
(WKT1, the WKT VLR and the global-encoding WKT bit) for point formats 6-10, GeoTIFF keys for
formats 0-5. GeoTIFF keys as laspy writes them hold an EPSG-coded horizontal CRS only, so a CRS
with a vertical datum (a compound CRS) needs WKT, hence LAS 1.4 and formats 6-10
(:func:`as_las14`); a CRS neither can hold is refused in one line (:func:`set_crs`).
"""

from __future__ import annotations

import copy
import logging
import math
import os
import struct
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from aldpat.core import units
from aldpat.core.height_codes import ScaledHeights
from aldpat.core.resources import check_memory, count_text
from aldpat.errors import DataError, InputFormatError, InputMissingError, UnstorableValue, UsageError
from aldpat.io.prefetch import read_ahead
from aldpat.io.table import PointTable
from aldpat.io.text import MAX_COORDINATE
from aldpat.io.textfmt import COORDINATE_DECIMALS, decimal_places

if TYPE_CHECKING:
    import laspy

log = logging.getLogger(__name__)

DEFAULT_CHUNK = 2_000_000
#: table column -> LAS dimension for the columns a task may set
LAS_DIMENSIONS = {"x": "x", "y": "y", "z": "z", "intensity": "intensity", "class": "classification",
                  "classification": "classification", "t": "gps_time", "gps_time": "gps_time",
                  "return_number": "return_number", "number_of_returns": "number_of_returns"}
#: the widest x or y range a header may declare: the Earth's circumference (in metres; degrees and
#: feet stay far below it in any CRS)
MOST_EXTENT = 4.1e7
_READ_DIMS = ("intensity", "classification", "return_number", "number_of_returns", "gps_time")
#: The extra-byte dimension marking the buffer points of a tile (``aldpat tile``): 1 for a copy of
#: a point of a neighbouring tile's core, 0 for the tile's own. Neither a class nor the withheld
#: flag, which the filters read as "leave out of the ground search": buffer points take part in it.
BUFFER_DIMENSION = "tile_buffer"
#: extra-byte dimension -> the description written in its extra-bytes record (32 characters at most)
EXTRA_DESCRIPTIONS = {BUFFER_DIMENSION: "1: buffer, a neighbour's point"}
#: the user id of a COPC file's records (its info VLR and its hierarchy EVLR; COPC 1.0, section 3)
COPC_USER = "copc"
#: The return columns of a point table and the LAS dimensions they set.
RETURN_DIMENSIONS = ("return_number", "number_of_returns")
#: point format -> what its records hold beyond the fields every format has, and its record's bytes
#: (LAS 1.4 R15, tables 7-17)
FORMAT_FIELDS = {0: (frozenset(), 20), 1: (frozenset({"time"}), 28), 2: (frozenset({"colour"}), 26),
                 3: (frozenset({"time", "colour"}), 34), 4: (frozenset({"time", "wave"}), 57),
                 5: (frozenset({"time", "colour", "wave"}), 63), 6: (frozenset({"time"}), 30),
                 7: (frozenset({"time", "colour"}), 36), 8: (frozenset({"time", "colour", "infrared"}), 38),
                 9: (frozenset({"time", "wave"}), 59), 10: (frozenset({"time", "colour", "infrared", "wave"}), 67)}
#: degrees of one unit of a LAS 1.4 scan angle (formats 6-10); formats 0-5 store whole degrees
SCAN_ANGLE_UNIT = 0.006


def generating_software() -> str:
    """What a LAS header written here names as its generating software (32 characters at most)."""
    from aldpat import __version__

    return f"aldpat {__version__}"[:32]


#: LAS header fields (LAS 1.4 R15, Table 3): header size, offset to the point data, number of
#: variable length records; from LAS 1.4, the start of the first extended one and their number
_HEADER_SIZES = struct.Struct("<HII")
_EVLR_PLACE = struct.Struct("<QI")
#: a variable length record's header (54 bytes) and an extended one's (60): the length of what
#: follows each sits at byte 20
_VLR_HEADER, _EVLR_HEADER = 54, 60


def check_record_layout(path: Path) -> None:
    """Refuse (:class:`InputFormatError`) a LAS/LAZ whose header places its variable length
    records where the file cannot hold them, before laspy reads them: it reads as many records as
    the header counts, past the end of the file, and a header counting 2^32 - 1 of them took
    24 GB and ten minutes. The records are walked by their headers alone (no record is read)."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(375)
        if len(head) < 227 or head[:4] != b"LASF":
            return  # laspy says what is wrong with it
        point_format = head[104] & 0x3F  # a LAZ sets the top bit (and some writers the next)
        if point_format > 10:
            raise InputFormatError(f"LAS header: point format {head[104]} is not one of LAS's 0-10", path=path)
        header_size, point_offset, vlr_count = _HEADER_SIZES.unpack_from(head, 94)
        if not header_size <= point_offset <= size:
            raise InputFormatError(f"LAS header: the points start at byte {point_offset:,}, outside the header's "
                                   f"{header_size} bytes and the file's {size:,}", path=path)
        if vlr_count * _VLR_HEADER > point_offset - header_size:
            raise InputFormatError(f"LAS header: {vlr_count:,} variable length records cannot fit in the "
                                   f"{point_offset - header_size:,} bytes before the points", path=path)
        _walk_records(fh, path, header_size, vlr_count, point_offset, _VLR_HEADER, "<H")
        if head[24:26] >= bytes((1, 4)) and len(head) >= 247:
            evlr_start, evlr_count = _EVLR_PLACE.unpack_from(head, 235)
            if evlr_count and (evlr_start > size or evlr_count * _EVLR_HEADER > size - evlr_start):
                raise InputFormatError(f"LAS header: {evlr_count:,} extended variable length records from byte "
                                       f"{evlr_start:,} cannot fit in the file's {size:,} bytes", path=path)
            _walk_records(fh, path, evlr_start, evlr_count, size, _EVLR_HEADER, "<Q")


def _walk_records(fh: BinaryIO, path: Path, start: int, count: int, end: int, header: int, length_format: str) -> None:
    """Each of ``count`` records from ``start`` must end by ``end``: its header, then as many bytes
    as the length at byte 20 of it says."""
    at = start
    for k in range(count):
        fh.seek(at + 2)
        raw = fh.read(18 + struct.calcsize(length_format))
        if len(raw) < 18 + struct.calcsize(length_format):
            raise InputFormatError(f"LAS header: variable length record {k + 1} starts past the end of the file",
                                   path=path)
        length = struct.unpack_from(length_format, raw, 18)[0]
        if raw[:16].rstrip(b"\0") == b"LASF_Spec" and struct.unpack_from("<H", raw, 16)[0] == 4:
            _check_extra_bytes(fh, path, at + header, length, k + 1)
        at += header + length
        if at > end:
            raise InputFormatError(f"LAS header: variable length record {k + 1} runs to byte {at:,}, past byte "
                                   f"{end:,} where it must end", path=path)


#: An Extra Bytes record's description of one dimension (LAS 1.4 R15, section 2.5.3 and table 24)
_EXTRA_BYTES_RECORD = 192


def _check_extra_bytes(fh: BinaryIO, path: Path, at: int, length: int, number: int) -> None:
    """Refuse, in one line, an Extra Bytes record (LAS 1.4 R15 §2.5.3) that describes no extra
    bytes a reader can lay out: a length not a whole number of 192-byte descriptions (read on, it
    shifted every record after it -- the CRS lost without a word, and two Extra Bytes records
    written), a reserved data type (31-255), or undocumented bytes (type 0) of no size."""
    where = f"LAS header: variable length record {number}, the Extra Bytes record,"
    if length % _EXTRA_BYTES_RECORD:
        raise InputFormatError(f"{where} is {length:,} bytes long, not a whole number of {_EXTRA_BYTES_RECORD}-byte "
                               "dimension descriptions", path=path)
    fh.seek(at)
    for d in range(min(length // _EXTRA_BYTES_RECORD, 341)):  # a VLR holds 65,535 bytes at most
        description = fh.read(_EXTRA_BYTES_RECORD)
        if len(description) < 4:
            return  # past the end: the walk says so
        data_type, options = description[2], description[3]
        if data_type > 30:
            raise InputFormatError(f"{where} gives its dimension {d + 1} the reserved data type {data_type} (0-30 "
                                   "are defined)", path=path)
        if data_type == 0 and options == 0:
            raise InputFormatError(f"{where} gives its dimension {d + 1} undocumented extra bytes of no size (data "
                                   "type 0 takes its number of bytes in its options)", path=path)


def _corrupt(path: Path, exc: Exception) -> InputFormatError:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return InputFormatError(f"truncated or corrupt LAS/LAZ ({text[:120]})", path=path)


class LasReader:
    format = "las"

    def __init__(self, path: str | Path, **_ignored: object) -> None:
        import laspy  # imported when used: it adds half a second to every command's start-up

        self.path = Path(path)
        if not self.path.exists():
            raise InputMissingError("no such file", path=self.path)
        check_record_layout(self.path)
        try:
            with laspy.open(self.path) as fh:
                self.header = fh.header
        except Exception as exc:  # noqa: BLE001  (laspy raises several unrelated types for bad files)
            raise _corrupt(self.path, exc) from None
        self.count = int(self.header.point_count)
        self._check_header()
        self._check_record_count()
        self.scales = tuple(float(s) for s in self.header.scales)
        try:
            self.crs = self.header.parse_crs()
        except Exception:  # noqa: BLE001  (a CRS record PROJ cannot read: the points are still usable)
            self.crs = None
        if self.crs is None and _crs_records(self.header) and str(self.path.resolve()) not in _UNREAD_CRS:
            # said, not passed over: ``info`` showed "crs unknown" for a file holding a CRS record
            # of nonsense, and its outputs were written without a CRS, as if it had none. Once a
            # file and process: ``dtm`` opens each tile for its extent, its pass and its neighbours
            _UNREAD_CRS.add(str(self.path.resolve()))
            log.warning("%s: its CRS record (%s) is no CRS PROJ can read: taken as none; give --crs to set one",
                        self.path, ", ".join(_crs_records(self.header)))
        self.names, self.decimals = _columns(self.header)

    def _check_header(self) -> None:
        """A header is data: refuse, in one line, one that contradicts itself -- scales that are
        not positive (every point at the offset, or mirrored), offsets or bounds that are no
        coordinates (NaN, 1e300: every x collapses to one value), bounds the wrong way round or
        wider than the Earth (the point counts: :meth:`_check_record_count`)."""
        h = self.header
        for axis, scale, offset in zip("xyz", h.scales, h.offsets, strict=False):
            if not (math.isfinite(scale) and scale > 0):
                raise InputFormatError(f"LAS header: {axis} scale {scale:g} is not a positive number", path=self.path)
            if not abs(offset) <= MAX_COORDINATE:  # NaN too
                raise InputFormatError(f"LAS header: {axis} offset {offset:g} is not a coordinate (a finite "
                                       f"number within +-{MAX_COORDINATE:g})", path=self.path)
        if self.count:
            for axis, low, high in zip("xyz", h.mins, h.maxs, strict=False):
                if not (abs(low) <= MAX_COORDINATE and abs(high) <= MAX_COORDINATE):
                    raise InputFormatError(f"LAS header: {axis} bounds {low:g} .. {high:g} are not coordinates "
                                           f"(finite numbers within +-{MAX_COORDINATE:g})", path=self.path)
                if low > high:
                    raise InputFormatError(f"LAS header: {axis} minimum {low:g} is above its maximum {high:g}",
                                           path=self.path)
                if axis != "z" and high - low > MOST_EXTENT:
                    raise InputFormatError(f"LAS header: {axis} bounds {low:g} .. {high:g} span more than the Earth's "
                                           "circumference", path=self.path)

    def check_within_header(self, cols: dict[str, np.ndarray], done: int) -> None:
        """Refuse decoded points outside the header's bounds (by more than a stored unit): a LAZ
        with damaged bytes inside a chunk decodes without an error, to points anywhere."""
        h = self.header
        for k, axis in enumerate("xyz"):
            values = cols[axis]
            if not len(values):
                continue
            slack = float(h.scales[k]) + 1e-9 * max(abs(float(h.mins[k])), abs(float(h.maxs[k])))
            outside = (values < h.mins[k] - slack) | (values > h.maxs[k] + slack)
            if outside.any():
                first = int(np.flatnonzero(outside)[0])
                raise InputFormatError(
                    f"point {done + first + 1:,} has {axis} = {values[first]:.10g}, outside the header's bounds "
                    f"{h.mins[k]:.10g} .. {h.maxs[k]:.10g}: corrupt data or a wrong header", path=self.path)

    def _check_record_count(self) -> None:
        """An uncompressed LAS whose header counts fewer records than it holds would lose the
        rest without a word (readers stop at the header's count), one that counts more would
        have them allocated before the reader finds the file short: refuse both. A LAZ file's
        count is bounded by its size (a point takes 0.007 bytes at the least: a million points,
        each the one before it)."""
        size = self.path.stat().st_size
        # by the header's compression bit, not the name: a LAZ file named .las is a LAZ file
        if getattr(self.header, "are_points_compressed", False) or self.path.suffix.lower() == ".laz":
            if self.count > size * 1024:
                raise InputFormatError(f"truncated or a corrupt header: header says {self.count:,} points, more than "
                                       f"the file's {size:,} bytes can hold", path=self.path)
            chunked = laz_chunk_points(self.path, self.header)
            if chunked is not None:
                least, most = chunked
                if self.count > most:
                    raise InputFormatError(f"truncated or a corrupt header: header says {self.count:,} points, its "
                                           f"compressed chunks hold at most {most:,}", path=self.path)
                if self.count < least:
                    raise InputFormatError(f"header says {self.count:,} points, its compressed chunks hold at least "
                                           f"{least:,}: the others would be lost", path=self.path)
            return
        end = int(getattr(self.header, "start_of_first_evlr", 0) or 0) or size
        record = int(self.header.point_format.size)
        held = max(0, end - int(self.header.offset_to_point_data)) // record if record else 0
        if held > self.count:
            raise InputFormatError(f"header says {self.count} points, the file holds {held} point records",
                                   path=self.path)
        if held < self.count:
            raise InputFormatError(f"truncated: header says {self.count} points, file holds {held}", path=self.path)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) as the header declares them."""
        mins, maxs = self.header.mins, self.header.maxs
        return float(mins[0]), float(mins[1]), float(maxs[0]), float(maxs[1])

    def height_codes(self) -> ScaledHeights | None:
        """How heights are stored: ``Z * scale + offset``, the integers :func:`z_codes` gives;
        ``None`` for a scale that is not positive (the integers' order is not the heights')."""
        scale = float(self.header.scales[2])
        return ScaledHeights(scale, float(self.header.offsets[2])) if scale > 0 else None

    def chunks(self, size: int = DEFAULT_CHUNK, *, only: Iterable[str] | None = None,
               ahead: bool = False) -> Iterator[PointTable]:
        """The file's points, ``size`` at a time. ``only``: the LAS dimensions the caller reads
        besides x, y and z (:data:`DECODED_LAYERS` names those it may ask for); the tables then
        hold just those columns, and a LAZ file of point formats 6-10 decodes just the layers
        holding them (LASzip's layered compression of those formats: no intensity, GPS time or colour
        decoded to find a grid's lowest points). Such a table is for reading: its record's other
        fields hold no data (the decoder repeats a compressed chunk's first point in them), and the
        writers refuse it. With ``ahead``, the next chunk is read on a thread while the caller
        works on this one (:func:`aldpat.io.prefetch.read_ahead`): a chunk more held, for a pass
        that holds little else."""
        chunks = self._chunks(size, only)
        return read_ahead(chunks) if ahead else chunks

    def _chunks(self, size: int, only: Iterable[str] | None) -> Iterator[PointTable]:
        if self.count == 0:
            raise InputFormatError("no points in file", path=self.path)
        import laspy

        names, selection, part = self.names, laspy.DecompressionSelection.all(), None
        if only is not None:
            wanted = set(only)
            names = tuple(n for n in self.names if n in ("x", "y", "z") or n in wanted)
            selection, part = decompression_selection(wanted), frozenset(names)
        done = 0
        try:
            with laspy.open(self.path, decompression_selection=selection) as fh:
                for chunk in fh.chunk_iterator(size):
                    table = _table(chunk, names, self.decimals)
                    if part is not None:
                        table.meta["decoded_only"] = part
                    self.check_within_header(table.columns, done)
                    done += len(chunk)
                    yield table
        except InputFormatError:
            raise
        except Exception as exc:  # noqa: BLE001  (laspy/lazrs raise several types for damaged data)
            raise _corrupt(self.path, exc) from None
        if done < self.count:
            raise InputFormatError(f"truncated: header says {self.count} points, file holds {done}",
                                   path=self.path)

    def read(self) -> PointTable:
        """The whole file as one table (one chunk: no concatenation, no second copy), told as
        the job's read pass (:mod:`aldpat.core.units`)."""
        check_memory(self.count * (int(self.header.point_format.size) + 8 * len(self.names)),
                     f"reading {count_text(self.count)} points whole", "use --chunk, or tile the data (aldpat tile)",
                     path=self.path)
        units.stage("read", self.count)
        table = next(iter(self.chunks(size=max(self.count, 1))))
        units.advance(len(table))
        return table


#: The layers of a LAZ file of point formats 6-10 (laspy's ``DecompressionSelection`` flags) that
#: hold each LAS dimension a caller of :meth:`LasReader.chunks` may ask for alone; x, y, z, the
#: returns and the scanner channel are always decoded.
DECODED_LAYERS = {
    "classification": "CLASSIFICATION",
    **dict.fromkeys(("synthetic", "key_point", "withheld", "overlap", "scan_direction_flag",
                     "edge_of_flight_line"), "FLAGS"),
    "intensity": "INTENSITY", "scan_angle": "SCAN_ANGLE", "user_data": "USER_DATA",
    "point_source_id": "POINT_SOURCE_ID", "gps_time": "GPS_TIME",
    **dict.fromkeys(("red", "green", "blue"), "RGB"), "nir": "NIR",
}


def decompression_selection(dimensions: Iterable[str]) -> Any:
    """laspy's selection of the LAZ layers holding ``dimensions`` (:data:`DECODED_LAYERS`): the
    coordinates, returns and channel always; every layer when one of them is not named there (an
    extra-bytes dimension, the waveform's). Files of point formats 0-5 are compressed point by
    point and decode whole whatever is selected."""
    import laspy

    flags = laspy.DecompressionSelection
    selection = flags.XY_RETURNS_CHANNEL | flags.Z
    for name in dimensions:
        if name in ("return_number", "number_of_returns", "scanner_channel"):
            continue
        if name not in DECODED_LAYERS:
            return flags.all()
        selection |= getattr(flags, DECODED_LAYERS[name])
    return selection


def _table(record: Any, names: tuple[str, ...], decimals: dict[str, int]) -> PointTable:
    """The table of a laspy point record: ``names`` (x, y, z as float64, then the attributes
    read), the record kept for the writers."""
    cols = {"x": np.asarray(record.x, dtype=np.float64),
            "y": np.asarray(record.y, dtype=np.float64),
            "z": np.asarray(record.z, dtype=np.float64)}
    for d in names[3:]:
        cols[d] = np.asarray(record[d])
    return PointTable(cols, record=record, meta={"decimals": decimals, "in_record": frozenset(cols)})


def las_table(las: laspy.LasData | laspy.ScaleAwarePointRecord) -> PointTable:
    """The points of a laspy ``LasData`` in memory as :meth:`LasReader.read` reads a file's; or of
    a point record alone (``las.points[keep]``, a selection a notebook makes), which carries the
    point format, scales and offsets a header would give."""
    if not hasattr(las, "header"):
        return _table(las, *_columns(las))
    return _table(las.points, *_columns(las.header))


def _columns(header: laspy.LasHeader | laspy.ScaleAwarePointRecord) -> tuple[tuple[str, ...], dict[str, int]]:
    """The columns read from a LAS file (x, y, z and the attributes tasks use), and the decimals
    its scales give x, y, z."""
    dims = set(header.point_format.dimension_names)
    names = ("x", "y", "z") + tuple(d for d in _READ_DIMS if d in dims)
    return names, dict(zip("xyz", stored_decimals(header.scales, header.offsets), strict=True))


def finest_scales(header: laspy.LasHeader, inputs: list[laspy.LasHeader]) -> np.ndarray:
    """Per axis, the finest of the inputs' scales where every input's coordinates are exact at it
    from ``header``'s offset (:func:`exact_axis`) and the 32-bit integers hold every input's
    extent from that offset; else ``header``'s own. A tile stored at 0.001 m merged (or tiled)
    after one at 0.01 m was rounded to centimetres (lasmerge and PDAL keep the first or a default
    scale): ``merge`` and ``tile`` write their points at these scales."""
    scales = np.array(header.scales, dtype=np.float64)
    lowest = np.min([h.mins for h in inputs], axis=0)
    highest = np.max([h.maxs for h in inputs], axis=0)
    for k in range(3):
        finer = min(float(h.scales[k]) for h in inputs)
        reach = max(float(highest[k]) - float(header.offsets[k]), float(header.offsets[k]) - float(lowest[k]))
        if finer < scales[k] and reach / finer < 2 ** 31 - 1 and all(
                exact_axis(float(h.scales[k]), float(h.offsets[k]), finer, float(header.offsets[k])) for h in inputs):
            scales[k] = finer
    return scales


def exact_axis(scale: float, offset: float, to_scale: float, to_offset: float) -> bool:
    """Whether a coordinate stored at ``scale`` from ``offset`` keeps every digit stored again at
    ``to_scale`` from ``to_offset`` (the scale a whole multiple of the other, the offsets apart by
    whole steps)."""
    ratio, shift = scale / to_scale, (offset - to_offset) / to_scale
    return ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) <= 1e-9 and abs(shift - round(shift)) <= 1e-6


def exact_at(header: laspy.LasHeader, template: laspy.LasHeader) -> bool:
    """Whether the coordinates stored under ``header`` keep every digit stored under ``template``'s
    scales and offsets."""
    return all(exact_axis(*axis) for axis in zip(header.scales, header.offsets, template.scales, template.offsets,
                                                   strict=True))


def stored_decimals(scales: Iterable[float], offsets: Iterable[float]) -> list[int]:
    """The decimals that write every x, y, z a LAS file stores at ``scales`` from ``offsets``
    exactly: the more of the scale's and the offset's (a scale of 0.025: 3)."""
    return [max(decimal_places(float(s)), decimal_places(float(o))) for s, o in zip(scales, offsets, strict=True)]


def buffer_marks(table: PointTable) -> np.ndarray | None:
    """Which points of a LAS chunk are a tile's buffer points (:data:`BUFFER_DIMENSION`); None
    when the file has no such mark."""
    record = table.record
    if record is None or BUFFER_DIMENSION not in record.point_format.dimension_names:
        return None
    return np.asarray(record[BUFFER_DIMENSION]) != 0


def z_codes(table: PointTable) -> np.ndarray:
    """The stored integers of a LAS chunk's heights (``z == Z * scale + offset``)."""
    assert table.record is not None, "a table read from LAS/LAZ"
    return np.asarray(table.record.Z)


def new_point_format(names: Iterable[str]) -> int:
    """The point format a LAS file made from non-LAS points gets: 6 (LAS 1.4) when they have a
    time, else 0."""
    return 6 if "t" in names or "gps_time" in names else 0


def needs_wkt(crs: Any) -> bool:
    """Whether ``crs`` can be recorded as WKT only (LAS 1.4, formats 6-10): a CRS with a vertical
    part, or one without the EPSG code laspy's GeoTIFF keys hold."""
    from laspy.vlrs.geotiff import create_geotiff_projection_vlrs

    if crs.is_compound or crs.is_vertical:
        return True
    try:
        create_geotiff_projection_vlrs(crs)
    except RuntimeError:  # laspy: "Projected CRS without epsg is not supported"...
        return True
    return False


#: The files whose unreadable CRS record this process has said (:class:`LasReader`).
_UNREAD_CRS: set[str] = set()
#: The GeoTIFF keys and WKT records of LAS's ``LASF_Projection`` user: record ids and names.
CRS_RECORDS = {34735: "GeoKeyDirectory", 2111: "OGC math transform WKT", 2112: "OGC coordinate system WKT"}


def _crs_records(header: laspy.LasHeader) -> list[str]:
    """The names of ``header``'s records that say its CRS (VLRs and EVLRs)."""
    return [CRS_RECORDS[r.record_id] for r in [*header.vlrs, *(header.evlrs or ())]
            if str(getattr(r, "user_id", "")).rstrip("\0") == "LASF_Projection" and r.record_id in CRS_RECORDS]


def set_crs(header: laspy.LasHeader, crs: Any) -> None:
    """Record ``crs`` in ``header`` in place of any CRS record: OGC WKT1 for point formats 6-10
    (PDAL and GDAL write WKT1, what LAS 1.4 readers parse), GeoTIFF keys for formats 0-5.

    Raises :class:`UsageError` when a format 0-5 header cannot hold ``crs`` (:func:`needs_wkt`).
    """
    import pyproj
    from laspy.vlrs.known import WktCoordinateSystemVlr

    if header.point_format.id < 6:
        if needs_wkt(crs):
            raise UsageError(f"CRS {crs.name!r} cannot be written in a LAS {header.version} point format "
                             f"{header.point_format.id} header (GeoTIFF keys hold an EPSG-coded horizontal CRS "
                             "only): give an EPSG code, or write LAS 1.4 point format 6-10")
        header.add_crs(crs)
        return
    header.add_crs(crs)  # removes every CRS record, then writes WKT2: replaced by WKT1 below
    header.vlrs.extract("WktCoordinateSystemVlr")
    try:
        wkt = crs.to_wkt(pyproj.enums.WktVersion.WKT1_GDAL)
    except pyproj.exceptions.CRSError:
        wkt = None
    # WKT2 for a CRS WKT1 cannot express (a dynamic datum's epoch...): what laspy writes
    header.vlrs.append(WktCoordinateSystemVlr(wkt or crs.to_wkt()))
    header.global_encoding.wkt = True


def _kept_records(header: laspy.LasHeader, replaced_crs: bool) -> list[Any]:
    """Prepare a source's header for an output, in place: its COPC info record dropped (the
    output's points are not in a COPC's order, and laspy writes no COPC); and return the extended
    VLRs (LAS 1.4 R15, section 2.5) the output keeps -- all but a COPC hierarchy, and but the CRS
    records when ``--crs`` replaced the source's. laspy writes EVLRs only when asked: a CRS a
    vendor stored in one was lost in every output."""
    from laspy.vlrs.vlrlist import VLRList

    def user(record: Any) -> str:
        return str(getattr(record, "user_id", "")).rstrip("\0")

    header.vlrs = VLRList([v for v in header.vlrs if user(v) != COPC_USER])
    return [record for record in header.evlrs or ()
            if user(record) != COPC_USER and not (replaced_crs and user(record) == "LASF_Projection")]


def holding_crs(header: laspy.LasHeader, crs: Any) -> laspy.LasHeader:
    """A copy of ``header`` recording ``crs`` (:func:`set_crs`): as LAS 1.4 (:func:`as_las14`,
    every attribute kept) when it is a format 0-5 header whose GeoTIFF keys cannot hold ``crs``."""
    header = as_las14(header) if header.point_format.id < 6 and needs_wkt(crs) else copy.deepcopy(header)
    set_crs(header, crs)
    return header


def as_las14(header: laspy.LasHeader) -> laspy.LasHeader:
    """A copy of ``header`` as LAS 1.4 with the point format of the same attributes (LAS 1.4 R15,
    section 2.6: 0, 1 -> 6; 2, 3 -> 7; 4 -> 9; 5 -> 10, the formats of :func:`holding_every` beside
    6; formats 6-10 kept), extra-byte dimensions and VLRs kept: the LAS :class:`LasWriter` writes a
    format 0-5 source's points into converts each attribute."""
    return with_point_format(header, holding_every((header.point_format.id, 6)))


def with_point_format(header: laspy.LasHeader, point_format_id: int) -> laspy.LasHeader:
    """A copy of ``header`` of point format ``point_format_id`` (LAS 1.4 for formats 6-10, else
    its own version, 1.2 at least), its extra-byte dimensions and VLRs kept."""
    import laspy

    header = copy.deepcopy(header)
    point_format = laspy.PointFormat(point_format_id)
    for dim in header.point_format.extra_dimensions:
        point_format.dimensions.append(dim)
    version = laspy.header.Version(1, 4) if point_format_id >= 6 \
        else max(header.version, laspy.header.Version(1, 2), key=lambda v: (v.major, v.minor))
    header.set_version_and_point_format(version, point_format)
    return header


def holding_formats_of(header: laspy.LasHeader, readers: list[LasReader], crs: Any,
                       note: Callable[[str], None], doing: str) -> laspy.LasHeader:
    """``header`` (of the first of ``readers``), or a copy of it of the point format of fewest bytes
    holding the attributes of every reader's points (:func:`holding_every`: formats 3 and 6 give
    7) where their formats differ, as a user asks PDAL's writer or las2las for; made LAS 1.4, its
    ``crs`` is then recorded as the WKT formats 6-10 take. Waveform packets point into their own
    file's waveform data, which the output does not hold: inputs with them are refused
    (:class:`DataError`) beside inputs of another format. Where the formats differ, ``note`` is
    told which format the output takes (``doing``: "written", "tiled")."""
    kinds = sorted({r.header.point_format.id for r in readers})
    if len(kinds) <= 1:
        return header
    waves = next((r for r in readers if "wave" in FORMAT_FIELDS[r.header.point_format.id][0]), None)
    if waves is not None:
        raise DataError(f"LAS inputs of point formats {kinds}: its point format {waves.header.point_format.id}'s "
                        "waveform packets point into its own waveform data, which the output does not hold; give "
                        "it with files of its own format only", path=waves.path)
    merged = holding_every(kinds)
    if merged != header.point_format.id:
        upgraded = merged >= 6 > header.point_format.id
        header = with_point_format(header, merged)
        if upgraded and crs is not None:
            set_crs(header, crs)  # formats 6-10 record their CRS as WKT, not in GeoTIFF keys
    note(f"LAS inputs of point formats {kinds} {doing} as point format {merged} (LAS {header.version}), which holds "
         "the attributes of each")
    return header


def say_mixed_gps_times(readers: list, template: laspy.LasHeader, warn: Callable[[str], None], doing: str) -> None:
    """A warning where LAS ``readers``' GPS times are of two kinds (seconds of the GPS week, or
    adjusted standard GPS time: the header's global encoding, LAS 1.4 R15 table 5): the output's
    header (``template``) says the first input's kind, and the others' times are copied as they
    are, not converted (``doing``: "merged", "tiled")."""
    kinds = {r.path.name: r.header.global_encoding.gps_time_type for r in readers
             if r.format == "las" and "gps_time" in r.header.point_format.dimension_names}
    if len(set(kinds.values())) > 1:
        other = next(name for name, kind in kinds.items() if kind != template.global_encoding.gps_time_type)
        warn(f"{other}: its GPS times are of another kind (week seconds or adjusted standard time) than the first "
             f"input's, which the {doing} header records; they are copied as they are, not converted")


def same_extra_dimensions(readers: list[LasReader], doing: str) -> None:
    """Refuse (:class:`DataError`, naming both files) LAS ``readers`` whose extra-byte dimensions
    differ from the first's -- in name, or in kind -- but for the buffer mark: their records go
    whole into one header's format (``doing``: "merged into one LAS file"), where a dimension one
    lacks was left out of the others' points, or made up as zeros for its own, and a later one's
    float32 0.75 was written into the first's int16 as 0 -- without a word."""
    first = readers[0]

    def extra(reader: LasReader) -> set[str]:
        return set(reader.header.point_format.extra_dimension_names) - {BUFFER_DIMENSION}

    own = extra(first)
    for reader in readers[1:]:
        theirs = extra(reader)
        if theirs != own:
            more, fewer = sorted(theirs - own), sorted(own - theirs)
            differ = "; ".join(part for part in (f"has {', '.join(more)}" if more else "",
                                                  f"lacks {', '.join(fewer)}" if fewer else "") if part)
            raise DataError(f"{differ} (extra bytes), unlike {first.path.name}: LAS inputs {doing} hold the same "
                            "extra dimensions", path=reader.path)
        for name in sorted(own):
            mine, their = _extra_kind(first, name), _extra_kind(reader, name)
            if mine != their:
                raise DataError(f"its extra dimension {name} is {their}, {mine} in {first.path.name}: LAS inputs "
                                f"{doing} hold the same extra dimensions", path=reader.path)


def _extra_kind(reader: LasReader, name: str) -> str:
    """An extra dimension's type as a message says it: ``float32``, ``3 x float64``, ``int16
    scaled 0.01``."""
    dim = reader.header.point_format.dimension_by_name(name)
    kind = f"{dim.num_elements} x {dim.dtype.base}" if dim.num_elements > 1 else str(dim.dtype)
    if dim.scales is not None or dim.offsets is not None:
        kind += f" scaled {np.asarray(dim.scales).tolist()} offset {np.asarray(dim.offsets).tolist()}"
    return kind


def common_columns(readers: list[LasReader]) -> tuple[str, ...]:
    """The first reader's columns that every reader has: of LAS files of point formats apart, the
    time one lacks is left out of the table, and :class:`LasWriter` copies each point's own
    record, every attribute, into the output's format."""
    return tuple(n for n in readers[0].names if all(n in r.names for r in readers))


def holding_every(point_formats: Iterable[int]) -> int:
    """The point format of fewest bytes whose records hold every attribute of points of
    ``point_formats``: one of LAS 1.2's (0-5) when all are, else one of LAS 1.4's (6-10), whose
    classes, returns and scan angle hold a 0-5 point's (LAS 1.4 R15, section 2.6). Formats 3 and
    6 give 7 (3's colour, 6's record), 1 and 2 give 3, as lasmerge and PDAL would be told to
    write by hand."""
    formats = set(point_formats)
    wanted = frozenset().union(*(FORMAT_FIELDS[f][0] for f in formats))
    family = range(6, 11) if max(formats) >= 6 else range(6)
    return min((f for f in family if wanted <= FORMAT_FIELDS[f][0]), key=lambda f: FORMAT_FIELDS[f][1])


#: the stored integers the first points of a file may take from its offset: half the 32-bit range,
#: the other half left for the points after them (the header is made from the first chunk)
CODES_ROOM = 2.0 ** 30


def new_header(table: PointTable, *, crs: Any = None, decimals: Mapping[str, int] | None = None) -> laspy.LasHeader:
    """A header for points that did not come from LAS: LAS 1.2 format 0, or LAS 1.4 format 6
    when a time exists or the CRS needs WKT (:func:`needs_wkt`). Its scales keep the decimals
    the text gives, up to :data:`COORDINATE_DECIMALS`, as far as the 32-bit integers hold these points
    from the offset (:data:`CODES_ROOM`); its offsets are the points' lowest, rounded down to
    whole kilometres, or to whole units where that leaves too little room (degrees)."""
    import laspy

    point_format = new_point_format(table.names)
    if crs is not None and needs_wkt(crs):
        point_format = 6
    header = laspy.LasHeader(point_format=point_format, version="1.4" if point_format >= 6 else "1.2")
    decimals = decimals or table.meta.get("decimals", {})
    scales, offsets = [], []
    for n, places in zip("xyz", asked_places(decimals), strict=True):
        lowest, highest = (float(np.min(table.columns[n])), float(np.max(table.columns[n]))) if len(table) else (0, 0)
        # whole kilometres, or whole units where that leaves too little room (degrees to 1e-8)
        offset = math.floor(lowest / 1000.0) * 1000.0
        if (highest - offset) * 10.0 ** places > CODES_ROOM >= (highest - math.floor(lowest)) * 10.0 ** places:
            offset = float(math.floor(lowest))
        scales.append(10.0 ** -places_held(places, lowest, highest, offset))
        offsets.append(offset)
    header.scales = np.array(scales)
    header.offsets = np.array(offsets)
    if crs is not None:
        set_crs(header, crs)
    return header


def asked_places(decimals: Mapping[str, int], unknown: int = 3) -> list[int]:
    """The decimals of x, y and z a header for text points is asked to keep: the text's own
    (``unknown`` where it says none), at most :data:`COORDINATE_DECIMALS`."""
    return [min(max(int(decimals.get(n, unknown)), 0), COORDINATE_DECIMALS) for n in "xyz"]


def places_held(places: int, lowest: float, highest: float, offset: float) -> int:
    """Of ``places`` decimals, as many as the integers hold between ``lowest`` and ``highest``
    from ``offset`` within :data:`CODES_ROOM`: UTM metres to 1e-6 over 10 km keep 5."""
    reach = max(highest - offset, offset - lowest, 0.0)
    while places > 0 and reach * 10.0 ** places > CODES_ROOM:
        places -= 1
    return places


def laz_chunk_points(path: Path, header: laspy.LasHeader) -> tuple[int, int] | None:
    """The fewest and the most points a LAZ file's compressed chunks hold, from its chunk table
    (LASzip: a table of each chunk's points and bytes, after the points): a header's count
    outside them is a damaged or hand-made header. With chunks of a fixed size (LASzip's 50,000)
    the last chunk holds 1 to that many; with variable chunks the table counts each. None where
    the file has no readable table (LASzip 1.x files may lack one), which then bounds nothing."""
    import lazrs

    vlr = next((v for v in header.vlrs if type(v).__name__ == "LasZipVlr"), None)
    if vlr is None:
        return None
    try:
        laz = lazrs.LazVlr(vlr.record_data_bytes())
        with open(path, "rb") as fh:
            fh.seek(int(header.offset_to_point_data))
            table = lazrs.read_chunk_table(fh, laz)
    except Exception:  # noqa: BLE001  (lazrs raises several kinds for a missing or damaged table)
        return None
    if not table:
        return None
    counts = [int(points) for points, _ in table]
    fixed = int(struct.unpack_from("<I", vlr.record_data_bytes(), 12)[0])  # LASzip VLR: chunk size at byte 12
    if fixed == 0xFFFFFFFF:  # variable chunks: each counted
        return sum(counts), sum(counts)
    return (len(counts) - 1) * fixed + 1, len(counts) * fixed


def _names_crs(header: laspy.LasHeader, crs: Any) -> bool:
    """Whether a header already names ``crs`` (a header whose CRS records do not parse does not)."""
    try:
        known = header.parse_crs()
    except Exception:  # noqa: BLE001  (laspy raises several kinds for malformed GeoTIFF keys or WKT)
        return False
    return known is not None and known.equals(crs, ignore_axis_order=True)


#: the integers a LAS file stores a coordinate as (``X * scale + offset``): 32 bits, signed
_LAS_CODES = (-(2 ** 31), 2 ** 31 - 1)


def _check_storable(lo: float, hi: float, axis: str, scale: float, offset: float) -> None:
    """Refuse (:class:`DataError`, one line) coordinates from ``lo`` to ``hi`` a LAS file cannot
    store at its scale and offset: its integers reach about 2,147 km either side of the offset at
    millimetres. One stray point far from the others, or a file of another coordinate system
    appended, made laspy's OverflowError an internal error."""
    first, last = (offset + scale * c for c in _LAS_CODES)
    if first <= lo and hi <= last:
        return
    bad = lo if lo < first else hi
    raise UnstorableValue(f"{axis} = {bad:.10g} cannot be stored in this LAS file: at its scale {scale:g} and "
                          f"offset {offset:.10g} its 32-bit integers hold {axis} from {first:.10g} to {last:.10g} "
                          "(a stray point far from the others? write text, or split the points)",
                          column=axis, value=bad)


#: (dimension, point format 6-10) -> the whole numbers it holds (LAS 1.4 R15, tables 7-8 and 13-14)
_WHOLE_RANGES = {("intensity", False): (0, 65535), ("intensity", True): (0, 65535),
                 ("classification", False): (0, 31), ("classification", True): (0, 255),
                 ("return_number", False): (0, 7), ("return_number", True): (0, 15),
                 ("number_of_returns", False): (0, 7), ("number_of_returns", True): (0, 15)}


def _check_whole(values: np.ndarray, name: str, dim: str, las14: bool) -> None:
    """Refuse (:class:`DataError`, one line) values LAS attribute ``dim`` of a point format 6-10
    (``las14``) or 0-5 file cannot hold: a text column's intensity of 70,000 was stored as 4,464
    and one of -5 as 65,531, reflectances of 0 to 1 became 0, and LAS 1.4 classes merged into a
    LAS 1.2 file lost their upper bits -- silently."""
    whole = _WHOLE_RANGES.get((dim, las14))
    if whole is None or not len(values):
        return
    lo, hi = whole
    if values.dtype.kind == "u" and np.iinfo(values.dtype).max <= hi:  # a LAS file's own, or as narrow
        return
    outside = (values < lo) | (values > hi)
    if values.dtype.kind == "f":
        outside |= values != np.round(values)
    if outside.any():
        bad = values[np.argmax(outside)]
        wider = _WHOLE_RANGES[(dim, True)][1]
        change = (f"point formats 6-10 of LAS 1.4 hold up to {wider}" if not las14 and lo <= bad <= wider
                  and bad == round(bad) else "write text, or scale the column")
        raise UnstorableValue(f"{name} = {bad:g} cannot be stored in this LAS file, whose {name} holds whole "
                              f"numbers from {lo} to {hi:,} ({change})", column=name, value=float(bad))


class LasWriter:
    """Writes chunks to a LAS/LAZ file opened for writing (the caller renames it into place).

    ``template`` is the source LasReader's header (kept as is) or ``None`` to derive one from the
    first chunk. Columns the point format lacks (``mark``...) become extra-byte dimensions.
    """

    def __init__(self, path: Path, names: tuple[str, ...], *, template: laspy.LasHeader | None = None,
                 crs: Any = None, compress: bool | None = None, decimals: Mapping[str, int] | None = None) -> None:
        self.path = Path(path)
        self.decimals = decimals  # of x, y, z, for a header made for text points; else each chunk's
        self.names = tuple(names)
        self.template = template
        self.crs = crs
        self.compress = self.path.suffix.lower() == ".laz" if compress is None else compress
        self.count = 0
        self._fh: laspy.LasWriter | None = None
        self._extra: list[str] = []
        self._given_extra: list[str] = []
        # the decimals of x, y, z the header's scales keep for text points (those it was made
        # from, or those a template's scales hold), and the file the points went to once its
        # scales were made finer
        self._asked: list[int] = []
        self._rescaled: Path | None = None
        self._coarse: set[int] = set()  # the axes whose scale keeps fewer decimals than asked, said once
        self._evlrs: list[Any] = []  # the template's extended VLRs, written once the points are
        self._reach: list[tuple[float, float]] = []  # lowest and highest x, y, z written, this chunk's too

    def _open(self, table: PointTable) -> None:
        import laspy

        header = copy.deepcopy(self.template) if self.template is not None \
            else new_header(table, crs=self.crs, decimals=self._decimals_of(table))
        self._asked = asked_places(self._decimals_of(table)) if self.template is None \
            else stored_decimals(header.scales, header.offsets)
        replaced_crs = self.template is not None and self.crs is not None and not _names_crs(header, self.crs)
        if replaced_crs:
            header = holding_crs(header, self.crs)  # --crs over the source's own (aldpat.core.crs.output_crs)
        self._evlrs = _kept_records(header, replaced_crs)
        known = set(header.point_format.dimension_names)
        self._extra = [n for n in self.names if n not in LAS_DIMENSIONS and n not in known]
        # extra-byte dimensions the template already has and the table sets (a tile of a tile)
        self._given_extra = [n for n in self.names if n not in LAS_DIMENSIONS and n in known]
        for name in self._extra:
            dtype = table.columns[name].dtype
            small = np.issubdtype(dtype, np.integer) and dtype.itemsize <= 4
            kind = dtype if small else np.int32 if np.issubdtype(dtype, np.integer) else np.float64
            header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=kind,
                                                        description=EXTRA_DESCRIPTIONS.get(name, "")))
        if (header.version.major, header.version.minor) < (1, 2):
            # LAS 1.0 and 1.1 points are 1.2's (formats 0 and 1); laspy writes 1.2 and later only
            header.version = laspy.header.Version(1, 2)
        if self._extra and (header.version.major, header.version.minor) < (1, 4):
            # extra bytes are a LAS 1.4 record: PDAL reads them from 1.4 files only (unless told to),
            # and 1.4 keeps point formats 0-5 as they are
            header.version = laspy.header.Version(1, 4)
        header.point_count = 0
        header.generating_software = generating_software()  # the file is ours, whatever the input's said
        self._header = header
        if self.template is None:
            self._say_coarse(header.scales)
        self._fh = laspy.open(self.path, mode="w", header=header, do_compress=self.compress)

    def write(self, table: PointTable) -> None:
        import laspy

        if "decoded_only" in table.meta:  # its record's other fields were never decoded
            raise AssertionError("a table read with only= is for reading, not for writing")
        # each coordinate's lowest and highest of this chunk, found once for every check of them
        extent = [(float(np.min(table.columns[a])), float(np.max(table.columns[a]))) for a in "xyz"] \
            if len(table) else []
        if extent:
            self._check_extent(extent, table)
        if self._fh is None:
            self._open(table)
        n = len(table)
        if n == 0:
            return
        if table.record is None:  # text points: their decimals may ask for finer scales
            self._keep_decimals(table)
        same: frozenset[str] = frozenset()
        if table.record is not None and self.template is not None and not self._extra \
                and self._stored_alike(table.record):
            # the source's own records: write them as they are, then only what changed (on a copy,
            # so the caller's table is never modified)
            same = table.meta.get("in_record", frozenset())
            changed = any(n not in same for n in table.columns if n in LAS_DIMENSIONS or n in self._given_extra)
            array = table.record.array.copy() if changed else table.record.array
            points = laspy.ScaleAwarePointRecord(array, self._header.point_format,
                                                 self._header.scales, self._header.offsets)
        else:
            points = laspy.ScaleAwarePointRecord.zeros(n, header=self._header)
            if table.record is not None:
                source = table.record.array
                if table.record.point_format.id == points.point_format.id:
                    for field in source.dtype.names:  # the stored fields as they are, bit fields packed
                        if field in points.array.dtype.names:
                            points.array[field] = source[field]
                else:
                    for dim in table.record.point_format.dimension_names:
                        if dim in points.point_format.dimension_names:
                            points[dim] = table.record[dim]
                    if "scan_angle_rank" in table.record.point_format.dimension_names \
                            and "scan_angle" in points.point_format.dimension_names:  # 1.2 -> 1.4
                        degrees = np.asarray(table.record["scan_angle_rank"], dtype=np.float64)
                        points["scan_angle"] = np.round(degrees / SCAN_ANGLE_UNIT).astype(np.int16)
        if table.record is None:
            # a point from text is one return of its pulse unless a column says otherwise (ASPRS:
            # return numbers start at 1; lidR's las_check calls 0 invalid)
            for dim in RETURN_DIMENSIONS:
                if dim not in table.columns:
                    points[dim] = np.ones(n, np.uint8)
        for k, name in enumerate("xyz"):
            if name not in same:
                _check_storable(*extent[k], name, float(self._header.scales[k]), float(self._header.offsets[k]))
                setattr(points, name, table.columns[name])
        for name, values in table.columns.items():
            dim = LAS_DIMENSIONS.get(name)
            if dim and dim not in "xyz" and name not in same and dim in points.point_format.dimension_names:
                _check_whole(values, name, dim, points.point_format.id >= 6)
                points[dim] = values
        for name in (*self._extra, *(n for n in self._given_extra if n not in same)):
            points[name] = table.columns[name]
        assert self._fh is not None  # opened above
        self._fh.write_points(points)
        self.count += n

    def _check_extent(self, extent: list[tuple[float, float]], table: PointTable) -> None:
        """Take a chunk's ``extent`` (lowest and highest x, y, z) into the file's, and refuse
        (:class:`UnstorableValue`, one line) x or y spreading over more than :data:`MOST_EXTENT`:
        the file could not be read back (:class:`LasReader` refuses such bounds). One stray point
        with a lost decimal point (51386646 among 513866.46) made such a file, and every x of it a
        decimal coarser. The value named is the end farther from the median of ``table``'s points,
        so the job can name the text line holding the stray point."""
        self._reach = [(min(lo, held[0]), max(hi, held[1])) for (lo, hi), held in zip(extent, self._reach, strict=True)] \
            if self._reach else list(extent)
        for name, (lo, hi) in zip("xy", self._reach, strict=False):
            if hi - lo > MOST_EXTENT:
                middle = float(np.median(table.columns[name]))
                stray = lo if middle - lo > hi - middle else hi
                raise UnstorableValue(f"{name} reaches from {lo:.10g} to {hi:.10g}, more than the Earth's "
                                      f"circumference: a LAS file of these points could not be read back (a stray "
                                      f"point at {name} = {stray:.10g}? aldpat info shows the bounds)",
                                      column=name, value=stray)

    def _say_coarse(self, scales: np.ndarray) -> None:
        """A warning, once an axis, where the scales keep fewer decimals of text points than the text
        holds, and fewer than three (a millimetre): the 32-bit integers cannot hold them over the
        points' extent from the offset. Past the third a lost decimal is below any survey's
        precision (z printed to 1e-8 over 100 m keeps 1e-7), and saying so would be noise."""
        for k, name in enumerate("xyz"):
            if k not in self._coarse and float(scales[k]) > 1.000001 * 10.0 ** -min(self._asked[k], 3):
                self._coarse.add(k)
                from aldpat.io.atomic import shown_name

                log.warning("%s: %s stored at %g, coarser than the %d decimals of the text: LAS integers cannot "
                            "hold them over the points' extent (a stray point far from the others?)",
                            shown_name(self.path), name, float(scales[k]), self._asked[k])

    def _stored_alike(self, record: Any) -> bool:
        """Whether ``record`` stores points as this file does (layout, scales, offsets), so that its
        bytes can be written as they are (another file's may not: a merge of tiles)."""
        if record.array.dtype != self._header.point_format.dtype():
            return False
        scales = getattr(record, "scales", None)
        if scales is None:  # records put together from one file's chunks
            return True
        return bool(np.array_equal(scales, self._header.scales)
                    and np.array_equal(record.offsets, self._header.offsets))

    def _decimals_of(self, table: PointTable) -> Mapping[str, int]:
        """The decimals of x, y, z the header keeps: the writer's, else the chunk's."""
        return self.decimals if self.decimals is not None else (table.meta.get("decimals") or {})

    def _keep_decimals(self, table: PointTable) -> None:
        """Make the scales finer where a chunk of text points holds more decimals than they keep:
        the lines a header was made from showed fewer (the reader widens its decimals as it reads:
        100.5 there, 512.125 further down), or a template's scales hold fewer (a text file merged
        after a LAS tile at centimetres) -- as far as the integers hold every point written and
        this chunk's from the offsets. The points written so far are copied into a new file at the
        finer scales, exactly (they held no more decimals than the old scales), and the rest go on
        into it. A text without decimals known asks for none more under a template."""
        assert self._fh is not None
        decimals = self._decimals_of(table)
        asked = asked_places(decimals, unknown=3 if self.template is None else 0)
        if all(a <= b for a, b in zip(asked, self._asked, strict=True)):
            return
        self._asked = [max(a, b) for a, b in zip(asked, self._asked, strict=True)]
        scales = self._header.scales.copy()
        for k, (lowest, highest) in enumerate(self._reach):  # every point written, and this chunk's
            places = places_held(self._asked[k], lowest, highest, float(self._header.offsets[k]))
            scales[k] = min(float(scales[k]), 10.0 ** -places)
        self._say_coarse(scales)
        if np.array_equal(scales, self._header.scales):
            return
        self._rescale(scales)

    def _rescale(self, scales: np.ndarray) -> None:
        """Go on writing into a new file whose header takes ``scales``, the points written so far
        copied into it at those scales."""
        import laspy

        from aldpat.io.atomic import temp_name

        assert self._fh is not None
        self._fh.close()
        self._fh = None
        written = self._rescaled or self.path
        header = copy.deepcopy(self._header)
        header.scales = scales
        header.point_count = 0
        target = temp_name(self.path)  # a temporary name: a killed run's leftover is recognised and removed
        writer = None
        try:
            writer = laspy.open(target, mode="w", header=header, do_compress=self.compress)
            with laspy.open(written) as source:
                for old in source.chunk_iterator(DEFAULT_CHUNK):
                    points = laspy.ScaleAwarePointRecord(old.array.copy(), header.point_format, header.scales,
                                                         header.offsets)
                    points.x, points.y, points.z = old.x, old.y, old.z
                    writer.write_points(points)
        except BaseException:
            if writer is not None:
                writer.close()
            target.unlink(missing_ok=True)
            raise
        if self._rescaled is not None:
            self._rescaled.unlink()
        self._fh, self._header, self._rescaled = writer, header, target
        log.info("%s: text points hold more decimals than the scales kept: LAS scales now %s", self.path,
                 ", ".join(f"{v:g}" for v in scales))

    def close(self) -> None:
        if self._fh is None:
            # an empty output still gets a valid header
            self._open(PointTable({n: np.zeros(0) for n in ("x", "y", "z")}))
        assert self._fh is not None
        if self._evlrs and (self._header.version.major, self._header.version.minor) >= (1, 4):
            from laspy.vlrs.vlrlist import VLRList

            self._fh.write_evlrs(VLRList(self._evlrs))
        self._fh.close()
        if self._rescaled is not None:
            os.replace(self._rescaled, self.path)
            self._rescaled = None
