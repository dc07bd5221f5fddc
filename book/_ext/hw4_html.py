"""Sphinx extension: what each HTML page of the book loads, and search snippets that work offline.

Page weight (measured by ``benchmarks/bench_html.py``, checked by ``tests_browser/``)
    * MathJax only on pages with maths. Sphinx already does this per page, but it counts a page's
      toctree children as its own, so the root page (the introduction, no formula) loaded 1.2 MB of
      MathJax; here the page's own doctree decides.
    * No icon JavaScript: pydata-sphinx-theme loads Font Awesome's "SVG with JavaScript" bundle
      (1.5 MB, every icon of the set) on every page, although its CSS already draws the same
      ``<i class="fa-solid fa-...">`` icons with the web font; the bundle's ``<script>`` is left out
      (``templates/static/webpack-macros.html``) and the files are not shipped.
    * The theme's CSS keeps the ``.fa-NAME::before`` rules of the icons the book uses (about 20 of
      1,900), and the three Font Awesome fonts are cut to the glyphs that CSS can show (a few KB of
      WOFF instead of 0.3 MB of WOFF2 per style).
    * The large style sheets (pydata-sphinx-theme, sphinx-design, myst-nb) lose the rules none of
      whose selectors can match: a selector stays when every class it names (outside :not() and
      the like) is on a page or is a word of a script the pages run (pydata: 397 KB -> 108 KB;
      screenshots of 10 pages x 2 widths x 7 states, menus and drawers open, dark mode, were
      pixel-identical with and without this step). Licence banners are kept; the themes' source
      maps are not shipped.
    * Sphinx's search scripts and index (80 KB) only on the search page (``templates/layout.html``;
      the theme's search-as-you-type, which needs them everywhere, is off).

Search snippets from disk
    Sphinx shows a snippet under each search result by fetching the result's page, which a browser
    refuses for a book opened from disk (file://), so ``html_show_search_summary`` is off. Instead
    the text of every section (prose, captions and tables; no code) is written once into
    ``_static/hw4-search-text.js``, which only ``search.html`` loads, and ``_static/hw4-search.js``
    puts a snippet around the first search term under each result.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.util import logging

logger = logging.getLogger(__name__)

SEARCH_TEXT = "hw4-search-text.js"
SEARCH_JS = "hw4-search.js"
FA_DIR = Path("vendor") / "fontawesome" / "webfonts"
FA_FONTS = ("fa-solid-900", "fa-regular-400", "fa-brands-400")
THEME_CSS = Path("styles") / "pydata-sphinx-theme.css"
# an icon rule of Font Awesome's CSS: `.fa-bars:before{content:"\f0c9"}` (aliases listed together)
ICON_RULE = re.compile(r'((?:\.fa-[a-z0-9-]+:{1,2}(?:before|after),?)+)\{content:"([^"]*)"\}')
ICON_NAME = re.compile(r"\bfa-[a-z0-9-]+")
CSS_ESCAPE = re.compile(r"\\([0-9a-fA-F]{1,6})\s?")


# ---------------------------------------------------------------------------- per page assets
def _is_mathjax(js, config) -> bool:
    name = str(getattr(js, "filename", js) or "")
    body = getattr(js, "attributes", {}).get("body", "") or ""
    path = config.mathjax_path
    return name in (path, "_static/" + path) or body.startswith(("window.MathJax", "MathJax.Hub"))


def page_assets(app: Sphinx, pagename: str, templatename: str, context: dict, doctree) -> None:
    """MathJax only where the page itself has maths; the snippet scripts on the search page."""
    if app.builder.format != "html":
        return
    scripts = context.get("script_files")
    if scripts is None:
        return
    has_maths = doctree is not None and any(doctree.findall(
        lambda n: isinstance(n, (nodes.math, nodes.math_block))))
    if not has_maths:
        scripts[:] = [js for js in scripts if not _is_mathjax(js, app.config)]
    if pagename == "search":
        app.builder.add_js_file(SEARCH_TEXT, priority=900)
        app.builder.add_js_file(SEARCH_JS, priority=901)


# ---------------------------------------------------------------------------- search snippets
_SKIP = (nodes.literal_block, nodes.raw, nodes.comment, nodes.system_message, nodes.title,
         nodes.target, nodes.substitution_definition)


def _text(node: nodes.Node, out: list[str]) -> None:
    """The readable text under ``node``: no code cells, no child sections, no raw HTML."""
    for child in node.children:
        if isinstance(child, nodes.section) or isinstance(child, _SKIP):
            continue
        if isinstance(child, nodes.Element) and "cell_input" in child.get("classes", ()):
            continue
        if isinstance(child, nodes.Text):
            out.append(str(child))
        elif isinstance(child, nodes.math):
            out.append(child.astext())
        else:
            _text(child, out)
            if isinstance(child, (nodes.Body, nodes.label, nodes.caption, nodes.entry,
                                  nodes.list_item, nodes.term)):
                out.append(" ")


def section_texts(doctree: nodes.document) -> dict[str, str]:
    """``{section id: its own text}`` for a page ("" for the text before the first section)."""
    texts = {}
    top: list[str] = []
    _text(doctree, top)
    for section in doctree.findall(nodes.section):
        own: list[str] = []
        _text(section, own)
        if section["ids"]:
            texts[section["ids"][0]] = " ".join("".join(own).split())
    texts[""] = " ".join("".join(top).split())
    return {k: v for k, v in texts.items() if v}


def write_search_text(app: Sphinx) -> None:
    env = app.env
    data = {}
    for docname in sorted(env.all_docs):
        try:  # resolved: the bibliography's entries are only there once resolved; the writing
            # of the page has reported its warnings already
            with logging.suppress_logging():
                doctree = env.get_and_resolve_doctree(docname, app.builder)
        except FileNotFoundError:
            continue
        data[docname] = section_texts(doctree)
    out = Path(app.outdir) / "_static" / SEARCH_TEXT
    out.write_text("/* The text of every section, for search snippets (book/_ext/hw4_html.py). */\n"
                   "window.HW4_SEARCH_TEXT = " + json.dumps(data, ensure_ascii=False,
                                                            separators=(",", ":")) + ";\n",
                   encoding="utf-8")


# ---------------------------------------------------------------------------- icons
def _used_icon_names(outdir: Path) -> set[str]:
    """Every ``fa-NAME`` that a page or a script of the book names."""
    names: set[str] = set()
    for path in outdir.rglob("*.html"):
        if "_static" in path.parts and "interactive" not in path.parts:
            continue
        names |= set(ICON_NAME.findall(path.read_text(encoding="utf-8", errors="ignore")))
    static = outdir / "_static"
    for path in static.rglob("*.js"):
        if path.name.startswith("fontawesome") or "mathjax" in path.parts or "plotly" in path.name:
            continue
        names |= set(ICON_NAME.findall(path.read_text(encoding="utf-8", errors="ignore")))
    return names


def trim_icons(outdir: Path) -> None:
    """Keep the icon rules the book uses and cut the fonts to the glyphs that the CSS shows."""
    static = outdir / "_static"
    css_path = static / THEME_CSS
    if not css_path.is_file():
        return
    css = css_path.read_text(encoding="utf-8")
    used = _used_icon_names(outdir)

    def keep(match: re.Match) -> str:
        names = {n.split(":")[0].lstrip(".") for n in match.group(1).split(",") if n}
        return match.group(0) if names & used else ""

    css = ICON_RULE.sub(keep, css)
    used_classes = _used_classes(outdir)
    css = _purge_keeping_licences(css, used_classes)
    css = re.sub(r"/\*# sourceMappingURL=[^*]*\*/", "", css)
    # every code point a `content:` of the book's CSS can show, icons or not (a superset)
    points: set[int] = set()
    for sheet in [css] + [p.read_text(encoding="utf-8", errors="ignore")
                          for p in static.rglob("*.css") if p != css_path
                          and "mathjax" not in p.parts]:
        for value in re.findall(r'(?:content|--[a-z0-9-]+)\s*:\s*"([^"]*)"', sheet):
            points |= {int(h, 16) for h in CSS_ESCAPE.findall(value)}
            points |= {ord(c) for c in CSS_ESCAPE.sub("", value)}
    fonts = static / FA_DIR
    for stem in FA_FONTS:
        ttf = fonts / f"{stem}.ttf"
        if not ttf.is_file():
            continue
        css, n = re.subn(rf"url\(\.\./vendor/fontawesome/webfonts/{stem}\.woff2\) format\(\"woff2\"\),"
                     rf"url\(\.\./vendor/fontawesome/webfonts/{stem}\.ttf\) format\(\"truetype\"\)",
                     f'url(../vendor/fontawesome/webfonts/{stem}.hw4.woff) format("woff")', css)
        if n != 1:
            logger.warning(f"hw4_html: no @font-face for {stem} in the theme's CSS; its font is "
                           "left as shipped")
            continue
        _subset(ttf, fonts / f"{stem}.hw4.woff", points)
        for suffix in (".ttf", ".woff2"):
            (fonts / f"{stem}{suffix}").unlink(missing_ok=True)
    css_path.write_text(css, encoding="utf-8")
    # the other large style sheets every page loads
    for sheet in [static / "sphinx-design.min.css", *static.glob("mystnb.*.css")]:
        if sheet.is_file():
            sheet.write_text(_purge_keeping_licences(sheet.read_text(encoding="utf-8"),
                                                     used_classes), encoding="utf-8")
    # unreferenced: the SVG-with-JavaScript bundle (its <script> is not written), and the themes'
    # source maps (1.8 MB; only a browser's developer tools ask for them)
    for name in ("fontawesome.js", "fontawesome.js.LICENSE.txt"):
        (static / "scripts" / name).unlink(missing_ok=True)
    for folder in ("scripts", "styles"):
        for source_map in (static / folder).glob("*.map"):
            source_map.unlink()


# ---------------------------------------------------------------------------- unused CSS
def _split_top(text: str, sep: str) -> list[str]:
    """``text`` split at ``sep`` outside brackets and strings."""
    parts, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(text):
        if quote:
            quote = "" if c == quote and text[i - 1] != "\\" else quote
        elif c in "\"'":
            quote = c
        elif c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif c == sep and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def _rules(css: str):
    """The top-level ``(prelude, body)`` pairs of a CSS text (comments dropped)."""
    css = re.sub(r"/\*.*?\*/", "", css, flags=re.S)
    i, n = 0, len(css)
    while i < n:
        j = css.find("{", i)
        semi = css.find(";", i)
        if j < 0:
            return
        if 0 <= semi < j:  # a statement such as @charset or @import
            yield css[i:semi + 1].strip(), None
            i = semi + 1
            continue
        depth, k, quote = 0, j, ""
        while k < n:
            c = css[k]
            if quote:
                quote = "" if c == quote and css[k - 1] != "\\" else quote
            elif c in "\"'":
                quote = c
            elif c == "{":
                depth += 1
            elif c == "}":
                depth -= 1
                if depth == 0:
                    break
            k += 1
        yield css[i:j].strip(), css[j + 1:k]
        i = k + 1


# classes inside :not(), :is(), :where() and :has() need not be on the page for a rule to apply
_PSEUDO_LIST = re.compile(r":(?:not|is|where|has|-webkit-any|-moz-any)\((?:[^()]|\([^()]*\))*\)")
_CLASS = re.compile(r"\.((?:[A-Za-z0-9_-]|\\.)+)")


def _selector_live(selector: str, used: set[str]) -> bool:
    bare = re.sub(r"\[[^\]]*\]", "", _PSEUDO_LIST.sub("", selector))  # no [href$=".pdf"]
    classes = _CLASS.findall(bare)
    return all("\\" in c or c in used for c in classes)


def purge_css(css: str, used: set[str]) -> str:
    """``css`` without the style rules none of whose selectors can match: a selector is kept
    when every class it names (outside :not() and the like) occurs in the book's pages or
    scripts. At-rules other than @media, @supports and @layer are kept whole."""
    out = []
    for prelude, body in _rules(css):
        if body is None:
            out.append(prelude)
        elif prelude.startswith(("@media", "@supports", "@layer", "@container")):
            inner = purge_css(body, used)
            if inner:
                out.append(f"{prelude}{{{inner}}}")
        elif prelude.startswith("@"):
            out.append(f"{prelude}{{{body}}}")
        elif any(_selector_live(sel, used) for sel in _split_top(prelude, ",")):
            out.append(f"{prelude}{{{body}}}")
    return "".join(out)


def _purge_keeping_licences(css: str, used: set[str]) -> str:
    """``purge_css``, with the sheet's licence comments (``/*! ... */``) kept at its top."""
    licences = re.findall(r"/\*!.*?\*/", css, flags=re.S)
    return "\n".join(licences + [purge_css(css, used)])


