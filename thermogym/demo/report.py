"""The demo report: one self-contained HTML page and its Markdown twin.

``report.html`` embeds every figure as PNG data (``data:`` URIs), so the page
can be mailed or archived alone; ``report.md`` links the same figures under
``figures/``. Both carry, in this order: a summary (what ran, key numbers,
failures), the stage timings, and per stage what it shows, its findings,
tables, figures and where its files are.

The stages' text uses a small Markdown subset (paragraphs, ``* `` lists,
```code```, ``**bold**``) that is converted here; a full Markdown library
would be a dependency for four rules.
"""

from __future__ import annotations

import base64
import html
import math
import platform
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from thermogym import __version__
from thermogym.demo.core import StageResult, Table

__all__ = ["SECTION_ORDER", "render_html", "render_markdown", "stage_anchor"]

#: Section ids of the page besides the stages (tests look for them).
SECTION_ORDER = ("summary", "timings")


def stage_anchor(key: str) -> str:
    """HTML id of a stage's section."""
    return f"stage-{key}"


def _cell(v: Any) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        return f"{v:.4g}"
    return str(v)


def _md_table(t: Table) -> str:
    head = [h.replace("|", "\\|") for h in t.header]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(t.header)]
    lines += ["| " + " | ".join(_cell(v).replace("|", "\\|") for v in r) + " |" for r in t.rows]
    if t.caption:
        lines = [f"*{t.caption}*", "", *lines]
    return "\n".join(lines)


def _status(r: StageResult) -> str:
    return f"{r.status} (earlier run, {r.ran_at})" if r.carried else r.status


def _summary_rows(results: Sequence[StageResult]) -> list[list[str]]:
    return [[r.title, _status(r), f"{r.seconds:.1f} s"] for r in results]


def _ran(results: Sequence[StageResult]) -> str:
    n_run = sum(not r.carried for r in results)
    kept = len(results) - n_run
    return f"{n_run} stage(s)" + (
        f" run, {kept} section(s) kept from earlier runs," if kept else ""
    )


def _not_done(results: Sequence[StageResult]) -> tuple[list[Any], list[Any], list[Any]]:
    failed = [r for r in results if r.status == "failed"]
    skipped = [r for r in results if r.status in ("skipped", "interrupted")]
    carried = [r for r in results if r.carried]
    return failed, skipped, carried


def _machine(total: float, load: tuple[float, float, float] | None) -> str:
    ld = f", load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}" if load else ""
    return f"{platform.node()} ({platform.machine()}, Python {platform.python_version()}){ld}"


def render_markdown(
    results: Sequence[StageResult],
    *,
    seed: int,
    quick: bool,
    total: float,
    load: tuple[float, float, float] | None = None,
) -> str:
    """The Markdown report (figures linked relative to the output folder)."""
    failed, skipped, carried = _not_done(results)
    lines = [
        "# thermogym demo report",
        "",
        "## Summary",
        "",
        f"thermogym {__version__}, seed {seed}{', quick mode' if quick else ''}; "
        f"{_ran(results)} in {total:.0f} s on {_machine(total, load)}.",
        "",
    ]
    if failed or skipped or carried:
        for r in failed:
            lines.append(f"* **FAILED** {r.title}: {r.error} (traceback in `logs/{r.key}.txt`)")
        for r in skipped:
            lines.append(f"* **{r.status.upper()}** {r.title}: {r.error}")
        for r in carried:
            lines.append(f"* **EARLIER RUN** {r.title}: {r.note}")
    else:
        lines.append("* Every stage finished.")
    lines.append("")
    hl = [(r.title, k, v) for r in results for k, v in r.highlights.items()]
    if hl:
        lines += ["Key numbers:", ""]
        lines += [f"* {k}: {v}" for _, k, v in hl]
        lines.append("")
    lines += ["## Stage timings", ""]
    lines.append(
        _md_table(
            Table(
                ["stage", "status", "time"],
                [*_summary_rows(results), ["total", "", f"{total:.1f} s"]],
            )
        )
    )
    lines.append("")
    for r in results:
        lines += [f"## {r.title}", ""]
        if r.status != "ok":
            lines += [f"**{r.status.upper()}**: {r.error}", ""]
        if r.carried:
            lines += [f"**EARLIER RUN**: {r.note}", ""]
        if r.shows:
            lines += [f"*What it shows:* {r.shows}", ""]
        if r.text:
            lines += [r.text, ""]
        for t in r.tables:
            lines += [_md_table(t), ""]
        for path, caption in r.figures:
            lines += [f"![{caption}]({path})", "", f"*{caption}*", ""]
        if r.files:
            lines += [f"*Files:* {_files_summary(r.files)}", ""]
    return "\n".join(lines)


