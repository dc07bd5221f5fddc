"""The report edition: a short PDF per student, built from the book's notebooks without editing them.

``python -m hw4.book.report [--name NAME] [--out _build/report_src]`` writes a Jupyter Book source
folder with one notebook per task (``task1.ipynb`` ... ``task5.ipynb``), a title page
(``intro.md``), ``_config.yml`` and ``_toc.yml``; ``bash scripts/build_book.sh report`` then
builds it into ``_build/hw4_report.pdf``. Each task notebook is made of

1. the task chapter's cells that glue numbers (code cells whose stored outputs hold glue
   records), hidden and with only those outputs, so that every ``{glue:text}`` of the report
   prints the value the book prints, byte for byte;
2. the report's own text, ``report/taskN.md`` (question and answer in a few sentences), in which
   a line ``<!-- figure: NAME -->`` or ``<!-- table: NAME -->`` is replaced by the chapter's
   figure cell (its stored image and caption, code removed) or table block of that name
   (myst-nb ``mystnb.figure.name`` metadata, or a ``:name:`` option). ``<!-- figure: A or B C -->``
   takes A when the chapter has it, else B and C; a name may end in ``*`` (every match, in
   chapter order); ``<!-- figure: NAME width=85% -->`` prints it at that share of the text width,
   and ``place=H`` (after the width, if any) gives it that LaTeX float placement instead of the
   report's ``!htbp`` (``H``: exactly there, between the paragraphs around the marker).
   A figure marker may be followed at once by the report's own caption for it,
   ``<!-- caption`` ... ``-->`` (the caption written for the grader, instead of the chapter's).

A caption's reference to something the report does not hold (a figure of the book only, or an
equation of the book: the report cites none, its captions carry the equations they need) stops
the build with one sentence. :data:`REQUIRED` lists the figures the
handout asks for; :func:`missing_figures` checks a built report's LaTeX for their labels.
"""
from __future__ import annotations

import argparse
import copy
import fnmatch
import json
import os
import re
import shutil
import sys
from pathlib import Path

from ..core.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
REPORT_DIR = ROOT / "report"
TASKS = {1: "notebooks/T1_discrete_csm.ipynb", 2: "notebooks/T2_continuous_csm.ipynb",
         3: "notebooks/T3_semantic_csm.ipynb", 4: "notebooks/T4_continuous_semantic_csm.ipynb",
         5: "notebooks/T5_bki_3d.ipynb"}
"""The chapter each task of the report takes its glue cells, figures and tables from."""

REQUIRED = {
    1: ["fig-t1-map", "fig-t1-var"],
    2: ["fig-t2-map", "fig-t2-var", "fig-t2-res-027", "fig-t2-res-05"],
    3: ["fig-t3-map", "fig-t3-var"],
    4: ["fig-t4-map", "fig-t4-var", "fig-t4-res-027", "fig-t4-res-05"],
    5: ["fig-t5-rviz-kitti", "fig-t5-rviz-top", "fig-t5-rviz-close"],
}
"""The figures the handout asks for, by task (its "visualize your map ... and its variance",
"generate the map and the variance map using grid_size = [0.135, 0.270, 0.5]" of Tasks 2B and
4B, whose 0.135 m maps are those of 2A / 4A, and Task 5's screenshots of the semantic map).
Task 5's screenshots are the chapter's RViz screenshots of sequence 04 (images, not the video;
those of them the chapter has, when it has any); without them, :data:`T5_FALLBACK` (the
chapter's renders of the same map) stand in, as the chapter says."""
T5_FALLBACK = ["fig-t5-kitti-3d", "fig-t5-kitti-top"]
VIDEO = "t5_kitti04_mapping.mp4"
"""The Task 5 mapping video named when the chapter's video files are not there."""


def chapter_videos(t5: dict | None = None) -> list[str]:
    """File names of the Task 5 chapter's ``{video}`` figures whose file exists, in chapter order
    (the submission's ``videos/`` holds them: ``hw4.package.VIDEOS``)."""
    t5 = t5 if t5 is not None else _load(ROOT / TASKS[5])
    names = []
    for cell in t5["cells"]:
        if cell["cell_type"] == "markdown":
            for m in re.finditer(r"^```\{video\} *(\S+)", _source(cell), re.M):
                if (_folder(5) / m.group(1)).is_file():
                    names.append(Path(m.group(1)).name)
    return names or [VIDEO]


