"""Sphinx extension for this book: numbered video figures, offline MathJax, the author override.

``video`` directive
    A figure whose body is an MP4 player in the HTML and a still image in the PDF, numbered and
    captioned like any ``figure`` (``{numref}`` works in both editions). In a notebook Markdown
    cell::

        ```{video} _static/t6_growth.mp4
        :still: _static/t6_growth_strip.png
        :name: fig-t6-growth
        :width: 70%

        The caption.
        ```

    ``:still:`` (the image the PDF prints in the player's place) defaults to the video's path
    with ``_strip.png``, else ``.png``, for its suffix; ``:poster:`` (the frame the HTML player
    shows before it plays: one with the map drawn) to the video's path with ``_poster.jpg``, which
    must exist (``hw4.bki.render.video_poster`` takes it from the video). Every option of
    ``figure`` (``name``, ``width``, ``align``, ``alt``, ``class``, ``figwidth``) applies;
    ``:html-width:`` sets the player's width when it should differ from the still's. The HTML
    player is ``<video controls loop muted playsinline preload="metadata" poster=...
    aria-label=...>`` (the label: ``:alt:``, else the caption's first sentence), so a page loads
    only the videos' headers and posters until a reader plays one, with a download link as its
    fallback; the MP4 and the poster are copied into ``_downloads`` as ``{download}`` would.

Offline MathJax
    ``mathjax_path`` in ``_config.yml`` points into ``_static``; the files come from npm
    (``scripts/setup.sh``). A missing copy stops the HTML build with one sentence instead of a
    book whose maths silently never renders.

Image descriptions
    An image without alt text gets its figure's caption (or a generic description), not its
    file path.

Code in the PDF
    A cell tagged ``hide-input`` (folded behind "Show code" in the HTML) prints without its
    code in the PDF; see :func:`hide_inputs_in_print`.

Unnumbered chapters (``hw4_unnumbered`` in ``_config.yml``)
    ``{docname: prefix}``: chapters outside the numbering, so that Task N is chapter N. Their
    figures, tables and equations are numbered ``prefix.k`` in both editions (``B.8`` for the
    background chapter's eighth equation); an empty prefix means they have none. In the HTML
    the prefix is put into Sphinx's figure numbers; in the PDF the chapter is preceded by
    ``\\hwunnumbered{prefix}`` (defined in the preamble), which makes the next ``\\chapter``
    unnumbered and numbers its floats and equations ``prefix.k``.

``HW4_BOOK_AUTHOR``
    When this environment variable is set (``python -m hw4 package --uniqname NAME`` sets it),
    the PDF title page names that student above the configured author line. Without it the title
    page says that this is the course book (``hw4_course_author`` in ``_config.yml``).
"""
from __future__ import annotations

import os
import posixpath
import re
import urllib.parse
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.application import Sphinx
from sphinx.directives.patches import Figure
from sphinx.errors import ConfigError
from sphinx.util import texescape
from sphinx.util.docutils import SphinxDirective

AUTHOR_ENV = "HW4_BOOK_AUTHOR"


class video(nodes.General, nodes.Element):
    """A video player; its child is the still image (what non-HTML builders print)."""


class VideoFigure(Figure, SphinxDirective):
    """``figure`` with an MP4 player in the HTML and the still image elsewhere."""

    option_spec = dict(Figure.option_spec, still=directives.unchanged, poster=directives.unchanged,
                       **{"html-width": directives.length_or_percentage_or_unitless})

    def run(self) -> list[nodes.Node]:
        video_rel = self.arguments[0]
        rel, abspath = self.env.relfn2path(video_rel)
        if not Path(abspath).is_file():
            raise self.error(f"video file {video_rel!r} not found (looked for {abspath}).")
        still = self.options.pop("still", None)
        html_width = self.options.pop("html-width", None)
        alt = self.options.get("alt", "")
        poster = self.options.pop("poster", None) or posixpath.splitext(video_rel)[0] + "_poster.jpg"
        poster_rel, poster_abs = self.env.relfn2path(poster)
        if not Path(poster_abs).is_file():
            raise self.error(f"video {video_rel!r} needs a poster frame for the HTML player: give "
                             f":poster: or add {poster} (hw4.bki.render.video_poster).")
        if still is None:
            stem = posixpath.splitext(video_rel)[0]
            for candidate in (f"{stem}_strip.png", f"{stem}.png"):
                if Path(self.env.relfn2path(candidate)[1]).is_file():
                    still = candidate
                    break
            else:
                raise self.error(f"video {video_rel!r} needs a still image for the PDF: give "
                                 f":still: or add {stem}_strip.png.")
        self.arguments[0] = still
        result = super().run()
        figs = [n for n in result if isinstance(n, nodes.figure)]
        if not figs:
            return result  # an error message from figure
        image = next(figs[0].findall(nodes.image))
        self.env.note_dependency(rel)
        self.env.note_dependency(poster_rel)
        if not alt:
            caption = next(figs[0].findall(nodes.caption), None)
            text = " ".join(caption.astext().split()) if caption is not None else ""
            alt = re.split(r"(?<=[a-z0-9)])\. ", text, maxsplit=1)[0].rstrip(".")
        player = video(src=self.env.dlfiles.add_file(self.env.docname, rel),
                       poster=self.env.dlfiles.add_file(self.env.docname, poster_rel),
                       width=html_width or image.get("width"),
                       label=f"Video: {alt}" if alt else "Video")
        image.replace_self(player)
        player += image
        return result


