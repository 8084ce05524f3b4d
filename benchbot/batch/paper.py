"""Tables of ``benchbot report`` for papers: HTML for the page, CSV for data, LaTeX (booktabs) for the paper.

The LaTeX files compile with pdflatex at one- and two-column widths, values in scientific notation included
(``tests/test_paper_latex.py`` compiles them with a real TeX engine and measures their width against the column).

A :class:`Table` holds raw values; a cell may be a number, a string, None, or an estimate (a dict with ``value``,
``low``, ``high``, ``reason``, ``n``, as :class:`benchbot.batch.stats.Estimate` writes it). Numbers are printed to 4
significant digits in HTML and LaTeX (:func:`benchbot.batch.figures.fmt`); CSV keeps every digit and splits an
estimate into its value and its interval's two ends (empty where there is none), so the numbers can be processed.
"""

from __future__ import annotations

import csv
import html
import io
import re
from dataclasses import dataclass, field

from benchbot.batch.figures import fmt

LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                 "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}
"""Characters LaTeX reads as commands, and what they become in a table."""


@dataclass
class Table:
    """A table of the report.

    Attributes:
        name: the file stem of its CSV and LaTeX files (``summary`` → ``summary.csv``, ``summary.tex``).
        caption: what it shows (the LaTeX caption and the HTML heading's tooltip).
        headers: column names.
        rows: one list of cells per row (numbers, strings, None, or estimate dicts).
        note: a footnote under it (e.g. why some cells have no interval).
    """

    name: str
    caption: str
    headers: list[str]
    rows: list[list] = field(default_factory=list)
    note: str = ""


def is_estimate(cell) -> bool:
    """Whether ``cell`` is an estimate dict (``value``, ``low``, ``high``...)."""
    return isinstance(cell, dict) and "value" in cell and "low" in cell


def cell_text(cell) -> str:
    """A cell as text: numbers to 4 significant digits; an estimate as ``mean [low, high]``, or ``mean`` followed
    by ``(n = 2: no CI)`` when it has no interval because n is too small."""
    if is_estimate(cell):
        value = fmt(cell["value"])
        if cell.get("low") is not None and cell.get("high") is not None:
            return f"{value} [{fmt(cell['low'])}, {fmt(cell['high'])}]"
        if cell.get("reason", "").startswith("n = "):
            return f"{value} (n = {cell.get('n')}: no CI)"
        return value
    if cell is None:
        return "–"
    if isinstance(cell, float):
        return fmt(cell)
    return str(cell)


