"""The reproduction scorecard: every claim of every paper, generated from the chapters'
claims registries at build time.

Each chapter keeps ``book/<chapter>/claims.yml``::

    paper: kim2007hpda                 # the paper's bibliography key
    title: HPDA particle filter        # short name used on the scorecard
    claims:
      - id: hpda-e-case1               # unique in the book
        claim: HPDA's cardinality error in case 1 is about 0.1
        where: Sec. 5, Fig. 8          # where the paper makes it
        kind: quantitative             # quantitative | qualitative | erratum
        paper_value: "e = 0.1"         # optional, quoted as printed
        ours: 06-monte-carlo::e_hpda_1 # glued "value [lo, hi]" (doc::key, doc in the chapter)
        verdict: reproduced            # see VERDICTS
        verdict_key: 06-monte-carlo::verdict_e_hpda_1   # optional glued verdict, must agree
        why: ...                       # required unless the verdict is "reproduced"
        evidence: 06-monte-carlo       # the notebook (or doc#label) with the evidence
        targets: [T1]                  # the chapter's "Our targets" rows this claim decides

``book/scorecard.md`` ends with the marker ``<!-- scorecard -->``; at ``source-read`` this
extension replaces it with one summary line and one table per paper, in MyST, whose "ours"
cells are cross-document glue pastes, so the page can never disagree with the notebooks.
:func:`load` and :func:`problems` are shared with ``tests/test_scorecard.py``.
"""
from __future__ import annotations

import ast
import json
import re
from collections import Counter
from pathlib import Path

import yaml

BOOK = Path(__file__).resolve().parent.parent
MARKER = "<!-- scorecard -->"
VERDICTS = {
    "reproduced": ("success", "reproduced"),
    "reproduced within tolerance": ("info", "within our tolerance"),
    "not reproduced": ("danger", "not reproduced"),
    "not testable": ("secondary", "not testable"),
}
KINDS = ("quantitative", "qualitative", "erratum")
_INTERVAL = re.compile(r"\[\s*[-+−]?[\d.]+(e[-+]?\d+)?\s*,\s*[-+−]?[\d.]+(e[-+]?\d+)?\s*\]")


def registries() -> list[Path]:
    return sorted(BOOK.glob("0*/claims.yml"))


def load(path: Path) -> dict:
    with open(path, encoding="utf-8") as f:
        data = yaml.safe_load(f)
    if not isinstance(data, dict) or not isinstance(data.get("claims"), list):
        raise ValueError(f"{path}: needs a mapping with a 'claims' list")
    return data


def glued(notebook: Path) -> dict[str, str]:
    """The text/plain value of every glued variable stored in a notebook."""
    out = {}
    nb = json.loads(notebook.read_text(encoding="utf-8"))
    for cell in nb["cells"]:
        for o in cell.get("outputs", []):
            name = o.get("metadata", {}).get("scrapbook", {}).get("name")
            if not name:
                continue
            prefix = o["metadata"]["scrapbook"].get("mime_prefix", "")
            text = o.get("data", {}).get(prefix + "text/plain")
            if text is None:
                continue
            text = "".join(text) if isinstance(text, list) else text
            try:
                value = ast.literal_eval(text)
            except (SyntaxError, ValueError):
                value = text
            out[name] = str(value)
    return out


def _split_ref(ref: str):
    doc, _, key = ref.partition("::")
    return doc.strip(), key.strip()


def _doc_path(chapter: Path, doc: str) -> Path | None:
    doc = doc.split("#")[0]
    for suffix in (".ipynb", ".md"):
        p = chapter / f"{doc}{suffix}"
        if p.is_file():
            return p
    return None


def target_ids(index: Path) -> list[str]:
    """The ids in the first column of the table under the heading "Our targets"."""
    text = index.read_text(encoding="utf-8")
    m = re.search(r"^#+\s*Our targets\s*$(.*?)(?=^#+\s|\Z)", text, re.M | re.S)
    if not m:
        return []
    ids = []
    for line in m.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.strip().startswith("|") and cells and re.fullmatch(r"T\d+[a-z]?", cells[0]):
            ids.append(cells[0])
    return ids


