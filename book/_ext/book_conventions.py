"""The book's own Sphinx conventions, in one local extension.

* **Paper equation numbers.** A labelled display equation whose TeX carries
  ``\\tag{15}`` is numbered "(15)" on the page and in every ``{eq}`` reference to it,
  instead of Sphinx's running count; the ``\\tag`` itself is removed before MathJax sees
  it. Equations of the paper keep the paper's numbers; the book's own equations use
  tags such as ``B1``. (Needs ``math_numfig = False``, set in ``_config.yml``.)
* **No thebe, no Binder.** Jupyter Book 1 always loads ``sphinx_thebe``; the book runs
  offline and has no Binder, so its two event handlers are disconnected: no thebe
  script, no Binder configuration on any page.
* **Open in a local JupyterLab.** Notebook pages get a header button that opens the
  notebook in a JupyterLab started at the repository root on ``localhost:8888`` (see the
  page "Running the notebooks").
* **Style.** ``book/_static/book.css``: a CJK fallback font for the Korean titles, and
  readable tables; ``book/_static/wide_tables.js`` fits a table that is wider than the text
  column (tighter type, vertical headers over columns of counts) and marks one that still
  cannot fit, so book.css shows a "scroll sideways" cue on it.
"""
from __future__ import annotations

import re
from pathlib import Path

from docutils import nodes

_TAG = re.compile(r"\\tag\*?\{([^{}]+)\}")
_STATIC = Path(__file__).resolve().parent.parent / "_static"


def _paper_numbers(app, doctree) -> None:
    """Number labelled equations by their ``\\tag``."""
    domain = app.env.get_domain("math")
    objects = domain.data["objects"]
    docname = app.env.docname
    for node in doctree.findall(nodes.math_block):
        label = node.get("label")
        text = node.astext()
        tags = _TAG.findall(text)
        if not label or not tags:
            continue
        if len(tags) > 1:
            raise ValueError(f"{docname}: equation {label!r} has more than one \\tag")
        number = tags[0].strip()
        stripped = _TAG.sub("", text)
        node.children = [nodes.Text(stripped)]
        node.rawsource = stripped
        node["number"] = number
        objects[label] = (docname, number)


def _no_thebe(app) -> None:
    for listeners in app.events.listeners.values():
        for listener in list(listeners):
            if getattr(listener.handler, "__module__", "").startswith("sphinx_thebe"):
                app.disconnect(listener.id)
    app.registry.css_files[:] = [f for f in app.registry.css_files if "thebe" not in f[0]]
    app.registry.js_files[:] = [f for f in app.registry.js_files if "thebe" not in str(f[0])]


def _local_lab_button(app, pagename, templatename, context, doctree) -> None:
    source = context.get("sourcename", "")
    if doctree is None or not source.endswith(".ipynb"):
        return
    buttons = context.get("header_buttons")
    if buttons is None:
        return
    path = source[: -len(".txt")] if source.endswith(".txt") else source
    buttons.append({
        "type": "link",
        "url": f"http://localhost:8888/lab/tree/{path}",
        "tooltip": "Open this notebook in JupyterLab on your machine "
                   "(start `jupyter lab` at the repository root first)",
        "icon": "fas fa-rocket",
        "label": "open-in-local-jupyterlab",
    })


def setup(app):
    app.connect("doctree-read", _paper_numbers)
    _no_thebe(app)  # sphinx_thebe is set up before the book's local extensions
    app.connect("builder-inited", _no_thebe, priority=1)
    app.connect("html-page-context", _local_lab_button, priority=900)
    app.config.html_static_path = list(app.config.html_static_path) + [str(_STATIC)]
    app.add_css_file("book.css")
    app.add_js_file("wide_tables.js", defer="defer")
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
