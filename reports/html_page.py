"""The report's HTML pages: each page of blocks (``reports.document``) as a document that opens in a browser
with no server and no network.

Every page has the report's title, a bar linking every page of the report (``index.html`` first, then one page
per scene, the studies, all runs) and its own headings. A chart is a plotly figure whose JSON is embedded and
drawn by plotly.js, written once beside the pages and shared by them (``interactive.PLOTLY_JS``); a table has its
file links, is folded when long (``Table.collapsible``, with a box filtering its rows) and may show a long text
column as a folded row under each row (``Table.details``). ``write_pages`` writes the pages, REPORT.md (every
page in order, ``document.render_markdown``) and the reference notes they cite.
"""

from __future__ import annotations

import hashlib
import html
from pathlib import Path
from typing import Sequence, cast

from foucault_bench.reports.document import (
    Block,
    Figure,
    Heading,
    Page,
    Paragraph,
    Table,
    _anchor,
    _attribute,
    _figure_anchor,
    _inline_html,
    _table_links,
    _url,
    copy_reference_docs,
    html_table,
    render_markdown,
)

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1360px; margin: 1.5em auto; padding: 0 1em; color: #222; }
h1 { border-bottom: 2px solid #444; margin: 0.3em 0; } h2 { border-bottom: 1px solid #bbb; margin-top: 2em; }
h2:first-of-type { margin-top: 0.6em; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.92em; color: #444; }
.table-wrap { overflow-x: auto; margin: 0.6em 0 1.2em 0; }
table.data { border-collapse: collapse; font-size: 0.85em; }
table.data th, table.data td { border: 1px solid #ccc; padding: 2px 6px; vertical-align: top; }
table.data th { background: #f0f0f0; }
table.data .num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
table.data .text { text-align: left; max-width: 32em; overflow-wrap: break-word; }
details.long-table > summary { cursor: pointer; }
details.long-table input { margin: 0.5em 0.5em 0.5em 0; }
.notes { font-size: 0.85em; color: #444; }
nav { display: flex; flex-wrap: wrap; gap: 0 1.2em; } nav ul.pages { font-weight: 600; }
nav ul { display: flex; flex-wrap: wrap; gap: 0.2em 1.2em; list-style: none; padding: 0; font-size: 0.85em;
  margin: 0.3em 0; }
div.chart { width: 100%; min-height: 520px; border: 1px solid #ddd; }
.side-by-side { display: grid; grid-template-columns: fit-content(50%) minmax(0, 1fr); gap: 1em; align-items: start; }
.side-table { min-width: 0; overflow-x: auto; } .side-table p { margin: 0 0 0.4em 0; font-size: 0.9em; }
.side-table .table-wrap { margin: 0; } .side-table table.data { font-size: 0.78em; }
.side-table table.data th, .side-table table.data td { padding: 1px 4px; }
.side-chart figure { margin: 0; } .side-chart div.chart { min-height: 0; }
"""


_FILTER_SCRIPT = """
function filterRows(input) {
  var words = input.value.toLowerCase().split(/\\s+/).filter(Boolean);
  var rows = input.parentNode.querySelectorAll('tbody tr');
  var shown = 0;
  rows.forEach(function (row) {
    var text = row.textContent.toLowerCase();
    var match = words.every(function (word) { return text.indexOf(word) >= 0; });
    row.style.display = match ? '' : 'none';
    if (match) { shown += 1; }
  });
  input.nextElementSibling.textContent = words.length ? shown + ' of ' + rows.length + ' rows' : '';
}
"""
"""Filters a collapsible table's rows: a row stays when it contains every word typed (case-insensitive)."""


def _anchors(blocks: list[Block]) -> dict[int, str]:
    """A unique anchor per heading (index in ``blocks`` → id): headings whose text differs only in punctuation
    (scenes ``a.b`` and ``a_b``) get ``-2``, ``-3``, … appended."""
    anchors: dict[int, str] = {}
    used: set[str] = set()
    for index, block in enumerate(blocks):
        if isinstance(block, Heading):
            anchor, count = _anchor(block.text), 1
            while anchor in used:
                count += 1
                anchor = f"{_anchor(block.text)}-{count}"
            used.add(anchor)
            anchors[index] = anchor
    return anchors


BESIDE_CHART_HEIGHT_PX = 440
"""The height of a chart drawn beside a table: with the table above the fold at 1400×900 (the first screen)."""


def _interactive_html(block: Figure) -> str:
    """A plotly chart: its div (``data-points``: the markers it should draw; its id unique in the report, a hash
    of its file stem) and the script drawing it (a chart beside a table ``BESIDE_CHART_HEIGHT_PX`` high, in a smaller
    font)."""
    chart_id = "chart-" + hashlib.sha256(block.stem.encode()).hexdigest()[:16]  # never markup, whatever the name
    layout = f"Object.assign(figure.layout, {{height: {BESIDE_CHART_HEIGHT_PX}, font: {{size: 10}}}})" if block.beside else "figure.layout"
    static = (f" (static: <a href='{_attribute(_url(block.stem + '.png'))}'>PNG</a>, "
              f"<a href='{_attribute(_url(block.stem + '.svg'))}'>SVG</a>)") if block.static else ""
    figure_json = cast(str, block.interactive).replace("<", "\\u003c")  # JSON strings only: no </script> or <!-- ends it
    return (f"<figure id='{_attribute(_figure_anchor(block))}' data-stem='{_attribute(block.stem)}'>"
            f"<div class='chart' id='{chart_id}' "
            f"data-points='{int(block.points)}'></div><script>"
            f"(function () {{ var figure = {figure_json}; "
            f"Plotly.newPlot('{chart_id}', figure.data, {layout}, {{responsive: true, displaylogo: false}})"
            f".then(function (chart) {{ chart.on('plotly_legendclick', function (event) "
            f"{{ return foucaultLegendClick(chart, event); }}); }}); }})();</script>"
            f"<figcaption>{_inline_html(block.caption)}{static}</figcaption></figure>")


def _table_html(block: Table) -> list[str]:
    """A table with its file links, folded when collapsible, and its column notes."""
    links = ", ".join(f"<a href='{_attribute(_url(path))}'>{kind}</a>" for kind, path in _table_links(block.stem))
    parts = [f"<p><strong>{html.escape(block.title)}</strong> ({links})</p>"]
    table = f"<div class='table-wrap'>{_details_table(block) if block.details else html_table(block.display)}</div>"
    if block.collapsible:
        table = (f"<details class='long-table'><summary>show the {len(block.display)} rows</summary>"
                 "<input type='search' placeholder='filter rows: words, all must match' "
                 "oninput='filterRows(this)'><span class='count'></span>" + table + "</details>")
    parts.append(table)
    if block.column_notes:
        notes = "; ".join(f"<code>{html.escape(name)}</code>: {_inline_html(note)}"
                          for name, note in block.column_notes.items())
        parts.append(f"<p class='notes'>Columns: {notes}</p>")
    return parts


def _details_table(block: Table) -> str:
    """A table whose ``details`` column is a folded row under each row (``<details>``, summary: the column's
    name) instead of a cell."""
    column = cast(str, block.details)
    rows = html_table(block.display.drop(columns=[column])).split("\n")
    body = iter(block.display[column])
    span = len(block.display.columns) - 1
    out = []
    for line in rows:
        out.append(line)
        if line.startswith("<tr><td"):
            out.append(f"<tr class='details'><td colspan='{span}'><details><summary>{html.escape(column)}</summary>"
                       f"{html.escape(str(next(body)))}</details></td></tr>")
    return "\n".join(out)


def render_html(title: str, blocks: list[Block], pages: Sequence[tuple[str, str]] = (),
                current: str = "index.html") -> str:
    """One HTML page of ``blocks``; ``pages``: (file, title) of every page of the report, linked at the top (the
    page ``current`` shown as the one open)."""
    anchors = _anchors(blocks)
    toc = "".join(f"<li><a href='#{_attribute(anchors[i])}'>{html.escape(b.text)}</a></li>"
                  for i, b in enumerate(blocks) if isinstance(b, Heading) and b.level == 2)
    page_links = "".join(f"<li><strong>{html.escape(name)}</strong></li>" if file == current else
                         f"<li><a href='{_attribute(_url(file))}'>{html.escape(name)}</a></li>" for file, name in pages)
    bar = f"<ul class='pages'>{page_links}</ul>" if pages else ""
    head = ""
    if any(isinstance(block, Figure) and block.interactive for block in blocks):
        from foucault_bench.reports.interactive import LEGEND_SCRIPT, PLOTLY_JS

        head = f"<script src='{PLOTLY_JS}' charset='utf-8'></script><script>{LEGEND_SCRIPT}</script>"
    if any(isinstance(block, Table) and block.collapsible for block in blocks):
        head += f"<script>{_FILTER_SCRIPT}</script>"
    parts = [f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_STYLE}</style>{head}</head><body>", f"<h1>{html.escape(title)}</h1>",
             f"<nav>{bar}<ul>{toc}</ul></nav>"]
    for index, block in enumerate(blocks):
        rendered: list[str] = []
        if isinstance(block, Heading):
            rendered.append(f"<h{block.level} id='{_attribute(anchors[index])}'>{html.escape(block.text)}"
                            f"</h{block.level}>")
        elif isinstance(block, Paragraph):
            link = (f" <a href='{_attribute(_url(block.link[1]))}'>{html.escape(block.link[0])}</a>"
                    if block.link else "")
            rendered.append(f"<p>{_inline_html(block.text)}{link}</p>")
        elif isinstance(block, Figure) and block.interactive:
            rendered.append(_interactive_html(block))
        elif isinstance(block, Figure):
            svg, png = _attribute(_url(block.stem + ".svg")), _attribute(_url(block.stem + ".png"))
            rendered.append(f"<figure><a href='{svg}'><img src='{png}' alt='{_attribute(block.caption)}'></a>"
                            f"<figcaption>{_inline_html(block.caption)} (<a href='{svg}'>SVG</a>)</figcaption>"
                            "</figure>")
        elif isinstance(block, Table):
            rendered += _table_html(block)
        if isinstance(block, Figure) and block.beside and index and isinstance(blocks[index - 1], Table):
            table_parts = parts.pop()
            rendered = [f"<div class='side-by-side'><div class='side-table'>{table_parts}</div>"
                        f"<div class='side-chart'>{''.join(rendered)}</div></div>"]
        parts.append("\n".join(rendered))
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _write_plotly(folder: Path, blocks: list[Block]) -> None:
    """plotly.js beside the pages, once, when a chart needs it."""
    if any(isinstance(block, Figure) and block.interactive for block in blocks):
        from plotly.offline import get_plotlyjs

        from foucault_bench.reports.interactive import PLOTLY_JS

        (folder / PLOTLY_JS).write_text(get_plotlyjs(), encoding="utf-8")


def write_document(folder: Path, title: str, blocks: list[Block], html_name: str = "index.html",
                   markdown_name: str = "REPORT.md") -> tuple[Path, Path]:
    """Write the HTML and Markdown renderings of ``blocks`` into ``folder``; return their paths."""
    return write_pages(folder, title, [Page(html_name, title, blocks)], markdown_name)


def write_pages(folder: Path, title: str, pages: list[Page], markdown_name: str = "REPORT.md") -> tuple[Path, Path]:
    """Write each page (the first is the report's front page) into ``folder``, plotly.js once for all of them,
    and the Markdown rendering of every page in order; return the paths of the first page and the Markdown."""
    folder.mkdir(parents=True, exist_ok=True)
    copy_reference_docs(folder)
    links = [(page.file, page.title) for page in pages] if len(pages) > 1 else []
    for page in pages:
        (folder / page.file).write_text(render_html(title, page.blocks, links, page.file), encoding="utf-8")
    _write_plotly(folder, [block for page in pages for block in page.blocks])
    markdown_path = folder / markdown_name
    markdown_path.write_text(render_markdown(title, pages), encoding="utf-8")
    return folder / pages[0].file, markdown_path
