"""The whole book as one PDF, offline: the single-page HTML build printed by the local Chromium.

Usage (``.ci/build_pdf`` runs both steps after ``jupyter-book build . --builder singlehtml``)::

    python .ci/book_pdf.py print [_build/singlehtml] [_build/pdf/trackcore-book.pdf]
    python .ci/book_pdf.py check [_build/pdf/trackcore-book.pdf]

``print`` opens the single page in headless Chromium (Sphinx writes it at the root
document's path, ``book/intro.html``, with links relative to the output's root, so it is
first copied to ``whole-book.html`` there) (the DevTools driver of
``browser_check.py``; no network, no download), waits until MathJax has typeset every
formula, lays the page out at the printed text width so that ``wide_tables.js`` fits the
tables to paper, and prints it to A4 with page numbers and a PDF outline (bookmarks) of the
headings. ``check`` reads the PDF back with poppler's ``pdfinfo``/``pdftotext`` (Debian
package ``poppler-utils``) and fails unless it has at least one page per page of the book
and the title of every page in ``_toc.yml`` appears in its text, in the table of contents'
order. Exits non-zero on any failure.
"""
from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import browser_check as bc

ROOT = Path(__file__).resolve().parents[1]
SINGLE = ROOT / "_build" / "singlehtml"
PDF = ROOT / "_build" / "pdf" / "trackcore-book.pdf"

# A4 with 15 mm margins: the printed text column is (210 - 30) mm = 680 CSS px wide.
PAPER_IN = (8.27, 11.69)
MARGIN_IN = 0.59
PRINT_WIDTH_PX = round((PAPER_IN[0] - 2 * MARGIN_IN) * 96)

PRINT_TIMEOUT_S = 1200
FOOTER = ('<div style="font-size:8px;width:100%;text-align:center;color:#555">'
          '<span class="pageNumber"></span> / <span class="totalPages"></span></div>')


def single_page(single: Path = SINGLE, root: Path = ROOT) -> Path:
    """The single-page book, copied where its relative links resolve."""
    import yaml

    doc = yaml.safe_load((root / "_toc.yml").read_text(encoding="utf-8"))["root"]
    src = single / f"{doc}.html"
    if not src.is_file():
        raise FileNotFoundError(f"{src} does not exist: run "
                                "`jupyter-book build . --builder singlehtml` first")
    html = single / "whole-book.html"
    shutil.copyfile(src, html)
    return html


def print_pdf(single: Path = SINGLE, pdf: Path = PDF, root: Path = ROOT) -> int:
    """Print the single-page build in ``single`` to ``pdf``; returns the PDF's size in bytes."""
    html = single_page(single, root)
    with bc.browser(PRINT_WIDTH_PX) as page:
        page.call("Emulation.setEmulatedMedia", media="print")
        problems = bc.check_page(page, html.as_uri())
        # console messages are the browser check's business; here only what breaks the PDF
        # (the single-page build has no search index, and the PDF needs none)
        fatal = [p for p in problems if ("MathJax" in p or p.startswith(("failed", "network")))
                 and "searchindex.js" not in p]
        if fatal:
            raise RuntimeError("the single-page book does not render cleanly:\n  "
                               + "\n  ".join(fatal))
        # what a browser announces before it prints: the theme opens folded cells and
        # dropdowns, wide_tables.js fits the tables again at the paper's width
        page.call("Runtime.evaluate",
                  expression="window.dispatchEvent(new Event('beforeprint'))")
        page.drain(1.0)
        page.ws.settimeout(PRINT_TIMEOUT_S)  # a 400-page print takes minutes on a busy machine
        res = page.call("Page.printToPDF", printBackground=True, paperWidth=PAPER_IN[0],
                        paperHeight=PAPER_IN[1], marginTop=MARGIN_IN, marginBottom=MARGIN_IN,
                        marginLeft=MARGIN_IN, marginRight=MARGIN_IN,
                        displayHeaderFooter=True, headerTemplate="<div></div>",
                        footerTemplate=FOOTER, generateTaggedPDF=True,
                        generateDocumentOutline=True, transferMode="ReturnAsStream")
        pdf.parent.mkdir(parents=True, exist_ok=True)
        with pdf.open("wb") as f:
            while True:
                chunk = page.call("IO.read", handle=res["stream"], size=1 << 20)
                data = chunk.get("data", "")
                f.write(base64.b64decode(data) if chunk.get("base64Encoded") else
                        data.encode("latin-1"))
                if chunk.get("eof"):
                    break
        page.call("IO.close", handle=res["stream"])
    return pdf.stat().st_size


