"""The reproduction scorecard: every claim of every paper, its verdict **computed** from a
rule declared before the runs, generated from the chapters' claims registries at build time.

Each chapter keeps ``book/<chapter>/claims.yml``::

    paper: kim2007hpda                 # the paper's bibliography key
    title: HPDA particle filter        # short name used on the scorecard
    measures:                          # the primary measure of each claim type, declared once
      e: mean cardinality-and-position error over the scans of a run, averaged over runs
      paired-e: paired difference of e between two trackers on the same runs
    readings:                          # the chapter's open readings, declared before the runs
      - name: pi11
        parameter: existence prior Π11
        default: "0.99"                # the chapter's default reading, and why
        why: ...
        values:                        # every defensible value, with a one-line reason
          - {value: "0.98", why: ...}
          - {value: "0.99", why: ...}
          - {value: "0.995", why: ...}
    claims:
      - id: hpda-vs-nn                 # unique in the book
        claim: HPDA associates better than NN
        where: Sec. 2.4                # where the paper makes it
        kind: quantitative             # quantitative | qualitative | erratum
        paper_value: "e = 0.1"         # optional, quoted as printed
        measure: paired-e              # a key of the chapter's `measures`
        ours: 06-monte-carlo::key      # a glued "value [lo, hi]" (doc::key, doc in the chapter)
        rule: {type: direction, expect: below}
        why: ...                       # how the measure reads the claim (optional)
        evidence: 06-monte-carlo       # the notebook (or doc#label) with the evidence
        targets: [T1]                  # the chapter's "Our targets" rows this claim decides

A claim evaluated across readings names them (``readings: [pi11]``) and gives ``ours`` as a
mapping from each reading value (several readings: the values joined by ``", "`` in the order
named) to a glued reference; every cell of the grid must be present, either as a reference or
as ``{pending: why}`` (a cell not yet run, or run at a size this book does not accept, which
counts as undecided; a claim or an ``all`` part without readings may give its one ``ours``
that way too).  Readings whose values cannot all be crossed may be varied one at a time
instead (``varied: [memory, tsi]``): each of their non-default values adds one cell, the
grid's default cell with that one reading changed, labelled ``"<default cell>; memory: 1"``
(``"default readings; memory: 1"`` for a claim without ``readings``, whose default cell is
then ``"default readings"``); their interactions are not run, which the chapter says.  Every
reading of the chapter is accounted for by every quantitative claim with a rule: named in
``readings`` or ``varied``, listed in ``open_readings: {name: why}`` (it applies and has not been run: the verdict is at
most *undecided*, whatever the run cells say), or in ``not_applicable: {name: why}``.

Rules (numbers are in the units the glued value prints; a rule whose glued values end in
``%`` says ``unit: "%"``, and only such a rule does):

* ``{type: direction, expect: below|above, ref: r, margin: m}``: the claim holds when the
  whole interval lies below (above) ``ref`` (given explicitly: 0 for a difference, 1 or 100 %
  for a ratio), however small the gain; it fails when the whole interval lies on the other
  side.  An interval that contains ``ref`` is undecided (a tie).  A claim may declare an
  equivalence ``margin`` before its runs: then an interval that lies wholly inside
  ``[ref - m, ref + m]`` fails, a demonstrated equivalence refuting a "better than" claim.
  Equivalence is checked first, so a gain decided on many runs but smaller than the margin
  fails too (the equivalence-first rule of the SPRT chapter's cause factorial; without a
  margin nothing changes).  A claim that states a size ("20 % better") is a band, not a
  direction.
* ``{type: band, paper: p, lo: a, hi: b}`` (or ``tol: t`` for ``p ± t``, ``rel_tol: r`` for
  ``p (1 ± r)``; either end may be left open): *reproduced* when the whole interval lies in the
  band and contains ``p`` (or no ``p`` is given), *reproduced within tolerance* when it lies in
  the band without containing ``p``, *not reproduced* when it lies wholly outside, otherwise
  *undecided*.
* ``{all: [rule, ...]}``: every part (each with its own ``ours``) must hold; it fails when any
  part fails; otherwise undecided (a part within tolerance makes the whole within tolerance).

A cell may be *not applicable*: its glued value starts with ``not applicable`` (say
``"not applicable: neither tracker confirms a track in any run"``), computed in the notebook
from the runs, and only for a claim whose measure has a declared premise (the registry's
top-level ``premises: {measure: when a cell is not applicable}``; a glued "not applicable"
in any other claim is an error).  Such a cell is one whose runs lack what the measure
compares (no tracker tracks at all, say), so it can neither support nor refute the claim:
within a cell a failing part fails it, then an undecided part leaves it undecided, then a
not-applicable part makes it not applicable; across readings the not-applicable cells are
left out and the verdict is computed from the others, and a claim with no applicable cell
is *not testable* (*undecided* while a reading is still open).

Across readings a verdict stands only if it is the same in every reading; a mix of holding
and failing readings is *depends on reading* (the parameter is named); a mix of one outcome
and undecided readings is *undecided*.  A typed ``verdict`` is allowed for qualitative claims
and errata (with ``why``), and for a quantitative claim only as ``not testable`` (with
``why``) or as a copy that must agree with the computed one.  Every erratum has a ``class``:
``paper error`` (a substantive error of the authors), ``source-text defect`` (an OCR or
transcription defect of the text we work from), ``notation`` (a convention), or ``none``
(the printed form checks out, verdict ``reproduced``); an erratum of the first three classes
shows ``printed``, ``corrected`` and ``check``.  Only paper errors count against a paper, and
only confirmed ones: an erratum whose verdict is ``not testable`` (the print could not be
checked) is counted as *suspected*, whatever its class.

``book/scorecard.md`` ends with the marker ``<!-- scorecard -->``; at ``source-read`` this
extension replaces it with the counts and one table per paper, in MyST, whose "ours" cells
are cross-document glue pastes.  ``<!-- scorecard-counts -->`` (any page) becomes the
counts table, ``<!-- scorecard-counts: 000-hpda -->`` one chapter's; the role
``{verdict}`claim-id``` prints a claim's computed verdict badge anywhere.  ``python
book/_ext/scorecard.py --readme`` rewrites the counts block of ``README.md``.
:func:`load`, :func:`problems` and :func:`evaluate` are shared with
``tests/test_scorecard.py``.
"""
from __future__ import annotations

