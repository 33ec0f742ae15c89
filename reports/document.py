"""A report as a list of blocks (headings, paragraphs, figures, tables), rendered twice: HTML and Markdown.

One document model keeps index.html and REPORT.md identical in content. Figures are files beside the document
(``<stem>.png`` and ``<stem>.svg``); tables are embedded (HTML with numbers right-aligned and text wrapped,
Markdown via pandas ``to_markdown``, which uses ``tabulate``) and written beside it as CSV, Markdown, LaTeX
(``reports.latex``: pure ASCII, fits a page) and HTML files (``write_table_files``). A long table can be
``collapsible``: folded in the HTML page, with a filter box (plain JavaScript, no network). Paths in blocks are
relative to the document's folder, so the folder opens in a browser with no server. The reference notes a document
cites (``docs/models/README.md "Airy precession"`` and the like) are copied from the installed package into its
``docs/`` folder (``copy_reference_docs``), so the folder reads on its own.

Texts come from the data (scene names of a database made elsewhere, plug-in family names, messages) and are
shown as themselves in both renderings: HTML escapes every text and attribute value (file links percent-encoded
first), Markdown backslash-escapes every character it would read (``markdown_text``: ``|`` would end a table
cell, ``<`` start a tag, ``&`` an entity). The only markup of a paragraph, caption or column note is `code` and
**bold** (``_inline_parts``), rendered alike in both.
"""

from __future__ import annotations

import html
import importlib.resources
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Iterator, Mapping
from urllib.parse import quote

import numpy as np
import pandas as pd

from foucault_bench.reports.latex import latex_table


@dataclass
class Heading:
    text: str
    level: int = 2


@dataclass
class Paragraph:
    """Plain text; `backticks` become code, **double stars** bold, in both renderings; ``link`` (text, a path
    relative to the report folder) is appended as a link."""

    text: str
    link: tuple[str, str] | None = None


@dataclass
class Figure:
    """An image pair ``<stem>.png`` / ``<stem>.svg`` (stem relative to the document's folder), and optionally
    the same chart as a plotly figure (``interactive``: its JSON; ``points``: how many markers it draws), which
    the HTML rendering shows instead of the PNG (with links to the PNG and SVG). ``static`` false: no PNG or SVG
    was written (a report built without ``--static``); REPORT.md then points to the chart in index.html."""

    stem: str
    caption: str
    interactive: str | None = None
    points: int = 0
    static: bool = True
    beside: bool = False
    """Drawn to the right of the table just before it in the HTML page (the recommendations)."""


@dataclass
class Table:
    """A table shown in the document (``display``, already formatted) with its files (``stem`` + .csv, .md,
    .tex, .html, relative to the document's folder) and a description of its columns."""

    title: str
    display: pd.DataFrame
    stem: str
    column_notes: dict[str, str] = field(default_factory=dict)
    collapsible: bool = False
    """Fold the table in the HTML page (``<details>``) with a box that filters its rows."""
    details: str | None = None
    """A text column (of ``display``) that the HTML page shows as a folded row under each row rather than as a
    cell (the scenes table's prose); REPORT.md and the table files keep it as a column."""


Block = Heading | Paragraph | Figure | Table


@dataclass
class Page:
    """One HTML page of a report (``file`` in the report folder, e.g. ``index.html``) with its title and blocks."""

    file: str
    title: str
    blocks: list[Block]


