"""The one declaration of every tunable.

A task's parameters are a frozen dataclass whose fields are made with :func:`param`::

    @dataclass(frozen=True)
    class ThinParams:
        cell_width: float = param(1.0, "cell width", unit="m", gt=0, manual="Width")

From that single declaration the rest of the project derives

* the click options (``--cell-width``) -- in :mod:`aldpat.cli.options`,
* the TOML keys a worksheet or ``--params`` file accepts (``cell_width``),
* the ``--help`` text (help, unit, default, bounds, choices),
* the log record (value and where it came from: default, params file, worksheet, CLI).

Names map mechanically: ``max_window`` <-> ``--max-window`` <-> ``max_window = 20``.
This module never imports click.
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import logging
import math
import numbers
import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from aldpat.core.paths import LONGEST_PATH, names_folder, not_local
from aldpat.errors import ParamError, shown

log = logging.getLogger(__name__)

#: Where a resolved value came from, lowest priority first.
SOURCES = ("default", "settings", "params file", "worksheet", "cli")

#: How far from everyday use a parameter is, with the heading ``--help`` lists it under, in the
#: order it lists them: what most runs set, what a run needs now and then, and the settings of the
#: published method itself (windows, thresholds, seed sizes: change them with the paper in hand).
LEVELS = {
    "common": "Options",
    "advanced": "Advanced options",
    "internal": "Method internals (as published; change with the source in hand)",
}


@dataclass(frozen=True)
class Spec:
    """Everything known about one parameter; built from a dataclass field."""

    name: str
    kind: str  # float, int, str, bool, floats, ints, strs, path
    default: Any
    help: str
    unit: str | None = None
    choices: tuple | None = None
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    length: int | None = None  # fixed number of items for sequences (e.g. bounds: 4)
    optional: bool = False  # None is an accepted value
    manual: str | None = None  # the ALDPAT manual's name for it, e.g. "Stop Gap"
    metavar: str | None = None
    path: bool = False  # a file path: worksheets resolve it against the worksheet's folder
    required: bool = False  # no default: the user must give a value (a usage error otherwise)
    renamed_from: tuple[str, ...] = ()  # earlier names, still accepted with a deprecation message
    renamed_values: tuple[tuple[str, str], ...] = ()  # (earlier value, value) pairs, the same way
    level: str = "common"  # a key of LEVELS: where --help lists it

    @property
    def option(self) -> str:
        """The command-line spelling: ``--max-window``."""
        return "--" + self.name.replace("_", "-")

    @property
    def is_sequence(self) -> bool:
        return self.kind in ("floats", "ints", "strs")

    def describe(self) -> str:
        """Help text with unit, bounds, choices and default, as ``--help`` shows it."""
        parts = [self.help.rstrip(".")]
        if self.manual:
            parts[0] += f" [{self.manual}]"
        extra = []
        if self.unit:
            extra.append(f"unit: {self.unit}")
        bounds = _bounds_text(self)
        if bounds:
            extra.append(bounds)
        if self.choices:
            extra.append("one of: " + ", ".join(map(str, self.choices)))
        if self.required:
            extra.append("required")
        elif not (self.default is None and "default:" in self.help):  # the help already says it
            extra.append(f"default: {format_value(self.default)}")
        return parts[0] + (" (" + "; ".join(extra) + ")" if extra else "")


def param(
    default: Any,
    help: str,
    *,
    unit: str | None = None,
    choices: typing.Iterable | None = None,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    manual: str | None = None,
    metavar: str | None = None,
    path: bool = False,
    required: bool = False,
    renamed_from: typing.Iterable[str] = (),
    renamed_values: Mapping[str, str] | None = None,
    level: str = "common",
) -> Any:
    """Declare a parameter as a dataclass field (see module docstring).

    Sequence defaults are given as tuples so that parameter objects stay immutable. ``level``
    (:data:`LEVELS`) says under which heading ``--help`` lists it: ``common`` (the default),
    ``advanced`` or ``internal`` (the published method's own settings).
    """
    if level not in LEVELS:
        raise ValueError(f"level {level!r} is not one of {', '.join(LEVELS)}")
    if isinstance(default, list):
        default = tuple(default)  # parameter objects stay immutable
    meta = {
        "help": help,
        "unit": unit,
        "choices": tuple(choices) if choices is not None else None,
        "gt": gt,
        "ge": ge,
        "lt": lt,
        "le": le,
        "manual": manual,
        "metavar": metavar,
        "path": path,
        "required": required,
        "renamed_from": tuple(renamed_from),
        "renamed_values": tuple((renamed_values or {}).items()),
        "level": level,
    }
    return dataclasses.field(default=default, metadata={"aldpat": meta})


def default_of(base: type, name: str, default: Any) -> Any:
    """Redeclare the parameter ``name`` of ``base`` in a subclass with another default only:
    help, unit and bounds stay declared once, in ``base``."""
    field = {f.name: f for f in dataclasses.fields(base)}[name]
    if isinstance(default, list):
        default = tuple(default)
    return dataclasses.field(default=default, metadata=field.metadata)


def _kind_of(annotation: Any) -> tuple[str, bool, int | None]:
    """Map a type annotation to (kind, optional, fixed length)."""
    optional = False
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        members = [a for a in typing.get_args(annotation) if a is not type(None)]
        optional = len(members) < len(typing.get_args(annotation))
        if len(members) != 1:
            raise TypeError(f"unsupported parameter annotation {annotation!r}")
        annotation = members[0]
        origin = typing.get_origin(annotation)
    if annotation is bool:
        return "bool", optional, None
    if annotation is int:
        return "int", optional, None
    if annotation is float:
        return "float", optional, None
    if annotation is str:
        return "str", optional, None
    if origin is tuple:
        args = typing.get_args(annotation)
        length = None if (len(args) == 2 and args[1] is Ellipsis) else len(args)
        item = args[0]
        kind = {float: "floats", int: "ints", str: "strs"}.get(item)
        if kind is None:
            raise TypeError(f"unsupported parameter annotation {annotation!r}")
        return kind, optional, length
    raise TypeError(f"unsupported parameter annotation {annotation!r}")


def specs(params_cls: type) -> list[Spec]:
    """The parameter specs of a params dataclass, in declaration order."""
    cached = _SPEC_CACHE.get(params_cls)
    if cached is not None:
        return cached
    hints = typing.get_type_hints(params_cls)
    out = []
    for f in sorted(dataclasses.fields(params_cls), key=lambda f: _is_shared(params_cls, f.name)):
        meta = f.metadata.get("aldpat")
        if meta is None:
            raise TypeError(f"{params_cls.__name__}.{f.name} is not declared with param()")
        kind, optional, length = _kind_of(hints[f.name])
        out.append(Spec(name=f.name, kind=kind, default=f.default, optional=optional, length=length, **meta))
    _SPEC_CACHE[params_cls] = out
    return out


_SPEC_CACHE: dict[type, list[Spec]] = {}


def _is_shared(params_cls: type, name: str) -> bool:
    """Whether ``name`` was first declared by a shared option (listed last; the sort is stable)."""
    first = next(k for k in reversed(params_cls.__mro__) if name in inspect.get_annotations(k))
    return SharedOption in first.__bases__


def spec_map(params_cls: type) -> dict[str, Spec]:
    return {s.name: s for s in specs(params_cls)}


# ---------------------------------------------------------------------------- values


def _bounds_text(spec: Spec) -> str:
    bits = []
    if spec.gt is not None:
        bits.append(f"> {spec.gt:g}")
    if spec.ge is not None:
        bits.append(f">= {spec.ge:g}")
    if spec.lt is not None:
        bits.append(f"< {spec.lt:g}")
    if spec.le is not None:
        bits.append(f"<= {spec.le:g}")
    return " and ".join(bits)


def format_value(value: Any) -> str:
    """A value as a user would type it (used in help text and logs)."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (tuple, list)):
        return ",".join(format_value(v) for v in value)
    return str(value)


def _scalar(kind: str, value: Any, spec: Spec, where: str) -> Any:
    """Convert one scalar (from TOML, a command-line string or a Python call, whose numbers may be
    numpy's) to the spec's kind."""
    def bad(expected: str) -> ParamError:
        # a value of a type no kind takes may print as one that is (a 0-d numpy array as 1.5):
        # its type is named, lest the message read "expected a number, got 1.5"
        cls = type(value)
        named = cls.__name__ if cls.__module__ == "builtins" else f"{cls.__module__}.{cls.__name__}"
        of = "" if isinstance(value, (str, numbers.Real)) else f" ({named})"
        return ParamError(f"{where}{spec.name}: expected {expected}, got {shown(value)}{of}")

    if kind == "bool":
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "yes", "on", "1", "false", "no", "off", "0"):
            return value.lower() in ("true", "yes", "on", "1")
        raise bad("true or false")
    if kind == "int":
        if isinstance(value, bool):
            raise bad("a whole number")
        if isinstance(value, numbers.Integral):  # numpy's integers too, as a call passes them
            return int(value)
        # 2.0 is 2; a float past 2**53 is no count anyone typed (1e308 was taken, and its range
        # error printed its 309 digits)
        if isinstance(value, numbers.Real) and float(value).is_integer() and abs(float(value)) <= 2.0 ** 53:
            return int(float(value))
        if isinstance(value, str):
            try:
                return int(value.strip())
            except ValueError:
                pass
        raise bad("a whole number")
    if kind == "float":
        if isinstance(value, bool):
            raise bad("a number")
        if isinstance(value, numbers.Real):  # numpy's float32, int64... too, as a call passes them
            v = float(value)
        elif isinstance(value, str):
            try:
                v = float(value.strip())
            except ValueError:
                raise bad("a number") from None
        else:
            raise bad("a number")
        if not math.isfinite(v):
            raise bad("a finite number")
        return v
    if kind == "str":
        if isinstance(value, (str, numbers.Real)) and not isinstance(value, bool):
            return str(value)
        raise bad("text")
    raise AssertionError(kind)


