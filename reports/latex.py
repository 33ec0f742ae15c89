"""Report tables as LaTeX that pdflatex compiles and that fits a page: pure ASCII, a few columns per table.

``latex_text`` turns a cell into ASCII LaTeX: the special characters escaped, the Unicode the report uses (≤, –,
−, ×, ±, ·, °, Greek letters, sub- and superscript digits, ▲ ▽ ✕) in math mode or as TeX ligatures, anything else
decomposed to ASCII (é → e) or, as a last resort, written as its Unicode name. ``latex_table`` lays a formatted
table out for a page of ``LINE_WIDTH_PT`` (the article class's text width at 10 pt): numbers right-aligned,
text wrapped in ``p`` columns, and a table wider than the page split into parts that each repeat the columns
naming a row (``KEY_COLUMNS``). Each part is a ``longtable`` (its header repeats on every page), in
``\\footnotesize``. The file needs ``\\usepackage{longtable,array}`` (both in the LaTeX ``tools`` bundle) and is
meant to be ``\\input`` into a document.
"""

from __future__ import annotations

import functools
import math
import re
import unicodedata

import pandas as pd

LINE_WIDTH_PT = 345.0
"""Width the tables are laid out for: the article class's ``\\textwidth`` at 10 pt (a wider page only adds
margin)."""
CHARACTER_PT = 4.6
"""Width of a character at ``\\footnotesize`` (8 pt Computer Modern: digits are 4.0 pt, the widest lower-case
letters 6.7 pt; a measured average of the report's cells plus margin)."""
HEADER_LETTER_RATIO = 1.25
"""Header words are lower-case letters, wider on average than the digits of numeric cells (``peak``: 20.5 pt)."""
COLUMN_SEPARATION_PT = 3.0
"""``\\tabcolsep``: the space on each side of a column."""
TEXT_WRAP_CHARACTERS = 34
"""Text columns (a note, a message) wrap at this many characters; numbers never wrap."""
KEY_COLUMNS = ("scene", "integrator", "setting", "kh", "tol")
"""Columns that name a row: repeated in every part of a table split for width."""