def _used_classes(outdir: Path) -> set[str]:
    """Every class of every page, and every word of the scripts the pages run (a script may
    add a class by name)."""
    used: set[str] = set()
    for path in outdir.rglob("*.html"):
        if "_static" in path.parts:
            continue
        text = path.read_text(encoding="utf-8", errors="ignore")
        for value in re.findall(r'class\s*=\s*["\']([^"\']*)["\']', text):
            used.update(value.split())
        for script in re.findall(r"<script[^>]*>(.*?)</script>", text, flags=re.S):
            used.update(re.findall(r"[A-Za-z0-9_-]+", script))
    for path in (outdir / "_static").rglob("*.js"):
        if "mathjax" in path.parts or "plotly" in path.name or path.name == SEARCH_TEXT:
            continue
        used.update(re.findall(r"[A-Za-z0-9_-]+", path.read_text(encoding="utf-8",
                                                                  errors="ignore")))
    return used


def _subset(ttf: Path, out: Path, points: set[int]) -> None:
    from fontTools import subset

    options = subset.Options()
    options.flavor = "woff"
    options.layout_features = ["*"]
    options.name_IDs = ["*"]        # the fonts' copyright and licence records stay
    options.name_languages = ["*"]
    font = subset.load_font(str(ttf), options)
    subsetter = subset.Subsetter(options)
    subsetter.populate(unicodes=sorted(points))
    subsetter.subset(font)
    subset.save_font(font, str(out), options)


def finish(app: Sphinx, exception) -> None:
    if exception is not None or app.builder.format != "html":
        return
    write_search_text(app)
    trim_icons(Path(app.outdir))


def setup(app: Sphinx) -> dict:
    # after sphinx.ext.mathjax's own html-page-context handler (priority 500)
    app.connect("html-page-context", page_assets, priority=900)
    app.connect("build-finished", finish)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
