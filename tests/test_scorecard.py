"""The claims registries behind the scorecard page (``book/_ext/scorecard.py``).

Every chapter has ``claims.yml``; every record has a place in the paper, a verdict from the
allowed set and, where the verdict rests on a number, a glued value with its interval that
the chapter's notebook stored; every row of the chapter's *Our targets* is decided by a claim.
"""
import json
import sys

import pytest
import yaml

from _book import BOOK, chapter_indexes, rel

sys.path.insert(0, str(BOOK / "_ext"))
import scorecard  # noqa: E402

CHAPTERS = [p.parent for p in chapter_indexes()]


@pytest.mark.parametrize("chapter", CHAPTERS, ids=[c.name for c in CHAPTERS])
def test_registry_is_complete_and_consistent(chapter):
    path = chapter / "claims.yml"
    assert path.is_file(), f"{rel(path)} is missing"
    problems = scorecard.problems(path)
    assert not problems, f"{rel(path)}:\n" + "\n".join(problems)


def test_claim_ids_are_unique_across_the_book():
    ids = [c["id"] for p in scorecard.registries() for c in scorecard.load(p)["claims"]]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    assert not dup, dup


def test_scorecard_page_renders_every_registry():
    text = scorecard.render()
    for p in scorecard.registries():
        data = scorecard.load(p)
        assert f"## {data['title']}" in text
        assert text.count(f"`{p.parent.name}/") >= len(data["claims"])


# --------------------------------------------------------------------------- the rule engine

EST = scorecard.parse_estimate


@pytest.mark.parametrize("text, expected", [
    ("0.094 [0.071, 0.118]", (0.094, 0.071, 0.118)),
    ("−0.036 [−0.056, −0.024]", (-0.036, -0.056, -0.024)),
    ("92.5 [90.8, 94.0] %", (92.5, 90.8, 94.0)),
    ("e = 1.5e-3 [1e-3, 2.0e-3] (n = 100)", (1.5e-3, 1e-3, 2e-3)),
    ("+0.038 [+0.038, +0.113]", (0.038, 0.038, 0.113)),
])
def test_parse_estimate_reads_the_first_interval(text, expected):
    assert EST(text) == pytest.approx(expected)


@pytest.mark.parametrize("text", ["0.3", "reproduced", "[1, 2]", "3 [2, 1]"])
def test_parse_estimate_rejects_text_without_a_sound_interval(text):
    with pytest.raises(ValueError):
        EST(text)


@pytest.mark.parametrize("est, rule, verdict", [
    # "A below B" on a paired difference
    ((-0.04, -0.06, -0.02), {"type": "direction", "expect": "below", "ref": 0}, "reproduced"),
    ((0.04, 0.02, 0.06), {"type": "direction", "expect": "below", "ref": 0},
     "not reproduced"),
    ((0.01, -0.01, 0.03), {"type": "direction", "expect": "below", "ref": 0}, "undecided"),
    ((0.0, 0.0, 0.0), {"type": "direction", "expect": "below", "ref": 0}, "undecided"),
    ((1.3, 1.1, 1.5), {"type": "direction", "expect": "above", "ref": 1}, "reproduced"),
    # a narrow tie is still a tie: never a refutation of a "better than" claim ...
    ((0.001, -0.004, 0.006), {"type": "direction", "expect": "below", "ref": 0},
     "undecided"),
    # ... unless an equivalence margin was declared and the interval lies inside it
    ((0.001, -0.004, 0.006), {"type": "direction", "expect": "below", "ref": 0,
                              "margin": 0.01}, "not reproduced"),
    ((0.001, -0.02, 0.006), {"type": "direction", "expect": "below", "ref": 0,
                             "margin": 0.01}, "undecided"),
    # equivalence is checked first: a decided improvement inside the declared margin is no
    # improvement (the SPRT chapter's cause rule, the same in its helper effect_verdict) ...
    ((-0.006, -0.010, -0.002), {"type": "direction", "expect": "below", "ref": 0,
                                "margin": 0.02}, "not reproduced"),
    ((0.006, 0.002, 0.010), {"type": "direction", "expect": "below", "ref": 0,
                             "margin": 0.02}, "not reproduced"),
    # ... and one that reaches beyond the margin holds
    ((-0.02, -0.03, -0.002), {"type": "direction", "expect": "below", "ref": 0,
                              "margin": 0.02}, "reproduced"),
    ((0.02, 0.002, 0.03), {"type": "direction", "expect": "below", "ref": 0,
                           "margin": 0.02}, "not reproduced"),
    # without a margin a small decided gain holds
    ((-0.006, -0.010, -0.002), {"type": "direction", "expect": "below", "ref": 0},
     "reproduced"),
    # bands around the paper's number
    ((0.10, 0.08, 0.12), {"type": "band", "paper": 0.1, "tol": 0.05}, "reproduced"),
    ((0.13, 0.11, 0.14), {"type": "band", "paper": 0.1, "tol": 0.05},
     "reproduced within tolerance"),
    ((0.3, 0.2, 0.4), {"type": "band", "paper": 0.1, "tol": 0.05}, "not reproduced"),
    ((0.14, 0.12, 0.17), {"type": "band", "paper": 0.1, "tol": 0.05}, "undecided"),
    ((0.2, 0.1, 0.25), {"type": "band", "hi": 0.3}, "reproduced"),
    ((98.0, 97.0, 99.0), {"type": "band", "paper": 98, "rel_tol": 0.02}, "reproduced"),
])
def test_decide(est, rule, verdict):
    assert scorecard.decide(rule, est) == verdict