def _video_text(names: list[str]) -> str:
    """``a``, ``a` and `b``, ``a`, `b` and `c``: the file names as inline code."""
    code = [f"`{n}`" for n in names]
    return code[0] if len(code) == 1 else ", ".join(code[:-1]) + " and " + code[-1]

RVIZ_WINDOW = (1854, 1056)
"""The size [px] of the RViz window in the Task 5 screenshots; :data:`RVIZ_VIEW` and
:data:`RVIZ_PANEL` are boxes in it."""
RVIZ_VIEW = (385, 300, 1561, 959)
"""(left, top, right, bottom) [px]: the part of RViz's 3D view the map of sequence 04 fills."""
RVIZ_PANEL = ((0, 84, 362, 256), (0, 445, 362, 542))
"""Boxes [px] of RViz's display panel: its global options and status, down to the point cloud
display's row, and the marker display with its status (the switched-off point cloud display's
greyed-out rows between them are left out)."""
RVIZ_PANEL_GAP = 8
"""Height [px, before enlarging] of the dashed gap that marks where rows were left out."""
PRINT_VERSIONS = {"fig-t5-rviz-kitti": "rviz_view_and_panel"}
"""Figures the report prints in a version of their own (a function of this module, by name):
RViz's full window printed 7 in wide sets its panel text at about 3 pt."""


def rviz_view_and_panel(src: Path, dst: Path) -> None:
    """Write to ``dst`` (PNG) the RViz screenshot ``src`` as the report prints it: RViz's display
    panel (:data:`RVIZ_PANEL`), enlarged to the height of the map's part of the 3D view
    (:data:`RVIZ_VIEW`), left of it. Printed 7 in wide, the panel's text is about 7 pt (in the
    whole window, 2-3 pt). One sentence (:class:`InputError`) if ``src`` is not an RViz window
    of :data:`RVIZ_WINDOW` pixels."""
    from PIL import Image, ImageDraw

    try:
        shot = Image.open(src).convert("RGB")
    except OSError as e:
        raise InputError(f"cannot read the RViz screenshot {src} ({e}).") from None
    if shot.size != RVIZ_WINDOW:
        raise InputError(f"the RViz screenshot {src} is {shot.size[0]} x {shot.size[1]} px, not "
                         f"the {RVIZ_WINDOW[0]} x {RVIZ_WINDOW[1]} px window whose panel and view "
                         "hw4.book.report.RVIZ_PANEL and RVIZ_VIEW locate.")
    view = shot.crop(RVIZ_VIEW)
    pieces = [shot.crop(box) for box in RVIZ_PANEL]
    width = max(p.width for p in pieces)
    panel = Image.new("RGB", (width, sum(p.height for p in pieces)
                              + RVIZ_PANEL_GAP * (len(pieces) - 1)), (239, 239, 239))
    y = 0
    draw = ImageDraw.Draw(panel)
    for i, piece in enumerate(pieces):
        panel.paste(piece, (0, y))
        y += piece.height
        if i < len(pieces) - 1:   # the cut: a dashed line across the gap
            mid = y + RVIZ_PANEL_GAP // 2
            for x in range(0, width, 12):
                draw.line([(x, mid), (x + 6, mid)], fill=(120, 120, 120), width=1)
            y += RVIZ_PANEL_GAP
    scale = view.height / panel.height
    panel = panel.resize((round(panel.width * scale), view.height), Image.LANCZOS)
    gap = 24
    out = Image.new("RGB", (panel.width + gap + view.width, view.height), (255, 255, 255))
    out.paste(panel, (0, 0))
    ImageDraw.Draw(out).rectangle([0, 0, panel.width - 1, panel.height - 1],
                                  outline=(150, 150, 150), width=2)
    out.paste(view, (panel.width + gap, 0))
    dst.parent.mkdir(parents=True, exist_ok=True)
    out.save(dst)


