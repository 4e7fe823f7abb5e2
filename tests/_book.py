"""Read the book's sources the way the build does, for the convention tests.

Markdown comes from ``book/**/*.md`` and from the markdown cells of ``book/**/*.ipynb``;
it is tokenised with the same markdown-it configuration as MyST in ``_config.yml``.
"""
from __future__ import annotations

import json
import re
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BOOK = ROOT / "book"

MYST_EXTENSIONS = {"amsmath", "colon_fence", "deflist", "dollarmath", "substitution"}


def _skip(p: Path) -> bool:
    return any(part in ("_build", ".ipynb_checkpoints", "_static") for part in p.parts)


def notebooks() -> list[Path]:
    return sorted(p for p in BOOK.rglob("*.ipynb") if not _skip(p))


def markdown_files() -> list[Path]:
    return sorted(p for p in BOOK.rglob("*.md") if not _skip(p))


def chapter_indexes() -> list[Path]:
    return sorted(BOOK.glob("0*/index.md"))


def rel(p: Path) -> str:
    return p.relative_to(ROOT).as_posix()


@lru_cache(maxsize=None)
def load_notebook(path: Path) -> dict:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def cell_source(cell) -> str:
    src = cell.get("source", "")
    return "".join(src) if isinstance(src, list) else src


def markdown_sources() -> list[tuple[str, str]]:
    """``(where, text)`` for every markdown file and markdown cell."""
    out = [(rel(p), p.read_text(encoding="utf-8")) for p in markdown_files()]
    for p in notebooks():
        for i, c in enumerate(load_notebook(p)["cells"]):
            if c["cell_type"] == "markdown":
                out.append((f"{rel(p)} cell {i}", cell_source(c)))
    return out


@lru_cache(maxsize=1)
def md_parser():
    from markdown_it.renderer import RendererHTML
    from myst_parser.config.main import MdParserConfig
    from myst_parser.parsers.mdit import create_md_parser

    return create_md_parser(MdParserConfig(enable_extensions=MYST_EXTENSIONS), RendererHTML)


def tokens(text: str):
    return md_parser().parse(text)


_TAG = re.compile(r"\\tag\*?\{([^{}]+)\}")
_ROLE = re.compile(r"\{[\w:.-]+\}`[^`]*`")


def strip_roles(text: str) -> str:
    """Remove MyST roles such as ``{glue:text}`key:.2f` `` and ``{doc}`x` ``."""
    return _ROLE.sub(" ", text)


def math_spans(text: str):
    """``(tex, display, kind)`` for every math span of a markdown text, with display math
    wrapped the way Sphinx's MathJax writer wraps it (``split`` for lines with ``\\\\``,
    ``align`` around several equations)."""
    for tok in tokens(text):
        if tok.type == "math_block":
            yield _sphinx_display(tok.content), True, tok.type
        elif tok.type == "math_block_label":
            # book/_ext/book_conventions.py moves a labelled equation's \tag into its number
            yield _sphinx_display(_TAG.sub("", tok.content)), True, tok.type
        elif tok.type == "amsmath":
            yield tok.content, True, "amsmath"
        elif tok.type == "fence" and tok.info.strip() == "{math}":
            body = "\n".join(l for l in tok.content.splitlines() if not l.startswith(":"))
            yield _sphinx_display(body), True, "math directive"
        for child in tok.children or []:
            if child.type in ("math_inline", "math_inline_double"):
                yield child.content, False, child.type


def _sphinx_display(tex: str) -> str:
    parts = [p for p in tex.split("\n\n") if p.strip()]
    wrapped = [r"\begin{split}" + p + r"\end{split}" if r"\\" in p else p for p in parts]
    if len(wrapped) > 1:
        return r"\begin{align}\begin{aligned}" + r"\\".join(wrapped) + \
            r"\end{aligned}\end{align}"
    return wrapped[0] if wrapped else ""


def tables(text: str):
    """Markdown tables as ``(header_cells, rows)``, each cell its raw inline source."""
    toks = tokens(text)
    i = 0
    while i < len(toks):
        if toks[i].type == "table_open":
            header, rows, row, in_head = [], [], [], False
            while toks[i].type != "table_close":
                t = toks[i]
                if t.type == "thead_open":
                    in_head = True
                elif t.type == "thead_close":
                    in_head = False
                elif t.type == "tr_open":
                    row = []
                elif t.type == "tr_close":
                    (header.extend(row) if in_head else rows.append(row))
                elif t.type == "inline":
                    row.append(t.content)
                i += 1
            yield header, rows
        i += 1
