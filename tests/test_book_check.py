"""book_check: the notebooks' checks assert on the book's runs and report on others."""
import pytest

from trackcore.experiments import book_check


def test_book_runs_assert():
    assert book_check(True, "holds", book=True) is None, "a check returns nothing (no cell output)"
    with pytest.raises(AssertionError, match="the target is met"):
        book_check(False, "the target is met", book=True)


def test_other_runs_report(capsys):
    assert book_check(False, "the target is met", book=False) is None, \
        "a check returns nothing (no cell output)"
    assert "the book's check fails here: the target is met" in capsys.readouterr().out, \
        "the note names the check"
    book_check(True, "quiet", book=False)
    assert capsys.readouterr().out == "", "a passing check prints nothing"


def test_message_must_be_text():
    with pytest.raises(TypeError, match="message"):
        book_check(True, 3, book=True)
