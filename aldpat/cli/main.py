"""The ``aldpat`` command: a root group whose commands are generated from the task registry.

Each command parses, resolves paths and hands the values to :func:`aldpat.jobs.run.run_task`;
no algorithm lives here. This is also the only place that turns errors into exit codes:
0 all done, 1 some inputs failed, 2 usage error.
"""

from __future__ import annotations

import logging
import shlex
import sys
from collections.abc import Iterable
from typing import Any

import click

import aldpat
from aldpat import interrupt
from aldpat.cli.help import GuidedCommand, GuidedGroup
from aldpat.cli.leave import leave_after
from aldpat.cli.logs import setup_logging
from aldpat.cli.options import option_for, params_file_opt, renamed_option
from aldpat.cli.progress import job_progress
from aldpat.cli.render import show, summarize
from aldpat.cli.run import run_command
from aldpat.errors import AldpatError, UsageError, one_line, shown
from aldpat.jobs.outputs import existing_outputs_refused
from aldpat.jobs.resolve import load_params_file
from aldpat.jobs.run import PlannedRun, formats_refused, plan_run, run_task
from aldpat.jobs.task import Task
from aldpat.params import renamed_keys, spec_map
from aldpat.tasks import TASKS

log = logging.getLogger("aldpat")


def fail_usage(message: str) -> None:
    click.echo(f"aldpat: error: {one_line(message)}", err=True)
    sys.exit(2)


def command_line(task: Task, inputs: Iterable[str], given: dict[str, Any], params_file: str | None) -> str:
    """The command as it would be typed to repeat this run (recorded in the logs)."""
    words = ["aldpat"] + task.key.split(" ") + [str(i) for i in inputs]
    specs = {s.name: s for s in task.all_specs()}
    renames = renamed_keys(specs.values())  # recorded under the names now, as the log replays them
    for name, value in given.items():
        spec = specs[renames.get(name, name)]
        if spec.kind == "bool":
            words.append(spec.option if value else f"--no-{spec.option[2:]}")
        elif isinstance(value, tuple):
            words += [spec.option, *map(str, value)]
        else:
            words += [spec.option, str(value)]
    if params_file:
        words += ["--params", params_file]
    return shlex.join(words)


def make_command(task: Task) -> click.Command:
    """A click command for ``task``: INPUT... plus an option for each declared parameter."""
    specs = task.all_specs()

    @click.pass_context
    def callback(ctx: click.Context, inputs: tuple[str, ...] = (), params_file: str | None = None, verbose: int = 0,
                 quiet: int = 0, dry_run: bool = False, **raw: Any) -> None:
        from click.core import ParameterSource

        root = ctx.find_root().params
        quiet = quiet + root.get("quiet", 0)
        if verbose or quiet:
            setup_logging(verbose + root.get("verbose", 0), quiet)

        given = {k: v for k, v in raw.items()
                 if v is not None and ctx.get_parameter_source(k) == ParameterSource.COMMANDLINE}
        layers: list[tuple[str, dict[str, Any]]] = []
        try:
            if params_file:
                layers.append(("params file", load_params_file(task, params_file)))
            layers.append(("cli", given))
            if dry_run:
                sys.exit(show_plan(task, plan_run(task, list(inputs), layers)))
            with job_progress(task, enabled=not quiet) as progress:
                report = run_task(task, list(inputs), layers, command=command_line(task, inputs, given, params_file),
                                  progress=progress)
        except UsageError as exc:
            fail_usage(str(exc))
        except AldpatError as exc:
            click.echo(f"aldpat: error: {one_line(exc)}", err=True)
            sys.exit(1)
        except OSError as exc:  # the system refused a file the plan looked at (each job catches its own)
            where = f"{shown(str(exc.filename), quoted=False)}: " if exc.filename is not None else ""
            click.echo(f"aldpat: error: {where}{(exc.strerror or str(exc)).lower()}", err=True)
            sys.exit(1)
        show(report, bool(getattr(report.params, "json", False)))
        if not quiet:
            summarize(report.results, task)
        for result in report.results:
            for w in result.outputs:
                log.info("wrote %s%s", w.path, f" ({w.count} points)" if w.count is not None else "")
        if report.failed and report.exit_code != 2:  # a usage error is the command's, not its inputs'
            if task.run_all is not None:  # one job of every input (merge, tile...): it failed whole
                named = sum(len(r.inputs) for r in report.results) + len(report.input_errors)
                log.warning("%s of %d %s failed", task.key, named, "input" if named == 1 else "inputs")
            else:
                failed, named = report.inputs_failed
                if failed:  # a mosaic that failed alone has said so: its inputs are no one's files
                    log.warning("%d of %d inputs failed", failed, named)
        sys.exit(report.exit_code)

    params: list[click.Parameter] = []
    if task.inputs != "none":
        params.append(click.Argument(["inputs"], nargs=-1, metavar="INPUT..."))
    params += [option_for(s) for s in specs]
    params += [renamed_option(s, old) for s in specs for old in s.renamed_from]
    params.append(params_file_opt)
    params.append(click.Option(["--dry-run"], is_flag=True, help="check the parameters, inputs and outputs, and show "
                               "the jobs as they would run; read and write nothing"))
    params.append(click.Option(["-v", "--verbose"], count=True, help="more detail on stderr"))
    params.append(click.Option(["-q", "--quiet"], count=True, help="only errors on stderr, no progress or summary"))
    return GuidedCommand(
        task.name, callback=callback, params=params, help=task.summary + ("\n\n" + task.epilog if task.epilog else ""),
        short_help=task.summary.rstrip("."), context_settings={"max_content_width": 110},
        no_args_is_help=task.inputs != "none", examples=task.examples,
    )


