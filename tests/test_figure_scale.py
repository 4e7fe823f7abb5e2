"""Notebook figures shrunk below the size they were drawn at: what ``.ci/browser_check.py``
measures, in headless Chromium on a small page of two figures in a 772 px text column (the
width it has at a 1400 px window). A figure of the book's width (7.5 in at 150 dpi, 1125 px)
renders its text at its set size or larger; one 1294 px wide (a legend drawn outside the axes
widens the saved image) is shrunk so that its 9-pt text renders at about 8.4 pt and is
reported. Skipped where Chromium is not installed (CI installs Debian's package).
"""
from __future__ import annotations

import importlib.util
import shutil

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from _book import ROOT  # noqa: E402

pytestmark = pytest.mark.skipif(
    not (shutil.which("chromium") or shutil.which("chromium-browser")),
    reason="needs chromium (Debian package 'chromium')")

_spec = importlib.util.spec_from_file_location("browser_check", ROOT / ".ci" / "browser_check.py")
bc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bc)


def _png(path, width_in):
    fig = plt.figure(figsize=(width_in, 2.0), dpi=bc.FIGURE_DPI)
    fig.savefig(path, dpi=bc.FIGURE_DPI)
    plt.close(fig)
    return path.as_uri()


def _page(tmp_path) -> str:
    book = _png(tmp_path / "book.png", 7.5)            # 1125 px
    wide = _png(tmp_path / "wide.png", 1294 / 150)     # 1294 px
    html = f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">
<style>body {{ margin: 0; }} article.bd-article {{ width: 772px; }}
img {{ max-width: 100%; }}</style></head><body><main><article class="bd-article">
<div class="cell_output"><img src="{book}" alt="book width"></div>
<div class="cell_output"><img src="{wide}" alt="too wide"></div>
</article></main></body></html>"""
    path = tmp_path / "figures.html"
    path.write_text(html, encoding="utf-8")
    return path.as_uri()


def test_a_figure_shrunk_below_its_drawn_size_is_reported_at_1400_px(tmp_path):
    with bc.browser(1400) as page:
        problems = bc.check_page(page, _page(tmp_path))
        figs = bc.measure_figures(page)
    scales = sorted(round(f["scale"], 3) for f in figs)
    assert [f["natural"] for f in figs] == [1125, 1294], f"two figures measured: {figs}"
    assert scales == [round(772 / 1294 * 1.5625, 3), round(772 / 1125 * 1.5625, 3)], scales
    assert len(problems) == 1 and "wide.png" in problems[0] and "8.4 pt" in problems[0], \
        f"only the 1294 px figure is reported, its 9-pt text at 8.4 pt: {problems}"


def test_figures_are_not_checked_on_a_phone(tmp_path):
    with bc.browser(400) as page:
        problems = bc.check_page(page, _page(tmp_path))
    assert problems == [], f"at 400 px every figure shrinks; nothing is reported: {problems}"
