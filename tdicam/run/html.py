"""``report.html``: report.md as one self-contained HTML page, every figure the run wrote
embedded inline as a base64 PNG ``data:`` URI (nothing is fetched from outside: no style
sheet, script, font or image address).

:func:`html_report` turns the Markdown that :func:`tdicam.run.report.markdown` writes (its
headings, paragraphs, ``*`` lists, ``|`` tables, ``**bold**`` and ```code```) into HTML
and adds a Figures section after the tables with every ``.png`` of the report's file list.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

__all__ = ["html_report", "figures"]

_STYLE = ("body{font-family:sans-serif;max-width:70em;margin:auto;padding:1em}"
          "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
          "img{max-width:100%}figure{margin:1em 0}")


def _inline(text):
    t = html.escape(text, quote=False)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)


def _cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def figures(files):
    """The figures of a report's file list: its ``.png`` files, in order."""
    return [f for f in files if f.endswith(".png")]


def _figure_html(out_dir, name, note):
    data = base64.b64encode((Path(out_dir) / name).read_bytes()).decode("ascii")
    cap = _inline(f"`{name}`" + (f": {note}" if note else ""))
    return (f'<figure id="{html.escape(name)}"><img alt="{html.escape(name)}" '
            f'src="data:image/png;base64,{data}"><figcaption>{cap}</figcaption></figure>')


def html_report(md, out_dir, files, notes=None):
    """The text of report.html: the Markdown ``md`` as HTML with a Figures section (the
    ``.png`` files of ``files``, read from ``out_dir``, captioned from ``notes``) before
    its ``## Files`` section (at the end when it has none)."""
    body, table, para, items = [], [], [], []

    def flush():
        if para:
            body.append(f"<p>{_inline(' '.join(para))}</p>")
            para.clear()
        if items:
            body.append("<ul>" + "".join(f"<li>{_inline(i)}</li>" for i in items) + "</ul>")
            items.clear()
        if table:
            head, rows = table[0], table[2:]
            body.append("<table><tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head)
                        + "</tr>" + "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>"
                                                              for c in r) + "</tr>"
                                            for r in rows) + "</table>")
            table.clear()

    figs = "<h2>Figures</h2>" + "".join(_figure_html(out_dir, f, (notes or {}).get(f, ""))
                                        for f in figures(files))
    placed = False
    for line in md.splitlines():
        if line.startswith("#"):
            flush()
            level = len(line) - len(line.lstrip("#"))
            if line.strip() == "## Files" and not placed:
                body.append(figs)
                placed = True
            body.append(f"<h{level}>{_inline(line[level:].strip())}</h{level}>")
        elif line.startswith("|"):
            if para or items:
                flush()
            table.append(_cells(line))
        elif line.startswith("* "):
            if para or table:
                flush()
            items.append(line[2:])
        elif not line.strip():
            flush()
        else:
            if table or items:
                flush()
            para.append(line)
    flush()
    if not placed:
        body.append(figs)
    title = html.escape(md.splitlines()[0].lstrip("# ")) if md else "tdicam run"
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + title
            + f"</title><style>{_STYLE}</style></head><body>\n" + "\n".join(body)
            + "\n</body></html>\n")