# --------------------------------------------------------------------------------------------------------------
# number formatting and table files
# --------------------------------------------------------------------------------------------------------------
def format_value(value: object, spec: str | None = None) -> str:
    """A cell as text: reals with the format ``spec`` (a Python format specification such as ``.4g``) or, without
    one, three significant digits, written out in full from 100 up to a million (3600 s is ``3600``, not
    ``3.6e+03``); '–' for missing values. Text keeps its characters, with line breaks as spaces (a cell is one
    line)."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, float):
        if spec is not None:
            return format(value, spec)
        return f"{value:.0f}" if 100.0 <= abs(value) < 1e6 else f"{value:.3g}"
    return " ".join(str(value).splitlines()) if isinstance(value, str) else str(value)


def display_frame(frame: pd.DataFrame, formats: Mapping[str, str] = MappingProxyType({})) -> pd.DataFrame:
    """A copy of ``frame`` with every cell formatted as text (``format_value`` with the column's format from
    ``formats``, column name → format specification)."""
    shown = frame.astype(object).copy()
    for column in shown.columns:
        spec = formats.get(str(column))
        shown[column] = [format_value(value, spec) for value in shown[column]]
    return shown


def write_table_files(frame: pd.DataFrame, folder: Path, stem: str, caption: str,
                      formats: Mapping[str, str] = MappingProxyType({}), shown: pd.DataFrame | None = None
                      ) -> pd.DataFrame:
    """Write ``frame`` as ``<stem>.csv`` (full precision), ``.md``, ``.tex`` and ``.html`` (formatted with
    ``formats``, see ``display_frame``; ``shown``: that formatted frame when already made) under ``folder``;
    return the formatted frame."""
    target = folder / stem
    target.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(target.with_suffix(".csv"), index=False)
    shown = display_frame(frame, formats) if shown is None else shown
    target.with_suffix(".md").write_text(f"**{markdown_text(caption)}**\n\n{markdown_table(shown)}\n", encoding="utf-8")
    target.with_suffix(".tex").write_text(latex_table(shown, caption, numeric_columns(shown)), encoding="ascii")
    target.with_suffix(".html").write_text(
        f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{html.escape(caption)}</title></head>"
        f"<body><h3>{html.escape(caption)}</h3>\n{html_table(shown)}\n</body></html>\n", encoding="utf-8")
    return shown


def markdown_table(shown: pd.DataFrame) -> str:
    """The formatted table as a GitHub-flavoured Markdown table, every header and cell escaped
    (``markdown_text``), so that a ``|`` or ``<`` of the data is shown as itself."""
    if shown.empty:
        return "_(no rows)_"
    escaped = shown.rename(columns=lambda column: markdown_text(str(column))).map(lambda cell: markdown_text(str(cell)))
    return escaped.to_markdown(index=False, disable_numparse=True)


def numeric_columns(shown: pd.DataFrame) -> frozenset[str]:
    """Columns of a formatted table whose cells are all numbers or '–' (at least one a number)."""
    def is_number(cell: object) -> bool:
        try:
            float(str(cell))
        except ValueError:
            return False
        return True

    return frozenset(str(column) for column in shown.columns
                     if any(is_number(cell) for cell in shown[column])
                     and all(is_number(cell) or cell == "–" for cell in shown[column]))


def html_table(shown: pd.DataFrame) -> str:
    """The formatted table as HTML: numeric columns right-aligned (class ``num``), text columns wrapping."""
    if shown.empty:
        return "<p><em>(no rows)</em></p>"
    numeric = numeric_columns(shown)
    kinds = ["num" if str(column) in numeric else "text" for column in shown.columns]
    head = "".join(f"<th class='{kind}'>{html.escape(str(column)).replace('_', '_<wbr>')}</th>"
                   for kind, column in zip(kinds, shown.columns, strict=True))  # long column names may break after an _
    body = "\n".join("<tr>" + "".join(f"<td class='{kind}'>{html.escape(str(cell))}</td>"
                                      for kind, cell in zip(kinds, row, strict=True)) + "</tr>"
                      for row in shown.itertuples(index=False))
    return f"<table class='data'>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody>\n</table>"


# --------------------------------------------------------------------------------------------------------------
# renderers
# --------------------------------------------------------------------------------------------------------------
_INLINE_MARKUP = re.compile(r"\\([\\`*])|`([^`]+)`|\*\*([^*]+)\*\*")
"""The markup of a paragraph, caption or note: `code` and **bold**, and a backslash before a backslash, a
backtick or an asterisk for that character itself (``literal``); everything else is plain text."""
_MARKDOWN_SPECIAL = re.compile(r"[\\`*\[\]<>&|#~!]|(?<![^\W_])_|_(?![^\W_])")
"""Characters that would be Markdown (or HTML inside Markdown) if written as they are: backslash, code, emphasis,
links and images, tags and entities, table cells, headings, strike-through; ``_`` unless it stands between two
letters or digits (intraword, where CommonMark never reads it as emphasis)."""


def literal(text: str) -> str:
    """``text`` (a name or message from the data) for a paragraph, caption or note, shown as it is: its
    backslashes, backticks and asterisks escaped from the markup."""
    return re.sub(r"[\\`*]", lambda match: "\\" + match.group(0), text)


def _inline_parts(text: str) -> Iterator[tuple[str, str]]:
    """``text`` split into ("plain" | "code" | "bold", content) parts (``_INLINE_MARKUP``)."""
    position = 0
    for match in _INLINE_MARKUP.finditer(text):
        if match.start() > position:
            yield "plain", text[position:match.start()]
        escaped, code, bold = match.groups()
        yield ("plain", escaped) if escaped is not None else ("code", code) if code is not None else ("bold", bold)
        position = match.end()
    if position < len(text):
        yield "plain", text[position:]


def markdown_text(text: str) -> str:
    """``text`` escaped for Markdown: shown as itself by any CommonMark parser, in a paragraph or a table cell
    (every special character backslash-escaped, line breaks as spaces); no HTML passes through."""
    return _MARKDOWN_SPECIAL.sub(lambda match: "\\" + match.group(0), " ".join(text.splitlines()))


def _code_span(text: str) -> str:
    """A Markdown code span holding ``text`` literally (a fence longer than any run of backticks in it)."""
    fence = "`" * (max((len(run) for run in re.findall("`+", text)), default=0) + 1)
    padding = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{padding}{text}{padding}{fence}"


def _inline_html(text: str) -> str:
    """A paragraph's text as HTML: `code` and **bold** marked up, everything else escaped."""
    tags = {"plain": "{}", "code": "<code>{}</code>", "bold": "<strong>{}</strong>"}
    return "".join(tags[kind].format(html.escape(part)) for kind, part in _inline_parts(text))


