"""``--help`` that guides: examples first, options by level, only the options that do something,
the commands in the workflow's order, and which filter to start with, with its measured error."""

from __future__ import annotations

import re
import shlex

import click
import pytest

from aldpat.cli.main import WORKFLOW, cli
from aldpat.filters import FILTERS
from aldpat.filters.scores import ISPRS_SCORES, START_WITH
from aldpat.params import LEVELS, coerce
from aldpat.tasks import TASKS
from tests.cli.fresh import REPO, aldpat

COMMANDS = sorted(TASKS) + ["run"]
#: every help page with examples: the root, the filter group and each command
PAGES = ["", "filter", *COMMANDS]


def help_of(runner, key: str) -> str:
    result = runner.invoke(cli, [*key.split(), "--help"], terminal_width=100)
    assert result.exit_code == 0, result.output
    return result.output


def sections(text: str) -> dict[str, str]:
    """Heading -> body of each section of a help page (headings end in a colon at column 0)."""
    out: dict[str, str] = {}
    heading = None
    for line in text.splitlines():
        if re.match(r"^\S.*:$", line):
            heading = line[:-1]
            out[heading] = ""
        elif heading is not None:
            out[heading] += line + "\n"
    return out


def command(key: str) -> click.Command:
    cmd: click.Command = cli
    for word in key.split():
        assert isinstance(cmd, click.Group)
        cmd = cmd.commands[word]
    return cmd


def parsed(words: list[str]) -> click.Context:
    """The context of the command ``aldpat WORDS...`` names, its options parsed as a user's
    command line is (an unknown option or a bad choice raises), nothing run."""
    cmd: click.Command = cli
    ctx = cli.make_context("aldpat", words[1:])
    while isinstance(cmd, click.Group):
        name, sub, rest = cmd.resolve_command(ctx, [*ctx._protected_args, *ctx.args])
        assert sub is not None and name is not None
        cmd, ctx = sub, sub.make_context(name, rest, parent=ctx)
    return ctx


@pytest.mark.parametrize("key", PAGES)
def test_every_help_page_opens_with_examples_that_parse(runner, key):
    text = help_of(runner, key)
    heads = list(sections(text))
    assert heads[0] == "Examples" and heads[1] == LEVELS["common"], heads
    examples = command(key).examples  # type: ignore[attr-defined]
    assert 2 <= len(examples) <= 3
    for line, what in examples:
        words = shlex.split(line)
        assert words[:len(key.split()) + 1] == ["aldpat", *key.split()], line
        assert line in text and what.split()[0] in text
        ctx = parsed(words)
        assert ctx.params.get("inputs") or key == "run", line  # every example names its inputs
        task = TASKS.get(ctx.command_path.removeprefix("aldpat "))
        for spec in task.all_specs() if task else ():
            if ctx.params.get(spec.name) is not None:
                coerce(spec, ctx.params[spec.name])  # a value the parameter takes (choices, bounds)


@pytest.mark.parametrize("key", COMMANDS)
def test_options_are_listed_common_first_then_advanced_then_internals(runner, key):
    heads = [h for h in sections(help_of(runner, key)) if h in LEVELS.values()]
    assert heads == [title for title in LEVELS.values() if title in heads]
    assert heads[0] == LEVELS["common"]


def test_a_filters_help_puts_the_few_common_options_first(runner):
    parts = sections(help_of(runner, "filter gapm"))
    common, advanced, internal = (parts[LEVELS[level]] for level in ("common", "advanced", "internal"))
    for option in ("--cell", "--auto", "--result", "--low-outliers", "--odir", "--overwrite", "-j, --jobs"):
        assert option in common, option
    for option in ("--chunk", "--origin", "--marks", "--scheduler", "--delimiter"):
        assert option in advanced, option
    for option in ("--window-series", "--cluster-thresholds", "--init-thresh-bin", "--directions"):
        assert option in internal, option


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_every_filter_keeps_its_common_options_few(name):
    """A parameter a filter declares is common only when most runs set it (cell, auto): the
    method's own settings are internals."""
    own = [s.name for s in TASKS[f"filter {name}"].all_specs() if s.level == "common"]
    run_and_output = {"odir", "out_format", "overwrite", "jobs"}
    assert len(set(own) - run_and_output) <= 5, own