def test_direction_with_margin_is_the_sprt_cause_rule():
    """The registry's direction rule with a margin and the SPRT chapter's effect_verdict
    (06-sensitivity) decide every interval alike: equivalence first, then direction."""
    from trackcore.scenarios._sprt_book import effect_verdict
    from trackcore.stats import Estimate

    as_registry = {"none": "not reproduced", "hurts": "not reproduced",
                   "helps": "reproduced", "undecided": "undecided"}
    ends = (-0.05, -0.02, -0.01, -0.001, 0.0, 0.001, 0.01, 0.02, 0.05)
    for lo in ends:
        for hi in ends:
            if hi < lo:
                continue
            est = Estimate((lo + hi) / 2, lo, hi, 0.95, 5000, "t")
            for expect in ("above", "below"):
                rule = {"type": "direction", "expect": expect, "ref": 0, "margin": 0.02}
                got = scorecard.decide(rule, (est.value, lo, hi))
                assert got == as_registry[effect_verdict(est, 0.02, expect)], (lo, hi, expect)


def test_combinations():
    assert scorecard.combine_all(["reproduced", "reproduced"]) == "reproduced"
    assert scorecard.combine_all(["reproduced", "undecided"]) == "undecided"
    assert scorecard.combine_all(["undecided", "not reproduced"]) == "not reproduced"
    assert scorecard.combine_all(["reproduced", "reproduced within tolerance"]) == \
        "reproduced within tolerance"
    r = scorecard.combine_readings
    assert r(["reproduced"] * 3) == "reproduced"
    assert r(["reproduced", "not reproduced", "reproduced"]) == "depends on reading"
    assert r(["reproduced", "undecided"]) == "undecided"
    assert r(["not reproduced", "undecided"]) == "undecided"
    assert r(["reproduced", "reproduced within tolerance"]) == "reproduced within tolerance"


def _nb(path, glued):
    """A minimal notebook whose outputs glue the given text values."""
    outputs = [{"output_type": "display_data", "data": {"text/plain": repr(v)},
                "metadata": {"scrapbook": {"name": k, "mime_prefix": ""}}}
               for k, v in glued.items()]
    nb = {"cells": [{"cell_type": "code", "source": "", "metadata": {}, "outputs": outputs,
                     "execution_count": 1}], "metadata": {}, "nbformat": 4,
          "nbformat_minor": 5}
    path.write_text(json.dumps(nb), encoding="utf-8")


def _registry(tmp_path, claims, readings=None, premises=None):
    ch = tmp_path / "000-x"
    ch.mkdir()
    (ch / "index.md").write_text("# X\n\n## Our targets\n\n| id | t |\n|--|--|\n| T1 | a |\n",
                                 encoding="utf-8")
    _nb(ch / "nb.ipynb", {"d98": "-0.03 [-0.05, -0.01]", "d99": "0.01 [-0.01, 0.02]",
                          "d995": "-0.04 [-0.06, -0.02]", "up": "0.02 [0.01, 0.03]",
                          "txt": "no interval", "v": "reproduced",
                          "pct": "12.0 [10.0, 14.0] %", "two": "1 [0, 2] and 3 [2, 4]",
                          "flat": "0 (no interval)",
                          "na": "not applicable: neither tracker confirms a track"})
    data = {"paper": "p", "title": "X", "measures": {"pd": "paired difference"},
            "readings": readings or [], "claims": claims}
    if premises is not None:
        data["premises"] = premises
    path = ch / "claims.yml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True), encoding="utf-8")
    return path


