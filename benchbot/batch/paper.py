"""Tables of ``benchbot report`` for papers: HTML for the page, CSV for data, LaTeX (booktabs) for the paper.

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
    """The table as an HTML ``<table>`` (escaped) inside a horizontally scrolling box, with its note."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.headers)
    body = []
    for row in table.rows:
        cells = []
        for cell in row:
            title = f" title='{html.escape(cell['reason'])}'" if is_estimate(cell) and cell.get("reason") else ""
            numeric = isinstance(cell, (int, float)) or is_estimate(cell) or cell is None
            cells.append(f"<td class='{'num' if numeric else 'txt'}'{title}>{html.escape(cell_text(cell))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    note = f"<p class='note'>{html.escape(table.note)}</p>" if table.note else ""
    return (f"<div class='scroll'><table id='t-{html.escape(table.name)}'><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table></div>{note}")


def to_csv(table: Table) -> str:
    """The table as CSV: full-precision numbers; an estimate column becomes three (``X``, ``X low``, ``X high``)."""
    estimate_cols = {i for row in table.rows for i, c in enumerate(row) if is_estimate(c)}
    headers = []
    for i, h in enumerate(table.headers):
        headers += [h, f"{h} low", f"{h} high"] if i in estimate_cols else [h]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(headers)
    for row in table.rows:
        out = []
        for i, cell in enumerate(row):
            if i in estimate_cols:
                est = cell if is_estimate(cell) else {"value": cell, "low": None, "high": None}
                out += ["" if est[k] is None else repr(float(est[k])) for k in ("value", "low", "high")]
            elif isinstance(cell, float):
                out.append(repr(cell))
            else:
                out.append("" if cell is None else str(cell))
        writer.writerow(out)
    return buffer.getvalue()


def latex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped; ``×10⁻⁵`` (from :func:`fmt`) becomes ``$\\times10^{-5}$``."""
    escaped = "".join(LATEX_SPECIAL.get(c, c) for c in text)
    escaped = re.sub("×10([⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)", lambda m: rf"$\times10^{{{m.group(1).translate(_PLAIN)}}}$", escaped)
    escaped = re.sub(r"(?<![\w$])-(?=\d)", "$-$", escaped)  # a negative number's sign, not a hyphen
    return escaped.replace("–", "--").replace("−", "$-$").replace("ρ", r"$\rho$")


_PLAIN = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def to_latex(table: Table) -> str:
    """The table as a LaTeX ``table`` environment (needs ``\\usepackage{booktabs}``): caption, label
    ``tab:<name>``, one ``l`` column then right-aligned ones, ``\\toprule``/``\\midrule``/``\\bottomrule``; the
    note becomes a footnote-size paragraph under the table."""
    spec = "l" + "r" * (len(table.headers) - 1)
    lines = [r"\begin{table}[t]", r"\centering", r"\small", rf"\caption{{{latex_escape(table.caption)}}}",
             rf"\label{{tab:{table.name}}}", rf"\begin{{tabular}}{{{spec}}}", r"\toprule",
             " & ".join(latex_escape(h) for h in table.headers) + r" \\", r"\midrule"]
    for row in table.rows:
        lines.append(" & ".join(latex_escape(cell_text(c)) for c in row) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}"]
    if table.note:
        lines.append(rf"\par\footnotesize {latex_escape(table.note)}")
    lines.append(r"\end{table}")
    return "\n".join(lines) + "\n"