#: The largest magnitude a number of a parameter may have on a side its declaration leaves open:
#: no length, count, threshold or coordinate of airborne LiDAR comes near (coordinates of any
#: CRS stay below 1e8), and past it sizes and counts that follow from the value (nodes, tiles,
#: windows) stop being numbers a machine can hold. A parameter declares its own bound where it
#: needs another (a nodata value: float32's range).
LARGEST = 1e12
#: The same for a window or a size counted in cells: 100 km at 1 m cells, wider than any tile.
MOST_CELLS = 100_000


def _check_bounds(spec: Spec, v: Any, where: str) -> None:
    if isinstance(v, str):
        if spec.choices and v not in spec.choices:
            hint = difflib.get_close_matches(v, [str(c) for c in spec.choices], n=1)
            did = f"; did you mean {hint[0]!r}?" if hint else ""
            raise ParamError(
                f"{where}{spec.name}: {shown(v)} is not one of {', '.join(map(str, spec.choices))}{did}"
            )
        return
    if spec.choices and v not in spec.choices:
        raise ParamError(f"{where}{spec.name}: {shown(v)} is not one of {', '.join(map(str, spec.choices))}")
    if isinstance(v, bool):
        return
    for op, limit, ok in (
        (">", spec.gt, lambda a, b: a > b),
        (">=", spec.ge, lambda a, b: a >= b),
        ("<", spec.lt, lambda a, b: a < b),
        ("<=", spec.le, lambda a, b: a <= b),
    ):
        if limit is not None and not ok(v, limit):
            raise ParamError(f"{where}{spec.name}: {format_value(v)} is out of range (must be {op} {limit:g})")
    largest = MOST_CELLS if spec.unit == "cells" else LARGEST
    if spec.lt is None and spec.le is None and v > largest:
        raise ParamError(f"{where}{spec.name}: {format_value(v)} is out of range (must be <= {largest:g})")
    if spec.gt is None and spec.ge is None and v < -LARGEST:
        raise ParamError(f"{where}{spec.name}: {format_value(v)} is out of range (must be >= {-LARGEST:g})")


