"""The book's conventions, checked on its sources (the page "How this book is made").

* it never cites our working notes ("spec");
* no control characters in notebook or markdown sources;
* notebook code is formatted (ruff, 88 columns) and nbval markers are cell tags;
* no figure text under 9 pt as rendered (``fontsize`` at least ``MIN_FONTSIZE``);
* notebook code cells are short (at most ``MAX_CELL_LINES`` lines: bookkeeping goes into
  tested helpers);
* every figure is a numbered, captioned figure; every display equation is labelled;
* "notebook NN" is a link, not plain text;
* in the chapter pages' tables, every "this book" cell is pasted (glue), never typed;
* every chapter index has "Choices we made" and "Our targets".
"""
from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest

from _book import (BOOK, ROOT, cell_source, chapter_indexes, load_notebook, markdown_files,
                   notebooks, rel, strip_roles, tables, tokens)

PRODUCT_FILES = sorted(
    [p for p in BOOK.rglob("*") if p.suffix in (".md", ".ipynb", ".py", ".bib", ".yml")
     and "_build" not in p.parts and ".ipynb_checkpoints" not in p.parts]
    + list((ROOT / "trackcore").rglob("*.py"))
    + [ROOT / "README.md", ROOT / "_config.yml", ROOT / "_toc.yml"])
SPEC = re.compile(r"\bspec\b", re.IGNORECASE)
IDS = [rel(p) for p in PRODUCT_FILES]


@pytest.mark.parametrize("path", PRODUCT_FILES, ids=IDS)
def test_no_reference_to_working_notes(path):
    hits = [f"line {i}: {line.strip()[:100]}"
            for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if SPEC.search(line)]
    assert not hits, "say it in the book's own words:\n" + "\n".join(hits)


def _sources():
    for p in markdown_files():
        yield rel(p), p.read_text(encoding="utf-8")
    for p in notebooks():
        for i, c in enumerate(load_notebook(p)["cells"]):
            yield f"{rel(p)} cell {i}", cell_source(c)


def test_no_control_characters():
    bad = [f"{where}: {ord(ch):#04x}" for where, text in _sources()
           for ch in text if ord(ch) < 32 and ch not in "\n\t"]
    assert not bad, "control characters (a '\\b' in a non-raw string?):\n" + "\n".join(bad)


def test_nbval_markers_are_tags():
    bad = [f"{rel(p)} cell {i}" for p in notebooks()
           for i, c in enumerate(load_notebook(p)["cells"])
           if c["cell_type"] == "code" and "NBVAL_" in cell_source(c)]
    assert not bad, "use the nbval-ignore-output cell tag, not a comment:\n" + "\n".join(bad)


NB_IDS = [rel(p) for p in notebooks()]


@pytest.mark.parametrize("path", notebooks(), ids=NB_IDS)
def test_code_lines_fit_the_column(path):
    wide = [f"cell {i}: {len(line)} columns: {line[:60]}..."
            for i, c in enumerate(load_notebook(path)["cells"]) if c["cell_type"] == "code"
            for line in cell_source(c).splitlines() if len(line) > 88]
    assert not wide, "code lines over 88 columns:\n" + "\n".join(wide)


#: A code cell of a notebook is "a few dozen lines at most"; 45 leaves room for a cell of
#: about 40 lines that ruff formatting lengthens by a few.
MAX_CELL_LINES = 45


@pytest.mark.parametrize("path", notebooks(), ids=NB_IDS)
def test_code_cells_are_short(path):
    long = [f"code cell {k}: {n} lines"
            for k, n in enumerate(len(cell_source(c).splitlines())
                                  for c in load_notebook(path)["cells"]
                                  if c["cell_type"] == "code")
            if n > MAX_CELL_LINES]
    assert not long, (f"code cells over {MAX_CELL_LINES} lines (move bookkeeping into a "
                      f"tested helper): {long}")


#: A full-width figure (7.5 in at 150 dpi) renders in the 756 px text column at 0.68 of its
#: pixels, so a font of f pt shows at about 1.06 f pt: 8.5 pt is the least that reads as 9.
MIN_FONTSIZE = 8.5
_FONTSIZE = re.compile(r"fontsize\s*=\s*(\d+(?:\.\d+)?)\b")


def test_figure_text_is_readable():
    sources = [(rel(p), "\n".join(cell_source(c) for c in load_notebook(p)["cells"]
                                  if c["cell_type"] == "code")) for p in notebooks()]
    sources += [(rel(p), p.read_text()) for p in sorted((ROOT / "trackcore").rglob("*.py"))]
    small = [f"{name}: fontsize={m.group(1)}" for name, text in sources
             for m in _FONTSIZE.finditer(text) if float(m.group(1)) < MIN_FONTSIZE]
    assert not small, f"figure text under {MIN_FONTSIZE} pt: {small}"