MARK = re.compile(r"^<!--\s*(figure|table):\s*(.+?)\s*-->\s*$", re.M)
CAPTION = re.compile(r"\A\s*<!--\s*caption\s*\n(.*?)\n\s*-->[ \t]*\n?", re.S)
"""The report's own caption of the figure whose marker it follows."""
TERM = "Winter 2023"
"""The title page's date when the student sets none: the handout's term (not the build day)."""
REF = re.compile(r"(?:\bof )?\{(numref|ref|eq|doc)\}`([^`]*)`")
GLUE_MIME = "application/papermill.record/"
SRC = "_build/report_src"


# --------------------------------------------------------------------------- reading the book

def _load(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InputError(f"cannot read the notebook {path} ({e}).") from None


def _source(cell: dict) -> str:
    src = cell.get("source", "")
    return "".join(src) if isinstance(src, list) else src


def figure_cells(nb: dict, videos: bool = True, folder: Path | None = None) -> dict[str, dict]:
    """``{name: cell}`` of a notebook's figures: code cells with ``mystnb.figure.name`` and an
    image output, and Markdown cells holding a ``{figure}`` or (with ``videos``) a ``{video}``
    block with ``:name:`` (with ``folder``, the notebook's folder, only those whose file is
    there: a screenshot not yet taken is not a figure the report can show)."""
    out = {}
    kinds = "figure|video" if videos else "figure"
    block = re.compile(r"^```\{(?:" + kinds + r")\} *([^\n]*)\n(?::[^\n]*\n)*?:name: (\S+)",
                       re.M)
    for cell in nb["cells"]:
        name = cell.get("metadata", {}).get("mystnb", {}).get("figure", {}).get("name")
        if name and cell["cell_type"] == "code":
            if any("image/png" in o.get("data", {}) for o in cell.get("outputs", [])):
                out[name] = cell
        elif cell["cell_type"] == "markdown":
            for m in block.finditer(_source(cell)):
                if folder is None or (folder / m.group(1).strip()).is_file():
                    out[m.group(2)] = cell
    return out


def _blocks(nb: dict, directive: str) -> dict[str, str]:
    """``{name: text}`` of the fenced ``{directive}`` blocks (with ``:name:``) in Markdown cells."""
    out = {}
    pattern = re.compile(r"^```\{" + directive + r"\}.*?^```[ \t]*$", re.M | re.S)
    for cell in nb["cells"]:
        if cell["cell_type"] != "markdown":
            continue
        for m in pattern.finditer(_source(cell)):
            name = re.search(r"^:name: (\S+)", m.group(0), re.M)
            if name:
                out[name.group(1)] = m.group(0)
    return out


def glue_cells(nb: dict) -> list[dict]:
    """The notebook's cells that glue values, each reduced to its glue outputs and hidden."""
    out = []
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        glued = [o for o in cell.get("outputs", [])
                 if any(k.startswith(GLUE_MIME) for k in o.get("data", {}))]
        if glued:
            new = {"cell_type": "code", "execution_count": None, "id": cell.get("id", ""),
                   "metadata": {"tags": ["remove-cell"]}, "outputs": copy.deepcopy(glued),
                   "source": _source(cell)}
            out.append(new)
    return out


GLUE_REF = re.compile(r"\{glue:(?:text|md|)\}`([A-Za-z_][\w]*)")


def borrowed_glue(text: str, own: dict, others: list[dict]) -> list[dict]:
    """Glue cells, each reduced to one record, for the values ``text`` cites that its chapter
    ``own`` does not glue but another chapter does (Task 4's answer may quote a Task 3 number):
    the value is that chapter's stored record, byte for byte."""
    def records(nb):
        out = {}
        for cell in glue_cells(nb):
            for o in cell["outputs"]:
                name = o.get("metadata", {}).get("scrapbook", {}).get("name")
                if name:
                    out[name] = (cell, o)
        return out
    mine = records(own)
    pool = {}
    for nb in others:
        for name, rec in records(nb).items():
            pool.setdefault(name, rec)
    cells = []
    for name in dict.fromkeys(GLUE_REF.findall(text)):
        if name not in mine and name in pool:
            cell, o = pool[name]
            cells.append({**copy.deepcopy(cell), "id": f"borrowed-{name}",
                          "outputs": [copy.deepcopy(o)]})
    return cells


def background_equations(path: Path | None = None) -> dict[str, str]:
    """``{label: "B.k"}``: the book's numbers of the background chapter's labelled equations."""
    nb = _load(path or ROOT / "book" / "background.ipynb")
    labels = []
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown":
            labels += re.findall(r"^:label: (\S+)", _source(cell), re.M)
            labels += re.findall(r"\$\$\s*\((eq-[\w-]+)\)", _source(cell))
    return {label: f"B.{k}" for k, label in enumerate(dict.fromkeys(labels), start=1)}


# --------------------------------------------------------------------------- writing the report

def _folder(task: int) -> Path:
    """The folder of a task's chapter (its Markdown figures' paths are relative to it)."""
    return (ROOT / TASKS[task]).parent


def _pick(spec: str, available: list[str], videos: frozenset = frozenset()) -> list[str]:
    """Names a marker asks for: ``A or B C`` -> A's matches if any, else B's and C's. A pattern
    with ``*`` matches no video (``videos``): a video is picked by its full name only."""
    for option in spec.split(" or "):
        names = []
        for pattern in option.replace(",", " ").split():
            pool = [n for n in available if "*" not in pattern or n not in videos]
            names += [n for n in pool if fnmatch.fnmatchcase(n, pattern) and n not in names]
        if names:
            return names
    return []


def _fix_refs(text: str, defined: set[str], equations: dict[str, str], where: str) -> str:
    """Rewrite references to targets the report does not hold (see the module docstring)."""
    def sub(m):
        role, target = m.group(1), m.group(2)
        label = re.sub(r"^.*<(.*)>$", r"\1", target)
        if label in defined:
            return m.group(0)
        if role == "eq":
            raise InputError(f"{where} cites the book's equation {label!r}; the report cites no "
                             "equation of the book: give the figure its own caption in the "
                             "report's text, with the equation it needs.")
        raise InputError(f"{where} refers to {label!r}, which the report does not hold: add it "
                         "to the report or pick another figure.")
    return REF.sub(sub, text)


def required_figures(t5: dict | None = None) -> dict[int, list[str]]:
    """:data:`REQUIRED` with Task 5's screenshots resolved against the Task 5 chapter: those of
    its RViz screenshots of sequence 04 it has, if any, else :data:`T5_FALLBACK`."""
    t5 = t5 if t5 is not None else _load(ROOT / TASKS[5])
    names = list(figure_cells(t5, videos=False))  # screenshots, not the video's still
    out = {task: list(figs) for task, figs in REQUIRED.items()}
    rviz = [n for n in REQUIRED[5] if n in names]
    out[5] = rviz or list(T5_FALLBACK)
    return out


def _plan(task: int, text: str, nb: dict) -> list[tuple]:
    """The report text of one task cut into ``("md", text)``, ``("figure", name, caption)`` and
    ``("table", name, None)`` pieces (``name`` possibly followed by `` width``; ``caption`` the
    report's own or None), the markers resolved against the chapter ``nb``."""
    figures, tables = figure_cells(nb, folder=_folder(task)), _blocks(nb, "table")
    videos = frozenset(figures) - set(figure_cells(nb, videos=False, folder=_folder(task)))
    parts = MARK.split(text)  # [text, kind, spec, text, kind, spec, ..., text]
    pieces: list[tuple[str, object]] = [("md", parts[0])]
    for i in range(1, len(parts), 3):
        kind, spec, after = parts[i], parts[i + 1], parts[i + 2]
        pool = list(figures) if kind == "figure" else list(tables)
        place = re.search(r"\s+place=([htbpH!]+)$", spec)
        if place:
            spec = spec[:place.start()]
        width = re.search(r"\s+width=(\d+%)$", spec)
        if width:
            spec = spec[:width.start()]
        options = ([width.group(1)] if width else []) + ([f"place={place.group(1)}"] if place else [])
        names = _pick(spec, pool, videos)
        if not names:
            raise InputError(f"report/task{task}.md asks for the {kind} {spec!r}, which "
                             f"{TASKS[task]} does not have.")
        caption = CAPTION.match(after)
        if caption:
            after = after[caption.end():]
            if len(names) > 1:
                raise InputError(f"report/task{task}.md gives one caption to the {len(names)} "
                                 f"figures of {spec!r}; give each its own marker.")
        for name in names:
            pieces.append((kind, " ".join([name] + options),
                           " ".join(caption.group(1).split()) if caption else None))
        pieces.append(("md", after))
    return pieces


def task_notebook(task: int, text: str, nb: dict, equations: dict[str, str],
                  elsewhere: set[str] = frozenset(), others: list[dict] = (),
                  prints: list | None = None) -> tuple[dict, list]:
    """The report's notebook for one task, and the figure names it holds.

    ``elsewhere``: names the other tasks of the report hold (a caption may refer to them);
    ``others``: the other chapters, whose glued values the text may quote
    (:func:`borrowed_glue`); ``prints``: a list to which the print versions
    (:data:`PRINT_VERSIONS`) of the Markdown figures it places are added, as
    ``(function, source image, image path in the report's folder)``; the figure then shows
    that path (without ``prints``, the chapter's image)."""
    figures = figure_cells(nb, folder=_folder(task))
    tables = _blocks(nb, "table")
    cells = glue_cells(nb) + borrowed_glue(text, nb, list(others))
    placed: list[str] = []
    pieces = _plan(task, text, nb)
    defined = {p[1].split()[0] for p in pieces if p[0] in ("figure", "table")} | set(elsewhere)
    defined |= set(re.findall(r"^\(([\w-]+)\)=", text, re.M))
    md: list[str] = []

    def flush():
        body = "".join(md).strip("\n")
        md.clear()
        if body:
            cells.append({"cell_type": "markdown", "id": f"r{task}-{len(cells)}",
                          "metadata": {}, "source": body})

    for kind, item, *own in pieces:
        if kind == "md":
            md.append(item)
            continue
        item, *opts = item.split()
        width = [o for o in opts if not o.startswith("place=")]
        place = [o[len("place="):] for o in opts if o.startswith("place=")]
        own = own[0]
        if place and kind == "figure":  # the next figure's placement (REPORT_PREAMBLE)
            md.append("\n```{raw} latex\n\\hwNextFigure{" + place[0] + "}\n```\n")
        if kind == "table":
            md.append("\n" + _fix_refs(tables[item], defined, equations,
                                       f"table {item} of {TASKS[task]}") + "\n")
        else:
            cell = figures[item]
            placed.append(item)
            if cell["cell_type"] == "markdown":  # a {figure} or {video} block
                block = [b for b in re.finditer(r"^```\{(?:figure|video)\}.*?^```[ \t]*$",
                                                _source(cell), re.M | re.S)
                         if re.search(r"^:name: " + re.escape(item) + r"\s*$", b.group(0), re.M)]
                text = block[0].group(0)
                if item in PRINT_VERSIONS and prints is not None:
                    head = re.match(r"(```\{figure\} *)(\S+)", text)
                    rel = f"_print/{item}.png"
                    prints.append((globals()[PRINT_VERSIONS[item]],
                                   _folder(task) / head.group(2), rel))
                    text = head.group(1) + rel + text[head.end():]
                if own is not None:  # the report's caption replaces the block's body
                    head = re.match(r"```\{(?:figure|video)\}[^\n]*\n(?::[^\n]*\n)*", text)
                    text = head.group(0) + "\n" + own + "\n```"
                if width:
                    text = re.sub(r"^:width: .*$", f":width: {width[0]}", text, flags=re.M)
                md.append("\n" + _fix_refs(text, defined, equations,
                                           f"figure {item} of {TASKS[task]}") + "\n")
                continue
            flush()
            new = copy.deepcopy(cell)
            # the code stays in the cell (myst-nb skips a code cell without source) but is
            # removed from the report (tag remove-input)
            new["outputs"] = [o for o in new.get("outputs", []) if "image/png" in o.get("data", {})]
            meta = new["metadata"]
            meta["tags"] = ["remove-input"]
            fig = meta["mystnb"]["figure"]
            fig["caption"] = _fix_refs(own if own is not None else fig.get("caption", ""),
                                       defined, equations,
                                       f"the caption of {item}")
            if width:  # printed narrower than the book prints it (mystnb image options)
                meta["mystnb"]["image"] = {"width": width[0]}
            cells.append(new)
    flush()
    out = {"cells": cells, "metadata": copy.deepcopy(nb.get("metadata", {})),
           "nbformat": 4, "nbformat_minor": 5}
    return out, placed


def _latex_text(text: str) -> str:
    """``text`` safe in LaTeX (the title page's author line is passed to LaTeX as it is)."""
    special = {"\\": r"\textbackslash{}", "{": r"\{", "}": r"\}", "$": r"\$", "&": r"\&",
               "#": r"\#", "^": r"\textasciicircum{}", "_": r"\_", "%": r"\%",
               "~": r"\textasciitilde{}"}
    return "".join(special.get(c, c) for c in text)


REPORT_PREAMBLE = r"""
% the report edition: chapters run on (no new page), headed by their title only
\makeatletter
\renewcommand{\chapter}{\par\FloatBarrier\vspace{1.2em}\global\@topnum\z@
  \@afterindentfalse\secdef\@chapter\@schapter}
\renewcommand{\@makechapterhead}[1]{{\parindent\z@\raggedright\normalfont\LARGE\bfseries
  #1\par\nobreak\vskip 10\p@}}
% the footer holds the page number only (chapters run on, so a chapter or section mark
% would name the section a page starts in, not the one it is mostly about)
\AtBeginDocument{\renewcommand{\chaptermark}[1]{}\renewcommand{\sectionmark}[1]{}%
  \renewcommand{\subsectionmark}[1]{}\markboth{}{}}
\renewcommand{\@makeschapterhead}[1]{{\parindent\z@\raggedright\normalfont\LARGE\bfseries
  #1\par\nobreak\vskip 10\p@}}
% \hwNextFigure{H} before a figure: that figure takes the placement H instead of the one
% Sphinx writes (the report's figure_align); the figures after it take Sphinx's again
\def\hw@place{}
\newcommand{\hwNextFigure}[1]{\gdef\hw@place{#1}}
\let\hw@figure\figure
\def\figure{\ifx\hw@place\@empty\expandafter\hw@figure\else\expandafter\hw@figure@placed\fi}
\def\hw@figure@placed[#1]{\edef\reserved@b{\noexpand\hw@figure[\hw@place]}\gdef\hw@place{}%
  \reserved@b}
\makeatother
"""


def _config(name: str | None, date: str | None = None) -> str:
    """The report's ``_config.yml``: the book's PDF settings with the report's title, author
    (the student; also the PDF's metadata) and date (``date``, else the handout's term)."""
    import yaml

    book = yaml.safe_load((ROOT / "_config.yml").read_text())
    cfg = {
        "title": "NA 568 Mobile Robotics, Homework 4: Mapping",
        "author": _latex_text(name) if name else "NA 568 Mobile Robotics, Homework 4",
        "copyright": book.get("copyright", ""),
        "only_build_toc_files": True,
        "exclude_patterns": ["_build/*", "**/.ipynb_checkpoints/*"],
        "execute": {"execute_notebooks": "off"},
        "parse": book["parse"],
        "latex": {"latex_engine": "xelatex", "use_jupyterbook_latex": True,
                  "latex_documents": {"targetname": "hw4_report.tex"}},
        "sphinx": {"local_extensions": {"hw4_book": str(ROOT / "book" / "_ext")},
                   "config": {}},
    }
    keep = ("numfig", "numfig_format", "math_numfig", "math_eqref_format", "nb_merge_streams",
            "mathjax3_config", "latex_elements", "jblatex_captions_to_parts")
    sc = cfg["sphinx"]["config"]
    for key in keep:
        if key in book["sphinx"]["config"]:
            sc[key] = copy.deepcopy(book["sphinx"]["config"][key])
    # a report of about 15 pages: no contents page (five chapters)
    elements = sc.setdefault("latex_elements", {})
    elements["tableofcontents"] = ""
    # figures float near their text (the book's "!htp" and float settings; flafter keeps each
    # after its anchor): a figure too tall for the rest of a page goes to the next one while the
    # answer's text fills the gap, instead of leaving the page half empty. The answers cite
    # every figure by number.
    elements["figure_align"] = "!htbp"
    # a task starts on the page where the last one ends, after all its figures (placeins'
    # \FloatBarrier), under a compact heading ("Task N: ..." is the chapter's own title, the
    # book's "Chapter N" banner would repeat it)
    elements["fncychap"] = ""
    elements["preamble"] = elements.get("preamble", "") + REPORT_PREAMBLE
    sc["latex_additional_files"] = [str(ROOT / f) for f in
                                    book["sphinx"]["config"].get("latex_additional_files", [])]
    sc["hw4_course_author"] = "" if name else "Homework report (no student name given)"
    sc["today"] = date or TERM  # the title page's date, never the build day
    sc["extensions"] = ["sphinx_togglebutton", "sphinx_copybutton", "myst_nb", "jupyter_book",
                        "sphinx_comments", "sphinx_external_toc", "sphinx_design",
                        "sphinx_book_theme", "hw4_book"]
    return yaml.safe_dump(cfg, sort_keys=False, allow_unicode=True)


def build_sources(out: str | Path = SRC, name: str | None = None, root: Path = ROOT,
                  report_dir: Path | None = None, date: str | None = None) -> dict[int, list[str]]:
    """Write the report's Jupyter Book source into ``out``; return the figures of each task.

    Nothing is written when a marker or a caption's reference cannot be resolved
    (:class:`InputError`, one sentence)."""
    report_dir = Path(report_dir or root / "report")
    out = Path(out)
    equations = background_equations(root / "book" / "background.ipynb")
    videos = _video_text(chapter_videos(_load(root / TASKS[5])))
    books, placed, texts, nbs, prints = {}, {}, {}, {}, []
    for task, rel in TASKS.items():
        text_path = report_dir / f"task{task}.md"
        if not text_path.is_file():
            raise InputError(f"{text_path} is missing: the report has one text per task.")
        nbs[task] = _load(root / rel)
        texts[task] = text_path.read_text(encoding="utf-8").replace("{{video}}", videos)
    names = {p[1].split()[0] for t in TASKS for p in _plan(t, texts[t], nbs[t]) if p[0] != "md"}
    for task in TASKS:
        others = [nbs[t] for t in TASKS if t != task]
        books[task], placed[task] = task_notebook(task, texts[task], nbs[task], equations, names,
                                                  others, prints)
    intro = (report_dir / "intro.md").read_text(encoding="utf-8")
    who = name or "(no name given)"
    intro = (intro.replace("{{student}}", who).replace("{{video}}", videos)
             .replace("{{date}}", date or TERM))
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    try:
        for make, src, rel in prints:
            make(src, out / rel)
    except InputError:
        shutil.rmtree(out)
        raise
    (out / "intro.md").write_text(intro, encoding="utf-8")
    for task, nb in books.items():
        (out / f"task{task}.ipynb").write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n",
                                               encoding="utf-8")
    (out / "_toc.yml").write_text(
        "format: jb-book\nroot: intro\nparts:\n  - numbered: true\n    chapters:\n"
        + "".join(f"      - file: task{t}\n" for t in TASKS), encoding="utf-8")
    (out / "_config.yml").write_text(_config(name, date), encoding="utf-8")
    static = root / "notebooks" / "_static"  # the stills of {video} figures
    if static.is_dir():
        os.symlink(static, out / "_static", target_is_directory=True)
    return placed


