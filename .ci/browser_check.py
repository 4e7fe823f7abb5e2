"""Open every page of the built book in headless Chromium and report what a reader would see
go wrong: console errors and warnings, uncaught exceptions, resources that fail to load, and
MathJax errors (``mjx-merror`` elements after typesetting), tables wider than the text
column at a desktop width (1400 px): a table may be wider than the column only inside a
scrolling box that shows a visible "scroll sideways" cue (``book/_static/wide_tables.js``
marks such boxes ``tc-wide``; ``book.css`` draws the cue), otherwise it is a problem; and
verdict badges that a reader cannot see without scrolling: every verdict badge in the first
column of a table (the scorecard's and each chapter's claim tables) must lie wholly inside
the viewport and every clipping box around it as the page opens, and the scorecard page
must show at least one; and, at a desktop width, notebook figures shrunk below the size
they were drawn at (their 9-pt text would render smaller than 9 pt).

Usage: python .ci/browser_check.py [_build/html] [--width PX] [--tables]   (needs /usr/bin/chromium; Debian package
``chromium``). Drives Chromium over the DevTools protocol with ``websocket-client`` (pinned in
requirements.txt as a JupyterLab dependency). Network access is blocked: every request that
is not ``file://`` or ``data:`` is reported as an error. Exits 1 if any page has a problem.
``--width`` sets the viewport width (default 1400; below 700 px the page is laid out as on a
phone); ``--tables`` lists every table wider than the text column, with or without a cue.
"""
from __future__ import annotations