import ast
import itertools
import json
import re
import sys
from collections import Counter
from pathlib import Path

import yaml

BOOK = Path(__file__).resolve().parent.parent
ROOT = BOOK.parent
MARKER = "<!-- scorecard -->"
COUNTS_MARKER = re.compile(r"<!-- scorecard-counts(?::\s*([\w-]+))?\s*-->")
README_START, README_END = "<!-- scorecard-counts:start -->", "<!-- scorecard-counts:end -->"

# verdict -> (badge colour, label)
VERDICTS = {
    "reproduced": ("success", "reproduced"),
    "reproduced within tolerance": ("info", "within our tolerance"),
    "undecided": ("warning", "undecided"),
    "depends on reading": ("primary", "depends on reading"),
    "not reproduced": ("danger", "not reproduced"),
    "not testable": ("secondary", "not testable"),
}
TYPED_VERDICTS = ("reproduced", "reproduced within tolerance", "not reproduced", "not testable")
HOLDS = ("reproduced", "reproduced within tolerance")
KINDS = ("quantitative", "qualitative", "erratum")
ERRATUM_CLASSES = {
    "paper error": ("danger", "paper error"),
    "source-text defect": ("secondary", "source-text defect"),
    "notation": ("light", "notation"),
    "none": ("success", "printed form holds"),
}
RULE_TYPES = ("direction", "band")

_NUM = r"[-+−]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+−]?\d+)?"
_ESTIMATE = re.compile(rf"({_NUM})\s*\[\s*({_NUM})\s*,\s*({_NUM})\s*\]\s*(%)?")
_INTERVAL = re.compile(rf"\[\s*{_NUM}\s*,\s*{_NUM}\s*\]")
NO_INTERVAL = "(no interval)"   # trackcore.stats refuses an interval on (nearly) equal runs
NOT_APPLICABLE = "not applicable"   # a glued value starting so: the cell's premise is absent
NA = "not applicable"   # the verdict of a cell (never of a claim) whose premise is absent


# --------------------------------------------------------------------------- reading

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


def parse_estimate(text: str) -> tuple[float, float, float]:
    """``(value, lo, hi)`` of the first ``value [lo, hi]`` in a glued text, in its printed
    units (a trailing ``%`` is kept as percent)."""
    m = _ESTIMATE.search(str(text))
    if not m:
        raise ValueError(f"no 'value [lo, hi]' in {text!r}")
    v, lo, hi = (float(g.replace("−", "-")) for g in m.groups()[:3])
    if not lo <= hi:
        raise ValueError(f"interval ends out of order in {text!r}")
    return v, lo, hi


def _split_ref(ref: str):
    doc, _, key = str(ref).partition("::")
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


# --------------------------------------------------------------------------- deciding

def decide(rule: dict, est: tuple[float, float, float]) -> str:
    """The verdict of one rule on one ``(value, lo, hi)``."""
    _, lo, hi = est
    kind = rule.get("type")
    if kind == "direction":
        ref = float(rule["ref"])
        margin = rule.get("margin")
        if margin is not None and ref - float(margin) <= lo and hi <= ref + float(margin):
            return "not reproduced"   # equivalence shown inside the declared margin (first)
        below, above = hi < ref, lo > ref
        if below or above:
            holds = below if rule["expect"] == "below" else above
            return "reproduced" if holds else "not reproduced"
        return "undecided"
    if kind == "band":
        b_lo, b_hi = band_ends(rule)
        if b_lo <= lo and hi <= b_hi:
            p = rule.get("paper")
            if p is None or lo <= float(p) <= hi:
                return "reproduced"
            return "reproduced within tolerance"
        if hi < b_lo or lo > b_hi:
            return "not reproduced"
        return "undecided"
    raise ValueError(f"unknown rule type {kind!r}")