def test_notebook_code_is_formatted():
    ruff = shutil.which("ruff") or str(ROOT / ".venv" / "bin" / "ruff")
    cmd = [ruff, "format", "--check", "--line-length", "88", *map(str, notebooks())]
    if not shutil.which(cmd[0]):
        cmd = [sys.executable, "-m", "ruff", *cmd[1:]]
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, "run `ruff format --line-length 88` on:\n" + res.stdout


@pytest.mark.parametrize("path", notebooks(), ids=NB_IDS)
def test_figures_are_numbered_and_captioned(path):
    bad = []
    for i, c in enumerate(load_notebook(path)["cells"]):
        if c["cell_type"] != "code":
            continue
        images = sum("image/png" in o.get("data", {}) for o in c.get("outputs", []))
        if not images:
            continue
        fig = c.get("metadata", {}).get("mystnb", {}).get("figure", {})
        if not fig.get("caption") or not fig.get("name"):
            bad.append(f"cell {i}: {images} image(s) without mystnb.figure caption and name")
        elif images > 1:
            bad.append(f"cell {i}: {images} images share one caption; one figure per cell")
    assert not bad, "\n".join(bad)


def _markdown_of(path):
    if path.suffix == ".md":
        return [(rel(path), path.read_text(encoding="utf-8"))]
    return [(f"{rel(path)} cell {i}", cell_source(c))
            for i, c in enumerate(load_notebook(path)["cells"]) if c["cell_type"] == "markdown"]


DOCS = markdown_files() + notebooks()
DOC_IDS = [rel(p) for p in DOCS]


@pytest.mark.parametrize("path", DOCS, ids=DOC_IDS)
def test_display_equations_are_labelled(path):
    bad = []
    for where, text in _markdown_of(path):
        for tok in tokens(text):
            if tok.type == "math_block":
                bad.append(f"{where}: unlabelled $$...$$: {tok.content.strip()[:60]}")
            elif tok.type == "amsmath":
                bad.append(f"{where}: bare amsmath block (wrap it in $$...$$ (label)): "
                           f"{tok.content.strip()[:60]}")
            elif tok.type == "math_block_label" and not re.search(r"\\tag\{", tok.content):
                bad.append(f"{where}: equation ({tok.info}) has no \\tag{{...}} number")
    assert not bad, "\n".join(bad)


PLAIN_NB = re.compile(r"\bnotebooks?\s+\d", re.IGNORECASE)


@pytest.mark.parametrize("path", DOCS, ids=DOC_IDS)
def test_notebook_mentions_are_links(path):
    bad = []
    for where, text in _markdown_of(path):
        for tok in tokens(text):
            if tok.type == "inline":
                plain = re.sub(r"\[[^\]]*\]\([^)]*\)", " ", strip_roles(tok.content))
                if PLAIN_NB.search(plain):
                    bad.append(f"{where}: {tok.content[:80]}")
    assert not bad, "link notebooks with {doc}`...`:\n" + "\n".join(bad)


OURS = re.compile(r"this book|\bours\b|\bour\b|measured", re.IGNORECASE)
TABLE_DOCS = [p for p in markdown_files() if p.name != "notation.md"]


@pytest.mark.parametrize("path", TABLE_DOCS, ids=[rel(p) for p in TABLE_DOCS])
def test_measured_numbers_in_tables_are_pasted(path):
    bad = []
    for header, rows in tables(path.read_text(encoding="utf-8")):
        cols = [j for j, h in enumerate(header) if OURS.search(h)]
        for row in rows:
            for j in cols:
                cell = row[j] if j < len(row) else ""
                if re.search(r"\d", strip_roles(cell)):
                    bad.append(f"[{header[j]}] {cell[:80]}")
    assert not bad, ("numbers in a 'this book' column must be pasted with {glue:text}:\n"
                     + "\n".join(bad))


@pytest.mark.parametrize("path", chapter_indexes(), ids=[rel(p) for p in chapter_indexes()])
def test_chapter_index_has_choices_and_targets(path):
    toks = tokens(path.read_text(encoding="utf-8"))
    heads = [toks[i + 1].content for i, tok in enumerate(toks) if tok.type == "heading_open"]
    assert "Choices we made" in heads and "Our targets" in heads, heads