#: the most values a list parameter takes: windows, thresholds, classes and fields are far fewer;
#: a parameter file's list of a million windows would run a million passes over the grid
MOST_ITEMS = 1000


def convert(spec: Spec, value: Any, where: str = "") -> Any:
    """``value`` as ``spec``'s kind: a native TOML value or a command-line string (sequences as
    ``1,2,3``), an earlier spelling of a choice replaced; a :class:`ParamError` naming the key
    (``where`` prefixes it, e.g. ``"job 2: "``) when it is not of that kind. Whether it is in
    range is the params instance's to say, once, when it is made (:func:`check_value`)."""
    if value is None or (isinstance(value, str) and value.lower() == "none" and spec.optional):
        if spec.optional:
            return None
        raise ParamError(f"{where}{spec.name}: a value is required")
    if spec.is_sequence:
        item_kind = spec.kind[:-1]
        if isinstance(value, str):
            items = [v for v in value.replace(";", ",").replace(" ", ",").split(",") if v != ""]
        elif isinstance(value, (list, tuple)):
            items = list(value)
        elif getattr(value, "ndim", None) == 1 and callable(getattr(value, "tolist", None)):
            # a numpy array (or another array library's), as a notebook holds its windows: its
            # values as Python's numbers, each then checked as a list's would be
            items = value.tolist()
        else:
            items = [value]
        if len(items) > MOST_ITEMS:
            raise ParamError(f"{where}{spec.name}: {len(items):,} values (at most {MOST_ITEMS:,})")
        return tuple(_scalar(item_kind, it, spec, where) for it in items)
    v = _scalar(spec.kind, value, spec, where)
    return _renamed_value(spec, v, where) if isinstance(v, str) else v