def band_ends(rule: dict) -> tuple[float, float]:
    p = rule.get("paper")
    lo, hi = rule.get("lo"), rule.get("hi")
    if rule.get("tol") is not None:
        lo, hi = float(p) - float(rule["tol"]), float(p) + float(rule["tol"])
    elif rule.get("rel_tol") is not None:
        a, b = float(p) * (1 - float(rule["rel_tol"])), float(p) * (1 + float(rule["rel_tol"]))
        lo, hi = min(a, b), max(a, b)
    return (-float("inf") if lo is None else float(lo),
            float("inf") if hi is None else float(hi))


def combine_all(verdicts: list[str]) -> str:
    """Every part must hold: a failing part fails the whole, then an undecided part leaves
    it undecided, then a part whose premise is absent makes it not applicable."""
    if "not reproduced" in verdicts:
        return "not reproduced"
    if "undecided" in verdicts:
        return "undecided"
    if NA in verdicts:
        return NA
    if "reproduced within tolerance" in verdicts:
        return "reproduced within tolerance"
    return "reproduced"


def combine_readings(verdicts: list[str]) -> str:
    """A verdict stands only if it is the same in every reading where the claim applies
    (cells whose premise is absent are left out; none applicable: not testable)."""
    verdicts = [v for v in verdicts if v != NA]
    if not verdicts:
        return "not testable"
    s = set(verdicts)
    if len(s) == 1:
        return verdicts[0]
    holds = bool(s & set(HOLDS))
    fails = "not reproduced" in s
    if holds and fails:
        return "depends on reading"
    if "undecided" in s:
        return "undecided"
    if s <= set(HOLDS):
        return "reproduced within tolerance"
    return "depends on reading"


DEFAULT_CELL = "default readings"


def _names(claim: dict, field: str) -> list[str]:
    names = claim.get(field) or []
    return [names] if isinstance(names, str) else list(names)


def reading_grid(data: dict, claim: dict) -> list[str]:
    """The labels of every cell of a claim's readings grid ([""] without readings).

    The readings named in ``readings`` span a full grid; those named in ``varied`` are
    varied one at a time from the grid's default cell (every other reading at its
    default), each of their other values adding the cell ``"<default cell>; <name>:
    <value>"`` (``"default readings"`` stands for the default cell of a claim with
    ``varied`` and no ``readings``)."""
    names = _names(claim, "readings")
    varied = _names(claim, "varied")
    decl = {r.get("name"): r for r in data.get("readings") or []}
    axes = []
    for n in names + varied:
        if n not in decl:
            raise ValueError(f"reading {n!r} is not declared in the chapter's readings")
    for n in names:
        axes.append([str(v["value"]) for v in decl[n]["values"]])
    if not axes:
        grid = [DEFAULT_CELL] if varied else [""]
    else:
        grid = [", ".join(cell) for cell in itertools.product(*axes)]
    base = ", ".join(str(decl[n]["default"]) for n in names) if names else DEFAULT_CELL
    for n in varied:
        if n in names:
            raise ValueError(f"reading {n!r} is both in the grid and varied alone")
        grid += [f"{base}; {n}: {v['value']}" for v in decl[n]["values"]
                 if str(v["value"]) != str(decl[n]["default"])]
    return grid


def default_label(data: dict, claim: dict) -> str:
    names = _names(claim, "readings")
    if not names and _names(claim, "varied"):
        return DEFAULT_CELL
    decl = {r.get("name"): r for r in data.get("readings") or []}
    return ", ".join(str(decl[n]["default"]) for n in names)


def _ref_for(ours, label: str):
    if isinstance(ours, dict) and not _is_pending(ours):
        return ours.get(label)
    return ours


class _Glue:
    """Glued values of a chapter's notebooks, read once."""

    def __init__(self, chapter: Path):
        self.chapter = chapter
        self.cache: dict[Path, dict] = {}

    def text(self, ref: str) -> str:
        doc, key = _split_ref(ref)
        nb = _doc_path(self.chapter, doc)
        if nb is None or nb.suffix != ".ipynb" or not key:
            raise ValueError(f"{ref!r} must be '<notebook>::<key>' of the chapter")
        if nb not in self.cache:  # (setdefault would re-read the notebook at every call)
            self.cache[nb] = glued(nb)
        values = self.cache[nb]
        if key not in values:
            raise ValueError(f"key {key!r} is not glued in {nb.name}")
        return values[key]


