"""Every registered task: the CLI options, the TOML keys and the log record are one declaration."""

from pathlib import Path

import pytest

from aldpat.cli.main import cli
from aldpat.jobs.resolve import resolve_run
from aldpat.options import RunParams
from aldpat.params import format_value, specs
from aldpat.tasks import TASKS

TASK_KEYS = sorted(TASKS)
#: a real file for required file parameters (ortho-height opens its geoid grid when checked)
REQUIRED_FILE = str(Path(__file__).resolve().parent / "data" / "egm96_15_nga1.gtx")


def command_for(key):
    parts = key.split(" ")
    cmd = cli
    for p in parts:
        cmd = cmd.commands[p]
    return cmd


def test_registry_has_the_foundation_tasks():
    assert {"info", "evaluate", "convert"} <= set(TASKS)


@pytest.mark.parametrize("key", TASK_KEYS)
def test_cli_options_are_derived_from_the_declaration(key):
    task = TASKS[key]
    cmd = command_for(key)
    options = {opt for p in cmd.params for opt in getattr(p, "opts", [])}
    for spec in task.all_specs():
        assert spec.option in options, f"{key}: {spec.option} missing from the command line"
        param = next(p for p in cmd.params if spec.option in p.opts)
        assert spec.help.rstrip(".") in param.help
    declared = {s.name for s in task.all_specs()} | {"inputs", "params_file", "verbose", "quiet", "dry_run"}
    renamed = {old for s in task.all_specs() for old in s.renamed_from}  # earlier names, hidden
    assert {p.name for p in cmd.params if not getattr(p, "hidden", False)} == declared
    assert {p.name for p in cmd.params if getattr(p, "hidden", False)} == renamed


RUN_OPTIONS = {s.name for s in specs(RunParams)}


@pytest.mark.parametrize("key", TASK_KEYS)
def test_toml_keys_and_log_record_match_the_declaration(key):
    task = TASKS[key]
    defaults = {s.name: s.default for s in task.all_specs() if s.default is not None}
    given = {s.name: REQUIRED_FILE for s in task.all_specs() if s.required}
    run = resolve_run(task, [("worksheet", defaults), ("cli", given)])
    record = {name: (value, source) for name, value, source in run.record()}
    for spec in task.all_specs():
        if spec.name in RUN_OPTIONS:
            continue  # how jobs run (-j, --scheduler) is not a task parameter
        assert spec.name in record, f"{key}: {spec.name} missing from the log record"
        if spec.required:
            assert record[spec.name] == (REQUIRED_FILE, "cli")
            continue
        assert record[spec.name][0] == format_value(spec.default)
        expected_source = "worksheet" if spec.default is not None else "default"
        assert record[spec.name][1] == expected_source


@pytest.mark.parametrize("key", TASK_KEYS)
def test_help_lists_every_parameter_with_its_default(key, runner):
    args = key.split(" ") + ["--help"]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    flat = " ".join(result.output.split())
    for spec in TASKS[key].all_specs():
        assert spec.option in flat
        if spec.required:
            assert "required" in flat
            continue
        if spec.default is None and "default:" in spec.help:
            continue  # the help text says what an unset value means
        assert f"default: {format_value(spec.default)}" in flat


@pytest.mark.parametrize("key", TASK_KEYS)
def test_every_task_that_writes_files_plans_them(key):
    """Outputs replacing inputs or each other are refused before a run only if every task says its
    outputs first (its ``outputs`` hook); a written output the plan lacks is a fault the run
    reports (JobContext.wrote)."""
    task = TASKS[key]
    writes = task.writes_outputs or any(s.name == "map" for s in task.all_specs())
    assert not writes or task.outputs is not None, f"{key} writes files but plans none"
