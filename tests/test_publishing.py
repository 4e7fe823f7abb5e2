"""The publishing layer: licence, citation metadata, the version stamp in the footer, and the
PDF of the whole book (``.ci/book_pdf.py``: the list of pages it checks, title matching, and
a small PDF printed by Chromium and checked with poppler, skipped where those are missing)."""
from __future__ import annotations

import importlib.util
import re
import shutil
import sys

import pytest
import yaml
from _book import ROOT

sys.path.insert(0, str(ROOT / "book" / "_ext"))
import book_conventions


def _load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / ".ci" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


book_pdf = _load("book_pdf")

CFF_KEYS = {"abstract", "authors", "cff-version", "commit", "contact", "date-released", "doi",
            "identifiers", "keywords", "license", "license-url", "message",
            "preferred-citation", "references", "repository", "repository-artifact",
            "repository-code", "title", "type", "url", "version"}


def test_citation_cff_is_valid_cff_1_2_0_and_names_the_package_version():
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0", cff["cff-version"]
    assert set(cff) <= CFF_KEYS, f"keys outside CFF 1.2.0: {set(cff) - CFF_KEYS}"
    for key in ("message", "title", "authors"):
        assert cff.get(key), f"CFF 1.2.0 requires {key!r}"
    assert cff["authors"] == [{"name": "trackcore-book contributors"}], cff["authors"]
    assert cff["type"] in ("software", "dataset"), cff["type"]
    assert re.fullmatch(r"\d{4}-(0[1-9]|1[012])-(0[1-9]|[12]\d|3[01])",
                        str(cff["date-released"])), cff["date-released"]
    assert str(cff["version"]) == book_conventions.trackcore_version(), (
        "CITATION.cff's version must be trackcore.__version__")
    assert "repository-code" not in cff, "no public repository exists: none may be named"


def test_trackcore_version_is_read_from_the_source_tree():
    import trackcore

    assert book_conventions.trackcore_version() == trackcore.__version__


def test_version_stamp_names_the_version_and_the_commit():
    stamp = book_conventions.version_stamp()
    assert re.fullmatch(r"trackcore [\w.+-]+, (commit [0-9a-f]{7,} of \d{4}-\d\d-\d\d"
                        r"(, with uncommitted changes)?|commit unknown .*)", stamp), stamp


def test_footer_is_generated_and_says_what_the_build_does():
    config = yaml.safe_load((ROOT / "_config.yml").read_text(encoding="utf-8"))
    assert "extra_footer" not in config.get("html", {}), "the footer is generated, not typed"
    text = book_conventions.FOOTER_TRUTH
    assert "re-computed at build time" not in text
    assert "stored" in text and "re-executes" in text, text


def test_licence_names_both_licences():
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "MIT License" in text and "CC-BY-4.0" in text, "LICENSE states both licences"


def test_pdf_check_lists_every_page_of_the_toc_in_order():
    pages = book_pdf.toc_pages()
    assert pages[0] == ROOT / "book" / "intro.md", pages[0]
    assert pages[-1] == ROOT / "book" / "bibliography.md", pages[-1]
    n_sources = len([p for p in (ROOT / "book").rglob("*")
                     if p.suffix in (".md", ".ipynb") and "_build" not in p.parts
                     and ".ipynb_checkpoints" not in p.parts])
    assert len(pages) == len(set(pages)) == n_sources, (len(pages), n_sources)
    assert book_pdf.page_title(pages[0]) == "trackcore-book"


def test_title_matching_ignores_roles_punctuation_and_line_breaks():
    assert book_pdf._words("Equations (7)–(12): and {cite}`kim2007`") == \
        book_pdf._words("equations (7)-\n(12):  and kim2007")


@pytest.mark.skipif(not (shutil.which("chromium") and shutil.which("pdftotext")),
                    reason="needs chromium and poppler-utils (Debian packages)")
def test_a_small_book_prints_and_checks(tmp_path):
    root = tmp_path / "repo"
    (root / "book").mkdir(parents=True)
    (root / "_toc.yml").write_text(
        "format: jb-book\nroot: book/a\nchapters:\n  - file: book/b\n  - file: book/c\n")
    for name, title in (("a", "Alpha page"), ("b", "Beta page with $x$ in it"),
                        ("c", "Gamma page")):
        (root / "book" / f"{name}.md").write_text(f"# {title}\n\ntext\n")
    single = root / "_build" / "singlehtml"
    (single / "book").mkdir(parents=True)
    (single / "book" / "a.html").write_text(
        "<html><body><h1>Alpha page</h1><p>one</p>"
        "<h2>Beta page with x in it</h2><p>two</p></body></html>")
    pdf = tmp_path / "book.pdf"
    assert book_pdf.print_pdf(single, pdf, root) > 1000
    problems = book_pdf.check_pdf(pdf, root)
    # Beta's title is found around its math; 1 PDF page for 3 pages, and Gamma is missing
    assert len(problems) == 2, problems
    assert "1 PDF pages for 3 pages" in problems[0], problems
    assert "Gamma page" in problems[1], problems