def _rule_parts(claim: dict) -> list[tuple[dict, object]]:
    rule = claim["rule"]
    if "all" in rule:
        return [(p, p.get("ours")) for p in rule["all"]]
    return [(rule, claim.get("ours"))]


def evaluate(data: dict, claim: dict, glue: _Glue) -> dict:
    """The computed verdict of one claim: ``{"verdict", "per_reading", "holds", "cells",
    "readings"}``; typed verdicts are passed through."""
    names = _names(claim, "readings") + _names(claim, "varied")
    if not claim.get("rule"):
        v = claim.get("verdict")
        return {"verdict": v, "per_reading": {}, "holds": None, "cells": 0,
                "readings": names, "computed": False}
    if claim.get("pending"):
        return {"verdict": "undecided", "per_reading": {}, "holds": None, "cells": 0,
                "readings": names, "computed": True, "pending": claim["pending"]}
    per, pending = {}, 0
    for label in reading_grid(data, claim):
        parts, waiting = [], False
        for rule, ours in _rule_parts(claim):
            ref = _ref_for(ours, label)
            if ref is None:
                raise ValueError(f"no 'ours' for reading {label!r}")
            if _is_pending(ref):
                parts.append("undecided")
                waiting = True
                continue
            text = glue.text(ref)
            if is_not_applicable(text):
                if not premise(data, claim):
                    raise ValueError(f"{ref!r} is glued {text!r}, but the measure "
                                     f"{claim.get('measure')!r} declares no premise")
                parts.append(NA)
            elif NO_INTERVAL in text and not _ESTIMATE.search(text):
                parts.append("undecided")   # the runs are (nearly) all equal: no interval
            else:
                parts.append(decide(rule, parse_estimate(text)))
        pending += waiting
        per[label] = combine_all(parts)
    verdicts = list(per.values())
    run = combine_readings(verdicts)
    open_ = dict(claim.get("open_readings") or {})
    verdict = run
    if open_ and run in HOLDS + ("not reproduced", "not testable"):
        verdict = "undecided"
    return {"verdict": verdict, "per_reading": per,
            "holds": sum(v in HOLDS for v in verdicts), "cells": len(verdicts),
            "not_applicable_cells": sum(v == NA for v in verdicts),
            "pending_cells": pending, "open_readings": open_, "run_verdict": run,
            "readings": names, "computed": True}


def is_not_applicable(text) -> bool:
    """Whether a glued value says its cell's premise is absent."""
    return str(text).strip().lower().startswith(NOT_APPLICABLE)


def premise(data: dict, claim: dict) -> str | None:
    """The declared premise of a claim's measure (``None`` if it declares none)."""
    prem = data.get("premises") or {}
    return prem.get(claim.get("measure")) if isinstance(prem, dict) else None


def _is_pending(ref) -> bool:
    return isinstance(ref, dict) and set(ref) == {"pending"}


_CACHE: dict = {}


def _stamp() -> tuple:
    files = registries() + sorted(BOOK.glob("0*/*.ipynb"))
    return tuple((str(p), p.stat().st_mtime_ns) for p in files)


def evaluate_all() -> dict[str, dict]:
    """Every claim of the book, by id: its chapter, record and evaluation (cached until a
    registry or notebook changes)."""
    stamp = _stamp()
    if _CACHE.get("stamp") != stamp:
        _CACHE.update(stamp=stamp, value=_evaluate_all())
    return _CACHE["value"]


def _evaluate_all() -> dict[str, dict]:
    out = {}
    for path in registries():
        data = load(path)
        glue = _Glue(path.parent)
        for c in data["claims"]:
            try:
                ev = evaluate(data, c, glue)
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{path.parent.name}/claims.yml, claim {c.get('id')!r}: "
                                 f"cannot compute the verdict: {exc}") from exc
            out[c["id"]] = {"chapter": path.parent.name, "claim": c, "eval": ev,
                            "data": data}
    return out


# --------------------------------------------------------------------------- checking