def _claim(**kw):
    c = {"id": "c1", "claim": "A beats B", "where": "Sec. 1", "kind": "quantitative",
         "evidence": "nb", "measure": "pd", "ours": "nb::d98",
         "rule": {"type": "direction", "expect": "below", "ref": 0}, "targets": ["T1"]}
    c.update(kw)
    return {k: v for k, v in c.items() if v is not None}


PI = [{"name": "pi", "parameter": "prior", "default": "0.99", "why": "the scenario's lives",
       "values": [{"value": "0.98", "why": "a"}, {"value": "0.99", "why": "b"},
                  {"value": "0.995", "why": "c"}]}]


def test_a_sound_registry_passes_and_computes(tmp_path):
    path = _registry(tmp_path, [_claim()])
    assert scorecard.problems(path) == []
    data = scorecard.load(path)
    ev = scorecard.evaluate(data, data["claims"][0], scorecard._Glue(path.parent))
    assert ev["verdict"] == "reproduced"


@pytest.mark.parametrize("claim, message", [
    (_claim(rule=None), "needs a 'rule'"),
    (_claim(measure="nope"), "not declared in the chapter's measures"),
    (_claim(verdict="not reproduced", not_applicable={"pi": "w"}), "disagrees with the rule"),
    (_claim(ours="nb::txt"), "has no 'value [lo, hi]'"),
    (_claim(ours="nb::missing"), "is not glued"),
    (_claim(ours=None), "or 'pending'"),
    (_claim(rule={"type": "direction", "expect": "sideways", "ref": 0}),
     "expect: below | above"),
    (_claim(rule={"type": "direction", "expect": "below"}), "needs its reference 'ref'"),
    (_claim(rule={"type": "direction", "expect": "below", "ref": 0, "margin": -0.1}),
     "margin must be positive"),
    (_claim(ours="nb::pct"), "in percent but the rule lacks unit"),
    (_claim(rule={"type": "direction", "expect": "below", "ref": 0, "unit": "%"}),
     "not in percent but the rule declares"),
    (_claim(ours="nb::two"), "more than one"),
    (_claim(), "reading 'pi' is not accounted for"),
    (_claim(open_readings={"pi": ""}), "needs a one-line why"),
    (_claim(open_readings={"nope": "w"}), "not a declared reading"),
    (_claim(readings=["pi"], ours={"0.98": "nb::d98", "0.99": "nb::d99",
                                   "0.995": "nb::d995"}, not_applicable={"pi": "w"}),
     "both run and in not_applicable"),
    (_claim(readings=["pi"], ours={"0.98": "nb::d98", "0.99": {"pending": ""},
                                   "0.995": "nb::d995"}), "a pending cell needs its why"),
    (_claim(rule={"type": "band", "paper": 1}), "needs lo, hi, tol or rel_tol"),
    (_claim(rule={"type": "band", "lo": 2, "hi": 1}), "is empty"),
    (_claim(rule={"type": "magic"}), "rule type must be one of"),
    (_claim(rule={"all": [{"type": "direction", "expect": "below", "ref": 0}]}),
     "at least two parts"),
    (_claim(kind="qualitative", rule={"type": "direction", "expect": "below", "ref": 0}),
     "only quantitative claims take a rule"),
    (_claim(verdict_key="nb::v", ours="nb::up", not_applicable={"pi": "w"}),
     "the notebook's verdict"),
    (_claim(readings=["pi"]), "maps each reading"),
    (_claim(readings=["pi"], ours={"0.98": "nb::d98"}), "cover the readings grid"),
    (_claim(readings=["nope"], ours={"x": "nb::d98"}), "not declared"),
    (_claim(kind="erratum", rule=None, measure=None, verdict="not reproduced", why="w"),
     "an erratum needs class"),
    (_claim(kind="erratum", rule=None, measure=None, verdict="not reproduced", why="w",
            **{"class": "paper error"}), "needs 'printed'"),
    (_claim(kind="erratum", rule=None, measure=None, verdict="not reproduced", why="w",
            **{"class": "none"}), "needs verdict 'reproduced'"),
])
def test_registry_problems_are_caught(tmp_path, claim, message):
    path = _registry(tmp_path, [claim], readings=PI)
    problems = scorecard.problems(path)
    assert any(message in p for p in problems), problems


