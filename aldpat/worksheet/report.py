"""The run report: one self-contained HTML page of a worksheet run (``aldpat run JOB.toml
--report``, or ``report = true`` in the worksheet's ``[settings]``).

``<worksheet-stem>.html`` beside the worksheet opens on a summary: how many jobs ended in which
state and the run's time, a table of the jobs (state, time, inputs, what each did: points, ground
share, grid nodes, errors), the table of ``evaluate``'s Type I / II / total error and kappa, and
every picture a job wrote (``preview``'s hillshades and plan views, ``evaluate --map``) large,
north up, with a north arrow, a scale bar and the coordinates of its corners (from the world file
written beside it). Below, every job in full: its message, parameters with where each came from,
inputs with their sizes, outputs with their point counts, and the text of its results.

Pictures are embedded as data URIs inside inline SVG and the style sheet is inline: the page needs
no network and no other file, so it can be mailed or archived with the project. Links to the
outputs are relative to the page, for opening them beside it.

Every name and value on the page is text from files and worksheets, so it is escaped, and a link
is only ever a path: percent-encoded, relative (``./``) or a ``file:`` URI, so an output named
``javascript:alert(1).txt`` links to that file and runs nothing.
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import math
import os
import re
import urllib.parse
from collections.abc import Iterable
from pathlib import Path

import aldpat
from aldpat.errors import AldpatError, one_line
from aldpat.io.atomic import atomic_output
from aldpat.io.sidefiles import own_place
from aldpat.io.worldfile import NorthUp, read_world_file, world_path
from aldpat.jobs.context import Record, Written
from aldpat.jobs.inputs import expand_inputs
from aldpat.worksheet.model import Worksheet
from aldpat.worksheet.runner import BLOCKED, DONE, FAILED, SKIPPED, JobStatus

#: longest side of an embedded picture (pixels): a DTM's own size up to this, so that the page
#: stays a few megabytes; the link opens the full picture
EMBED_MAX = 2000
#: width of a picture on the page, in the SVG's units: about its width in pixels on a screen
#: (the page is 1100 px wide), so a small DTM is enlarged node by node and a large one fills it
PICTURE_WIDTH = 1000
#: a job's list of outputs is shown open up to this many (a tile run's hundreds are folded)
OPEN_OUTPUTS = 10
#: the colour of a picture's frame (drawn crisp: the browser test finds the picture by it)
FRAME_RGB = (31, 78, 121)

STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; padding: 0 1em; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { font-size: 1.25em; margin: 1.2em 0 0.4em; }
h3 { font-size: 1.05em; margin: 1em 0 0.3em; }
section.job h2 { font-size: 1.1em; margin: 0; }
.meta { color: #555; margin-bottom: 1em; }
.totals { font-size: 1.1em; margin: 0.3em 0 0.8em; }
section.job { border: 1px solid #ccc; border-radius: 6px; padding: 0.8em 1em; margin: 1em 0; }
.state { display: inline-block; padding: 0 0.6em; border-radius: 4px; color: #fff; font-weight: 600; }
.Done { background: #2e7d32; } .Failed { background: #c62828; } .Blocked { background: #ef6c00; }
.Skipped { background: #607d8b; } .Ready, .Running { background: #9e9e9e; }
table { border-collapse: collapse; margin: 0.4em 0; }
table.wide { width: 100%; }
td, th { border-bottom: 1px solid #e5e5e5; padding: 0.15em 0.8em 0.15em 0; text-align: left; vertical-align: top;
         overflow-wrap: anywhere; }
th, td.word { white-space: nowrap; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.path { min-width: 12em; }
.message { color: #444; } .failed-message { color: #c62828; }
pre.record { background: #f7f7f7; padding: 0.5em 0.8em; white-space: pre-wrap; overflow-wrap: anywhere; margin: 0.4em 0; }
figure.picture { margin: 1em 0 1.5em; } figure.picture svg { display: block; width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #444; }
details summary { cursor: pointer; color: #333; }
.legend span { display: inline-block; width: 0.9em; height: 0.9em; margin: 0 0.3em 0 0.8em; vertical-align: -0.1em; }
"""