def to_html(table: Table) -> str:
    """The table as an HTML ``<table>`` (escaped) inside a horizontally scrolling box, with its note; an estimate
    shows its value over its interval (or over why it has none), so a column is as wide as an interval."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.headers)
    body = []
    for row in table.rows:
        cells = []
        for cell in row:
            title = f" title='{html.escape(cell['reason'])}'" if is_estimate(cell) and cell.get("reason") else ""
            numeric = isinstance(cell, (int, float)) or is_estimate(cell) or cell is None
            if is_estimate(cell) and cell.get("low") is not None and cell.get("high") is not None:
                text = (f"{html.escape(fmt(cell['value']))}<br><small>[{html.escape(fmt(cell['low']))}, "
                        f"{html.escape(fmt(cell['high']))}]</small>")
            elif is_estimate(cell) and cell.get("reason", "").startswith("n = "):
                text = f"{html.escape(fmt(cell['value']))}<br><small>n = {cell.get('n')}: no CI</small>"
            else:
                text = html.escape(cell_text(cell))
            cells.append(f"<td class='{'num' if numeric else 'txt'}'{title}>{text}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    note = f"<p class='note'>{html.escape(table.note)}</p>" if table.note else ""
    return (f"<div class='scroll'><table id='t-{html.escape(table.name)}'><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table></div>{note}")


def to_csv(table: Table) -> str:
    """The table as CSV: full-precision numbers; an estimate column becomes four (``X``, ``X low``, ``X high``,
    ``X n``: what its interval is over)."""
    estimate_cols = {i for row in table.rows for i, c in enumerate(row) if is_estimate(c)}
    headers = []
    for i, h in enumerate(table.headers):
        headers += [h, f"{h} low", f"{h} high", f"{h} n"] if i in estimate_cols else [h]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(headers)
    for row in table.rows:
        out = []
        for i, cell in enumerate(row):
            if i in estimate_cols:
                est = cell if is_estimate(cell) else {"value": cell, "low": None, "high": None}
                out += ["" if est[k] is None else repr(float(est[k])) for k in ("value", "low", "high")]
                out.append("" if est.get("n") is None else str(int(est["n"])))
            elif isinstance(cell, float):
                out.append(repr(cell))
            else:
                out.append("" if cell is None else str(cell))
        writer.writerow(out)
    return buffer.getvalue()


LATEX_UNICODE = {"–": "--", "—": "---", "−": "$-$", "ρ": r"$\rho$", "→": r"$\to$", "≥": r"$\geq$", "≤": r"$\leq$",
                 "×": r"$\times$", "·": r"$\cdot$", "≈": r"$\approx$", "µ": r"$\mu$", "μ": r"$\mu$", "°": r"$^\circ$",
                 "±": r"$\pm$", "…": r"\dots{}", "‘": "`", "’": "'", "“": "``", "”": "''"}
"""Characters of the report's text that LaTeX (pdflatex, inputenc utf8) cannot take as they are, and what they become.
Other characters beyond Latin-1 become ``?`` (pdflatex stops on a character it has no glyph set up for)."""

_SCIENTIFIC = re.compile(r"(-?)(\d+(?:\.\d+)?)×10([⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)")
_PLAIN = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def _escape_text(text: str) -> str:
    out = []
    for c in text:
        if c in LATEX_SPECIAL:
            out.append(LATEX_SPECIAL[c])
        elif c in LATEX_UNICODE:
            out.append(LATEX_UNICODE[c])
        elif ord(c) > 0xFF:
            out.append("?")
        else:
            out.append(c)
    escaped = "".join(out)
    return re.sub(r"(?<![\w$])-(?=\d)", "$-$", escaped)  # a negative number's sign, not a hyphen


def latex_escape(text: str) -> str:
    r"""``text`` for LaTeX: its special characters escaped (:data:`LATEX_SPECIAL`, :data:`LATEX_UNICODE`), a
    number in :func:`~benchbot.batch.figures.fmt`'s scientific notation (``-1.5×10⁻⁵``) as one math expression
    (``$-1.5\times10^{-5}$``), a negative number's sign as a minus."""
    parts, last = [], 0
    for m in _SCIENTIFIC.finditer(text):
        parts.append(_escape_text(text[last:m.start()]))
        parts.append(rf"${m.group(1)}{m.group(2)}\times10^{{{m.group(3).translate(_PLAIN)}}}$")
        last = m.end()
    parts.append(_escape_text(text[last:]))
    return "".join(parts)


LATEX_PACKAGES = ("booktabs", "array", "graphicx")
r"""What a document needs to ``\input`` the tables: ``\usepackage{booktabs,array,graphicx}``."""

COLUMN_PT = 249.0
"""Tables estimated (:func:`latex_layout`) at most this wide are ``table`` floats, set in one column of a two-column
document (IEEE's column is 252 pt; the estimate is within about 2 pt of what pdflatex sets, 5 pt for numbers in
scientific notation); wider ones are ``table*``, which span both columns (and are ordinary floats in a one-column
document)."""

TEXT_COLUMN_EM = 10
"""A text column whose longest cell is wider than this many ems of the table's font wraps (a ragged ``p`` column of
that width) instead of widening the table."""

_COLUMN_SEP_PT = 4.0  # \tabcolsep in the tables

