"""Bibliography labels in author-year form, to match the author-year citations in the text.

The book cites with ``bibtex_reference_style: author_year`` ("Doherty et al., 2019"); pybtex's
``plain`` style would label the list ``[1]``, ``[2]``, ... This registers a formatting style
``authoryear`` (``plain`` with labels "Doherty et al., 2019") for ``bibtex_default_style``, which
also sorts a corporate author ("{NA 568 ...}") by its name rather than after every letter, and
writes a paper in proceedings as "In Proceedings ..., pp. 9297--9307, 2019." (pages and year in
one sentence).
"""
from __future__ import annotations

from pybtex.plugin import register_plugin
from pybtex.style.formatting import toplevel
from pybtex.style.formatting.plain import Style as PlainStyle
from pybtex.style.formatting.unsrt import date, pages
from pybtex.style.labels import BaseLabelStyle
from pybtex.style.sorting.author_year_title import SortingStyle as AuthorYearTitleSorting
from pybtex.style.template import optional, optional_field, sentence, words


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


class AuthorYearSorting(AuthorYearTitleSorting):
    """Author, year, title order, with the braces of a corporate author's name ignored."""

    def person_key(self, person):
        return super().person_key(person).replace("{", "").replace("}", "")


class AuthorYearStyle(PlainStyle):
    default_label_style = "authoryear"
    default_sorting_style = "authoryear"

    def get_inproceedings_template(self, e):
        """Authors. Title. In Proceedings, pp. first--last, year. Note. Links."""
        return toplevel[
            sentence[self.format_names("author")],
            self.format_title(e, "title"),
            words[
                "In",
                sentence[
                    optional[self.format_editor(e, as_sentence=False)],
                    self.format_btitle(e, "booktitle", as_sentence=False),
                    self.format_volume_and_series(e, as_sentence=False),
                    optional[words["pp.", pages]],
                    optional_field("address"),
                    optional_field("organization"),
                    optional_field("publisher"),
                    date,
                ],
            ],
            sentence[optional_field("note")],
            self.format_web_refs(e),
        ]


def setup(app):
    register_plugin("pybtex.style.labels", "authoryear", AuthorYearLabelStyle)
    register_plugin("pybtex.style.sorting", "authoryear", AuthorYearSorting)
    register_plugin("pybtex.style.formatting", "authoryear", AuthorYearStyle)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