def missing_figures(tex: str | Path, required: dict[int, list[str]] | None = None) -> list[str]:
    """The required figures whose label is not in the report's LaTeX file ``tex``."""
    text = Path(tex).read_text(encoding="utf-8")
    labels = set(re.findall(r"\\label\{\\detokenize\{task\d:([\w-]+)\}\}", text))
    required = required or required_figures()
    return [n for figs in required.values() for n in figs if n not in labels]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m hw4.book.report",
                                description="Write the report edition's Jupyter Book source.")
    p.add_argument("--name", default=None, help="the student's name for the title page")
    p.add_argument("--date", default=os.environ.get("HW4_REPORT_DATE") or None,
                   help=f"the title page's date (default: $HW4_REPORT_DATE, else {TERM!r})")
    p.add_argument("--out", default=str(ROOT / SRC), help=f"output folder (default: {SRC})")
    args = p.parse_args(argv)
    try:
        placed = build_sources(args.out, args.name, date=args.date)
    except InputError as e:
        print(f"report: {e}", file=sys.stderr)
        return 2
    required = required_figures()
    for task, figs in required.items():
        gone = [f for f in figs if f not in placed[task]]
        if gone:
            print(f"report: warning: Task {task}'s required figure(s) {', '.join(gone)} are not "
                  f"in the report (not asked for in report/task{task}.md, or the chapter's image "
                  "file is missing); tests/test_report.py fails until they are.", file=sys.stderr)
    print(f"report: source in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
