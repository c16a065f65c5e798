"""How a command's results are shown on stdout: each record's own text for people, JSON for
scripts (``--json``)."""

from __future__ import annotations

import json

import click

from aldpat.jobs.run import RunReport


def show(report: RunReport, as_json: bool) -> None:
    for result in report.results:
        for record in result.records:
            click.echo(json.dumps(record) if as_json else "\n".join(record.lines()))