#: the colours of ``evaluate --map`` (:data:`aldpat.tasks.preview.CALL_RGB`), told beside its picture
MAP_LEGEND = (('rgb(225,40,40)', "bare earth rejected (Type I)"), ('rgb(40,90,230)', "object accepted (Type II)"),
              ('rgb(120,185,110)', "ground, right"), ('rgb(175,175,175)', "object, right"))


#: what a run report aldpat wrote holds in its first lines
MARK = re.compile(rb"<title>aldpat run: ")


def report_path(ws: Worksheet) -> Path:
    """``<worksheet-stem>.html``, or aldpat's other name for it when that is the user's page
    (:mod:`aldpat.io.sidefiles`)."""
    return own_place(ws.path.with_name(ws.path.stem + ".html"), MARK)[0]


def write_report(ws: Worksheet, statuses: list[JobStatus], *, command: str = "aldpat run") -> Path:
    """Write the page for ``statuses`` atomically, replacing the last run's (never a page aldpat
    did not write); return its path."""
    path = report_path(ws)
    page = render_report(ws, statuses, command=command)
    with atomic_output(path, overwrite=True) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


def render_report(ws: Worksheet, statuses: list[JobStatus], *, command: str = "aldpat run") -> str:
    when = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>aldpat run: {_e(ws.path.name)}</title>",
        f"<style>{STYLE}</style></head><body>",
        f"<h1>{_e(ws.path.name)}</h1>",
        f'<div class="meta">{_e(command)}<br>aldpat {_e(aldpat.__version__)}, {when}</div>',
        _summary(ws, statuses),
        "<h2>Jobs</h2>",
    ]
    parts += [_job_section(ws, status) for status in statuses]
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


# ------------------------------------------------------------------------------ the summary


def _summary(ws: Worksheet, statuses: list[JobStatus]) -> str:
    counts = {state: sum(s.state == state for s in statuses) for state in (DONE, FAILED, BLOCKED, SKIPPED)}
    states = ", ".join(f"{n} {state.lower()}" for state, n in counts.items() if n) or "none run"
    seconds = sum(s.seconds for s in statuses)
    out = ['<section class="summary" id="summary">',
           f'<div class="totals">{len(statuses)} jobs: {_e(states)}; {seconds:.1f} s in all</div>',
           _jobs_table(ws, statuses)]
    errors = [rec for s in statuses for r in s.results for rec in r.records if "type1" in rec]
    if errors:
        out += ["<h3>Ground classification errors</h3>", _errors_table(ws, errors)]
    pictures = [(s, Path(w.path)) for s in statuses for w in _written(s)
                if w.path.lower().endswith(".png") and os.path.exists(w.path)]
    if pictures:
        out.append("<h3>Pictures</h3>")
        out += [_picture(ws, s, path) for s, path in pictures]
    out.append("</section>")
    return "\n".join(out)


def _jobs_table(ws: Worksheet, statuses: list[JobStatus]) -> str:
    head = ('<tr><th class="num">job</th><th>task</th><th>state</th><th class="num">time</th><th>inputs</th>'
            "<th>what it did</th></tr>")
    rows = []
    for s in statuses:
        job = s.job
        sources, _ = expand_inputs(job.inputs)
        if len(sources) == 1:
            inputs = _relative(ws, sources[0])
        else:  # none yet (a blocked job's pattern), or many
            inputs = f"{len(sources)} files" if sources else ", ".join(_relative(ws, i) for i in job.inputs)
        timing = f"{s.seconds:.2f} s" if s.state in (DONE, FAILED) else ""
        did = _did(s)
        rows.append(f'<tr><td class="num">{job.number}</td><td class="word">{_e(job.task.key)}</td>'
                    f'<td class="word"><span class="state {s.state}">{s.state}</span></td>'
                    f'<td class="num">{timing}</td><td class="path">{_e(inputs)}</td><td>{_e(did)}</td></tr>')
    return f'<table class="wide jobs">{head}{"".join(rows)}</table>'