def _files_summary(files: Sequence[str], limit: int = 12) -> str:
    """Folders with their file counts, and single files, of a stage."""
    groups: dict[str, int] = {}
    for f in files:
        head, _, rest = f.partition("/")
        key = f"{head}/" if rest else f
        groups[key] = groups.get(key, 0) + 1
    items = [f"`{k}` ({n} files)" if k.endswith("/") else f"`{k}`" for k, n in groups.items()]
    if len(items) > limit:
        items = [*items[:limit], f"and {len(items) - limit} more"]
    return ", ".join(items)


# --------------------------------------------------------------------------- HTML
_INLINE_CODE = re.compile(r"`([^`]+)`")
_BOLD = re.compile(r"\*\*([^*]+)\*\*")
_ITALIC = re.compile(r"(?<![*\w])\*([^*\s][^*]*)\*(?![*\w])")


def _inline(text: str) -> str:
    s = html.escape(text, quote=False)
    s = _INLINE_CODE.sub(r"<code>\1</code>", s)
    s = _BOLD.sub(r"<strong>\1</strong>", s)
    return _ITALIC.sub(r"<em>\1</em>", s)


def _blocks(text: str) -> str:
    """Paragraphs and ``* `` lists of the Markdown subset as HTML."""
    out = []
    for block in re.split(r"\n\s*\n", text.strip()):
        lines = block.splitlines()
        if lines and all(
            ln.lstrip().startswith(("* ", "- ")) or ln.startswith("  ") for ln in lines
        ):
            items: list[str] = []
            for ln in lines:
                if ln.lstrip().startswith(("* ", "- ")):
                    items.append(ln.lstrip()[2:])
                elif items:
                    items[-1] += " " + ln.strip()
            out.append("<ul>" + "".join(f"<li>{_inline(i)}</li>" for i in items) + "</ul>")
        elif block.strip():
            out.append(f"<p>{_inline(' '.join(ln.strip() for ln in lines))}</p>")
    return "\n".join(out)


def _html_table(t: Table) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in t.header)
    body = "".join(
        "<tr>" + "".join(f"<td>{_inline(_cell(v))}</td>" for v in r) + "</tr>" for r in t.rows
    )
    cap = f"<caption>{_inline(t.caption)}</caption>" if t.caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;max-width:1150px;margin:1.5em auto;
padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #c0392b;padding-bottom:.2em}
h2{margin-top:2em;border-bottom:1px solid #ddd;padding-bottom:.15em}
table{border-collapse:collapse;margin:.8em 0;font-size:.88em}
td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#f3f3f3}caption{caption-side:top;text-align:left;font-style:italic;color:#555;
padding:.2em 0}
img{max-width:100%;border:1px solid #eee}figure{margin:1.2em 0}
figcaption{color:#555;font-style:italic;font-size:.92em}
code{background:#f4f4f4;padding:0 3px;border-radius:3px}
.status-ok{color:#1e8449;font-weight:600}.status-failed{color:#c0392b;font-weight:700}
.status-skipped,.status-interrupted{color:#b9770e;font-weight:600}
.alert{border-left:4px solid #c0392b;background:#fdf2f0;padding:.5em 1em;margin:.8em 0}
.shows{background:#f4f8fb;border-left:4px solid #2e86c1;padding:.4em 1em}
.files{color:#555;font-size:.92em}nav ol{columns:2}
"""


def render_html(
    results: Sequence[StageResult],
    out: Path,
    *,
    seed: int,
    quick: bool,
    total: float,
    load: tuple[float, float, float] | None = None,
) -> str:
    """The self-contained HTML page (figures read from ``out`` and embedded)."""
    failed, skipped, carried = _not_done(results)
    e = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>thermogym demo report</title><style>{_STYLE}</style></head><body>",
        "<h1>thermogym demo report</h1>",
        '<section id="summary"><h2>Summary</h2>',
        f"<p>thermogym {e(__version__)}, seed {seed}{', quick mode' if quick else ''}; "
        f"{_ran(results)} in {total:.0f} s on {e(_machine(total, load))}.</p>",
    ]
    if failed or skipped or carried:
        items = (
            [
                f"<li><strong>FAILED</strong> {e(r.title)}: {e(r.error or '')} (traceback in "
                f"<code>logs/{e(r.key)}.txt</code>)</li>"
                for r in failed
            ]
            + [
                f"<li><strong>{e(r.status.upper())}</strong> {e(r.title)}: {e(r.error or '')}</li>"
                for r in skipped
            ]
            + [f"<li><strong>EARLIER RUN</strong> {e(r.title)}: {e(r.note)}</li>" for r in carried]
        )
        parts.append(f'<div class="alert"><ul>{"".join(items)}</ul></div>')
    else:
        parts.append("<p>Every stage finished.</p>")
    hl = [(k, v) for r in results for k, v in r.highlights.items()]
    if hl:
        parts.append(
            "<table><thead><tr><th>key number</th><th>value</th></tr></thead><tbody>"
            + "".join(f"<tr><td>{_inline(k)}</td><td>{_inline(v)}</td></tr>" for k, v in hl)
            + "</tbody></table>"
        )
    parts.append(
        "<nav><ol>"
        + "".join(f'<li><a href="#{stage_anchor(r.key)}">{e(r.title)}</a></li>' for r in results)
        + "</ol></nav></section>"
    )
    rows = "".join(
        f'<tr><td><a href="#{stage_anchor(r.key)}">{e(r.title)}</a></td>'
        f'<td class="status-{e(r.status)}">{e(_status(r))}</td><td>{r.seconds:.1f} s</td></tr>'
        for r in results
    )
    parts.append(
        '<section id="timings"><h2>Stage timings</h2><table><thead><tr><th>stage</th>'
        f"<th>status</th><th>time</th></tr></thead><tbody>{rows}"
        f"<tr><td><strong>total</strong></td><td></td><td>{total:.1f} s</td></tr>"
        "</tbody></table></section>"
    )
    for r in results:
        parts.append(
            f'<section id="{stage_anchor(r.key)}" class="stage" data-status="{e(r.status)}">'
            f"<h2>{e(r.title)}</h2>"
        )
        if r.status != "ok":
            parts.append(
                f'<div class="alert"><span class="status-{e(r.status)}">{e(r.status.upper())}'
                f"</span>: {e(r.error or '')}</div>"
            )
        if r.carried:
            parts.append(
                f'<div class="alert"><strong>EARLIER RUN</strong>: {_inline(r.note)}</div>'
            )
        if r.shows:
            parts.append(f'<p class="shows"><em>What it shows:</em> {_inline(r.shows)}</p>')
        if r.text:
            parts.append(_blocks(r.text))
        parts += [_html_table(t) for t in r.tables]
        for path, caption in r.figures:
            src = out / path
            parts.append(
                f'<figure><img src="{_data_uri(src)}" alt="{e(caption)}" '
                f'data-file="{e(path)}"><figcaption>{_inline(caption)} '
                f"(<code>{e(path)}</code>)</figcaption></figure>"
            )
        if r.files:
            parts.append(f'<p class="files"><em>Files:</em> {_inline(_files_summary(r.files))}</p>')
        parts.append("</section>")
    parts.append("</body></html>\n")
    return "\n".join(parts)