import contextlib
import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import websocket

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-extensions", "--mute-audio"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Page:
    def __init__(self, ws_url: str):
        self.ws = websocket.create_connection(ws_url, timeout=60, suppress_origin=True)
        self.next_id = 0
        self.events: list[dict] = []
        self.last_tables: list[dict] = []
        self.width = 1400

    def call(self, method: str, **params):
        self.next_id += 1
        my_id = self.next_id
        self.ws.send(json.dumps({"id": my_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == my_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})
            self.events.append(msg)

    def drain(self, seconds: float) -> None:
        end = time.time() + seconds
        self.ws.settimeout(0.2)
        while time.time() < end:
            try:
                self.events.append(json.loads(self.ws.recv()))
            except websocket.WebSocketTimeoutException:
                pass
        self.ws.settimeout(60)


WAIT_MATHJAX = """
new Promise((resolve) => {
  const done = () => resolve(document.querySelectorAll('mjx-merror').length);
  const start = Date.now();
  (function poll() {
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
      MathJax.startup.promise.then(done, done);
    } else if (Date.now() - start > 15000) { resolve(-1); }
    else { setTimeout(poll, 100); }
  })();
})
"""


# Every table in the page's article whose laid-out width exceeds the width a reader can see:
# the text column (the article's content box) or a narrower clipping/scrolling ancestor. A
# table counts as having a scroll affordance when its nearest horizontally scrolling ancestor
# carries the class tc-wide and the cue that book.css draws for it is displayed.
MEASURE_TABLES = """
(() => {
  const art = document.querySelector('article.bd-article') || document.querySelector('main')
              || document.body;
  const acs = getComputedStyle(art);
  const column = art.clientWidth - parseFloat(acs.paddingLeft) - parseFloat(acs.paddingRight);
  const out = [];
  for (const t of art.querySelectorAll('table')) {
    const r = t.getBoundingClientRect();
    if (r.width === 0 && r.height === 0) continue;   // not displayed (folded)
    const width = Math.max(t.scrollWidth, r.width);
    let box = column, scroller = null;
    for (let a = t.parentElement; a && a !== art; a = a.parentElement) {
      const ox = getComputedStyle(a).overflowX;
      if (ox === 'visible') continue;
      box = Math.min(box, a.clientWidth);
      if (!scroller && (ox === 'auto' || ox === 'scroll')) scroller = a;
    }
    if (width <= box + 1) continue;
    let cue = false;
    if (scroller && scroller.classList.contains('tc-wide')) {
      const before = getComputedStyle(scroller, '::before');
      cue = before.display !== 'none' && before.content !== 'none' && before.content !== '';
    }
    const head = Array.from(t.querySelectorAll('th')).slice(0, 4)
      .map(h => h.textContent.trim().slice(0, 20)).join(' | ');
    out.push({width: Math.round(width), box: Math.round(box), column: Math.round(column),
              cue: cue, head: head || (t.textContent || '').trim().slice(0, 60)});
  }
  return out;
})()
"""


# Verdict badges (sphinx-design badges) in the first column of a table, and those not wholly
# visible as the page opens: outside the viewport or outside a clipping/scrolling ancestor.
MEASURE_BADGES = """
(() => {
  const vw = document.documentElement.clientWidth;
  const hidden = [];
  let n = 0;
  for (const b of document.querySelectorAll('table td:first-child .sd-badge')) {
    const r = b.getBoundingClientRect();
    if (r.width === 0 && r.height === 0) continue;   // folded
    n++;
    let left = 0, right = vw;
    for (let a = b.parentElement; a && a !== document.body; a = a.parentElement) {
      if (getComputedStyle(a).overflowX === 'visible') continue;
      const ar = a.getBoundingClientRect();
      left = Math.max(left, ar.left);
      right = Math.min(right, ar.right);
    }
    if (r.left < left - 1 || r.right > right + 1)
      hidden.push(`${b.textContent.trim()} at x = ${Math.round(r.left)}..${Math.round(r.right)}`
                  + ` (visible ${Math.round(left)}..${Math.round(right)})`);
  }
  return {n: n, hidden: hidden};
})()
"""


# Figures drawn by a notebook (images in cell outputs): the book's figures are saved at
# FIGURE_DPI, so text set at s pt renders at s * (displayed / natural width) * FIGURE_DPI / 96
# pt (CSS has 96 px per inch). At a desktop width no figure may be shrunk below its set size
# (MIN_FIGURE_SCALE): the 9-pt legends and tick labels must render at 9 pt or more.
FIGURE_DPI = 150
MIN_FIGURE_SCALE = 0.99
MEASURE_FIGURES = """
(() => {
  const out = [];
  for (const im of document.querySelectorAll('.cell_output img, div.output img')) {
    const r = im.getBoundingClientRect();
    if (!im.naturalWidth || r.width === 0) continue;
    out.push({shown: r.width, natural: im.naturalWidth,
              src: (im.getAttribute('src') || '').split('/').pop().slice(0, 40)});
  }
  return out;
})()
"""


def measure_figures(page: Page) -> list[dict]:
    """Each notebook figure of the page: its displayed and natural width and ``scale``, the
    factor between a font size set in the figure and its rendered size (MEASURE_FIGURES)."""
    figs = page.call("Runtime.evaluate", expression=MEASURE_FIGURES,
                     returnByValue=True)["result"]["value"]
    for f in figs:
        f["scale"] = f["shown"] / f["natural"] * FIGURE_DPI / 96.0
    return figs


def measure_badges(page: Page) -> dict:
    """Verdict badges in tables' first columns and those a reader cannot see (MEASURE_BADGES)."""
    return page.call("Runtime.evaluate", expression=MEASURE_BADGES,
                     returnByValue=True)["result"]["value"]


def measure_tables(page: Page) -> list[dict]:
    """Tables of the current page wider than what a reader sees (see MEASURE_TABLES)."""
    return page.call("Runtime.evaluate", expression=MEASURE_TABLES,
                     returnByValue=True)["result"]["value"]


def check_page(page: Page, url: str) -> list[str]:
    page.events.clear()
    page.call("Page.navigate", url=url)
    # wait for the load event
    deadline = time.time() + 60
    while time.time() < deadline and not any(
            e.get("method") == "Page.loadEventFired" for e in page.events):
        page.drain(0.2)
    has_math = page.call("Runtime.evaluate", expression="document.querySelector('.math') !== null",
                         returnByValue=True)["result"]["value"]
    merrors = 0
    if has_math:
        res = page.call("Runtime.evaluate", expression=WAIT_MATHJAX, awaitPromise=True,
                        returnByValue=True)
        merrors = res["result"]["value"]
    page.drain(0.5)
    wide = measure_tables(page)
    page.last_tables = wide
    badges = measure_badges(page)
    page.last_badges = badges["n"]
    figures = measure_figures(page) if page.width >= 1000 else []
    # every page is checked as a first visit: forget the theme mode and anything else stored
    page.call("Runtime.evaluate", expression="localStorage.clear(); sessionStorage.clear()")
    problems = [f"table {t['width']} px wide in {t['box']} px without a scroll cue: {t['head']}"
                for t in wide if not t["cue"]]
    problems += [f"verdict badge not visible without scrolling: {h}" for h in badges["hidden"][:5]]
    problems += [f"figure {f['src']} shown at {f['shown']:.0f} of its {f['natural']} px: its "
                 f"9-pt text renders at {9 * f['scale']:.1f} pt (below 9 pt)"
                 for f in figures if f["scale"] < MIN_FIGURE_SCALE]
    if url.endswith("/book/scorecard.html") and badges["n"] == 0:
        problems.append("the scorecard shows no verdict badge in its tables")
    if merrors == -1:
        problems.append("MathJax did not start")
    elif merrors:
        texts = page.call("Runtime.evaluate", returnByValue=True, expression=(
            "Array.from(document.querySelectorAll('mjx-merror')).map("
            "e => e.getAttribute('data-mjx-error') || e.textContent).slice(0, 5)"))
        problems.append(f"{merrors} MathJax error(s): {texts['result']['value']}")
    urls = {e["params"]["requestId"]: e["params"]["request"]["url"] for e in page.events
            if e.get("method") == "Network.requestWillBeSent"}
    for e in page.events:
        m, p = e.get("method"), e.get("params", {})
        if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "warning", "assert"):
            args = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
            problems.append(f"console.{p['type']}: {args[:200]}")
        elif m == "Runtime.exceptionThrown":
            d = p["exceptionDetails"]
            text = d.get("exception", {}).get("description") or d.get("text")
            problems.append(f"uncaught exception: {str(text)[:200]}")
        elif m == "Log.entryAdded" and p["entry"]["level"] in ("error", "warning"):
            ent = p["entry"]
            problems.append(f"{ent['level']}: {ent['text'][:160]} {ent.get('url', '')[:120]}")
        elif m == "Network.requestWillBeSent":
            req = p["request"]["url"]
            if not req.startswith(("file:", "data:", "blob:", "about:")):
                problems.append(f"network request: {req[:160]}")
        elif m == "Network.loadingFailed" and not p.get("canceled"):
            url = urls.get(p.get("requestId"), f"request {p.get('requestId')}")
            problems.append(f"failed to load: {p.get('errorText')} ({url[:160]})")
    return problems


