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
* **Version stamp and footer.** Every page's footer names the ``trackcore`` version (read
  from ``trackcore/__init__.py``) and the git commit the book was built from (with its date,
  and a note if the checkout has uncommitted changes), generated at build time and never
  typed, and says what the build does: it renders stored outputs, which the test suite
  re-executes and compares.
* **PDF of the whole book.** When ``_build/pdf/trackcore-book.pdf`` exists (made by
  ``bash .ci/build_pdf``), the HTML build copies it to the site's root and the download
  menu of every page links to it beside the theme's "print this page".
* **Style.** ``book/_static/book.css``: a CJK fallback font for the Korean titles, and
  readable tables; ``book/_static/wide_tables.js`` fits a table that is wider than the text
  column (tighter type, vertical headers over columns of counts) and marks one that still
  cannot fit, so book.css shows a "scroll sideways" cue on it.
"""
from __future__ import annotations

import html
import re
import subprocess
from pathlib import Path

from docutils import nodes

_TAG = re.compile(r"\\tag\*?\{([^{}]+)\}")
_STATIC = Path(__file__).resolve().parent.parent / "_static"
_ROOT = Path(__file__).resolve().parents[2]
PDF_NAME = "trackcore-book.pdf"
PDF_FILE = _ROOT / "_build" / "pdf" / PDF_NAME

FOOTER_TRUTH = (
    "The book shows the outputs stored in its notebooks; the test suite re-executes every "
    "notebook and fails if an output differs from the stored one; a notebook that reads "
    "Monte Carlo results stored in <code>results/</code> re-simulates a random sample of "
    "the stored runs and fails if one differs. Code under the MIT licence; text and "
    "figures under CC BY 4.0 (see LICENSE)."
)


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


def _git(*args: str) -> str:
    try:
        done = subprocess.run(["git", "-C", str(_ROOT), *args], capture_output=True,
                              text=True, timeout=20, check=True)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.strip()


def trackcore_version(root: Path = _ROOT) -> str:
    """``trackcore.__version__`` as written in the package's ``__init__.py`` (not imported,
    so the stamp is the source tree's even where another copy is installed)."""
    text = (root / "trackcore" / "__init__.py").read_text(encoding="utf-8")
    m = re.search(r"^__version__\s*=\s*[\"']([^\"']+)[\"']", text, re.MULTILINE)
    if not m:
        raise ValueError(f"no __version__ in {root / 'trackcore' / '__init__.py'}")
    return m.group(1)


def version_stamp() -> str:
    """'trackcore 0.1.0, commit abc1234 of 2026-12-03' (with a note on uncommitted changes,
    or 'commit unknown' outside a git checkout)."""
    sha = _git("rev-parse", "--short=7", "HEAD")
    if not sha:
        commit = "commit unknown (not built from a git checkout)"
    else:
        commit = f"commit {sha} of {_git('show', '-s', '--format=%cs', 'HEAD')}"
        if _git("status", "--porcelain", "--untracked-files=no"):
            commit += ", with uncommitted changes"
    return f"trackcore {trackcore_version()}, {commit}"


def _footer(app, config) -> None:
    options = dict(config.html_theme_options or {})
    options["extra_footer"] = (f"<p>Built offline from {html.escape(version_stamp())}. "
                               f"{FOOTER_TRUTH}</p>")
    config.html_theme_options = options


def _ship_pdf(app) -> None:
    """The HTML site carries the PDF of the whole book when one has been built."""
    if app.builder.name == "html" and PDF_FILE.is_file():
        app.config.html_extra_path = list(app.config.html_extra_path) + [str(PDF_FILE)]


def _pdf_button(app, pagename, templatename, context, doctree) -> None:
    """Beside the theme's 'print this page', a link to the PDF of the whole book."""
    if app.builder.name != "html" or not PDF_FILE.is_file():
        return
    for group in context.get("header_buttons") or []:
        if group.get("label") != "download-buttons":
            continue
        for button in group["buttons"]:
            if button.get("label") == "download-pdf-button":
                button["text"] = ".pdf (this page)"
                button["tooltip"] = "Print this page to PDF"
        group["buttons"].append({
            "type": "link",
            "url": context["pathto"](PDF_NAME, 1),
            "text": ".pdf (whole book)",
            "tooltip": "The whole book as one PDF (built offline by .ci/build_pdf)",
            "icon": "fas fa-book",
            "label": "download-book-pdf-button",
        })


def setup(app):
    app.connect("doctree-read", _paper_numbers)
    _no_thebe(app)  # sphinx_thebe is set up before the book's local extensions
    app.connect("builder-inited", _no_thebe, priority=1)
    app.connect("html-page-context", _local_lab_button, priority=900)
    app.connect("html-page-context", _pdf_button, priority=900)
    app.connect("config-inited", _footer)
    app.connect("builder-inited", _ship_pdf)
    app.config.html_static_path = list(app.config.html_static_path) + [str(_STATIC)]
    app.add_css_file("book.css")
    app.add_js_file("wide_tables.js", defer="defer")
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
