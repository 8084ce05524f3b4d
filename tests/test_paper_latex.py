"""The report's tables and figures at print size, compiled with a real TeX engine (pdflatex, from Debian's
texlive-latex-base and texlive-latex-recommended, which .ci/run installs) in a two-column page of IEEE's measures
(516 pt text, 252 pt columns) and in a one-column article (345 pt line): tables are ``table`` where they fit one
column and are never scaled down; figures are made at their final width, one column or two, and print 1:1 with no
text under 7 pt, read from the compiled PDF itself. Representative tables (three runs with long labels over ten
environments, a per-class table, predictivity, tiny p-values) and the figures of real reports, not all of them."""

from __future__ import annotations

import re
import shutil
import zlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.batch import predictivity as pred
from benchbot.batch.analysis import analyse
from benchbot.batch.paper import LATEX_PACKAGES, Table, latex_escape, latex_layout, to_latex
from benchbot.batch.report_tables import tables
from benchbot.batch.run_data import assign_labels, load_run
from benchbot.core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
from report_runs import make_run, scores_only_run  # noqa: E402

MEASURE = (r"\newcommand{\benchbotfit}[1]{\sbox0{#1}\typeout{BENCHBOT-TABLE \the\wd0\space\the\linewidth}"
           r"\ifdim\wd0>\linewidth\resizebox{\linewidth}{!}{\usebox0}\else\usebox0\fi}")
"""The tables' fitting macro, as they define it, plus a line in the log with each table's natural width and the
line's (the test defines it first, so the tables' \\providecommand leaves it)."""

LAYOUTS = {"two columns": (r"\documentclass[10pt,twocolumn]{article}"
                           r"\usepackage[textwidth=516pt,columnsep=12pt]{geometry}"),
           "one column": r"\documentclass[10pt]{article}"}
"""IEEE's measures (IEEEtran: 516 pt text, 252 pt columns; article with geometry, since IEEEtran is not in
Debian's texlive-latex-* packages), and article's one-column 345 pt line."""

PDFLATEX = pytest.mark.skipif(shutil.which("pdflatex") is None, reason="pdflatex is not installed (apt-get install "
                              "texlive-latex-base texlive-latex-recommended; .ci/run does)")


def pdflatex(folder: Path, name: str, preamble: str, body: str) -> str:
    """Compile ``name``.tex (``preamble``, the table packages, graphicx, the measuring macro, ``body``) in ``folder``;
    its log, after checking that it compiled without an overfull box."""
    (folder / f"{name}.tex").write_text(f"{preamble}\n\\usepackage{{{','.join(LATEX_PACKAGES)}}}\n{MEASURE}\n"
                                        f"\\begin{{document}}\n{body}\\end{{document}}\n")
    proc = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", f"{name}.tex"], cwd=folder,
                          capture_output=True, text=True, timeout=120)
    log = (folder / f"{name}.log").read_text(errors="replace")
    assert proc.returncode == 0, f"{name}: pdflatex failed:\n" + proc.stdout[-3000:]
    assert "Overfull \\hbox" not in log, f"{name}: " + "\n".join(l for l in log.splitlines() if "Overfull" in l)
    return log


def pdf_streams(data: bytes) -> list[bytes]:
    """Every Flate-compressed stream of a PDF file, decompressed (the content of its pages and forms)."""
    out = []
    for m in re.finditer(rb"stream\r?\n", data):
        try:
            out.append(zlib.decompressobj().decompress(data[m.end():m.end() + 50_000_000]))
        except zlib.error:
            continue  # not Flate (an image, a font)
    return out


MATPLOTLIB_TEXT = re.compile(rb"(-?[\d.]+) (-?[\d.]+) (-?[\d.]+) (-?[\d.]+) -?[\d.]+ -?[\d.]+ cm\s*BT\b(.*?)\bET\b",
                             re.S)
"""How matplotlib's PDF backend sets a text: ``q a b c d e f cm BT /F1 size Tf ... ET Q`` (another ``/F2 size Tf``
inside for a glyph of another font); printed at size times the scale of the matrix (1 for a rotation)."""


def text_sizes(stream: bytes) -> list[float]:
    """The printed sizes (pt) of the texts of a matplotlib figure's content stream; every ``Tf`` of it must be one
    of them (none left unmeasured)."""
    sizes = [float(size) * abs(float(a) * float(d) - float(b) * float(c)) ** 0.5
             for a, b, c, d, block in MATPLOTLIB_TEXT.findall(stream)
             for size in re.findall(rb"/\S+ ([\d.]+) Tf", block)]
    assert len(sizes) == stream.count(b" Tf"), "a text set in a way this test does not read"
    return sizes


def test_scientific_notation_becomes_one_math_expression():
    assert latex_escape("p = 1.489×10⁻¹⁰") == r"p = $1.489\times10^{-10}$"
    assert latex_escape("-2.5×10⁻⁷ and -0.5") == r"$-2.5\times10^{-7}$ and $-$0.5"  # the sign inside, not $-$ in ^{}
    assert latex_escape("none → high, ρ ≥ 0.5, 50 % of #1_a") == (
        r"none $\to$ high, $\rho$ $\geq$ 0.5, 50 \% of \#1\_a")