_CMR_WIDTHS = {  # characters '!'..'~' of Computer Modern Roman 8 and 7 pt (tftopl cmr8.tfm, cmr7.tfm), 1/1000 em
    8: (295, 531, 885, 531, 885, 826, 295, 413, 413, 531, 826, 295, 354, 295, 531, 531, 531, 531, 531, 531, 531, 531,
        531, 531, 531, 295, 295, 295, 826, 502, 502, 826, 796, 752, 767, 811, 723, 693, 834, 796, 383, 545, 825, 664,
        973, 796, 826, 723, 826, 782, 590, 767, 796, 796, 1091, 796, 796, 649, 295, 531, 295, 531, 295, 295, 531, 590,
        472, 590, 472, 325, 531, 590, 295, 325, 561, 295, 885, 590, 531, 590, 561, 414, 419, 413, 590, 561, 767, 561,
        561, 472, 531, 1063, 531, 531),
    7: (323, 569, 938, 569, 938, 877, 323, 446, 446, 569, 877, 323, 385, 323, 569, 569, 569, 569, 569, 569, 569, 569,
        569, 569, 569, 323, 323, 323, 877, 539, 539, 877, 843, 799, 815, 860, 768, 737, 884, 843, 413, 583, 874, 706,
        1028, 843, 877, 768, 877, 829, 631, 815, 843, 843, 1151, 843, 843, 692, 323, 569, 323, 569, 323, 323, 569, 631,
        508, 631, 508, 354, 569, 631, 323, 354, 600, 323, 938, 631, 569, 631, 600, 446, 453, 446, 631, 600, 815, 600,
        600, 508, 569, 1139, 569, 569),
}
_SPACE_EM = {8: 0.354, 7: 0.385}  # interword space (its natural width)
_OTHER_EM = {"_": 0.42, "−": 0.778, "–": 0.531, "—": 1.063, "→": 1.0, "×": 0.778, "≥": 0.778, "≤": 0.778,
             "±": 0.778}


def text_pt(text: str, size: int = 8) -> float:
    """The natural width in TeX points of ``text`` set in Computer Modern Roman at ``size`` pt (8: the tables'
    footnote size, 7: their script size, in a 10 pt document): the sum of its characters' widths from the fonts'
    metrics (kerning left out: a few tenths of a point); a number's minus sign as a math minus, other characters
    beyond ASCII as 0.6 em. Computer Modern is wider than Times (IEEEtran's font), so in such a paper the tables come
    out narrower than estimated."""
    widths = _CMR_WIDTHS[size]
    total = 0.0
    for c in text:
        if c == " ":
            total += _SPACE_EM[size]
        elif c in _OTHER_EM:
            total += _OTHER_EM[c]
        elif "!" <= c <= "~":
            total += widths[ord(c) - 33] / 1000
        else:
            total += 0.6
    total += 0.424 * len(re.findall(r"(?<![\w])-(?=\d)", text))  # '-' before a digit: $-$, 0.778 em, not 0.354
    total += 0.444 * text.count("×")  # a binary operator's spaces in math (2 × 4 mu)
    return total * size


def _width_pt(cell) -> float:
    """A cell's natural width: an estimate as the wider of its value (8 pt) and the interval under it (7 pt)."""
    if is_estimate(cell) and cell.get("low") is not None:
        return max(text_pt(fmt(cell["value"])), text_pt(f"[{fmt(cell['low'])}, {fmt(cell['high'])}]", 7))
    if is_estimate(cell) and cell.get("value") is not None and str(cell.get("reason", "")).startswith("n = "):
        return max(text_pt(fmt(cell["value"])), text_pt(f"n = {cell.get('n')}: no CI", 7))
    return text_pt(cell_text(cell))


def latex_layout(table: Table) -> tuple[list[str], list[bool], float]:
    r"""``(column specs, numeric, estimated natural width in pt)`` of ``table``'s ``tabular``: numbers right-aligned,
    the first column and other text left-aligned, text wider than :data:`TEXT_COLUMN_EM` ems wrapped in a ragged
    ``p`` column of that width; headings wrap at 10 characters (:func:`header_lines`). The width is the sum of the
    columns' widest cells (:func:`text_pt`, from the fonts' metrics) and their separation, within about 1 % of what
    pdflatex sets (``tests/test_paper_latex.py`` measures it)."""
    specs, numeric, width = [], [], 0.0
    wrap_pt = TEXT_COLUMN_EM * 8.5  # an em of cmr8: its quad, 1.0625 × 8 pt
    for i, header in enumerate(table.headers):
        cells = [row[i] for row in table.rows if i < len(row)]
        is_number = i > 0 and all(isinstance(c, (int, float)) or c is None or is_estimate(c) for c in cells)
        pt = max([_width_pt(c) for c in cells] + [max(text_pt(line) for line in header_lines(header))])
        if not is_number and pt > wrap_pt:
            specs.append(rf">{{\raggedright\arraybackslash}}p{{{TEXT_COLUMN_EM:g}em}}")
            pt = wrap_pt
        else:
            specs.append("r" if is_number else "l")
        numeric.append(is_number)
        width += pt + 2 * _COLUMN_SEP_PT
    return specs, numeric, width