def visit_video_html(self, node: video) -> None:
    src = posixpath.join(self.builder.dlpath, urllib.parse.quote(node["src"]))
    style = f' style="width: {node["width"]}"' if node.get("width") else ""
    poster = posixpath.join(self.builder.dlpath, urllib.parse.quote(node["poster"]))
    label = self.attval(node["label"])
    self.body.append(
        f'<video class="hw4-video" controls loop muted playsinline preload="metadata" '
        f'poster="{poster}" aria-label="{label}" title="{label}"{style}>'
        f'<source src="{src}" type="video/mp4">'
        f'<a href="{src}">Download the video (MP4)</a></video>\n')
    raise nodes.SkipNode


def visit_video_other(self, node: video) -> None:
    """Other builders (LaTeX, text, ...) print the still image, the node's only child."""


def depart_video_other(self, node: video) -> None:
    pass


def describe_images(app: Sphinx, doctree: nodes.document, docname: str) -> None:
    """Give every image without alt text a description: its figure's caption (without the
    number), or, for a plot output without a caption, "Plot from the code cell above". Sphinx
    would otherwise write the image's file path as its alt text, which a screen reader reads."""
    for image in doctree.findall(nodes.image):
        if image.get("alt"):
            continue
        figure = image.parent
        while figure is not None and not isinstance(figure, nodes.figure):
            figure = figure.parent
        captions = list(figure.findall(nodes.caption)) if figure is not None else []
        text = " ".join(captions[0].astext().split()) if captions else ""
        text = re.sub(r"\\([A-Za-z]+)", r"\1", text).replace("{", "").replace("}", "")  # TeX
        image["alt"] = text or "Plot from the code cell above"


def check_mathjax(app: Sphinx) -> None:
    """Stop an HTML build whose MathJax copy (scripts/setup.sh) is missing."""
    if app.builder.format != "html":
        return
    path = app.config.mathjax_path
    if "://" in path or path.startswith("//"):
        raise ConfigError(f"mathjax_path {path!r} loads MathJax from the network; the book must "
                          "work offline (see _config.yml).")
    for static in app.config.html_static_path:
        if (Path(app.confdir) / static / path).is_file():
            return
    raise ConfigError(f"MathJax ({path}) is not in html_static_path: run `bash scripts/setup.sh`, "
                      "which copies it there from npm.")


def light_mode(app: Sphinx, config) -> None:
    """Light theme unless the reader picks another: the figures are drawn on white, and without a
    default the theme logs "Got invalid theme mode" as a console error on every page."""
    config.html_context.setdefault("default_mode", "light")


def override_author(app: Sphinx, config) -> None:
    """The PDF title page's author line: ``$HW4_BOOK_AUTHOR`` (the student) above the configured
    author line, or, without it, ``hw4_course_author`` (this is the course book, nobody's
    submission) below it."""
    name = os.environ.get(AUTHOR_ENV, "").strip()
    if name:
        line = texescape.escape(name, config.latex_engine)
        join = lambda author: f"{line}\\\\{author}" if author else line  # noqa: E731
    elif config.hw4_course_author:
        line = texescape.escape(config.hw4_course_author, config.latex_engine)
        join = lambda author: f"{author}\\\\{line}" if author else line  # noqa: E731
    else:
        return
    config.latex_documents = [(doc, target, title, join(author), *rest)
                              for doc, target, title, author, *rest in config.latex_documents]