def _check_rule(rule, where: str, ours_needed: bool) -> list[str]:
    out = []
    if not isinstance(rule, dict):
        return [f"{where}: rule must be a mapping"]
    if "all" in rule:
        parts = rule["all"]
        if not isinstance(parts, list) or len(parts) < 2:
            return [f"{where}: rule 'all' needs a list of at least two parts"]
        for k, p in enumerate(parts):
            if not isinstance(p, dict) or not p.get("ours"):
                out.append(f"{where}: part {k} of 'all' needs its own 'ours'")
            out += _check_rule({k2: v for k2, v in (p or {}).items() if k2 != "ours"},
                               f"{where} part {k}", False)
        return out
    kind = rule.get("type")
    if kind not in RULE_TYPES:
        return [f"{where}: rule type must be one of {RULE_TYPES}, got {kind!r}"]
    numeric = ("ref", "margin", "paper", "lo", "hi", "tol", "rel_tol")
    for f in numeric:
        if f in rule and not isinstance(rule[f], (int, float)) or isinstance(rule.get(f), bool):
            out.append(f"{where}: rule field {f!r} must be a number")
    if rule.get("unit") not in (None, "%"):
        out.append(f"{where}: rule unit must be '%' or absent")
    if out:
        return out
    if kind == "direction":
        if rule.get("expect") not in ("below", "above"):
            out.append(f"{where}: a direction rule needs expect: below | above")
        if rule.get("ref") is None:
            out.append(f"{where}: a direction rule needs its reference 'ref' (0 for a "
                       "difference, 1 or 100 for a ratio)")
        if rule.get("margin") is not None and rule["margin"] <= 0:
            out.append(f"{where}: margin must be positive")
        extra = set(rule) - {"type", "expect", "ref", "margin", "unit"}
    else:
        if rule.get("tol") is not None or rule.get("rel_tol") is not None:
            if rule.get("paper") is None:
                out.append(f"{where}: tol / rel_tol need the paper's value 'paper'")
            if rule.get("lo") is not None or rule.get("hi") is not None:
                out.append(f"{where}: give either lo/hi or tol/rel_tol, not both")
        elif rule.get("lo") is None and rule.get("hi") is None:
            out.append(f"{where}: a band rule needs lo, hi, tol or rel_tol")
        if not out:
            lo, hi = band_ends(rule)
            if lo > hi:
                out.append(f"{where}: band [{lo}, {hi}] is empty")
        extra = set(rule) - {"type", "paper", "lo", "hi", "tol", "rel_tol", "unit"}
    if extra:
        out.append(f"{where}: unknown rule fields {sorted(extra)}")
    return out


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
    measures = data.get("measures") or {}
    if not isinstance(measures, dict):
        out.append("measures must be a mapping name -> description")
        measures = {}
    premises = data.get("premises") or {}
    if not isinstance(premises, dict):
        out.append("premises must be a mapping measure -> when a cell is not applicable")
        premises = {}
    for m, why in premises.items():
        if m not in measures:
            out.append(f"premises names {m!r}, not a declared measure")
        if not why or not isinstance(why, str):
            out.append(f"premise of {m!r} needs its text")
    readings = data.get("readings") or []
    if not isinstance(readings, list):
        out.append("readings must be a list")
        readings = []
    for r in readings:
        rn = r.get("name", "?") if isinstance(r, dict) else "?"
        if not isinstance(r, dict):
            out.append("each reading must be a mapping")
            continue
        for f in ("name", "parameter", "default", "why", "values"):
            if not r.get(f):
                out.append(f"reading {rn}: missing {f!r}")
        vals = r.get("values") or []
        labels = [str(v.get("value")) for v in vals if isinstance(v, dict)]
        if len(labels) < 2:
            out.append(f"reading {rn}: needs at least two values")
        for v in vals:
            if not isinstance(v, dict) or v.get("value") is None or not v.get("why"):
                out.append(f"reading {rn}: every value needs 'value' and a one-line 'why'")
        if r.get("default") is not None and str(r["default"]) not in labels:
            out.append(f"reading {rn}: default {r['default']!r} is not one of its values")
    seen, covered = set(), set()
    glue = _Glue(chapter)
    for n, c in enumerate(data["claims"]):
        where = f"claim {n} ({c.get('id', '?')})"
        for field in ("id", "claim", "where", "kind", "evidence"):
            if not c.get(field):
                out.append(f"{where}: missing {field!r}")
        if c.get("id") in seen:
            out.append(f"{where}: duplicate id")
        seen.add(c.get("id"))
        kind = c.get("kind")
        if kind not in KINDS:
            out.append(f"{where}: kind must be one of {KINDS}")
        typed = c.get("verdict")
        if typed is not None and typed not in TYPED_VERDICTS:
            out.append(f"{where}: a typed verdict must be one of {TYPED_VERDICTS}")
        if c.get("evidence") and _doc_path(chapter, c["evidence"]) is None:
            out.append(f"{where}: evidence {c['evidence']!r} is not a document of the chapter")
        # quantitative: a declared measure and rule, or a reasoned "not testable"
        if kind == "quantitative":
            if c.get("rule"):
                if c.get("measure") not in measures:
                    out.append(f"{where}: measure {c.get('measure')!r} is not declared in "
                               "the chapter's measures")
                out += _check_rule(c["rule"], where, True)
                if c.get("pending"):
                    if c.get("ours") or "all" in c["rule"]:
                        out.append(f"{where}: 'pending' means no estimate yet: drop 'ours'")
                    if typed is not None:
                        out.append(f"{where}: a pending claim is undecided: drop 'verdict'")
                elif "all" not in c["rule"] and not c.get("ours"):
                    out.append(f"{where}: a rule needs 'ours' (a glued value and interval), "
                               "or 'pending' saying which estimate is still to be computed")
            elif typed != "not testable":
                out.append(f"{where}: a quantitative claim needs a 'rule' (or the typed "
                           "verdict 'not testable' with 'why')")
            elif not c.get("why"):
                out.append(f"{where}: 'not testable' needs 'why'")
        else:
            if c.get("rule"):
                out.append(f"{where}: only quantitative claims take a rule")
            if typed is None:
                out.append(f"{where}: a {kind} claim needs a typed 'verdict'")
            elif typed != "reproduced" and not c.get("why"):
                out.append(f"{where}: a verdict other than 'reproduced' needs 'why'")
        if kind == "erratum":
            cls = c.get("class")
            if cls not in ERRATUM_CLASSES:
                out.append(f"{where}: an erratum needs class, one of {sorted(ERRATUM_CLASSES)}")
            elif cls == "none" and typed != "reproduced":
                out.append(f"{where}: class 'none' (printed form holds) needs verdict "
                           "'reproduced'")
            elif cls != "none":
                if typed == "reproduced":
                    out.append(f"{where}: class {cls!r} contradicts verdict 'reproduced'")
                for f in ("printed", "corrected", "check"):
                    if not c.get(f):
                        out.append(f"{where}: an erratum of class {cls!r} needs {f!r}")
        # readings
        names = _names(c, "readings") + _names(c, "varied")
        if names and not c.get("rule"):
            out.append(f"{where}: readings need a rule")
        if names:
            try:
                grid = reading_grid(data, c)
            except ValueError as exc:
                out.append(f"{where}: {exc}")
                grid = []
            refs = [c.get("ours")] + [p.get("ours") for p in c["rule"].get("all", [])] \
                if isinstance(c.get("rule"), dict) else []
            for ours in refs:
                if ours is None:
                    continue
                if not isinstance(ours, dict):
                    out.append(f"{where}: with readings, 'ours' maps each reading to a ref")
                    continue
                keys = {str(k) for k in ours}
                if keys != set(grid):
                    out.append(f"{where}: 'ours' must cover the readings grid exactly: "
                               f"missing {sorted(set(grid) - keys)}, extra "
                               f"{sorted(keys - set(grid))}")
        elif isinstance(c.get("ours"), dict) and not _is_pending(c["ours"]):
            out.append(f"{where}: 'ours' is a mapping but the claim names no readings")
        # every reading of the chapter is named, open or not applicable, with a reason
        declared = [r.get("name") for r in readings if isinstance(r, dict)]
        open_ = c.get("open_readings") or {}
        na = c.get("not_applicable") or {}
        for field, m in (("open_readings", open_), ("not_applicable", na)):
            if not isinstance(m, dict):
                out.append(f"{where}: {field} must map a reading's name to why")
                continue
            for name, why in m.items():
                if name not in declared:
                    out.append(f"{where}: {field} names {name!r}, not a declared reading")
                if not why or not isinstance(why, str):
                    out.append(f"{where}: {field} {name!r} needs a one-line why")
                if name in names:
                    out.append(f"{where}: reading {name!r} is both run and in {field}")
        if isinstance(open_, dict) and isinstance(na, dict):
            for name in set(open_) & set(na):
                out.append(f"{where}: reading {name!r} is both open and not applicable")
            if kind == "quantitative" and c.get("rule") and not c.get("pending"):
                for name in declared:
                    if name not in names and name not in open_ and name not in na:
                        out.append(f"{where}: reading {name!r} is not accounted for: name "
                                   "it in readings, open_readings or not_applicable")
        # every glued reference resolves; quantitative ones carry one interval, in the
        # units the rule declares
        refs = []
        for field in ("ours", "verdict_key"):
            v = c.get(field)
            if isinstance(v, dict) and not _is_pending(v):
                refs += [(field, r, c.get("rule")) for r in v.values()]
            elif v:
                refs.append((field, v, c.get("rule")))
        if isinstance(c.get("rule"), dict):
            for p in c["rule"].get("all", []) or []:
                v = p.get("ours") if isinstance(p, dict) else None
                many = isinstance(v, dict) and not _is_pending(v)
                refs += [("ours", r, p) for r in (v.values() if many else [v]) if r]
        for field, ref, rule in refs:
            if _is_pending(ref):
                if not isinstance(ref["pending"], str) or not ref["pending"].strip():
                    out.append(f"{where}: a pending cell needs its why")
                continue
            if isinstance(ref, dict):
                out.append(f"{where}: a cell is a glued reference or {{pending: why}}")
                continue
            try:
                text = glue.text(ref)
            except ValueError as exc:
                out.append(f"{where}: {field}: {exc}")
                continue
            if field == "ours" and c.get("rule"):
                if is_not_applicable(text):
                    if not premise(data, c):
                        out.append(f"{where}: glued value {text!r} says not applicable, but "
                                   f"the measure {c.get('measure')!r} declares no premise "
                                   "(the registry's premises)")
                    continue
                found = _ESTIMATE.findall(text)
                if not found and NO_INTERVAL in text:
                    continue
                if not found:
                    out.append(f"{where}: glued value {text!r} has no 'value [lo, hi]'")
                elif len(found) > 1:
                    out.append(f"{where}: glued value {text!r} holds more than one "
                               "'value [lo, hi]': glue the one the rule decides on")
                elif isinstance(rule, dict) and "all" not in rule:
                    pct = bool(found[0][3])
                    if pct != (rule.get("unit") == "%"):
                        out.append(f"{where}: glued value {text!r} is "
                                   f"{'in' if pct else 'not in'} percent but the rule "
                                   f"{'lacks' if pct else 'declares'} unit: '%'")
        # the computed verdict, and agreement with any typed or notebook verdict
        if c.get("rule") and not c.get("pending") and \
                not any(p.startswith(where) for p in out):
            try:
                ev = evaluate(data, c, glue)
            except (KeyError, TypeError, ValueError) as exc:
                out.append(f"{where}: cannot compute the verdict: {exc}")
            else:
                if typed is not None and typed != ev["verdict"]:
                    out.append(f"{where}: typed verdict {typed!r} disagrees with the rule's "
                               f"{ev['verdict']!r}")
                if c.get("verdict_key"):
                    try:
                        nbv = glue.text(c["verdict_key"])
                    except ValueError:
                        nbv = None
                    if nbv is not None and nbv != ev["verdict"]:
                        out.append(f"{where}: the notebook's verdict {nbv!r} disagrees with "
                                   f"the rule's {ev['verdict']!r}")
        elif c.get("verdict_key") and typed is not None:
            try:
                nbv = glue.text(c["verdict_key"])
            except ValueError:
                nbv = None
            if nbv is not None and nbv != typed:
                out.append(f"{where}: the notebook's verdict {nbv!r} disagrees with the "
                           f"registry's {typed!r}")
        if c.get("rule") and c.get("measure") is None:
            out.append(f"{where}: a rule needs its declared 'measure'")
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