def test_small_text_is_found_in_the_figure_and_in_its_pdf():
    """The measures the print-size tests rely on see what they should: a 5 pt label on a one-column figure is
    reported by figures.print_problems and read as 5 pt from the PDF's content."""
    from benchbot.batch import figures

    plt = figures.pyplot()
    fig, ax = plt.subplots(figsize=(figures.COLUMN_IN, 2.0), layout="constrained")
    ax.set_title("a title at 8 pt")
    ax.text(0.5, 0.5, "tiny", fontsize=5)
    assert figures.print_problems(fig) == ["'tiny' is 5 pt (< 7)"]
    fig.set_size_inches(3.5, 2.0)
    assert figures.print_problems(fig)[0] == "width 3.500 in is neither 3.487 (one column) nor 7.140 (two)"
    fig.set_size_inches(figures.COLUMN_IN, 2.0)
    pdf = figures.render(fig)["pdf"]
    sizes = sorted(size for stream in pdf_streams(pdf) if MATPLOTLIB_TEXT.search(stream) for size in text_sizes(stream))
    assert sizes[0] == 5.0 and 8.0 in sizes


def representative_tables(root: Path) -> list[Table]:
    rng = np.random.default_rng(1)
    envs = [f"miniroom:{v}" for v in range(1, 6)] + [f"house:{v}" for v in range(1, 6)]
    runs = []
    for k, example in enumerate(["semslam_geometric", "semslam_geometric", "hello_active"]):
        scores = {e: list(np.clip(rng.uniform(0.1, 0.5) + rng.normal(0, 0.02, 3) + 0.03 * k, 0, 1)) for e in envs}
        runs.append(load_run(scores_only_run(root, f"batch-2026112{k}-103519", scores, example=example)))
    assign_labels(runs, None)  # long labels: "semslam_geometric (batch-20261120-103519)"
    objects = load_run(make_run(root, "per-class", {"miniroom:1": [0.9, 0.85], "miniroom:2": [0.8]}))
    out = tables(runs, analyse(runs))
    out += [t for t in tables([objects], analyse([objects], get_registry())) if t.name.startswith("per_class")]
    sim = [load_run(scores_only_run(root, f"sim{k}", {e: [0.1 * k + 0.01 * i] for i, e in enumerate(envs[:5])},
                                    example=f"solution{k}")) for k in range(1, 4)]
    real = [load_run(scores_only_run(root, f"real{k}", {e: [0.12 * k - 0.01 * i] for i, e in enumerate(envs[:5])},
                                     example=f"solution{k}")) for k in range(1, 4)]
    out += pred.tables(pred.analyse(sim, real, "environments", ("primitives", "furnished")))
    out.append(Table("tiny", "p-values such as 1.2×10⁻¹⁰", ["test", "p", "difference"],
                     [["t-test", 1.234e-10, {"value": -2.5e-7, "low": -3.1e-7, "high": -1.9e-7, "n": 8, "reason": ""}],
                      ["Wilcoxon", 3.2e-5, -0.5]], "p < 10⁻⁵ in both"))
    return out




@pytest.mark.slow
@PDFLATEX
def test_tables_are_one_column_where_they_fit_and_never_scaled(tmp_path):
    """Measured 2026-11-26 with this test's tables (natural width in pt, pdflatex; estimate beside): one column of
    252 pt: scores 196.4 (196.6), environments 250.5 (248.6), units 244.5 (244.7), tiny p-values 207.6 (202.1);
    both columns, 516 pt: summary 312.7 (312.8), comparisons 280.7 (280.1), comparisons over episodes 251.4 (250.6),
    per class 291.7 (292.1), predictivity 294.9 (294.3); in the one-column article (345 pt) every one at its natural
    width too."""
    chosen = representative_tables(tmp_path)
    assert {"summary", "scores", "environments", "comparisons", "comparisons_episodes", "per_class_1", "predictivity",
            "tiny"} <= {t.name for t in chosen}
    for t in chosen:
        (tmp_path / f"{t.name}.tex").write_text(to_latex(t))
    body = "".join(f"\\input{{{t.name}.tex}}\n\\clearpage\n" for t in chosen)
    for layout, preamble in LAYOUTS.items():
        log = pdflatex(tmp_path, layout.replace(" ", "_"), preamble, body)
        widths = [(float(w), float(line)) for w, line in re.findall(r"BENCHBOT-TABLE ([\d.]+)pt\s*([\d.]+)pt", log)]
        assert len(widths) == len(chosen)
        wide = {t.name: w for t, w in zip(chosen, widths) if w[0] > w[1]}
        assert wide == {}, f"{layout}: tables wider than their line (natural, line in pt), scaled down: {wide}"
        assert "is scaled down to the line" not in log
        if layout == "two columns":
            for t, (natural, line) in zip(chosen, widths):
                star = "\\begin{table*}" in to_latex(t)
                assert line == (516.0 if star else 252.0), t.name
                # table* only where one column would not hold it (the estimate is within 2 pt; 6 for 'tiny')
                assert not star or natural > 252.0 - 4.0, f"{t.name} is a table* at {natural} pt: it fits a column"
                assert abs(latex_layout(t)[2] - natural) < (6.0 if t.name == "tiny" else 4.0), t.name