def _did(status: JobStatus) -> str:
    """What a job did, in a few words: its message when it did not finish, else its counts."""
    if status.state != DONE:
        text = status.message
        return text if len(text) <= 240 else text[:237] + "..."
    counts: dict[str, int] = {}
    for r in status.results:
        for key, n in r.counts.items():
            counts[key] = counts.get(key, 0) + n
    parts = []
    if "points" in counts:
        parts.append(f"{counts['points']:,} points")
        if "ground" in counts and counts["points"]:
            parts.append(f"{100 * counts['ground'] / counts['points']:.1f} % ground")
        if "noise" in counts and counts["points"]:
            parts.append(f"{100 * counts['noise'] / counts['points']:.1f} % noise")
    if counts.get("nodes"):
        blank = counts.get("blank", 0)
        parts.append(f"{counts['nodes']:,} nodes" + (f", {100 * blank / counts['nodes']:.1f} % blank" if blank else ""))
    records = [rec for r in status.results for rec in r.records]
    if records and "total" in records[0]:
        parts.append("total error " + ", ".join(f"{rec['total']:.2f} %" for rec in records[:5]))
    elif records and "count" in records[0]:
        parts.append(f"{sum(int(rec['count']) for rec in records):,} points")
    written = _written(status)
    if written:
        parts.append(f"{len(written)} output{'s' if len(written) != 1 else ''}")
    return ", ".join(parts) or status.message


def _errors_table(ws: Worksheet, records: list[Record]) -> str:
    head = ('<tr><th>result</th><th>reference</th><th class="num">Type I %</th><th class="num">Type II %</th>'
            '<th class="num">total %</th><th class="num">kappa</th><th class="num">points</th></tr>')
    rows = []
    for rec in records:
        cells = [f'<td class="path">{_e(_relative(ws, rec[key]))}</td>' for key in ("path", "reference")]
        cells += [f'<td class="num">{rec[k]:.2f}</td>' for k in ("type1", "type2", "total")]
        cells += [f'<td class="num">{rec["kappa"]:.4f}</td>', f'<td class="num">{int(rec["points"]):,}</td>']
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f'<table class="wide errors">{head}{"".join(rows)}</table>'


# ------------------------------------------------------------------------------ pictures


def _picture(ws: Worksheet, status: JobStatus, path: Path) -> str:
    """A picture at the page's width, north up, framed; with its world file a north arrow, a scale
    bar and its corners' coordinates."""
    uri, (w, h), place = embedded(path)
    width = PICTURE_WIDTH if h <= 1.5 * w else PICTURE_WIDTH * 1.5 * w / h  # a tall strip stays on screen
    height = width * h / w
    top, bottom = 24.0, 24.0
    x0 = (PICTURE_WIDTH - width) / 2
    box = f'x="{x0:.1f}" y="{top}" width="{width:.1f}" height="{height:.1f}"'
    svg = [
        (f'<svg viewBox="0 0 {PICTURE_WIDTH} {top + height + bottom:.1f}" role="img" '
         f'aria-label="{_e(path.name)}" font-family="system-ui, sans-serif" font-size="13">'),
        f'<rect {box} fill="#eef1f4"/>',  # what blank nodes and empty pixels show
        # each pixel kept square and crisp: a DTM's nodes and a map's calls, enlarged, stay themselves
        f'<image href="{uri}" {box} preserveAspectRatio="none" style="image-rendering: pixelated"/>',
        f'<rect {box} fill="none" stroke="rgb{FRAME_RGB}" stroke-width="3" shape-rendering="crispEdges"/>',
    ]
    if place is not None:
        svg += _map_furniture(place, w, h, x0, top, width, height)
    svg.append("</svg>")
    job = status.job
    caption = f"job {job.number} {job.task.key}: {_relative(ws, path)}"
    if place is not None:
        caption += f" ({w} x {h} pixels of {place.dx:.3g} m; north up)"
    legend = ""
    if job.task.key == "evaluate":
        legend = '<span class="legend">' + "".join(f'<span style="background:{c}"></span>{_e(t)}'
                                                   for c, t in MAP_LEGEND) + "</span>"
    return (f'<figure class="picture"><a href="{_e(_href(ws, path))}">{"".join(svg)}</a>'
            f"<figcaption>{_e(caption)} {legend}</figcaption></figure>")


