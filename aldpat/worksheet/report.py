"""The run report: one self-contained HTML page of a worksheet run (``aldpat run JOB.toml
--report``, or ``report = true`` in the worksheet's ``[settings]``).

``<worksheet-stem>.html`` beside the worksheet shows every job -- its state, time, message,
parameters with where each came from, inputs with their sizes, outputs with their point counts
-- the tables of reporting jobs (``evaluate``'s Type I / II / total error and kappa, ``info``),
and every PNG a job wrote (``preview``, ``evaluate --map``) as a thumbnail. Thumbnails are
embedded as data URIs and the style sheet is inline: the page needs no network and no other
file, so it can be mailed or archived with the project. Links to the outputs are relative to the
page, for opening them beside it.

Every name and value on the page is text from files and worksheets, so it is escaped, and a link
is only ever a path: percent-encoded, relative (``./``) or a ``file:`` URI, so an output named
``javascript:alert(1).txt`` links to that file and runs nothing.
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import os
import urllib.parse
from collections.abc import Iterable
from pathlib import Path

import aldpat
from aldpat.errors import one_line
from aldpat.io.atomic import atomic_output
from aldpat.jobs.context import Record, Written
from aldpat.jobs.inputs import expand_inputs
from aldpat.worksheet.model import Worksheet
from aldpat.worksheet.runner import BLOCKED, DONE, FAILED, SKIPPED, JobStatus

#: longest side of an embedded thumbnail (pixels): small pages, pictures still readable
THUMBNAIL = 480
#: a job's list of outputs is shown open up to this many (a tile run's hundreds are folded)
OPEN_OUTPUTS = 10

STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; padding: 0 1em; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { font-size: 1.15em; margin: 0; }
.meta { color: #555; margin-bottom: 1.5em; }
section.job { border: 1px solid #ccc; border-radius: 6px; padding: 0.8em 1em; margin: 1em 0; }
.state { display: inline-block; padding: 0 0.6em; border-radius: 4px; color: #fff; font-weight: 600; }
.Done { background: #2e7d32; } .Failed { background: #c62828; } .Blocked { background: #ef6c00; }
.Skipped { background: #607d8b; } .Ready, .Running { background: #9e9e9e; }
table { border-collapse: collapse; margin: 0.4em 0; }
td, th { border-bottom: 1px solid #e5e5e5; padding: 0.15em 0.8em 0.15em 0; text-align: left; vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.message { color: #444; } .failed-message { color: #c62828; }
figure { display: inline-block; margin: 0.5em 1em 0.5em 0; } figcaption { font-size: 0.85em; color: #555; }
img { border: 1px solid #ddd; max-width: 100%; image-rendering: pixelated; }
details summary { cursor: pointer; color: #333; }
.wide { overflow-x: auto; }
.legend span { display: inline-block; width: 0.9em; height: 0.9em; margin: 0 0.3em 0 0.8em; vertical-align: -0.1em; }
"""

#: the colours of ``evaluate --map`` (:data:`aldpat.tasks.preview.CALL_RGB`), told beside its thumbnail
MAP_LEGEND = (('rgb(225,40,40)', "bare earth rejected (Type I)"), ('rgb(40,90,230)', "object accepted (Type II)"),
              ('rgb(120,185,110)', "ground, right"), ('rgb(175,175,175)', "object, right"))


def report_path(ws: Worksheet) -> Path:
    return ws.path.with_name(ws.path.stem + ".html")


def write_report(ws: Worksheet, statuses: list[JobStatus], *, command: str = "aldpat run") -> Path:
    """Write the page for ``statuses`` atomically, replacing the last run's; return its path."""
    path = report_path(ws)
    page = render_report(ws, statuses, command=command)
    with atomic_output(path, overwrite=True) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


def render_report(ws: Worksheet, statuses: list[JobStatus], *, command: str = "aldpat run") -> str:
    counts = {state: sum(s.state == state for s in statuses) for state in (DONE, FAILED, BLOCKED, SKIPPED)}
    summary = ", ".join(f"{n} {state.lower()}" for state, n in counts.items() if n)
    seconds = sum(s.seconds for s in statuses)
    when = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>aldpat run: {_e(ws.path.name)}</title>",
        f"<style>{STYLE}</style></head><body>",
        f"<h1>{_e(ws.path.name)}</h1>",
        (f'<div class="meta">{_e(command)}<br>aldpat {_e(aldpat.__version__)}, {when}: {len(statuses)} jobs '
        f"({_e(summary or 'none run')}), {seconds:.1f} s</div>"),
    ]
    parts += [_job_section(ws, status) for status in statuses]
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _job_section(ws: Worksheet, status: JobStatus) -> str:
    job = status.job
    timing = f" {status.seconds:.2f} s" if status.state in (DONE, FAILED) else ""
    message_class = "failed-message" if status.state in (FAILED, BLOCKED) else "message"
    out = [
        f'<section class="job" id="job-{job.number}">',
        (f'<h2>job {job.number}: {_e(job.task.key)} <span class="state {status.state}">{status.state}</span>'
        f"{timing}</h2>"),
    ]
    if status.message:
        out.append(f'<div class="{message_class}">{_e(status.message)}</div>')
    out.append(_table_details("parameters", ["name", "value", "from"], job.run.record()))
    out.append(_inputs(ws, job.inputs))
    written = [w for r in status.results for w in r.outputs] or [Written(p) for p in status.outputs]
    if written:
        out.append(_outputs(ws, written))
    records = [rec for r in status.results for rec in r.records]
    if records:
        out.append(_records(records))
    pictures = [w.path for w in written if w.path.lower().endswith(".png") and os.path.exists(w.path)]
    if pictures:
        out.append("<div>" + "".join(_figure(ws, Path(p)) for p in pictures) + "</div>")
        if job.task.key == "evaluate":
            out.append('<div class="legend">' + "".join(f'<span style="background:{c}"></span>{_e(t)}'
                                                        for c, t in MAP_LEGEND) + "</div>")
    out.append("</section>")
    return "\n".join(out)


