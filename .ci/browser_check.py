"""Open every page of the built book in headless Chromium and report what a reader would see
go wrong: console errors and warnings, uncaught exceptions, resources that fail to load, and
MathJax errors (``mjx-merror`` elements after typesetting).

Usage: python .ci/browser_check.py [_build/html]   (needs /usr/bin/chromium; Debian package
``chromium``). Drives Chromium over the DevTools protocol with ``websocket-client`` (pinned in
requirements.txt as a JupyterLab dependency). Network access is blocked: every request that
is not ``file://`` or ``data:`` is reported as an error. Exits 1 if any page has a problem.
"""
from __future__ import annotations

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
    # every page is checked as a first visit: forget the theme mode and anything else stored
    page.call("Runtime.evaluate", expression="localStorage.clear(); sessionStorage.clear()")
    problems = []
    if merrors == -1:
        problems.append("MathJax did not start")
    elif merrors:
        texts = page.call("Runtime.evaluate", returnByValue=True, expression=(
            "Array.from(document.querySelectorAll('mjx-merror')).map("
            "e => e.getAttribute('data-mjx-error') || e.textContent).slice(0, 5)"))
        problems.append(f"{merrors} MathJax error(s): {texts['result']['value']}")
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
            problems.append(f"failed to load: {p.get('errorText')} (request {p.get('requestId')})")
    return problems


def main(root: str = "_build/html") -> int:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        print("browser_check: chromium not found (Debian package 'chromium')", file=sys.stderr)
        return 2
    root_path = Path(root).resolve()
    pages = sorted(p for p in root_path.rglob("*.html")
                   if not {"_static", "_sources", "_images", "mathjax"} & set(p.relative_to(root_path).parts)
                   and p.name not in ("search.html", "genindex.html"))
    port = _free_port()
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:
        proc = subprocess.Popen([chromium, *FLAGS, f"--remote-debugging-port={port}",
                                 f"--user-data-dir={profile}", "about:blank"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(100):
                try:
                    tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json"))
                    break
                except OSError:
                    time.sleep(0.1)
            else:
                print("browser_check: chromium did not open its debugging port", file=sys.stderr)
                return 2
            tab = next(t for t in tabs if t.get("type") == "page")
            page = Page(tab["webSocketDebuggerUrl"])
            for domain in ("Page", "Runtime", "Log", "Network"):
                page.call(f"{domain}.enable")
            bad = 0
            for p in pages:
                problems = check_page(page, p.as_uri())
                rel = p.relative_to(root_path)
                if problems:
                    bad += 1
                    print(f"FAIL {rel}")
                    for line in problems:
                        print(f"     {line}")
            print(f"browser_check: {len(pages)} pages, {bad} with problems "
                  f"(console errors/warnings, exceptions, failed loads, network requests, "
                  f"MathJax errors)")
            return 1 if bad else 0
        finally:
            proc.terminate()
            proc.wait(timeout=10)


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
