"""Tables wider than the text column: what ``book/_static/wide_tables.js`` does to them, and
what ``.ci/browser_check.py`` measures, in headless Chromium on a small page of test tables.

The page imitates the theme's layout (an ``article.bd-article`` text column 772 px wide, the
width it has at a 1400 px window, and the theme's scrolling box around each table) and loads
the book's own ``book.css`` and ``wide_tables.js``. Skipped where Chromium is not installed
(CI installs Debian's package).
"""
from __future__ import annotations

import importlib.util
import shutil

import pytest
from _book import ROOT

pytestmark = pytest.mark.skipif(
    not (shutil.which("chromium") or shutil.which("chromium-browser")),
    reason="needs chromium (Debian package 'chromium')")

_spec = importlib.util.spec_from_file_location("browser_check", ROOT / ".ci" / "browser_check.py")
bc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bc)

STATIC = ROOT / "book" / "_static"
HEADS = ["claims", "reproduced", "within tolerance", "undecided", "depends on reading",
         "not reproduced", "not testable", "errata: paper errors",
         "suspected (print unchecked)", "source-text defects", "notation",
         "printed forms confirmed"]


def _table(head: list[str], rows: list[list[str]]) -> str:
    th = "".join(f"<th><p>{h}</p></th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td><p>{c}</p></td>" for c in r) + "</tr>" for r in rows)
    return (f'<div class="pst-scrollable-table-container"><table class="table">'
            f"<thead><tr>{th}</tr></thead><tbody>{body}</tbody></table></div>")


def _page(tmp_path, script: bool) -> str:
    counts = _table(["paper", *HEADS],
                    [[f"paper number {i} of the book", *[str(7 * i + j) for j in range(12)]]
                     for i in range(5)])
    token = _table(["claim", "evidence"],
                   [["a claim", ("see tests/test_tbd_pf.py::test_erratum4_weighted_mean_of_"
                                 "equal_points_returns_the_point_in_every_setting_of_the_"
                                 "chapter_and_nothing_else for the check")]])
    hopeless = _table([f"column heading {i}" for i in range(30)],
                      [[f"unbreakable_value_{i}" for i in range(30)]])
    small = _table(["a", "b"], [["1", "2"]])
    js = f'<script defer src="{(STATIC / "wide_tables.js").as_uri()}"></script>' if script else ""
    html = f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<link rel="stylesheet" href="{(STATIC / 'book.css').as_uri()}">{js}
<style>body {{ margin: 0; font: 16px sans-serif; }}
article.bd-article {{ width: min(772px, 100%); }}
.pst-scrollable-table-container {{ overflow-x: auto; }}
table {{ border-collapse: collapse; }} td, th {{ padding: 0.3rem 0.55rem; }}</style>
</head><body><main><article class="bd-article">
<p>counts</p>{counts}<p>token</p>{token}<p>hopeless</p>{hopeless}<p>small</p>{small}
</article></main></body></html>"""
    path = tmp_path / ("with.html" if script else "without.html")
    path.write_text(html, encoding="utf-8")
    return path.as_uri()


def _classes(page) -> list[str]:
    return page.call("Runtime.evaluate", returnByValue=True, expression=(
        "Array.from(document.querySelectorAll('article table')).map(t => t.className + ' | ' "
        "+ t.parentElement.className)"))["result"]["value"]


def test_without_the_script_the_check_reports_every_overflowing_table(tmp_path):
    with bc.browser(1400) as page:
        problems = bc.check_page(page, _page(tmp_path, script=False))
    wide = page.last_tables
    assert len(wide) == 3, f"the counts, token and 30-column tables overflow; measured {wide}"
    assert not any(t["cue"] for t in wide), f"nothing draws a cue without the script: {wide}"
    assert all(t["box"] == 772 for t in wide), f"the text column is 772 px: {wide}"
    assert len(problems) == 3 and all("without a scroll cue" in p for p in problems), problems


def test_at_1400_px_tables_are_fitted_and_the_one_that_cannot_fit_shows_a_cue(tmp_path):
    with bc.browser(1400) as page:
        problems = bc.check_page(page, _page(tmp_path, script=True))
        classes = _classes(page)
    wide = page.last_tables
    assert problems == [], f"no table may overflow without a cue at 1400 px: {problems}"
    assert len(wide) == 1 and wide[0]["cue"], f"only the 30-column table stays wide: {wide}"
    assert wide[0]["head"].startswith("column heading 0"), wide
    counts, token, hopeless, small = classes
    assert "tc-tight" in counts and "tc-wide" not in counts, f"counts table fitted: {counts}"
    assert "tc-wide" not in token, f"a long test name breaks instead of widening: {token}"
    assert "tc-wide" in hopeless, f"the 30-column table scrolls with a cue: {hopeless}"
    assert small == "table | pst-scrollable-table-container", f"a fitting table untouched: {small}"


def test_at_400_px_every_table_wider_than_the_screen_shows_a_cue(tmp_path):
    with bc.browser(400) as page:
        problems = bc.check_page(page, _page(tmp_path, script=True))
    wide = page.last_tables
    assert problems == [], f"every wide table carries a cue on a phone: {problems}"
    assert any(t["head"].startswith("column heading 0") for t in wide), wide
    assert all(t["cue"] for t in wide), wide