def _inline_markdown(text: str) -> str:
    """The same text as Markdown: code spans and bold kept, everything else escaped (``markdown_text``), and a
    start that would open a list or a code block (``- ``, ``+ ``, ``1. ``, leading spaces) kept as text."""
    rendered = {"plain": markdown_text, "code": _code_span, "bold": lambda part: f"**{markdown_text(part)}**"}
    markdown = "".join(rendered[kind](part) for kind, part in _inline_parts(text.lstrip()))
    return re.sub(r"^(\d*)([-+=.)])", r"\1\\\2", markdown, count=1)


def _attribute(value: str) -> str:
    """A value for an HTML attribute in quotes (single or double): every quote and ``<&>`` escaped."""
    return html.escape(value, quote=True)


def _url(path: str) -> str:
    """A relative file path as a URL: each part percent-encoded (a name holding a quote, a space or ``#`` still
    names its file)."""
    return quote(path, safe="/")


def _anchor(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _table_links(stem: str) -> list[tuple[str, str]]:
    return [(kind, f"{stem}.{suffix}") for kind, suffix in
            (("CSV", "csv"), ("Markdown", "md"), ("LaTeX", "tex"), ("HTML", "html"))]


def _figure_anchor(block: Figure) -> str:
    """The id of a chart's figure element in its HTML page: its file stem's name (unique per report)."""
    return "figure-" + block.stem.rsplit("/", 1)[-1]


def render_markdown(title: str, blocks: list[Block] | list[Page]) -> str:
    """The blocks (or every page's blocks, in order) as Markdown (GitHub-flavoured: tables with pipes); every
    text from the data escaped (``markdown_text``), so the only HTML in it is the ``<details>`` fold of a
    collapsible table. An interactive chart without static files links its place in its HTML page."""
    pages = [page for page in blocks if isinstance(page, Page)]
    placed = ([(page.file, block) for page in pages for block in page.blocks] if pages
              else [("index.html", block) for block in blocks if not isinstance(block, Page)])
    lines = [f"# {markdown_text(title)}", ""]
    for file, block in placed:
        if isinstance(block, Heading):
            lines += ["#" * block.level + " " + markdown_text(block.text), ""]
        elif isinstance(block, Paragraph):
            link = f" [{block.link[0]}]({_url(block.link[1])})" if block.link else ""
            lines += [_inline_markdown(block.text) + link, ""]
        elif isinstance(block, Figure) and block.static:
            caption = _inline_markdown(block.caption)
            lines += [f"![{caption}]({_url(block.stem + '.png')})", "",
                      f"*{caption}* ([SVG]({_url(block.stem + '.svg')}))", ""]
        elif isinstance(block, Figure):
            lines += [f"*{_inline_markdown(block.caption)}* (interactive chart in "
                      f"[{file}]({_url(file)}#{_figure_anchor(block)}); static PNG and SVG: "
                      "`foucault-bench report --static`)", ""]
        elif isinstance(block, Table):
            links = ", ".join(f"[{kind}]({_url(path)})" for kind, path in _table_links(block.stem))
            table = markdown_table(block.display)
            if block.collapsible:
                table = f"<details><summary>show the {len(block.display)} rows</summary>\n\n{table}\n\n</details>"
            lines += [f"**{markdown_text(block.title)}** ({links})", "", table, ""]
            if block.column_notes:
                lines += ["Columns: " + "; ".join(f"{_code_span(name)}: {_inline_markdown(note)}"
                                                  for name, note in block.column_notes.items()), ""]
    return "\n".join(lines).rstrip() + "\n"


REFERENCE_DOCS = ("models", "integrators", "bench", "reports")
"""Sub-packages whose README.md (package data) generated documents may cite, as ``docs/<package>/README.md``."""
DOCS_FOLDER = "docs"


def copy_reference_docs(folder: Path) -> list[Path]:
    """Copy each ``foucault_bench.<package>/README.md`` of ``REFERENCE_DOCS`` to ``folder/docs/<package>/README.md``
    (the layout of the repository, so the notes' links to each other keep working); return the paths written."""
    written = []
    for package in REFERENCE_DOCS:
        source = importlib.resources.files(f"foucault_bench.{package}").joinpath("README.md")
        target = folder / DOCS_FOLDER / package / "README.md"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
        written.append(target)
    return written