_MATH = {
    "≤": r"\le", "≥": r"\ge", "≠": r"\ne", "≈": r"\approx", "−": "-", "×": r"\times", "±": r"\pm", "·": r"\cdot",
    "°": r"^\circ", "∞": r"\infty", "√": r"\surd", "→": r"\to", "←": r"\leftarrow", "∝": r"\propto",
    "▲": r"\bigtriangleup", "△": r"\bigtriangleup", "▽": r"\bigtriangledown", "▼": r"\bigtriangledown",
    "✕": r"\times", "✗": r"\times", "<": "<", ">": ">", "|": "|", "∼": r"\sim", "ε": r"\varepsilon",
}
_TEXT = {"–": "--", "—": "---", "…": r"\dots{}", "‘": "`", "’": "'", "“": "``", "”": "''", "\u00a0": "~",
         "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_\allowbreak{}", "{": r"\{", "}": r"\}",
         "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "\\": r"\textbackslash{}", '"': "''"}
_ALIGN = {True: r"\raggedleft", False: r"\raggedright"}
_GREEK_CAPITALS = {"GAMMA", "DELTA", "THETA", "LAMDA", "XI", "PI", "SIGMA", "UPSILON", "PHI", "PSI", "OMEGA"}
_LATIN_CAPITALS = {"ALPHA": "A", "BETA": "B", "EPSILON": "E", "ZETA": "Z", "ETA": "H", "IOTA": "I", "KAPPA": "K",
                   "MU": "M", "NU": "N", "OMICRON": "O", "RHO": "P", "TAU": "T", "CHI": "X"}
"""Greek capitals LaTeX writes as Latin letters (they look the same)."""
_SUBSCRIPTS = {chr(0x2080 + digit): str(digit) for digit in range(10)}
_SUPERSCRIPTS = {"⁰": "0", "¹": "1", "²": "2", "³": "3", "⁴": "4", "⁵": "5", "⁶": "6", "⁷": "7", "⁸": "8",
                 "⁹": "9", "ⁿ": "n", "⁻": "-", "⁺": "+"}


@functools.cache  # a pure function of one character, called for every character of every table
def _greek(character: str) -> str | None:
    """``\\psi`` for ψ, ``\\Omega`` for Ω, ``A`` for a capital alpha (LaTeX has no command for it); None if not
    Greek."""
    name = unicodedata.name(character, "")
    match = re.fullmatch(r"GREEK (SMALL|CAPITAL) LETTER (FINAL )?(\w+)", name)
    if match is None:
        symbol = {"GREEK PHI SYMBOL": "GREEK SMALL LETTER PHI",
                  "GREEK THETA SYMBOL": "GREEK SMALL LETTER THETA"}.get(name)
        match = re.fullmatch(r"GREEK (SMALL|CAPITAL) LETTER (FINAL )?(\w+)", symbol) if symbol else None
    if not match:
        return None
    case, final, letter = match.groups()
    word = "lambda" if letter == "LAMDA" else letter.lower()
    if case == "CAPITAL":
        return "\\" + word.capitalize() if letter in _GREEK_CAPITALS else _LATIN_CAPITALS[letter]
    if word == "omicron":
        return "o"
    return r"\varsigma" if final else "\\" + word


@functools.lru_cache(maxsize=1 << 16)  # cells repeat (scene, integrator, status names)
def latex_text(text: str) -> str:
    """``text`` as pure-ASCII LaTeX (text mode; math where a symbol needs it, adjacent math merged into one
    ``$…$``)."""
    pieces: list[tuple[bool, str]] = []  # (math?, LaTeX)
    index = 0
    while index < len(text):
        character = text[index]
        if character in _SUBSCRIPTS or character in _SUPERSCRIPTS:
            table, mark = (_SUBSCRIPTS, "_") if character in _SUBSCRIPTS else (_SUPERSCRIPTS, "^")
            end = index
            while end < len(text) and text[end] in table:
                end += 1
            pieces.append((True, mark + "{" + "".join(table[c] for c in text[index:end]) + "}"))
            index = end
            continue
        greek = _greek(character)
        if character in _MATH:
            pieces.append((True, _MATH[character]))
        elif greek is not None:
            pieces.append((greek.startswith("\\"), greek))
        elif character in _TEXT:
            pieces.append((False, _TEXT[character]))
        elif character.isascii():
            pieces.append((False, character))
        else:
            ascii_form = unicodedata.normalize("NFKD", character).encode("ascii", "ignore").decode()
            pieces.append((False, ascii_form or "[" + unicodedata.name(character, f"U+{ord(character):04X}").lower()
                           + "]"))
        index += 1
    out: list[str] = []
    for is_math, group in _merge(pieces):
        out.append(f"${group}$" if is_math else group)
    return "".join(out)


def _merge(pieces: list[tuple[bool, str]]) -> list[tuple[bool, str]]:
    """Adjacent pieces of the same mode joined; a command followed by a letter gets a space (``\\le x``)."""
    merged: list[tuple[bool, str]] = []
    for is_math, piece in pieces:
        if merged and merged[-1][0] == is_math:
            previous = merged[-1][1]
            space = " " if is_math and re.search(r"\\[A-Za-z]+$", previous) and piece[:1].isalpha() else ""
            merged[-1] = (is_math, previous + space + piece)
        else:
            merged.append((is_math, piece))
    return merged


def _characters(column: str, cells: pd.Series, numeric: bool) -> int:
    """Width of a column in characters: its longest cell (text wrapped at ``TEXT_WRAP_CHARACTERS``, at least its
    longest word) and its header's longest word (headers break at underscores and spaces)."""
    header = math.ceil(HEADER_LETTER_RATIO * max((len(word) for word in re.split(r"[_\s]+", column) if word),
                                                 default=1))
    lengths = [len(str(cell)) for cell in cells]
    longest = max(lengths, default=1)
    if not numeric:
        word = max((len(word) for cell in cells for word in str(cell).split()), default=1)
        longest = max(min(longest, TEXT_WRAP_CHARACTERS), min(word, TEXT_WRAP_CHARACTERS))
    return max(header, longest, 2)


def _parts(widths: dict[str, float], keys: list[str]) -> list[list[str]]:
    """Columns grouped so that each group, with the key columns in front, fits ``LINE_WIDTH_PT``."""
    key_width = sum(widths[key] for key in keys)
    parts: list[list[str]] = [[]]
    for column in (column for column in widths if column not in keys):
        used = key_width + sum(widths[c] for c in parts[-1])
        if parts[-1] and used + widths[column] > LINE_WIDTH_PT:
            parts.append([])
        parts[-1].append(column)
    return [keys + part for part in parts] if parts != [[]] else [keys]


def latex_table(shown: pd.DataFrame, caption: str, numeric: set[str] | frozenset[str] = frozenset()) -> str:
    """The formatted table ``shown`` (text cells) as one or more ``longtable``s fitting the page; columns named in
    ``numeric`` are right-aligned. Pure ASCII."""
    columns = [str(column) for column in shown.columns]
    if not columns:  # nothing to lay out (a table of runs none of which has a value to show)
        return f"% generated by foucault-bench, pure ASCII\n% {latex_text(caption)}: no columns, no rows\n"
    pad = 2.0 * COLUMN_SEPARATION_PT
    widths = {column: CHARACTER_PT * _characters(column, shown[column], column in numeric) + pad
              for column in columns}
    keys = [column for column in columns if column in KEY_COLUMNS]
    if sum(widths[key] for key in keys) > 0.5 * LINE_WIDTH_PT:  # keys alone would crowd every part out
        keys = keys[:1]
    parts = _parts(widths, keys)
    lines = ["% needs \\usepackage{longtable,array}; generated by foucault-bench, pure ASCII",
             "{\\footnotesize", f"\\setlength{{\\tabcolsep}}{{{COLUMN_SEPARATION_PT:g}pt}}"]
    for number, part in enumerate(parts, start=1):
        scale = min(1.0, LINE_WIDTH_PT / sum(widths[column] for column in part))
        spec = "".join(f">{{{_ALIGN[column in numeric]}\\arraybackslash}}"
                       f"p{{{max(scale * widths[column] - pad, CHARACTER_PT):.1f}pt}}" for column in part)
        title = latex_text(caption)
        if len(parts) > 1:
            title += f" (part {number} of {len(parts)})"
        header = " & ".join(latex_text(column) for column in part) + r" \\ \hline"
        lines += [f"\\begin{{longtable}}{{{spec}}}", f"\\caption{{{title}}}\\\\", r"\hline", header, r"\endfirsthead",
                  r"\hline", header, r"\endhead", r"\hline", r"\endfoot"]
        lines += [" & ".join(latex_text(str(value)) for value in row) + r" \\"
                  for row in shown[part].itertuples(index=False)]
        lines.append(r"\end{longtable}")
    lines.append("}")
    text = "\n".join(lines) + "\n"
    assert text.isascii(), "latex_table must write pure ASCII"
    return text


__all__ = ["latex_table", "latex_text"]