def problems(path: Path) -> list[str]:
    """Everything wrong with one chapter's registry (empty when it is sound)."""
    chapter = path.parent
    out = []
    try:
        data = load(path)
    except (ValueError, yaml.YAMLError) as exc:
        return [str(exc)]
    for field in ("paper", "title"):
        if not data.get(field):
            out.append(f"missing top-level field {field!r}")
    seen, covered = set(), set()
    cache: dict[Path, dict] = {}
    for n, c in enumerate(data["claims"]):
        where = f"claim {n} ({c.get('id', '?')})"
        for field in ("id", "claim", "where", "kind", "verdict", "evidence"):
            if not c.get(field):
                out.append(f"{where}: missing {field!r}")
        if c.get("id") in seen:
            out.append(f"{where}: duplicate id")
        seen.add(c.get("id"))
        if c.get("kind") not in KINDS:
            out.append(f"{where}: kind must be one of {KINDS}")
        if c.get("verdict") not in VERDICTS:
            out.append(f"{where}: verdict must be one of {sorted(VERDICTS)}")
        if c.get("verdict") != "reproduced" and not c.get("why"):
            out.append(f"{where}: a verdict other than 'reproduced' needs 'why'")
        if c.get("evidence") and _doc_path(chapter, c["evidence"]) is None:
            out.append(f"{where}: evidence {c['evidence']!r} is not a document of the chapter")
        for field in ("ours", "verdict_key"):
            ref = c.get(field)
            if not ref:
                continue
            doc, key = _split_ref(ref)
            nb = _doc_path(chapter, doc)
            if nb is None or nb.suffix != ".ipynb" or not key:
                out.append(f"{where}: {field} {ref!r} must be '<notebook>::<key>'")
                continue
            values = cache.setdefault(nb, glued(nb))
            if key not in values:
                out.append(f"{where}: {field} key {key!r} is not glued in {nb.name}")
            elif field == "ours" and c.get("kind") == "quantitative" and \
                    not _INTERVAL.search(values[key]):
                out.append(f"{where}: glued value {values[key]!r} has no [lo, hi] interval")
            elif field == "verdict_key" and values[key] != c.get("verdict"):
                out.append(f"{where}: the notebook's verdict {values[key]!r} disagrees "
                           f"with the registry's {c.get('verdict')!r}")
        if c.get("kind") == "quantitative" and not c.get("ours"):
            out.append(f"{where}: a quantitative claim needs 'ours' (a glued value and interval)")
        targets = c.get("targets") or []
        if not isinstance(targets, list):
            out.append(f"{where}: targets must be a list")
        else:
            covered.update(targets)
    index = chapter / "index.md"
    ids = target_ids(index) if index.is_file() else []
    if not ids:
        out.append(f"{index.name}: no 'Our targets' table with ids T1, T2, ... in its first column")
    for t in ids:
        if t not in covered:
            out.append(f"target {t} of the chapter's 'Our targets' is decided by no claim")
    for t in sorted(covered - set(ids)):
        out.append(f"claims name target {t}, which is not in the chapter's 'Our targets'")
    return out


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ").strip() if text else "—"


def render() -> str:
    """The scorecard in MyST markdown."""
    lines = []
    for path in registries():
        chapter = path.parent.name
        data = load(path)
        claims = data["claims"]
        count = Counter(c.get("verdict") for c in claims)
        summary = ", ".join(f"{count[v]} {VERDICTS[v][1]}" for v in VERDICTS if count[v])
        lines += [f"## {data['title']}", "",
                  f"{{cite:t}}`{data['paper']}` · chapter {{doc}}`{chapter}/index` · "
                  f"**{len(claims)} claims: {summary}**.", "",
                  "| claim (where in the paper) | paper | this book (95 % interval) "
                  "| verdict | evidence |",
                  "|:--|:--|:--|:--|:--|"]
        for c in claims:
            colour, label = VERDICTS.get(c.get("verdict"), ("secondary", "?"))
            ours = "—"
            if c.get("ours"):
                doc, key = _split_ref(c["ours"])
                ours = f"{{glue:text}}`{chapter}/{doc}.ipynb::{key}:s`"
            verdict = f"{{bdg-{colour}}}`{label}`"
            if c.get("why"):
                verdict += f" {_cell(c['why'])}"
            ev = c["evidence"]
            doc, _, label_ = ev.partition("#")
            link = f"{{ref}}`{label_}`" if label_ else f"{{doc}}`{chapter}/{doc}`"
            lines.append(f"| {_cell(c['claim'])} *({_cell(c.get('where'))})* | "
                         f"{_cell(c.get('paper_value'))} | {ours} | {verdict} | {link} |")
        lines.append("")
    return "\n".join(lines)


def _source_read(app, docname, source):
    if docname == "book/scorecard" and MARKER in source[0]:
        source[0] = source[0].replace(MARKER, render())


def setup(app):
    app.connect("source-read", _source_read)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
