from dataclasses import dataclass

import pytest

from aldpat.errors import ParamError
from aldpat.params import Checked, check_value, coerce, convert, param, resolve, spec_map, specs


@dataclass(frozen=True)
class Demo:
    cell: float = param(1.0, "grid cell size", unit="m", gt=0)
    windows: tuple[int, ...] = param((1, 2, 4), "half windows", unit="cells", ge=1)
    bounds: tuple[float, float, float, float] | None = param(None, "min x, min y, max x, max y")
    method: str = param("lowest", "which point", choices=("lowest", "median", "center"))
    flag: bool = param(False, "a switch")
    count: int = param(3, "how many", ge=0, le=10)


def test_specs_follow_the_declaration():
    s = spec_map(Demo)
    assert [x.name for x in specs(Demo)] == ["cell", "windows", "bounds", "method", "flag", "count"]
    assert s["cell"].kind == "float" and s["cell"].option == "--cell" and s["cell"].unit == "m"
    assert s["windows"].kind == "ints" and s["windows"].length is None
    assert s["bounds"].kind == "floats" and s["bounds"].length == 4 and s["bounds"].optional
    assert "unit: m" in s["cell"].describe() and "default: 1" in s["cell"].describe()
    assert "one of: lowest, median, center" in s["method"].describe()


@pytest.mark.parametrize("name, raw, expected", [
    ("cell", "2.5", 2.5), ("cell", 3, 3.0), ("windows", "1,2,3", (1, 2, 3)), ("windows", [4, 8], (4, 8)),
    ("bounds", ("0", "1", "2", "3"), (0.0, 1.0, 2.0, 3.0)), ("bounds", None, None), ("flag", "yes", True),
    ("count", 10, 10), ("method", "median", "median"),
])
def test_coerce_accepts_cli_strings_and_toml_values(name, raw, expected):
    assert coerce(spec_map(Demo)[name], raw) == expected


@pytest.mark.parametrize("name, raw, message", [
    ("cell", 0, "cell: 0 is out of range (must be > 0)"),
    ("cell", "abc", "cell: expected a number, got 'abc'"),
    ("cell", "nan", "cell: expected a finite number"),
    ("windows", "1,0", "windows: 0 is out of range (must be >= 1)"),
    ("bounds", (1, 2, 3), "bounds: expected 4 values, got 3"),
    ("method", "lowst", "did you mean 'lowest'?"),
    ("count", 2.5, "count: expected a whole number"),
    ("count", True, "count: expected a whole number"),
    ("count", 1e308, "count: expected a whole number, got 1e+308"),  # its range error printed 309 digits
    ("count", 11, "must be <= 10"),
    ("flag", "maybe", "flag: expected true or false"),
])
def test_coerce_rejects_with_a_message_naming_the_key(name, raw, message):
    with pytest.raises(ParamError, match=message.replace("(", r"\(").replace(")", r"\)").replace("?", r"\?").replace("+", r"\+")):
        coerce(spec_map(Demo)[name], raw, where="job 2: ")


def test_resolve_layers_and_sources():
    r = resolve(Demo, [("params file", {"cell": 2.0, "method": "center"}), ("cli", {"cell": "0.5"})])
    assert r.values.cell == 0.5 and r.values.method == "center" and r.values.count == 3
    assert r.sources == {"cell": "cli", "windows": "default", "bounds": "default", "method": "params file",
                         "flag": "default", "count": "default"}
    assert ("cell", "0.5", "cli") in r.record()


def test_unknown_key_suggests_the_closest():
    with pytest.raises(ParamError, match=r"job 3: unknown key 'windos'; did you mean 'windows'\?"):
        resolve(Demo, [("worksheet", {"windos": [1]})], where="job 3: ")
    # dashes and underscores are the same key
    assert resolve(Demo, [("cli", {"cell": 2})]).values.cell == 2.0


# ---------------------------------------------------------------------------- checked once


