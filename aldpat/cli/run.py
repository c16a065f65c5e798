"""``aldpat run JOB.toml``: validate a whole worksheet, then run its jobs in order."""

from __future__ import annotations

import sys

import click

from aldpat.cli.help import GuidedCommand
from aldpat.cli.logs import setup_logging
from aldpat.cli.render import show, summarize
from aldpat.errors import AldpatError, UsageError, one_line
from aldpat.jobs.run import RunReport
from aldpat.worksheet.model import load_worksheet
from aldpat.worksheet.runner import BLOCKED, DONE, FAILED, JobStatus, job_table, run_worksheet


def _parse_only(values: tuple[str, ...]) -> set[int] | None:
    if not values:
        return None
    out = set()
    for v in values:
        for part in v.split(","):
            part = part.strip()
            if not (part.isascii() and part.isdigit()):
                raise UsageError(f"--only {v!r}: expected job numbers such as 2 or 2,3")
            if int(part) == 0:
                raise UsageError(f"--only {v!r}: jobs are numbered from 1")
            out.add(int(part))
    return out


@click.command("run", cls=GuidedCommand, examples=(
    ("aldpat run jobs/demo.toml --report",
     "every job of the demo worksheet, and demo.html beside it: states, times, errors and pictures"),
    ("aldpat run project.toml --resume",
     "only the jobs whose inputs, parameters or outputs changed since they last finished"),
    ("aldpat run project.toml --dry-run", "check the worksheet and show each job as it would run"),
))
@click.argument("worksheet", metavar="JOB.toml")
@click.option("--resume", is_flag=True, help="skip jobs whose inputs, parameters and outputs are unchanged "
              "since they last finished")
@click.option("--dry-run", is_flag=True, help="validate and show the jobs as they would run; run nothing")
@click.option("--only", multiple=True, metavar="N[,N...]", help="run only these jobs (numbers from 1)")
@click.option("--set", "overrides", multiple=True, metavar="job.N.key=VALUE",
              help="override a key of job N (or settings.key=VALUE) for this run")
@click.option("-j", "--jobs", type=int, default=None,
              help="worker processes per job (0 = all cores), overriding the worksheet")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="run the jobs on this Dask cluster (tcp://host:8786, or local:N); a worksheet may name an "
              "address only when it is this one or $ALDPAT_SCHEDULER, since the scheduler can run code here")
@click.option("--report", is_flag=True, help="write <worksheet>.html beside the worksheet: every job's state, "
              "time, parameters, inputs, outputs, results and pictures, in one self-contained page "
              "(also: report = true in [settings])")
@click.option("-v", "--verbose", count=True, help="more detail on stderr")
@click.option("-q", "--quiet", count=True, help="only errors on stderr: no job statuses")
@click.pass_context
def run_command(ctx: click.Context, worksheet: str, resume: bool, dry_run: bool, only: tuple[str, ...],
                overrides: tuple[str, ...], jobs: int | None, scheduler: str | None, report: bool, verbose: int,
                quiet: int) -> None:
    """Run a worksheet: jobs in order, each Ready -> Running -> Done or Failed."""
    root = ctx.find_root().params
    quiet += root.get("quiet", 0)
    if verbose or quiet:
        setup_logging(verbose + root.get("verbose", 0), quiet)
    try:
        ws = load_worksheet(worksheet, overrides, scheduler=scheduler)
        selected = _parse_only(only)
        report = report or ws.wants_report
        if jobs is not None and jobs < 0:  # in the words a task's own -j is refused in
            raise UsageError(f"jobs: {jobs} is out of range (must be >= 0)")
        if selected and max(selected) > len(ws.jobs):
            raise UsageError(f"--only {max(selected)}: the worksheet has {len(ws.jobs)} jobs")
    except UsageError as exc:
        click.echo(f"aldpat: error: {one_line(exc)}", err=True)
        sys.exit(2)
    except Exception as exc:  # noqa: BLE001  (e.g. a missing worksheet file: one line, exit 2)
        click.echo(f"aldpat: error: {one_line(exc)}", err=True)
        sys.exit(2)
    if dry_run:
        for job in ws.jobs:
            if selected and job.number not in selected:
                continue
            click.echo(f"# job {job.number}: Ready" + (f" (after job {', '.join(map(str, sorted(job.depends_on)))})"
                                                       if job.depends_on else ""))
            click.echo("\n".join(job_table(job)) + "\n")
        sys.exit(0)

    def on_status(st: JobStatus) -> None:
        if not quiet or st.state in (FAILED, BLOCKED):
            extra = f": {one_line(st.message)}" if st.message else ""
            timing = f" ({st.seconds:.2f} s)" if st.state in (DONE, FAILED) else ""
            click.echo(f"job {st.job.number} {st.job.task.key}: {st.state}{extra}{timing}", err=True)
            if st.state == DONE and not quiet:
                summarize(st.results, st.job.task)
        if st.state == DONE:  # results (info, evaluate) go to stdout even with -q
            show(RunReport(st.job.task.key, st.results, []),
                 as_json=bool(getattr(st.job.run.params.values, "json", False)))

    command = "aldpat run " + " ".join(sys.argv[2:])
    from aldpat.cli.progress import job_progress

    try:
        statuses = run_worksheet(ws, only=selected, resume=resume, jobs=jobs, on_status=on_status, command=command,
                                 progress=lambda job: job_progress(job.task, enabled=not quiet))
    except AldpatError as exc:  # the worksheet is being run already, or its lock cannot be made
        click.echo(f"aldpat: error: {exc}", err=True)
        sys.exit(2 if isinstance(exc, UsageError) else 1)
    if report:
        from aldpat.worksheet.report import write_report

        try:
            page = write_report(ws, statuses, command=command)
        except OSError as exc:
            click.echo(f"aldpat: error: report not written: {one_line(exc)}", err=True)
            sys.exit(1)
        if not quiet:
            click.echo(f"report: {one_line(page)}", err=True)
    failed = [s for s in statuses if s.state in (FAILED, BLOCKED)]
    sys.exit(1 if failed else 0)