def check_value(spec: Spec, v: Any, where: str = "") -> None:
    """A :class:`ParamError` naming the key when the converted value ``v`` is out of
    ``spec``'s range: bounds, choices, a sequence's length, a path that is not a local file."""
    if v is None:
        return
    if spec.is_sequence:
        if spec.length is not None and len(v) != spec.length:
            raise ParamError(f"{where}{spec.name}: expected {spec.length} values, got {len(v)}")
        if not v and spec.length is None and not spec.optional:
            raise ParamError(f"{where}{spec.name}: expected at least one value")
        for item in v:
            _check_bounds(spec, item, where)
        return
    if isinstance(v, str) and spec.path and (why := not_local(v)) is not None:
        named = repr(v) if len(v) <= LONGEST_PATH else shown(v)  # a path is shown whole, unless endless
        raise ParamError(f"{where}{spec.name}: {named} is {why}")
    if isinstance(v, str) and spec.path and v.startswith("-") and len(v) > 1:
        # ``--odir -q`` or ``--map --odir out``: the option's value was left out and click took
        # the next word for it -- a folder named "-q" was made, a picture named "--odir" written
        raise ParamError(f"{where}{spec.name}: {shown(v)} looks like an option, not a file name (was the value "
                         f"left out?); a file whose name starts with '-' is ./{shown(v, quoted=False)}")
    if isinstance(v, str) and spec.path and spec.metavar != "DIR" and names_folder(v):
        raise ParamError(f"{where}{spec.name}: {v!r} is a folder; name a file")  # not_local bounds it
    _check_bounds(spec, v, where)


def coerce(spec: Spec, value: Any, where: str = "") -> Any:
    """Validate and convert ``value`` for ``spec`` (:func:`convert`, then :func:`check_value`);
    raise :class:`ParamError` naming the key. ``where`` prefixes the message (e.g. ``"job 2: "``)."""
    v = convert(spec, value, where)
    check_value(spec, v, where)
    return v


def check_values(obj: Any) -> None:
    """Every parameter of the params instance ``obj`` of its kind and in its range: what
    :class:`Checked` does when an instance is made, before its own rules."""
    for s in specs(type(obj)):
        check_value(s, convert(s, getattr(obj, s.name)))


def _renamed_value(spec: Spec, value: str, where: str) -> str:
    new = dict(spec.renamed_values).get(value)
    if new is None:
        return value
    log.warning("%s%s: %r is now spelled %r; the old spelling will stop working in a later version",
                where, spec.name, value, new)
    return new


def renamed_keys(all_specs: typing.Iterable[Spec]) -> dict[str, str]:
    """Earlier parameter names -> their names now."""
    return {old: s.name for s in all_specs for old in s.renamed_from}


