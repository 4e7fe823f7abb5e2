"""Author-year labels for the bibliography, matching the author-year citations.

Registers the pybtex formatting style ``authoryear`` (``_config.yml`` sets
``bibtex_default_style: authoryear``): entries are sorted by author, year and title as in
``plain``, and each is labelled "Kim and Song 2007", "Bar-Shalom et al. 2001", with a
letter added when two entries would share a label ("2016a", "2016b"). DOIs and URLs are
printed by the base style.
"""
from __future__ import annotations

from collections import Counter

from pybtex.plugin import register_plugin
from pybtex.style.formatting.plain import Style as PlainStyle
from pybtex.style.labels import BaseLabelStyle


def _surname(person) -> str:
    parts = person.prelast_names + person.last_names
    return " ".join(str(p) for p in parts).replace("{", "").replace("}", "")


class AuthorYearLabels(BaseLabelStyle):
    def format_label(self, entry) -> str:
        persons = entry.persons.get("author") or entry.persons.get("editor") or []
        if not persons:
            names = entry.fields.get("organization") or entry.fields.get("key") or entry.key
        elif len(persons) == 1:
            names = _surname(persons[0])
        elif len(persons) == 2:
            names = f"{_surname(persons[0])} and {_surname(persons[1])}"
        else:
            names = f"{_surname(persons[0])} et al."
        return f"{names} {entry.fields.get('year', 'n.d.')}"

    def format_labels(self, sorted_entries):
        labels = [self.format_label(e) for e in sorted_entries]
        count = Counter(labels)
        seen = Counter()
        for label in labels:
            if count[label] == 1:
                yield label
            else:
                seen[label] += 1
                yield label + "abcdefghijklmnopqrstuvwxyz"[seen[label] - 1]


class AuthorYearStyle(PlainStyle):
    default_label_style = "authoryear"


def setup(app):
    register_plugin("pybtex.style.labels", "authoryear", AuthorYearLabels)
    register_plugin("pybtex.style.formatting", "authoryear", AuthorYearStyle)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