def test_readings_grid_decides_depends_on_reading(tmp_path):
    ours = {"0.98": "nb::d98", "0.99": "nb::d99", "0.995": "nb::d995"}
    path = _registry(tmp_path, [_claim(readings=["pi"], ours=ours)], readings=PI)
    assert scorecard.problems(path) == []
    data = scorecard.load(path)
    ev = scorecard.evaluate(data, data["claims"][0], scorecard._Glue(path.parent))
    # reproduced at 0.98 and 0.995, a tie at 0.99: undecided, not "reproduced"
    assert ev["verdict"] == "undecided"
    assert (ev["holds"], ev["cells"]) == (2, 3)
    ours["0.99"] = "nb::up"   # fails at 0.99: holds in some readings, fails in another
    path.write_text(yaml.safe_dump({**data, "claims": [_claim(readings=["pi"], ours=ours)]}),
                    encoding="utf-8")
    data = scorecard.load(path)
    ev = scorecard.evaluate(data, data["claims"][0], scorecard._Glue(path.parent))
    assert ev["verdict"] == "depends on reading"


def test_pending_estimate_is_undecided(tmp_path):
    path = _registry(tmp_path, [_claim(ours=None, pending="paired e at prior 0.995")])
    assert scorecard.problems(path) == []
    data = scorecard.load(path)
    ev = scorecard.evaluate(data, data["claims"][0], scorecard._Glue(path.parent))
    assert ev["verdict"] == "undecided"


def _eval(path):
    data = scorecard.load(path)
    return scorecard.evaluate(data, data["claims"][0], scorecard._Glue(path.parent))


def test_pending_cells_count_as_undecided(tmp_path):
    # holds at two priors, the third not run: undecided, with the pending cell counted
    ours = {"0.98": "nb::d98", "0.99": {"pending": "paired e at 0.99"}, "0.995": "nb::d995"}
    path = _registry(tmp_path, [_claim(readings=["pi"], ours=ours)], readings=PI)
    assert scorecard.problems(path) == []
    ev = _eval(path)
    assert ev["verdict"] == "undecided"
    assert (ev["holds"], ev["cells"], ev["pending_cells"]) == (2, 3, 1)
    # a failing cell beside a holding one decides "depends on reading" whatever is pending
    ours["0.98"] = "nb::up"
    path.write_text(yaml.safe_dump({**scorecard.load(path),
                                    "claims": [_claim(readings=["pi"], ours=ours)]}),
                    encoding="utf-8")
    assert _eval(path)["verdict"] == "depends on reading"


def test_a_single_cell_may_be_pending(tmp_path):
    # the claim's one estimate not yet run at an accepted size: undecided
    path = _registry(tmp_path, [_claim(ours={"pending": "20 runs, fewer than 40"})])
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "undecided"
    # an `all` rule: a failing part decides whatever the pending part would give
    rule = {"all": [{"type": "direction", "expect": "below", "ref": 0, "ours": "nb::up"},
                    {"type": "direction", "expect": "below", "ref": 0,
                     "ours": {"pending": "not run"}}]}
    path.write_text(yaml.safe_dump({**scorecard.load(path),
                                    "claims": [_claim(ours=None, rule=rule)]}),
                    encoding="utf-8")
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "not reproduced"


def test_depends_on_reading_is_not_capped_by_open_readings(tmp_path):
    ours = {"0.98": "nb::d98", "0.99": "nb::up", "0.995": "nb::d995"}
    readings = PI + [{"name": "rho", "parameter": "snr", "default": "10", "why": "w",
                      "values": [{"value": "10", "why": "a"}, {"value": "3", "why": "b"}]}]
    path = _registry(tmp_path, [_claim(readings=["pi"], ours=ours,
                                       open_readings={"rho": "not run"})], readings=readings)
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "depends on reading"


