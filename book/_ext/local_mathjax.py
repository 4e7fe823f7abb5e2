"""Serve MathJax 3 from the local Python environment, so the book renders offline.

MathJax comes from the pinned PyPI package ``django-static-mathjax`` (it ships the
official MathJax 3 ``es5`` build).  At ``config-inited`` this extension copies the
parts of it the book needs (``tex-chtml.js``, the TeX input extensions, the CHTML
fonts, the UI menu) into ``_build/mathjax-extra/mathjax/`` and appends that folder
to ``html_extra_path``; Sphinx then places it at ``_build/html/mathjax/``, and
``mathjax_path`` points every page at it.  Nothing is fetched from the network.
"""
from __future__ import annotations

import shutil
from pathlib import Path

_KEEP = ("tex-chtml.js", "input", "output/chtml", "ui", "a11y", "adaptors", "core.js",
         "loader.js", "startup.js")


def _mathjax_es5() -> Path:
    try:
        import mathjax  # provided by django-static-mathjax
    except ImportError as exc:  # pragma: no cover - a broken install
        raise RuntimeError("local_mathjax: install django-static-mathjax (see requirements.txt)") from exc
    es5 = Path(mathjax.__file__).parent / "static" / "mathjax" / "es5"
    if not (es5 / "tex-chtml.js").is_file():
        raise RuntimeError(f"local_mathjax: tex-chtml.js not found under {es5}")
    return es5


def _stage(app, config) -> None:
    es5 = _mathjax_es5()
    staging = Path(app.outdir).parent / "mathjax-extra"
    target = staging / "mathjax"
    marker = target / ".source"
    if not (marker.is_file() and marker.read_text() == str(es5)):
        shutil.rmtree(staging, ignore_errors=True)
        for rel in _KEEP:
            src = es5 / rel
            dst = target / rel
            if src.is_dir():
                shutil.copytree(src, dst)
            elif src.is_file():
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, dst)
        marker.write_text(str(es5))
    config.html_extra_path = list(config.html_extra_path) + [str(staging)]


def setup(app):
    app.connect("config-inited", _stage)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