def show_plan(task: Task, plan: PlannedRun) -> int:
    """``--dry-run``: the jobs, the outputs they would write and every parameter with its source,
    on stdout; the exit status (1 when an input cannot be found or is of no point format, or an
    output exists without ``--overwrite``, as the run would end)."""
    click.echo(f"# aldpat {task.key}: {len(plan.jobs)} job(s) as they would run; nothing read or written")
    for number, job in enumerate(plan.jobs, 1):
        click.echo(f"# job {number}: {', '.join(job) if job else '(no input)'}")
        for out in plan.outputs:
            if out.source is not None and job and str(out.source) == job[0]:
                click.echo(f"#   writes {out.path}")
    for out in plan.outputs:
        if out.source is None:
            click.echo(f"# writes {out.path} (from every input)")
    for name, value, source in plan.run.record():
        click.echo(f"{name} = {value}    # {source}")
    refused = formats_refused(task, plan) + existing_outputs_refused(plan.outputs, plan.run)
    for line in refused:
        log.error(line)
    return 1 if plan.input_errors or refused else 0


#: ``aldpat --help`` lists the commands in the order of ALDPAT's workflow (the README's table),
#: under these headings; a command not named here is listed last, under "Other commands".
WORKFLOW: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Prepare strips and tiles (manual tasks 1-7)",
     ("split-tape", "separate-returns", "ortho-height", "strip-boundary", "merge-boundary", "shapefile", "tile")),
    ("Ground and terrain (tasks 8-10)", ("filter", "grid", "grd2bin", "dtm", "preview")),
    ("Points and checks", ("thin", "polygon-extract", "merge", "info", "evaluate", "convert")),
    ("Projects", ("run",)),
)


class WorkflowRoot(GuidedGroup):
    """``aldpat``: examples, then the commands in the workflow's order (:data:`WORKFLOW`)."""

    examples = (
        ("aldpat info site.laz", "count, bounds, density and CRS of a point file"),
        ("aldpat filter gapm site.laz --odir ground/", "its ground points (aldpat filter --help: which filter)"),
        ("aldpat dtm site.laz --cell 1 --odir dtm/", "a bare-earth DTM, a Cloud Optimized GeoTIFF"),
    )

    def list_commands(self, ctx: click.Context) -> list[str]:
        placed = [name for _, names in WORKFLOW for name in names if name in self.commands]
        return placed + sorted(set(self.commands) - set(placed))

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rest = sorted(set(self.commands) - {n for _, names in WORKFLOW for n in names})
        width = max(map(len, self.commands))
        for heading, names in (*WORKFLOW, ("Other commands", tuple(rest))):
            rows = [(n, self.commands[n].get_short_help_str(formatter.width - 6 - width))
                    for n in names if n in self.commands and not self.commands[n].hidden]
            if rows:
                with formatter.section(heading):
                    formatter.write_dl(rows, col_max=width + 2)