@pytest.mark.parametrize("ref, run", [("nb::d98", "reproduced"), ("nb::up", "not reproduced")])
def test_open_readings_cap_a_verdict_at_undecided(tmp_path, ref, run):
    path = _registry(tmp_path, [_claim(ours=ref, open_readings={"pi": "prior not run"})],
                     readings=PI)
    assert scorecard.problems(path) == []
    ev = _eval(path)
    assert (ev["verdict"], ev["run_verdict"]) == ("undecided", run)


RHO = [{"name": "rho", "parameter": "snr", "default": "10", "why": "w",
        "values": [{"value": "10", "why": "a"}, {"value": "3", "why": "b"},
                   {"value": "5", "why": "c"}]}]


def test_varied_readings_add_one_cell_per_other_value(tmp_path):
    # pi spans the grid; rho is varied alone from the default cell (pi = 0.99)
    ours = {"0.98": "nb::d98", "0.99": "nb::d995", "0.995": "nb::d995",
            "0.99; rho: 3": "nb::d98", "0.99; rho: 5": "nb::d98"}
    claim = _claim(readings=["pi"], varied=["rho"], ours=ours)
    path = _registry(tmp_path, [claim], readings=PI + RHO)
    assert scorecard.problems(path) == []
    data = scorecard.load(path)
    assert scorecard.reading_grid(data, data["claims"][0]) == list(ours)
    ev = _eval(path)
    assert (ev["verdict"], ev["holds"], ev["cells"]) == ("reproduced", 5, 5)
    assert ev["readings"] == ["pi", "rho"]
    # a varied cell that fails beside holding cells: depends on reading
    ours["0.99; rho: 5"] = "nb::up"
    path.write_text(yaml.safe_dump({**data, "claims": [dict(claim, ours=ours)]}),
                    encoding="utf-8")
    assert _eval(path)["verdict"] == "depends on reading"


def test_varied_without_a_grid_and_its_problems(tmp_path):
    ours = {"default readings": "nb::up", "default readings; rho: 3": "nb::up",
            "default readings; rho: 5": {"pending": "not run yet"}}
    claim = _claim(varied=["rho"], ours=ours, not_applicable={"pi": "w"})
    path = _registry(tmp_path, [claim], readings=PI + RHO)
    assert scorecard.problems(path) == []
    ev = _eval(path)   # fails in two cells, the third pending: undecided
    assert (ev["verdict"], ev["cells"], ev["pending_cells"]) == ("undecided", 3, 1)
    for bad, message in (
            (dict(claim, ours={"default readings": "nb::up"}), "cover the readings grid"),
            (dict(claim, open_readings={"rho": "w"}), "both run and in open_readings"),
            (dict(claim, readings=["rho"]), "both in the grid and varied alone")):
        path.write_text(yaml.safe_dump({**scorecard.load(path), "claims": [bad]}),
                        encoding="utf-8")
        assert any(message in p for p in scorecard.problems(path)), scorecard.problems(path)


def test_not_applicable_reading_leaves_the_verdict(tmp_path):
    path = _registry(tmp_path, [_claim(not_applicable={"pi": "a prior of another tracker"})],
                     readings=PI)
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "reproduced"


def test_a_value_without_interval_is_undecided(tmp_path):
    path = _registry(tmp_path, [_claim(ours="nb::flat")])
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "undecided"


def test_unchecked_errata_count_as_suspected(tmp_path):
    erratum = dict(kind="erratum", rule=None, measure=None, ours=None, why="w",
                   printed="a", corrected="b", check="c", targets=[])
    claims = [_claim(id="e1", verdict="not reproduced", **erratum, **{"class": "paper error"}),
              _claim(id="e2", verdict="not testable", **erratum, **{"class": "paper error"}),
              _claim(id="e3", verdict="not testable", **erratum,
                     **{"class": "source-text defect"})]
    path = _registry(tmp_path, claims)
    data = scorecard.load(path)
    glue = scorecard._Glue(path.parent)
    evaluated = {c["id"]: {"chapter": "000-x", "claim": c, "data": data,
                           "eval": scorecard.evaluate(data, c, glue)} for c in data["claims"]}
    errata = scorecard.counts(evaluated)["all"]["errata"]
    assert (errata["paper error"], errata["suspected"], errata["source-text defect"]) == \
        (1, 2, 0)