class BrowserUnavailable(RuntimeError):
    pass


@contextlib.contextmanager
def browser(width: int = 1400):
    """A headless Chromium with one tab, its viewport ``width`` px wide (a phone's layout
    below 700 px), and the DevTools domains the check needs enabled; yields its Page."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        raise BrowserUnavailable("chromium not found (Debian package 'chromium')")
    port = _free_port()
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:
        proc = subprocess.Popen([chromium, *FLAGS, f"--remote-debugging-port={port}",
                                 f"--user-data-dir={profile}", "about:blank"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(300):  # 30 s: Chromium starts slowly on a loaded machine
                try:
                    tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json"))
                    break
                except OSError:
                    time.sleep(0.1)
            else:
                raise BrowserUnavailable("chromium did not open its debugging port")
            tab = next(t for t in tabs if t.get("type") == "page")
            page = Page(tab["webSocketDebuggerUrl"])
            page.width = width
            for domain in ("Page", "Runtime", "Log", "Network"):
                page.call(f"{domain}.enable")
            page.call("Emulation.setDeviceMetricsOverride", width=width, height=900,
                      deviceScaleFactor=1, mobile=width < 700)
            yield page
        finally:
            proc.terminate()
            proc.wait(timeout=10)


def main(*argv: str) -> int:
    args = list(argv)
    width, list_tables = 1400, False
    if "--tables" in args:
        args.remove("--tables")
        list_tables = True
    if "--width" in args:
        i = args.index("--width")
        width = int(args[i + 1])
        del args[i:i + 2]
    root = args[0] if args else "_build/html"
    root_path = Path(root).resolve()
    pages = sorted(p for p in root_path.rglob("*.html")
                   if not {"_static", "_sources", "_images", "mathjax"} & set(p.relative_to(root_path).parts)
                   and p.name not in ("search.html", "genindex.html"))
    try:
        with browser(width) as page:
            bad = 0
            n_wide = n_cued = n_badges = 0
            wide_pages = set()
            for p in pages:
                problems = check_page(page, p.as_uri())
                rel = p.relative_to(root_path)
                n_wide += len(page.last_tables)
                n_cued += sum(t["cue"] for t in page.last_tables)
                n_badges += page.last_badges
                if page.last_tables:
                    wide_pages.add(rel)
                if list_tables:
                    for t in page.last_tables:
                        print(f"WIDE {rel}: {t['width']} px in {t['box']} px "
                              f"(column {t['column']} px), cue {'yes' if t['cue'] else 'NO'}: "
                              f"{t['head']}")
                if problems:
                    bad += 1
                    print(f"FAIL {rel}")
                    for line in problems:
                        print(f"     {line}")
    except BrowserUnavailable as e:
        print(f"browser_check: {e}", file=sys.stderr)
        return 2
    print(f"browser_check at {width} px: {n_wide} table(s) on {len(wide_pages)} page(s) "
          f"wider than the text column, {n_wide - n_cued} of them without a scroll cue")
    print(f"browser_check at {width} px: {n_badges} verdict badge(s) in the first column of "
          f"tables, checked visible without scrolling")
    print(f"browser_check: {len(pages)} pages, {bad} with problems "
          f"(console errors/warnings, exceptions, failed loads, network requests, "
          f"MathJax errors, tables overflowing without a scroll cue, verdict badges out of "
          f"view)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