def report_figures(root: Path) -> dict[str, bytes]:
    """The PDF figures of two real reports (two runs over three environments with a house, maps of two panels;
    one run over one environment, a one-panel map) and of a predictivity scatter: ``{name: PDF bytes}``."""
    from benchbot.batch import figures, stats
    from benchbot.batch.report import write_report

    reg = get_registry()
    a = load_run(make_run(root, "batch-20261122-100000", {"miniroom:1": [0.9, 0.85], "miniroom:2": [0.8],
                                                         "house:1": [0.7]}, trajectories=True))
    b = load_run(make_run(root, "batch-20261122-110000", {"miniroom:1": [0.6, 0.65], "miniroom:2": [0.7],
                                                         "house:1": [0.75]}, example="hello_active"))
    assign_labels([a, b], None)
    write_report([a, b], root / "two" / "report.html", reg)
    one = load_run(make_run(root, "one", {"miniroom:3": [0.9]}, trajectories=True))
    write_report([one], root / "one" / "report.html", reg)
    out = {f"two_{p.stem}": p.read_bytes() for p in sorted((root / "two" / "report_files").glob("*.pdf"))}
    out.update({f"one_{p.stem}": p.read_bytes() for p in sorted((root / "one" / "report_files").glob("*.pdf"))})
    sim, real = [0.1, 0.3, 0.2, 0.5, 0.4], [0.15, 0.25, 0.3, 0.45, 0.5]
    out["scatter"] = figures.render(figures.scatter_predictivity(
        [f"solution {k}" for k in range(5)], sim, real, stats.predictivity(sim, real), "primitives", "furnished",
        "OMQ"))["pdf"]
    return out


@pytest.mark.slow
@PDFLATEX
def test_figures_print_at_their_width_with_text_of_7_pt_or_more(tmp_path):
    """Every figure PDF is one column (252 pt = 251.03 bp) or two (516 pt = 514.07 bp) wide, and, included at its
    natural size (no width given) in a page of IEEE's measures, fits its column or the page, is drawn unscaled, and
    prints no text under 7 pt (read from the compiled PDF's content)."""
    from benchbot.batch import figures

    pdfs = report_figures(tmp_path)
    assert {"two_summary", "two_environments", "two_comparison_1", "two_per_class_1", "two_map_house_1",
            "one_map_miniroom_3", "scatter"} <= set(pdfs)
    column_bp, page_bp = figures.COLUMN_IN * 72, figures.PAGE_IN * 72
    body, kinds = [], {}
    for name, data in pdfs.items():
        width = float(re.search(rb"/MediaBox\s*\[\s*0 0 ([\d.]+)", data).group(1))
        assert min(abs(width - column_bp), abs(width - page_bp)) < 0.01, f"{name}: {width} bp wide"
        kinds[name] = "figure" if abs(width - column_bp) < 0.01 else "figure*"
        (tmp_path / f"{name}.pdf").write_bytes(data)
        body.append(f"\\begin{{{kinds[name]}}}\\sbox0{{\\includegraphics{{{name}.pdf}}}}"
                    f"\\typeout{{BENCHBOT-FIGURE {name} \\the\\wd0\\space\\the\\linewidth}}\\usebox0"
                    f"\\caption{{{name.replace('_', ' ')}}}\\end{{{kinds[name]}}}\\clearpage\n")
    assert set(kinds.values()) == {"figure", "figure*"}  # both widths are exercised
    log = pdflatex(tmp_path, "figures", LAYOUTS["two columns"], "".join(body))
    measured = {name: (float(w), float(line)) for name, w, line in
                re.findall(r"BENCHBOT-FIGURE (\S+) ([\d.]+)pt\s*([\d.]+)pt", log)}
    assert set(measured) == set(pdfs)
    for name, (width, line) in measured.items():
        assert line == (252.0 if kinds[name] == "figure" else 516.0) and width <= line, (name, width, line)
    compiled = (tmp_path / "figures.pdf").read_bytes()
    placed = re.findall(rb"(-?[\d.]+) (-?[\d.]+) (-?[\d.]+) (-?[\d.]+) -?[\d.]+ -?[\d.]+ cm\s*/Im\d+ Do", compiled
                        + b"".join(pdf_streams(compiled)))
    assert len(placed) == len(pdfs) and all(tuple(map(float, m)) == (1.0, 0.0, 0.0, 1.0) for m in placed)
    sizes = [size for stream in pdf_streams(compiled) if MATPLOTLIB_TEXT.search(stream)
             for size in text_sizes(stream)]
    assert len(sizes) > 300 and min(sizes) >= figures.MIN_FONT_PT, sorted(sizes)[:5]