def with_current_names(mapping: Mapping[str, Any], renames: Mapping[str, str], where: str = "") -> dict[str, Any]:
    """``mapping`` with earlier parameter names replaced by their names now (each with a
    deprecation message); a value given under both names is a :class:`ParamError`."""
    out: dict[str, Any] = {}
    for raw_key, value in mapping.items():
        key = raw_key.replace("-", "_")
        new = renames.get(key)
        if new is None:
            out[raw_key] = value
            continue
        if new in out or new in mapping or new.replace("_", "-") in mapping:
            raise ParamError(f"{where}{key} and {new} are one parameter; give {new} only")
        log.warning("%s%s is now called %s; the old name will stop working in a later version", where, key, new)
        out[new] = value
    return out


def unknown_key_error(key: str, known: typing.Iterable[str], where: str = "") -> ParamError:
    """An 'unknown key' error with a did-you-mean suggestion."""
    known = sorted(set(known))
    k = key.replace("-", "_")
    hint = difflib.get_close_matches(k, known, n=1, cutoff=0.6)
    did = f"; did you mean {hint[0]!r}?" if hint else ""
    return ParamError(f"{where}unknown key {key!r}{did}")


@dataclass
class Resolved:
    """A params instance plus where every value came from (for the log)."""

    values: Any
    sources: dict[str, str]

    def record(self) -> list[tuple[str, str, str]]:
        """(name, value as typed, source) rows for the log."""
        return [
            (s.name, format_value(getattr(self.values, s.name)), self.sources[s.name])
            for s in specs(type(self.values))
        ]


def resolve(params_cls: type, layers: Sequence[tuple[str, Mapping[str, Any]]], where: str = "",
            allow_unknown: bool = False) -> Resolved:
    """Merge layers of raw values (lowest priority first) into a validated params instance.

    Each layer is ``(source_name, mapping)``; keys may use dashes or underscores.
    Unknown keys raise :class:`ParamError` with a suggestion unless ``allow_unknown``.
    """
    smap = spec_map(params_cls)
    renames = renamed_keys(smap.values())
    layers = [(source, with_current_names(mapping, renames, where)) for source, mapping in layers]
    values = {name: s.default for name, s in smap.items()}
    sources = {name: "default" for name in smap}
    for source, mapping in layers:
        for raw_key, raw in mapping.items():
            key = raw_key.replace("-", "_")
            spec = smap.get(key)
            if spec is None:
                if allow_unknown:
                    continue
                raise unknown_key_error(raw_key, smap, where)
            values[key] = convert(spec, raw, where + _from(source))  # in range: checked when the instance is made
            sources[key] = source
    for name, spec in smap.items():
        if spec.required and values[name] is None:
            raise ParamError(f"{where}{name}: required ({spec.option} on the command line)")
    try:
        obj = params_cls(**values)  # a Checked class checks its values and rules as it is made
        if not isinstance(obj, Checked):
            check_values(obj)
    except ParamError as exc:
        named = exc.message.split(":", 1)[0]
        raise ParamError(f"{where}{_from(sources.get(named, ''))}{exc.message}") from None
    return Resolved(obj, sources)


def _from(source: str) -> str:
    """Where a worksheet's ``[settings]`` gave a value, said before its error: every job takes it
    from there, and "job 1: cell" sent the user to a job that does not name it."""
    return "[settings] " if source == "settings" else ""


class Checked:
    """Base of a params class whose instances are checked as they are made, once, wherever they
    are made -- by :func:`resolve` (which names the job in the error, so ``aldpat run --dry-run``
    reports it before any input is read), by ``dataclasses.replace`` or in Python: every value
    of its kind and in its range (:func:`check_values`), then the class's rules that relate
    several parameters or need more than a bound (series that must fit together, a CRS or geoid
    that must exist), which it states by overriding :meth:`check`, calling ``super().check()``."""

    def __post_init__(self) -> None:
        check_values(self)
        self.check()

    def check(self) -> None:
        """Raise :class:`ParamError` naming the key when the values do not fit together."""


class SharedOption:
    """Direct base of an option several params classes take by inheritance (:mod:`aldpat.options`):
    its fields are listed after the class's own in ``--help`` and logs."""
