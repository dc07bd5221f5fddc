"""Bibliography labels in author-year form, to match the author-year citations in the text.

The book cites with ``bibtex_reference_style: author_year`` ("Doherty et al., 2019"); pybtex's
``plain`` style would label the list ``[1]``, ``[2]``, ... This registers a formatting style
``authoryear`` (``plain`` with labels "Doherty et al., 2019") for ``bibtex_default_style``.
"""
from __future__ import annotations

from pybtex.plugin import register_plugin
from pybtex.style.formatting.plain import Style as PlainStyle
from pybtex.style.labels import BaseLabelStyle


def _last(person) -> str:
    name = " ".join(person.prelast_names + person.last_names)
    return name.replace("{", "").replace("}", "")   # a corporate author kept whole by braces


class AuthorYearLabelStyle(BaseLabelStyle):
    """Labels "Last, year", "Last and Other, year" or "Last et al., year"."""

    def format_labels(self, sorted_entries):
        labels = list(self._labels(sorted_entries))
        for i, label in enumerate(labels):   # "Gan et al., 2020a", "... 2020b" when two agree
            same = [j for j, other in enumerate(labels) if other == label]
            yield label + ("abcdefghij"[same.index(i)] if len(same) > 1 else "")

    def _labels(self, sorted_entries):
        for entry in sorted_entries:
            people = entry.persons.get("author") or entry.persons.get("editor") or []
            if not people:
                name = entry.fields.get("organization", entry.key)
            elif len(people) == 1:
                name = _last(people[0])
            elif len(people) == 2:
                name = f"{_last(people[0])} and {_last(people[1])}"
            else:
                name = f"{_last(people[0])} et al."
            yield f"{name}, {entry.fields.get('year', 'n.d.')}"


class AuthorYearStyle(PlainStyle):
    default_label_style = "authoryear"


def setup(app):
    register_plugin("pybtex.style.labels", "authoryear", AuthorYearLabelStyle)
    register_plugin("pybtex.style.formatting", "authoryear", AuthorYearStyle)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
