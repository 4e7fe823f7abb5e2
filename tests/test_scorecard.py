"""The claims registries behind the scorecard page (``book/_ext/scorecard.py``).

Every chapter has ``claims.yml``; every record has a place in the paper, a verdict from the
allowed set and, where the verdict rests on a number, a glued value with its interval that
the chapter's notebook stored; every row of the chapter's *Our targets* is decided by a claim.
"""
import sys

import pytest

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