# --------------------------------------------------------------------------- counting

COUNT_COLUMNS = ("reproduced", "reproduced within tolerance", "undecided",
                 "depends on reading", "not reproduced", "not testable")
ERRATA_COLUMNS = ("paper error", "suspected", "source-text defect", "notation", "none")


def final_verdict(entry: dict) -> str | None:
    return entry["eval"]["verdict"]


def counts(evaluated: dict | None = None) -> dict[str, dict]:
    """Per chapter and overall: claims (quantitative and qualitative) by verdict, errata by
    class."""
    evaluated = evaluate_all() if evaluated is None else evaluated
    out: dict[str, dict] = {}
    for cid, e in evaluated.items():
        for key in (e["chapter"], "all"):
            row = out.setdefault(key, {"title": e["data"]["title"] if key != "all" else
                                       "All five papers", "claims": Counter(),
                                       "errata": Counter(), "n": 0})
            row["n"] += 1
            if e["claim"].get("kind") == "erratum":
                suspected = e["claim"].get("verdict") == "not testable"
                row["errata"]["suspected" if suspected else e["claim"].get("class")] += 1
            else:
                row["claims"][final_verdict(e)] += 1
    return out


def counts_markdown(chapter: str | None = None, evaluated: dict | None = None,
                    links: bool = True) -> str:
    """The counts as a MyST/GitHub table (one chapter, or every paper and the total)."""
    table = counts(evaluated)
    keys = [chapter] if chapter else [k for k in sorted(table) if k != "all"] + ["all"]
    head = ("| paper | claims | reproduced | within tolerance | undecided | depends on reading "
            "| not reproduced | not testable | errata: paper errors | suspected (print "
            "unchecked) | source-text defects | notation | printed forms confirmed |")
    lines = [head, "|:--" + "|--:" * 12 + "|"]
    for k in keys:
        row = table[k]
        name = row["title"]
        if links and k != "all":
            name = f"{{doc}}`{row['title']} </book/{k}/index>`" if links == "doc" \
                else row["title"]
        if k == "all":
            name = f"**{name}**"
        cells = [str(row["n"])] + [str(row["claims"][v]) for v in COUNT_COLUMNS] + \
                [str(row["errata"][v]) for v in ERRATA_COLUMNS]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# --------------------------------------------------------------------------- rendering

