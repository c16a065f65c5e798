"""How a command's results are shown on stdout: plain text for people, JSON for scripts."""

from __future__ import annotations

import json

import click

from aldpat.tasks.base import RunReport


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.3f}"
    if isinstance(v, list):
        return "  ".join(_fmt(x) for x in v)
    return "-" if v is None else str(v)


def show_info(record: dict) -> None:
    click.echo(record["path"])
    b = record["bounds"]
    rows = [
        ("format", record["format"] + (f" ({record['delimiter']}-delimited)" if record.get("delimiter") else "")),
        ("points", f"{record['count']:,}"),
        ("fields", " ".join(record["fields"])),
        ("x range", f"{b[0]:.3f} .. {b[2]:.3f}  ({b[2] - b[0]:.3f})"),
        ("y range", f"{b[1]:.3f} .. {b[3]:.3f}  ({b[3] - b[1]:.3f})"),
        ("z range", f"{record['z_range'][0]:.3f} .. {record['z_range'][1]:.3f}"),
        ("density", "-" if record["density"] is None else f"{record['density']:.3f} points per unit² (bounding box)"),
        ("crs", record["crs"] or "unknown"),
    ]
    for k, v in rows:
        click.echo(f"  {k:8} {v}")


def show_evaluate(record: dict) -> None:
    click.echo(f"{record['path']}  vs  {record['reference']}")
    click.echo(f"  Type I   {record['type1']:7.2f} %   ({record['ground_as_object']} of "
               f"{record['ground_as_ground'] + record['ground_as_object']} bare-earth points rejected)")
    click.echo(f"  Type II  {record['type2']:7.2f} %   ({record['object_as_ground']} of "
               f"{record['object_as_ground'] + record['object_as_object']} object points accepted)")
    click.echo(f"  total    {record['total']:7.2f} %   ({record['ground_as_object'] + record['object_as_ground']}"
               f" of {record['points']} points)")
    click.echo(f"  kappa    {record['kappa']:7.4f}")
    if record.get("unmatched"):
        click.echo(f"  ({record['unmatched']} result points matched no reference point)")


RENDERERS = {"info": show_info, "evaluate": show_evaluate}


def show(report: RunReport, as_json: bool) -> None:
    renderer = RENDERERS.get(report.task)
    for result in report.results:
        for record in result.records:
            if as_json:
                click.echo(json.dumps(record))
            elif renderer is not None:
                renderer(record)
            else:
                click.echo("  ".join(f"{k}={_fmt(v)}" for k, v in record.items()))