@pytest.mark.parametrize("key", [k for k in sorted(TASKS) if TASKS[k].writes_outputs and not TASKS[k].writes_points])
def test_commands_that_write_no_points_list_no_point_output_options(runner, key):
    text = help_of(runner, key)
    assert "--delimiter" not in text and "--out-format" not in text
    assert "--odir" in text and "--overwrite" in text


@pytest.mark.parametrize("key", ["dtm", "grid", "preview"])
def test_grid_commands_refuse_point_output_options(runner, key, tmp_path):
    result = runner.invoke(cli, [key, str(tmp_path / "x.txt"), "--out-format", "laz"])
    assert result.exit_code == 2 and "--out-format" in result.output


@pytest.mark.parametrize("key", [k for k in sorted(TASKS) if not TASKS[k].reads_points])
def test_commands_that_read_no_points_have_no_input_format(runner, key):
    assert "--format" not in help_of(runner, key)


def test_the_root_lists_the_commands_in_the_workflow_order_of_the_readme():
    text = aldpat("--help").ok().stdout
    listed = [m.group(1) for m in re.finditer(r"^  ([a-z][a-z0-9-]*)\s{2,}", text, re.MULTILINE)]
    placed = [name for _, names in WORKFLOW for name in names]
    assert listed == [n for n in placed if n in listed] + sorted(set(listed) - set(placed))
    assert set(cli.commands) <= set(listed)
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    table = [m.group(1) for m in re.finditer(r"^\| `([a-z][a-z0-9-]*)[^`]*` \|", readme, re.MULTILINE)]
    assert [n for n in listed if n in table] == table


def test_filter_help_says_which_to_start_with_and_each_filters_error(runner):
    text = " ".join(help_of(runner, "filter").split())
    assert f"Start with {START_WITH}" in text
    for name in FILTERS:
        assert re.search(rf"\b{re.escape(name)} {re.escape(ISPRS_SCORES[name].text())}", text), name
    listed = [m.group(1) for m in re.finditer(r"^  ([a-z][a-z0-9-]*)\s{2,}\d", help_of(runner, "filter"), re.MULTILINE)]
    assert listed[0] == START_WITH and len(listed) == len(FILTERS)
    assert [ISPRS_SCORES[n].total for n in listed] == sorted(ISPRS_SCORES[n].total for n in listed)


def bench_rows() -> dict[str, list[str]]:
    """``| name (`name.toml`...) | ... |`` rows of bench/README.md: name -> their last cells."""
    rows: dict[str, list[str]] = {}
    for line in (REPO / "bench" / "README.md").read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\| ([a-z0-9-]+) \(`([a-z0-9-]+)\.toml`", line)
        if m and m.group(1) == m.group(2):  # the filter with its shipped (default) parameter file
            rows.setdefault(m.group(1), []).append(line.strip().strip("|").split("|")[-1])
    return rows


def test_the_scores_are_those_the_benchmarks_measured():
    """The figures of ``aldpat filter --help`` are bench/README.md's: a filter's row with its
    default parameter file ends on its mean, and the held-out figure is tabled too."""
    rows = bench_rows()
    readme = (REPO / "bench" / "README.md").read_text(encoding="utf-8")
    assert set(ISPRS_SCORES) == set(FILTERS)
    for name, score in ISPRS_SCORES.items():
        mean = re.compile(rf"(?<![\d.]){score.total:.2f}(?!\d)")
        assert any(mean.search(last) for last in rows.get(name, [])), (name, rows.get(name))
        if score.held_out is not None:
            assert re.search(rf"\*\*{score.held_out:.2f}\*\*|\| {score.held_out:.2f} \|", readme), name