class FilterGroup(GuidedGroup):
    """``aldpat filter``: which filter to start with, and each one's measured error."""

    examples = (
        ("aldpat filter gapm site.laz", "the ground points of one file, beside it (gapm's defaults)"),
        ("aldpat filter gapm tiles/ -j 0 --odir ground/", "every point file of a folder, on all cores"),
        ("aldpat filter atin site.laz --params atin.toml", "another filter, its parameters from a TOML file"),
    )

    def list_commands(self, ctx: click.Context) -> list[str]:
        from aldpat.filters.scores import ISPRS_SCORES

        return sorted(self.commands, key=lambda n: (ISPRS_SCORES[n].total if n in ISPRS_SCORES else 1e9, n))

    def guide(self, ctx: click.Context) -> str:
        from aldpat.filters import FILTERS
        from aldpat.filters.scores import ISPRS_SCORES, START_WITH

        auto = " (--auto derives its cell and windows from the data)" \
            if "auto" in spec_map(FILTERS[START_WITH].params) else ""
        return (f"Start with {START_WITH}: its defaults have the lowest error measured, "
                f"{ISPRS_SCORES[START_WITH].text()}{auto}. Below, each filter with its mean total error with its "
                "defaults on seven ISPRS filter-test reference samples, and where measured on samples held out of "
                "choosing them (bench/README.md). 'aldpat filter ALGO --help' lists a filter's options, the few "
                "most runs set first.")

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        from aldpat.filters.scores import ISPRS_SCORES

        rows = []
        for name in self.list_commands(ctx):
            score = ISPRS_SCORES[name].text() if name in ISPRS_SCORES else "not measured"
            rows.append((name, f"{score}; {self.commands[name].get_short_help_str(200)}"))
        with formatter.section("Filters (ISPRS mean total error)"):
            formatter.write_dl(rows)


@click.group(cls=WorkflowRoot, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 110})
@click.version_option(aldpat.__version__, prog_name="aldpat")
@click.option("-v", "--verbose", count=True, help="more detail on stderr (-vv: debugging)")
@click.option("-q", "--quiet", count=True, help="only errors on stderr, no progress or summary")
def cli(verbose: int, quiet: int) -> None:
    """Batch airborne LiDAR processing: the ALDPAT tasks and its research ground filters,
    on ASCII and LAS/LAZ, from a shell or a TOML worksheet."""
    setup_logging(verbose, quiet)


@cli.group("filter", cls=FilterGroup, subcommand_metavar="ALGO INPUT...",
           short_help="Separate ground from non-ground points: twelve filters, which to start with")
def filter_group() -> None:
    """Separate ground from non-ground points."""


def _register_commands() -> None:
    for task in TASKS.values():
        command = make_command(task)
        if task.group == "filter":
            filter_group.add_command(command)
        elif task.group is None:
            cli.add_command(command)


_register_commands()
cli.add_command(run_command)


def main() -> None:
    """The ``aldpat`` command: runs it, then ends the process without the interpreter's teardown
    (:mod:`aldpat.cli.leave`)."""
    try:
        run()
    except SystemExit as exc:  # how run() ends every command, its status and all
        leave_after(exc)


def run() -> None:
    """The command of ``sys.argv``, its status raised as ``SystemExit`` (what a caller running
    several command lines in one process uses: :func:`main` ends the process)."""
    interrupt.install()
    try:
        cli.main(standalone_mode=False)
    except click.exceptions.Abort as exc:  # click's wrapper of a KeyboardInterrupt
        _interrupted(exc.__context__ if isinstance(exc.__context__, KeyboardInterrupt) else KeyboardInterrupt())
    except click.ClickException as exc:
        # an option of a megabyte is not echoed whole
        exc.message = one_line(exc.message if len(exc.message) <= 300  # type: ignore[misc]
                               else f"{exc.message[:300]}... ({len(exc.message):,} characters)")
        exc.show()
        sys.exit(2)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except KeyboardInterrupt as exc:
        _interrupted(exc)
    sys.exit(0)


def _interrupted(exc: BaseException) -> None:
    click.echo(f"aldpat: {interrupt.describe(exc)}", err=True)
    sys.exit(interrupt.exit_status(exc))