def _e(text: object) -> str:
    """Text as HTML shows it: markup escaped, control characters as their escapes."""
    return html.escape(one_line(text), quote=True)


def _relative(ws: Worksheet, path: str | Path) -> str:
    try:
        return Path(os.path.relpath(Path(path).resolve(), ws.folder.resolve())).as_posix()
    except ValueError:  # another drive (Windows)
        return Path(path).resolve().as_posix()


def _href(ws: Worksheet, path: str | Path) -> str:
    """A link to a file that can only be that file: the path relative to the page with each part
    percent-encoded (so no ``scheme:`` can appear) behind ``./``, or a ``file:`` URI."""
    rel = _relative(ws, path)
    if Path(rel).is_absolute():
        return Path(rel).as_uri()
    return "./" + urllib.parse.quote(rel, safe="/")


def _table_details(title: str, header: list[str], rows: Iterable[Iterable[object]], *, open_: bool = False) -> str:
    rows = list(rows)
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_e(v)}</td>" for v in row) + "</tr>" for row in rows)
    return (f"<details{' open' if open_ else ''}><summary>{_e(title)} ({len(rows)})</summary>"
            f"<table><tr>{head}</tr>{body}</table></details>")


def _inputs(ws: Worksheet, inputs: list[str]) -> str:
    sources, _ = expand_inputs(inputs)
    rows = []
    for s in sources:
        try:
            size = f"{os.path.getsize(s):,} bytes"
        except OSError:
            size = "missing"
        rows.append((_relative(ws, s), size))
    return _table_details("inputs", ["file", "size"], rows)


def _outputs(ws: Worksheet, written: list[Written]) -> str:
    rows = []
    for w in written:
        rel = _relative(ws, w.path)
        count = "" if w.count is None else f"{w.count:,} points"
        rows.append(f'<tr><td><a href="{_e(_href(ws, w.path))}">{_e(rel)}</a></td><td class="num">{_e(count)}</td></tr>')
    return (f"<details{' open' if len(written) <= OPEN_OUTPUTS else ''}><summary>outputs ({len(written)})</summary>"
            f"<table><tr><th>file</th><th>points</th></tr>{''.join(rows)}</table></details>")


def _records(records: list[Record]) -> str:
    """The results of a reporting job, one row per record, a column per key."""
    keys: list[str] = []
    for rec in records:
        keys += [k for k in rec if k not in keys]
    head = "".join(f"<th>{_e(k)}</th>" for k in keys)
    rows = []
    for rec in records:
        cells = []
        for k in keys:
            v = rec.get(k)
            numeric = isinstance(v, (int, float)) and not isinstance(v, bool)
            text = f"{v:.4f}" if k == "kappa" and numeric else f"{v:.2f}" if isinstance(v, float) else \
                "" if v is None else str(v)
            cells.append(f'<td class="num">{_e(text)}</td>' if numeric else f"<td>{_e(text)}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f"<div class=\"wide\"><table><tr>{head}</tr>{''.join(rows)}</table></div>"


def _figure(ws: Worksheet, path: Path) -> str:
    rel = _relative(ws, path)
    uri, (width, height) = thumbnail(path)
    return (f'<figure><a href="{_e(_href(ws, path))}"><img alt="{_e(path.name)}" width="{width}" height="{height}" '
            f'src="{uri}"></a><figcaption>{_e(rel)}</figcaption></figure>')


def thumbnail(path: Path) -> tuple[str, tuple[int, int]]:
    """The picture as a PNG data URI, at most :data:`THUMBNAIL` pixels on its longer side, and
    the size to show it at: a small grid's hillshade is shown enlarged to that size, pixels kept
    square (Pillow is there: the job that wrote the PNG needed it)."""
    from PIL import Image

    with Image.open(path) as image:
        image.load()
        if max(image.size) > THUMBNAIL:
            image.thumbnail((THUMBNAIL, THUMBNAIL), Image.Resampling.BOX)
        buffer = io.BytesIO()
        image.save(buffer, format="PNG", optimize=True)
        scale = THUMBNAIL / max(image.size)
        shown = (round(image.size[0] * scale), round(image.size[1] * scale))
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii"), shown