def test_every_quantitative_claim_of_the_book_has_a_computed_verdict():
    typed = [cid for cid, e in scorecard.evaluate_all().items()
             if e["claim"].get("kind") == "quantitative" and not e["eval"].get("computed")
             and e["claim"].get("verdict") != "not testable"]
    assert not typed, f"quantitative claims without a rule: {typed}"


def test_counts_add_up_and_readme_is_current():
    table = scorecard.counts()
    total = table["all"]
    assert total["n"] == sum(len(scorecard.load(p)["claims"]) for p in scorecard.registries())
    assert total["n"] == sum(total["claims"].values()) + sum(total["errata"].values())
    assert None not in total["claims"], "a claim has no verdict"
    readme = (BOOK.parent / "README.md").read_text(encoding="utf-8")
    assert scorecard.readme_block() in readme, (
        "README's scorecard counts are stale: run `python book/_ext/scorecard.py --readme`")


# --------------------------------------------------------------------------- premises

PREMISE = {"pd": "a tracker confirms a track in some run"}


def test_combining_not_applicable_cells():
    a = scorecard.combine_all
    assert a(["reproduced", "not applicable"]) == "not applicable"
    assert a(["not reproduced", "not applicable"]) == "not reproduced"
    assert a(["undecided", "not applicable"]) == "undecided"
    r = scorecard.combine_readings
    assert r(["not reproduced", "not applicable", "not reproduced"]) == "not reproduced"
    assert r(["reproduced", "not applicable"]) == "reproduced"
    assert r(["reproduced", "not reproduced", "not applicable"]) == "depends on reading"
    assert r(["undecided", "not applicable"]) == "undecided"
    assert r(["not applicable"] * 3) == "not testable"


def test_not_applicable_cells_are_left_out(tmp_path):
    # fails at two priors, premise absent at the third: not reproduced, one cell left out
    ours = {"0.98": "nb::up", "0.99": "nb::na", "0.995": "nb::up"}
    path = _registry(tmp_path, [_claim(readings=["pi"], ours=ours)], readings=PI,
                     premises=PREMISE)
    assert scorecard.problems(path) == []
    ev = _eval(path)
    assert ev["verdict"] == "not reproduced"
    assert (ev["holds"], ev["cells"], ev["not_applicable_cells"]) == (0, 3, 1)
    # the same cell with no interval (a tie) instead keeps the claim undecided
    ours["0.99"] = "nb::flat"
    path.write_text(yaml.safe_dump({**scorecard.load(path),
                                    "claims": [_claim(readings=["pi"], ours=ours)]}),
                    encoding="utf-8")
    assert _eval(path)["verdict"] == "undecided"


def test_no_applicable_cell_is_not_testable_unless_a_reading_is_open(tmp_path):
    path = _registry(tmp_path, [_claim(ours="nb::na", not_applicable={"pi": "w"})],
                     readings=PI, premises=PREMISE)
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "not testable"
    (tmp_path / "b").mkdir()
    path = _registry(tmp_path / "b", [_claim(ours="nb::na", open_readings={"pi": "w"})],
                     readings=PI, premises=PREMISE)
    ev = _eval(path)
    assert (ev["verdict"], ev["run_verdict"]) == ("undecided", "not testable")


def test_an_all_rule_cell_with_a_part_not_applicable(tmp_path):
    # one part holds, the other's premise is absent: the cell is not applicable, so a
    # claim whose only cell it is cannot be computed as reproduced
    rule = {"all": [{"type": "direction", "expect": "below", "ref": 0, "ours": "nb::d98"},
                    {"type": "direction", "expect": "below", "ref": 0, "ours": "nb::na"}]}
    path = _registry(tmp_path, [_claim(ours=None, rule=rule, not_applicable={"pi": "w"})],
                     readings=PI, premises=PREMISE)
    assert scorecard.problems(path) == []
    assert _eval(path)["verdict"] == "not testable"


@pytest.mark.parametrize("premises, message", [
    (None, "declares no premise"),
    ({"pd": ""}, "needs its text"),
    ({"nope": "w", "pd": "w"}, "not a declared measure"),
])
def test_not_applicable_needs_a_declared_premise(tmp_path, premises, message):
    path = _registry(tmp_path, [_claim(ours="nb::na", not_applicable={"pi": "w"})],
                     readings=PI, premises=premises)
    problems = scorecard.problems(path)
    assert any(message in p for p in problems), problems
    if premises is None:
        with pytest.raises(ValueError, match="declares no premise"):
            _eval(path)