def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ").strip() if text else "—"


def badge(verdict: str | None) -> str:
    colour, label = VERDICTS.get(verdict, ("secondary", "?"))
    return f"{{bdg-{colour}}}`{label}`"


def _verdict_cell(e: dict) -> str:
    c, ev = e["claim"], e["eval"]
    if c.get("kind") == "erratum":
        colour, label = ERRATUM_CLASSES.get(c.get("class"), ("secondary", "?"))
        if c.get("class") not in (None, "none") and c.get("verdict") == "not testable":
            label += " (suspected)"
        return f"{{bdg-{colour}}}`{label}`"
    out = badge(ev["verdict"])
    if ev.get("cells", 0) > 1:
        names = ", ".join(ev["readings"])
        na = ev.get("not_applicable_cells", 0)
        out += f" holds in {ev['holds']} of {ev['cells'] - na} readings ({names})"
        if na:
            out += (f"; {na} not applicable ({_cell(premise(e['data'], c))})")
        if ev.get("pending_cells"):
            out += f", {ev['pending_cells']} still to run"
    elif ev.get("pending"):
        out += f" estimate pending: {_cell(ev['pending'])}"
    if ev.get("open_readings"):
        out += (f"; {VERDICTS[ev['run_verdict']][1]} on the readings run, "
                f"still to run: {_cell(', '.join(ev['open_readings']))}")
    return out