@dataclass(frozen=True)
class CheckedDemo(Checked):
    cell: float = param(1.0, "grid cell size", unit="m", gt=0)
    windows: tuple[int, ...] = param((1, 2, 4), "half windows", unit="cells", ge=1)

    def check(self) -> None:
        super().check()
        if self.windows[-1] * self.cell > 100:
            raise ParamError("windows: the largest reaches past 100 m")


def test_convert_gives_the_kind_and_check_value_the_range():
    cell = spec_map(CheckedDemo)["cell"]
    assert convert(cell, "-2") == -2.0  # of its kind; whether it is in range is the instance's to say
    with pytest.raises(ParamError, match="cell: expected a number"):
        convert(cell, "abc")
    with pytest.raises(ParamError, match=r"cell: -2 is out of range \(must be > 0\)"):
        check_value(cell, -2.0)


def test_an_instance_is_checked_once_wherever_it_is_made(monkeypatch):
    import dataclasses

    import aldpat.params as params_module

    seen: list[str] = []
    checked = params_module._check_bounds
    monkeypatch.setattr(params_module, "_check_bounds", lambda spec, v, where: (seen.append(spec.name),
                                                                                checked(spec, v, where)))
    resolve(CheckedDemo, [("cli", {"cell": "2", "windows": "1,3"})])
    assert sorted(seen) == ["cell", "windows", "windows"]  # each value once (a sequence: each item)
    with pytest.raises(ParamError, match=r"job 3: cell: -1 is out of range"):
        resolve(CheckedDemo, [("worksheet", {"cell": -1})], where="job 3: ")
    # made in Python, or replaced: the same checks, values and rules alike
    with pytest.raises(ParamError, match=r"cell: 0 is out of range"):
        CheckedDemo(cell=0)
    with pytest.raises(ParamError, match="windows: 0 is out of range"):
        dataclasses.replace(CheckedDemo(), windows=(0, 2))
    with pytest.raises(ParamError, match="the largest reaches past 100 m"):
        dataclasses.replace(CheckedDemo(), cell=50.0)


def test_a_class_without_rules_is_checked_by_resolve():
    with pytest.raises(ParamError, match=r"job 1: count: 11 is out of range"):
        resolve(Demo, [("worksheet", {"count": 11})], where="job 1: ")


@pytest.mark.parametrize("given, metres", [("auto", None), ("12.5", 12.5), ("0", 0.0)])
def test_chunk_buffer_is_read_in_one_place(given, metres):
    from aldpat.options import ChunkOption

    assert ChunkOption(chunk_buffer=given).buffer_metres() == metres


@pytest.mark.parametrize("given, message", [
    ("abc", "chunk_buffer: expected metres or auto, got 'abc'"), ("-1", "chunk_buffer: must be at least 0"),
    ("inf", "chunk_buffer: must be at least 0"), ("nan", "chunk_buffer: must be at least 0"),
])
def test_a_bad_chunk_buffer_is_refused_when_the_parameters_are_made(given, message):
    from aldpat.options import ChunkOption

    with pytest.raises(ParamError, match=message):
        ChunkOption(chunk_buffer=given)
    with pytest.raises(ParamError, match="job 2: " + message):
        resolve(ChunkOption, [("worksheet", {"chunk_buffer": given})], where="job 2: ")


def test_a_list_parameter_takes_at_most_a_thousand_values():
    """A parameter file's list of a million windows ran a million passes over the grid."""
    from aldpat.filters.pm import PMParams
    from aldpat.params import MOST_ITEMS

    spec = next(s for s in specs(PMParams) if s.name == "window_series")
    assert convert(spec, list(range(1, MOST_ITEMS + 1))) == tuple(range(1, MOST_ITEMS + 1))
    with pytest.raises(ParamError, match=r"^window_series: 1,001 values \(at most 1,000\)$"):
        convert(spec, list(range(1, MOST_ITEMS + 2)))
    with pytest.raises(ParamError, match="2,000 values"):
        convert(spec, ",".join(map(str, range(1, 2001))))