def _latex_cell(cell) -> str:
    """A cell in LaTeX: an estimate as its value over its interval (or over why it has none) in script size (two
    lines, so the column is as wide as the interval, not value and interval side by side)."""
    below = None
    if is_estimate(cell) and cell.get("low") is not None and cell.get("high") is not None:
        below = f"[{fmt(cell['low'])}, {fmt(cell['high'])}]"
    elif is_estimate(cell) and cell.get("value") is not None and str(cell.get("reason", "")).startswith("n = "):
        below = f"n = {cell.get('n')}: no CI"
    if below is not None:
        return (rf"\begin{{tabular}}[t]{{@{{}}r@{{}}}}{latex_escape(fmt(cell['value']))}\\[-1pt]"
                rf"\scriptsize {latex_escape(below)}\end{{tabular}}")
    text = latex_escape(cell_text(cell))
    return "{}" + text if text.startswith("[") else text  # not read as the optional argument of the \\ before it


def header_lines(text: str, width: int = 10) -> list[str]:
    """A heading broken into lines of at most ``width`` characters (a longer word stays whole)."""
    lines: list[str] = []
    for word in text.split():
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return lines or [""]


def _header(text: str, numeric: bool) -> str:
    """A heading cell: one line as it is, several (:func:`header_lines`) in a nested tabular aligned as the column."""
    lines = header_lines(text)
    if len(lines) == 1:
        return latex_escape(text)
    return (rf"\begin{{tabular}}[b]{{@{{}}{'r' if numeric else 'l'}@{{}}}}" + r"\\\relax ".join(map(latex_escape, lines))
            + r"\end{tabular}")


FIT = (r"\providecommand{\benchbotfit}[1]{\sbox0{#1}\ifdim\wd0>\linewidth"
       r"\typeout{BenchBot: a table \the\wd0\space wide is scaled down to the line, \the\linewidth}"
       r"\resizebox{\linewidth}{!}{\usebox0}\else\usebox0\fi}")
r"""Defined by every table file unless the document defines it first: sets the tabular at its natural width, scaled
down to ``\linewidth`` only when it is wider, saying so in the log (a last resort: :func:`latex_layout` keeps tables
narrow, and a ``table*`` is at most 516 pt wide wherever it can be; in a one-column document with a 345 pt line, a
table between 345 and 516 pt is scaled)."""


def to_latex(table: Table) -> str:
    r"""The table as a LaTeX float for ``\usepackage{booktabs,array,graphicx}`` (:data:`LATEX_PACKAGES`): caption,
    label ``tab:<name>``, a ``tabular`` in footnote size with 4 pt between columns, laid out by
    :func:`latex_layout` with ``\toprule``/``\midrule``/``\bottomrule``, estimates as value over interval, long
    headings broken into lines, the note as a paragraph under it. Estimated at most :data:`COLUMN_PT` wide, the float
    is a ``table`` (one column of a two-column document), else a ``table*`` (both columns); the tabular is scaled
    down to the line only if it is still wider (:data:`FIT`, which says so in the log)."""
    specs, numeric, width = latex_layout(table)
    spec = "".join(specs)
    env = "table*" if width > COLUMN_PT else "table"
    lines = [FIT, rf"\begin{{{env}}}[t]", r"\centering", rf"\caption{{{latex_escape(table.caption)}}}",
             rf"\label{{tab:{table.name}}}", r"\footnotesize", r"\setlength{\tabcolsep}{4pt}",
             rf"\benchbotfit{{\begin{{tabular}}{{{spec}}}", r"\toprule",
             " & ".join(_header(h, n) for h, n in zip(table.headers, numeric)) + r" \\", r"\midrule"]
    for row in table.rows:
        lines.append(" & ".join(_latex_cell(c) for c in row) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}}"]
    if table.note:
        lines.append(rf"\par\footnotesize {latex_escape(table.note)}")
    lines.append(rf"\end{{{env}}}")
    return "\n".join(lines) + "\n"