def toc_pages(root: Path = ROOT) -> list[Path]:
    """Every page of ``_toc.yml`` (root first), as source files, in reading order."""
    import yaml

    toc = yaml.safe_load((root / "_toc.yml").read_text(encoding="utf-8"))
    names: list[str] = [toc["root"]]

    def walk(node):
        if isinstance(node, dict):
            if "file" in node:
                names.append(node["file"])
            if "glob" in node:
                names.extend(sorted(str(f.relative_to(root).with_suffix(""))
                                    for f in root.glob(node["glob"])
                                    if f.suffix in (".md", ".ipynb")))
            for key in ("parts", "chapters", "sections"):
                for child in node.get(key, []) or []:
                    walk(child)
        elif isinstance(node, list):
            for child in node:
                walk(child)

    walk(toc)
    pages = []
    for name in names:
        for ext in ("", ".md", ".ipynb"):
            p = root / f"{name}{ext}"
            if p.is_file():
                pages.append(p)
                break
        else:
            raise FileNotFoundError(f"_toc.yml names {name!r}, which has no .md or .ipynb file")
    return pages


def page_title(path: Path) -> str:
    """The first level-1 heading of a MyST page or a notebook's markdown cells."""
    if path.suffix == ".ipynb":
        nb = json.loads(path.read_text(encoding="utf-8"))
        text = "\n".join("".join(c["source"]) if isinstance(c["source"], list) else c["source"]
                         for c in nb["cells"] if c["cell_type"] == "markdown")
    else:
        text = path.read_text(encoding="utf-8")
    m = re.search(r"^# +(.+?)\s*$", text, re.MULTILINE)
    if not m:
        raise ValueError(f"{path} has no level-1 heading")
    return m.group(1)


def _words(text: str) -> str:
    """Lower-case letters and digits only: what survives pdftotext's line breaks, ligatures
    and hyphenation of a title (MyST roles are reduced to their text first)."""
    text = re.sub(r"\{[a-z:]+\}`([^`<]*)(<[^>]*>)?`", r"\1", text)
    text = text.replace("\ufb01", "fi").replace("\ufb02", "fl")
    return re.sub(r"[^0-9a-z]+", "", text.lower())


def check_pdf(pdf: Path = PDF, root: Path = ROOT) -> list[str]:
    """Problems with the PDF (empty when every page of the book is in it, in order)."""
    for tool in ("pdfinfo", "pdftotext"):
        if not shutil.which(tool):
            return [f"{tool} not found (Debian package poppler-utils)"]
    if not pdf.is_file():
        return [f"{pdf} does not exist"]
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True, check=True)
    n_pages = int(re.search(r"^Pages:\s+(\d+)", info.stdout, re.MULTILINE).group(1))
    text = subprocess.run(["pdftotext", "-enc", "UTF-8", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    flat = _words(text)
    pages = toc_pages(root)
    problems = []
    if n_pages < len(pages):
        problems.append(f"{n_pages} PDF pages for {len(pages)} pages of the book")
    at = 0
    for p in pages:
        title = page_title(p)
        # the parts of the title around its math, each in order (MathJax's glyphs are not
        # text that pdftotext gives back reliably)
        keys = [k for k in (_words(part) for part in re.split(r"\$[^$]*\$", title)) if k]
        pos, missing = at, not keys
        for key in keys:
            i = flat.find(key, pos)
            if i < 0:
                missing = True
                break
            pos = i + len(key)
        if missing:
            where = ("anywhere" if not keys or any(flat.find(k) < 0 for k in keys)
                     else "after the previous title")
            problems.append(f"title of {p.relative_to(root)} ({title!r}) not found {where}")
            continue
        at = pos
    print(f"book_pdf: {pdf.relative_to(root) if pdf.is_relative_to(root) else pdf}: "
          f"{n_pages} pages, {pdf.stat().st_size / 2**20:.1f} MiB, "
          f"{len(pages) - len(problems)} of {len(pages)} page titles found in order")
    return problems


def main(argv: list[str]) -> int:
    if not argv or argv[0] not in ("print", "check"):
        print(__doc__, file=sys.stderr)
        return 2
    if argv[0] == "print":
        single = Path(argv[1]) if len(argv) > 1 else SINGLE
        pdf = Path(argv[2]) if len(argv) > 2 else PDF
        try:
            size = print_pdf(single.resolve(), pdf.resolve())
        except (bc.BrowserUnavailable, FileNotFoundError, RuntimeError) as e:
            print(f"book_pdf: {e}", file=sys.stderr)
            return 1
        print(f"book_pdf: wrote {pdf} ({size / 2**20:.1f} MiB)")
        return 0
    pdf = Path(argv[1]) if len(argv) > 1 else PDF
    problems = check_pdf(pdf.resolve())
    for p in problems:
        print(f"book_pdf: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
