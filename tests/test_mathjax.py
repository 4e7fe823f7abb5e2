"""Zero MathJax errors: typeset every math span of the book with MathJax itself.

``jupyter-book build -W`` cannot see MathJax errors: they happen in the reader's browser.
This test extracts every inline and display math span the build would hand to MathJax
(markdown files, notebook markdown cells, Markdown/LaTeX outputs stored in notebooks, and
``:math:`` roles in the package docstrings that the API reference renders), wraps display
math as Sphinx does, and typesets all of it under node with the MathJax 3 that the book
serves (``tests/mathjax_check.js``). Any TeX error fails the test.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from _book import ROOT, cell_source, load_notebook, markdown_sources, math_spans, notebooks


def _spans():
    for where, text in markdown_sources():
        for tex, display, kind in math_spans(text):
            yield [f"{where} ({kind})", tex, display]
    for p in notebooks():
        for i, c in enumerate(load_notebook(p)["cells"]):
            for o in c.get("outputs", []):
                data = o.get("data", {})
                md = data.get("text/markdown")
                if md:
                    md = "".join(md) if isinstance(md, list) else md
                    for tex, display, kind in math_spans(md):
                        yield [f"{p.relative_to(ROOT)} cell {i} output ({kind})", tex, display]
                latex = data.get("text/latex")
                if latex:
                    latex = "".join(latex) if isinstance(latex, list) else latex
                    yield [f"{p.relative_to(ROOT)} cell {i} text/latex",
                           latex.strip().strip("$"), True]
    role = re.compile(r":math:`([^`]+)`")
    for py in sorted((ROOT / "trackcore").rglob("*.py")):
        text = py.read_text(encoding="utf-8")
        for m in role.finditer(text):
            # docstrings are Python strings: undo the doubled backslashes of non-raw ones
            tex = m.group(1).replace("\\\\", "\\")
            yield [f"{py.relative_to(ROOT)} (docstring)", tex, False]


def _mathjax_es5() -> Path:
    import mathjax  # django-static-mathjax

    return Path(mathjax.__file__).parent / "static" / "mathjax" / "es5"


def test_every_math_span_typesets_without_error():
    node = shutil.which("node") or shutil.which("nodejs")
    assert node, "node is needed to typeset the book's math with MathJax (Node.js >= 16)"
    spans = list(_spans())
    assert len(spans) > 500, f"only {len(spans)} math spans found: is the extractor broken?"
    res = subprocess.run([node, str(ROOT / "tests" / "mathjax_check.js"), str(_mathjax_es5())],
                         input=json.dumps(spans), capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    errors = json.loads(res.stdout)
    report = "\n".join(f"{w}: {m}\n    {t[:120]!r}" for w, t, m in errors)
    assert not errors, f"{len(errors)} of {len(spans)} math spans fail in MathJax:\n{report}"


def test_mathjax_check_catches_errors():
    """The checker itself: known-bad TeX must be reported."""
    node = shutil.which("node") or shutil.which("nodejs")
    if not node:
        pytest.fail("node is needed")
    bad = [["a", r"\begin{split}a \tag{1}\\ b\end{split}", True], ["b", r"\foo x", False],
           ["c", "a\bb", False], ["d", r"x^2 \tag{3}", True]]
    res = subprocess.run([node, str(ROOT / "tests" / "mathjax_check.js"), str(_mathjax_es5())],
                         input=json.dumps(bad), capture_output=True, text=True, timeout=120)
    assert [e[0] for e in json.loads(res.stdout)] == ["a", "b", "c"]