def render() -> str:
    """The scorecard in MyST markdown: the counts, then one table per paper."""
    evaluated = evaluate_all()
    lines = ["## Counts", "", counts_markdown(evaluated=evaluated, links="doc"), ""]
    for path in registries():
        chapter = path.parent.name
        data = load(path)
        entries = [evaluated[c["id"]] for c in data["claims"]]
        lines += [f"## {data['title']}", "",
                  f"{{cite:t}}`{data['paper']}` · chapter {{doc}}`{chapter}/index`", "",
                  "| verdict | claim (where in the paper) | paper | this book (95 % interval) "
                  "| evidence and reading |",
                  "|:--|:--|:--|:--|:--|"]
        for e in entries:
            c = e["claim"]
            ours = "—"
            ref = c.get("ours")
            if isinstance(ref, dict):
                ref = ref.get(default_label(data, c))
            if _is_pending(ref):
                ours = f"still to run: {_cell(ref['pending'])}"
            elif ref:
                doc, key = _split_ref(ref)
                ours = f"{{glue:text}}`{chapter}/{doc}.ipynb::{key}:s`"
            ev = c["evidence"]
            doc, _, label_ = ev.partition("#")
            link = f"{{ref}}`{label_}`" if label_ else f"{{doc}}`{chapter}/{doc}`"
            why = f" {_cell(c['why'])}" if c.get("why") else ""
            if c.get("kind") == "erratum" and c.get("class") not in (None, "none"):
                why = (f" Printed: {_cell(c.get('printed'))}. Corrected: "
                       f"{_cell(c.get('corrected'))}. Check: {_cell(c.get('check'))}.{why}")
            # the explanation is folded (a reader opens it; printing opens every fold)
            fold = f" <details><summary>why</summary>{why}</details>" if why else ""
            lines.append(f"| {_verdict_cell(e)} | {_cell(c['claim'])} "
                         f"*({_cell(c.get('where'))})* | {_cell(c.get('paper_value'))} | "
                         f"{ours} | {link}.{fold} |")
        lines.append("")
    return "\n".join(lines)


def _source_read(app, docname, source):
    text = source[0]
    if docname == "book/scorecard" and MARKER in text:
        text = text.replace(MARKER, render())
    if COUNTS_MARKER.search(text):
        evaluated = evaluate_all()
        text = COUNTS_MARKER.sub(
            lambda m: counts_markdown(m.group(1), evaluated, links="doc"), text)
    source[0] = text


def _verdict_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    from docutils import nodes
    cid = text.strip()
    e = evaluate_all().get(cid)
    if e is None:
        msg = inliner.reporter.error(f"verdict: no claim with id {cid!r}", line=lineno)
        return [inliner.problematic(rawtext, rawtext, msg)], [msg]
    colour, label = VERDICTS.get(final_verdict(e), ("secondary", "?"))
    node = nodes.inline(rawtext, label, classes=["sd-sphinx-override", "sd-badge",
                                                 f"sd-bg-{colour}", f"sd-bg-text-{colour}"])
    return [node], []


def setup(app):
    app.connect("source-read", _source_read)
    app.add_role("verdict", _verdict_role)
    return {"version": "2.0", "parallel_read_safe": True, "parallel_write_safe": True}


# --------------------------------------------------------------------------- README

def readme_block() -> str:
    return (f"{README_START}\n{counts_markdown(links=False)}\n{README_END}")


def update_readme(path: Path = ROOT / "README.md") -> bool:
    """Rewrite the counts block of the README; True when it changed."""
    text = path.read_text(encoding="utf-8")
    pat = re.compile(re.escape(README_START) + ".*?" + re.escape(README_END), re.S)
    if not pat.search(text):
        raise ValueError(f"{path}: no {README_START} ... {README_END} block")
    new = pat.sub(lambda m: readme_block(), text)
    if new != text:
        path.write_text(new, encoding="utf-8")
    return new != text


if __name__ == "__main__":
    if sys.argv[1:] == ["--readme"]:
        print("README.md updated" if update_readme() else "README.md already current")
    else:
        print(counts_markdown(links=False))