def _map_furniture(place: NorthUp, w: int, h: int, x0: float, top: float, width: float, height: float) -> list[str]:
    """The corners' coordinates, a north arrow and a scale bar over a picture drawn at
    ``x0, top`` ``width`` x ``height`` units, ``w`` x ``h`` pixels placed by ``place``."""
    east, south = place.west + w * place.dx, place.north - h * place.dy
    digits = 1 if place.dx >= 0.1 else 3

    def xy(x: float, y: float) -> str:
        return f"x {x:.{digits}f}, y {y:.{digits}f}"

    out = [f'<text x="{x0:.1f}" y="{top - 7}">{_e(xy(place.west, place.north))}</text>',
           f'<text x="{x0 + width:.1f}" y="{top - 7}" text-anchor="end">{_e(xy(east, place.north))}</text>',
           f'<text x="{x0:.1f}" y="{top + height + 17:.1f}">{_e(xy(place.west, south))}</text>',
           f'<text x="{x0 + width:.1f}" y="{top + height + 17:.1f}" text-anchor="end">{_e(xy(east, south))}</text>']
    ax, ay = x0 + width - 28, top + 10
    out.append(f'<g class="north-arrow" stroke="#fff" stroke-width="1.5" paint-order="stroke">'
               f'<polygon points="{ax},{ay + 16} {ax + 9},{ay + 42} {ax},{ay + 35} {ax - 9},{ay + 42}" fill="#111"/>'
               f'<text x="{ax}" y="{ay + 12}" text-anchor="middle" font-weight="700" fill="#111">N</text></g>')
    ground = w * place.dx
    length = nice_length(ground / 4)
    units = length / ground * width
    bx, by = x0 + 12, top + height - 22
    out.append(f'<g class="scale-bar"><rect x="{bx - 6}" y="{by - 16}" width="{units + 70:.1f}" height="30" rx="3" '
               'fill="#fff" fill-opacity="0.85"/>')
    for k in range(4):
        out.append(f'<rect x="{bx + k * units / 4:.1f}" y="{by}" width="{units / 4:.1f}" height="6" '
                   f'fill="{"#111" if k % 2 == 0 else "#fff"}" stroke="#111" stroke-width="1"/>')
    out.append(f'<text x="{bx}" y="{by - 4}" text-anchor="middle">0</text>'
               f'<text x="{bx + units:.1f}" y="{by - 4}" text-anchor="middle">{_e(f"{length:g} m")}</text></g>')
    return out


def nice_length(limit: float) -> float:
    """The longest 1, 2 or 5 times a power of ten that is at most ``limit`` (a scale bar's)."""
    if not limit > 0:
        return 1.0
    power = 10.0 ** math.floor(math.log10(limit))
    return max(m * power for m in (1, 2, 5) if m * power <= limit * (1 + 1e-9))


def embedded(path: Path) -> tuple[str, tuple[int, int], NorthUp | None]:
    """The picture as a PNG data URI (its own pixels, at most :data:`EMBED_MAX` on the longer
    side), its size, and where it lies (from its world file; None without one). Pillow is there:
    the job that wrote the PNG needed it."""
    from PIL import Image

    with Image.open(path) as image:
        image.load()
        full = image.size
        if max(image.size) > EMBED_MAX:
            image.thumbnail((EMBED_MAX, EMBED_MAX), Image.Resampling.BOX)
        buffer = io.BytesIO()
        image.save(buffer, format="PNG", optimize=True)
        size = image.size
    place = None
    if world_path(path).exists():
        try:
            whole = read_world_file(world_path(path))
        except AldpatError:
            whole = None
        if whole is not None:
            place = NorthUp(whole.west, whole.north, whole.dx * full[0] / size[0], whole.dy * full[1] / size[1])
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii"), size, place


# ------------------------------------------------------------------------------ each job


def _written(status: JobStatus) -> list[Written]:
    return [w for r in status.results for w in r.outputs] or [Written(p) for p in status.outputs]


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
    written = _written(status)
    if written:
        out.append(_outputs(ws, written))
    for r in status.results:
        for rec in r.records:
            out.append('<pre class="record">' + "\n".join(_e(line) for line in rec.lines()) + "</pre>")
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