def prefix_unnumbered(app: Sphinx, env) -> list[str]:
    """HTML numbers of the unnumbered chapters' figures, tables and equations: ``prefix.k``.

    Sphinx numbers the floats of a document outside every numbered toctree 1, 2, ...; with
    several such documents the numbers would repeat. ``hw4_unnumbered`` gives each a prefix
    (the PDF does the same with ``\\hwunnumbered``), so ``Eq. (B.8)`` reads the same in both."""
    changed = False
    for docname, prefix in app.config.hw4_unnumbered.items():
        if not prefix:
            continue
        for numbers in env.toc_fignumbers.get(docname, {}).values():
            if any(number and number[0] == prefix for number in numbers.values()):
                continue  # done on an earlier call
            # Sphinx counts on across the unnumbered documents (the introduction's figure is 1,
            # the background's first 2); the PDF restarts at the chapter: B.1, B.2, ...
            order = sorted(numbers, key=lambda key: numbers[key][-1])
            for k, key in enumerate(order, start=1):
                numbers[key] = (prefix, k)
            changed = True
    # every page may cite these numbers: rewrite them all when the numbers were (re)assigned
    return sorted(env.found_docs) if changed else []


def mark_unnumbered(app: Sphinx, doctree: nodes.document) -> None:
    """Put ``\\hwunnumbered{prefix}`` before an unnumbered chapter's heading (LaTeX only)."""
    prefix = app.config.hw4_unnumbered.get(app.env.docname)
    if prefix is None:
        return
    doctree.insert(0, nodes.raw("", f"\\hwunnumbered{{{prefix}}}\n", format="latex"))


SUPERSCRIPTS = dict(zip("⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁺", "0123456789-+"))
"""Unicode superscripts in prose and captions (``10⁻⁶``): TeX Gyre Termes has only ¹²³."""


def superscripts_as_math(app: Sphinx) -> None:
    """Typeset Unicode superscript digits and signs as math superscripts in the PDF (the text
    font lacks most of them, and XeLaTeX would drop them with a "Missing character" warning)."""
    from sphinx.util import texescape as tex

    for char, plain in SUPERSCRIPTS.items():
        tex._tex_escape_map_without_unicode[ord(char)] = f"\\ensuremath{{^{{{plain}}}}}"
        tex._tex_escape_map[ord(char)] = f"\\ensuremath{{^{{{plain}}}}}"


def hide_inputs_in_print(app: Sphinx, doctree: nodes.document, docname: str) -> None:
    """The PDF prints the code of a cell only when the notebook shows it open in the HTML: the
    input of a cell tagged with one of ``hw4_pdf_hidden_input_tags`` (default ``hide-input``,
    a listing the HTML folds behind a "Show code" button) is left out of the LaTeX, its output
    kept. So each section's one short instructive listing prints and the plotting and glue code
    stays in the HTML (and the notebook) only; no code is deleted."""
    if app.builder.format != "latex":
        return
    tags = {f"tag_{t}" for t in app.config.hw4_pdf_hidden_input_tags}
    for cell in list(doctree.findall(nodes.container)):
        if "cell" not in cell.get("classes", []) or not tags & set(cell["classes"]):
            continue
        for child in list(cell.children):
            if isinstance(child, nodes.container) and "cell_input" in child.get("classes", []):
                cell.remove(child)


def setup(app: Sphinx) -> dict:
    app.add_node(video, html=(visit_video_html, None),
                 latex=(visit_video_other, depart_video_other),
                 text=(visit_video_other, depart_video_other),
                 man=(visit_video_other, depart_video_other),
                 texinfo=(visit_video_other, depart_video_other))
    app.add_directive("video", VideoFigure)
    app.add_config_value("hw4_unnumbered", {}, "env", types=[dict])
    app.add_config_value("hw4_course_author", "", "env", types=[str])
    app.connect("doctree-read", mark_unnumbered)
    # after Sphinx's TocTreeCollector (priority 500) has assigned the figure numbers
    app.connect("env-get-updated", prefix_unnumbered, priority=900)
    app.connect("builder-inited", check_mathjax)
    app.connect("builder-inited", superscripts_as_math)
    app.connect("doctree-resolved", describe_images)
    app.add_config_value("hw4_pdf_hidden_input_tags", ["hide-input"], "env", types=[list])
    app.connect("doctree-resolved", hide_inputs_in_print)
    # after sphinx-external-toc has set root_doc, which the default latex_documents names
    app.connect("config-inited", override_author, priority=900)
    app.connect("config-inited", light_mode)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
