from dataclasses import dataclass

import pytest

from aldpat.errors import ParamError
from aldpat.params import coerce, param, resolve, spec_map, specs


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
    ("count", 11, "must be <= 10"),
    ("flag", "maybe", "flag: expected true or false"),
])
def test_coerce_rejects_with_a_message_naming_the_key(name, raw, message):
    with pytest.raises(ParamError, match=message.replace("(", r"\(").replace(")", r"\)").replace("?", r"\?")):
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
