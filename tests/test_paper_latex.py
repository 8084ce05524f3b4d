"""The report's LaTeX tables compile with a real TeX engine (pdflatex, from Debian's texlive-latex-base and
texlive-latex-recommended) at one- and two-column widths, values in scientific notation included, and fit the
width they are set at without being scaled down: a handful of representative tables (three runs with long labels
over ten environments, a per-class table, predictivity, tiny p-values), not all of them."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.batch import predictivity as pred
from benchbot.batch.paper import LATEX_PACKAGES, Table, latex_escape, to_latex
from benchbot.batch.report import analyse, assign_labels, load_run, tables
from benchbot.core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
from report_runs import make_run, scores_only_run  # noqa: E402

MEASURE = (r"\newcommand{\benchbotfit}[1]{\sbox0{#1}\typeout{BENCHBOT-TABLE \the\wd0\space\the\linewidth}"
           r"\ifdim\wd0>\linewidth\resizebox{\linewidth}{!}{\usebox0}\else\usebox0\fi}")
"""The tables' fitting macro, as they define it, plus a line in the log with each table's natural width and the
line's (the test defines it first, so the tables' \\providecommand leaves it)."""

LAYOUTS = {"one column": "onecolumn", "two columns": "twocolumn"}
"""article, 10 pt: a 345 pt line in one column; 229.5 pt columns (469 pt for table*) in two."""


def test_scientific_notation_becomes_one_math_expression():
    assert latex_escape("p = 1.489×10⁻¹⁰") == r"p = $1.489\times10^{-10}$"
    assert latex_escape("-2.5×10⁻⁷ and -0.5") == r"$-2.5\times10^{-7}$ and $-$0.5"  # the sign inside, not $-$ in ^{}
    assert latex_escape("none → high, ρ ≥ 0.5, 50 % of #1_a") == (
        r"none $\to$ high, $\rho$ $\geq$ 0.5, 50 \% of \#1\_a")


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
@pytest.mark.skipif(shutil.which("pdflatex") is None,
                    reason="pdflatex is not installed (apt-get install texlive-latex-base texlive-latex-recommended)")
def test_tables_compile_and_fit_one_and_two_columns(tmp_path):
    """Measured 2026-11-24 with this test's tables (natural width / line, pt): one column summary 312.7/345,
    environments 250.5/345, comparisons 280.7/345, per class 291.7/345; two columns the same tables in table* at
    469, scores 196.4/229.5 and tiny p-values 201.2/229.5 in a column; none scaled, no overfull box."""
    chosen = representative_tables(tmp_path)
    assert {"summary", "scores", "environments", "comparisons", "comparisons_episodes", "per_class_1", "predictivity",
            "tiny"} <= {t.name for t in chosen}
    for t in chosen:
        (tmp_path / f"{t.name}.tex").write_text(to_latex(t))
    body = "".join(f"\\input{{{t.name}.tex}}\n\\clearpage\n" for t in chosen)
    for layout, option in LAYOUTS.items():
        (tmp_path / f"{option}.tex").write_text(
            f"\\documentclass[10pt,{option}]{{article}}\n\\usepackage{{{','.join(LATEX_PACKAGES)}}}\n{MEASURE}\n"
            f"\\begin{{document}}\n{body}\\end{{document}}\n")
        proc = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", f"{option}.tex"],
                              cwd=tmp_path, capture_output=True, text=True, timeout=120)
        log = (tmp_path / f"{option}.log").read_text(errors="replace")
        assert proc.returncode == 0, f"{layout}: pdflatex failed:\n" + proc.stdout[-3000:]
        assert (tmp_path / f"{option}.pdf").stat().st_size > 1000
        assert "Overfull \\hbox" not in log, f"{layout}: " + "\n".join(
            line for line in log.splitlines() if "Overfull" in line)
        widths = [(float(w), float(line)) for w, line in re.findall(r"BENCHBOT-TABLE ([\d.]+)pt\s*([\d.]+)pt", log)]
        assert len(widths) == len(chosen)
        wide = {t.name: w for t, w in zip(chosen, widths) if w[0] > w[1]}
        assert wide == {}, f"{layout}: tables wider than their line (natural, line in pt), scaled down: {wide}"
