"""How a command's results are shown: on stdout each record's own text for people, JSON for
scripts (``--json``); on stderr one line per job of a task that writes outputs, saying what it
did (:meth:`aldpat.jobs.context.JobResult.summary`)."""

from __future__ import annotations

import json

import click

from aldpat.jobs.context import JobResult
from aldpat.jobs.run import RunReport
from aldpat.jobs.task import Task


def show(report: RunReport, as_json: bool) -> None:
    for result in report.results:
        for record in result.records:
            click.echo(json.dumps(record) if as_json else "\n".join(record.lines()))


def summarize(results: list[JobResult], task: Task) -> None:
    """The line each finished job of a file-writing task ends with (points in, ground share or
    nodes, time, output), on stderr."""
    if not task.writes_outputs:
        return  # a reporting task's records are its summary
    for result in results:
        if result.ok and result.outputs:
            click.echo(result.summary(one_input=task.run_one is not None), err=True)
