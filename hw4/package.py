"""The homework submission: ``python -m hw4 package --uniqname NAME``.

Gradescope takes two attachments (handout, "Submission Instructions"):

1. ``NAME_hw4.tgz`` holding the directory ``NAME_hw4/`` with the four model files
   ``ogm_CSM.py``, ``ogm_continuous_CSM.py``, ``ogm_S_CSM.py``, ``ogm_continuous_S_CSM.py``
   (plus ``ogm_continous_S_CSM.py``, the misspelt module name the course's ``run.py`` imports);
2. ``NAME_hw4.pdf``, the written part: the report edition of the book (``report/``,
   :mod:`hw4.book.report`), about 15 pages with each task's question, required figures and
   answer, the student's name on its title page.

Task 5 asks for "a video of the mapping sequence included in the submission": the tgz also holds
``NAME_hw4/videos/`` with the mapping videos the Task 5 chapter shows (:data:`VIDEOS`: RViz while
the reference package maps SemanticKITTI sequence 04, recorded by ``scripts/reference_ros.sh``,
and ours of the same scans), or the files given with ``--video``.

The four files in ``hw4/`` are thin faces over the package's shared core (``template``,
``evidence``, ``grid``, ``sensor``, ``kernel``, ``posterior``, ...). So that they run next to the
course's ``run.py`` and ``utils.py`` without the rest of this repository, the packager follows
their imports (statically, through the module sources), copies every ``hw4`` module they need
into ``NAME_hw4/hw4core/``, and rewrites the imports that would otherwise reach ``hw4``:
``from .template import X`` in a face becomes ``from hw4core.template import X``, a face that
imports another face imports it as a top-level module, and absolute ``hw4.x`` imports become
``hw4core.x``. Relative imports between core modules stay as they are. Before writing anything
the bundle is imported in a fresh interpreter with ``hw4`` made unimportable, so a submission
that would fail to import is never written.

Errors raise :class:`hw4.core.errors.InputError` with one sentence.
"""
from __future__ import annotations

import argparse
import ast
import io
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from .core.errors import InputError

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_ROOT = PACKAGE_DIR.parent
CORE = "hw4core"
FACES = ("ogm_CSM", "ogm_continuous_CSM", "ogm_S_CSM", "ogm_continuous_S_CSM",
         "ogm_continous_S_CSM")
CLASSES = {"ogm_CSM": "ogm_CSM", "ogm_continuous_CSM": "ogm_continuous_CSM",
           "ogm_S_CSM": "ogm_S_CSM", "ogm_continuous_S_CSM": "ogm_continuous_S_CSM",
           "ogm_continous_S_CSM": "ogm_continous_S_CSM"}
PDF_CANDIDATES = ("_build/hw4_report.pdf",)
"""The report edition's PDF (``bash scripts/build_book.sh report``), relative to the project."""
UNIQNAME = re.compile(r"[a-z0-9]{1,8}")
VIDEOS = ("notebooks/_static/t5_rviz_kitti04_mapping.mp4", "notebooks/_static/t5_kitti04_mapping.mp4")
"""The Task 5 mapping videos of sequence 04 the report names, relative to the project: RViz
running the reference package (``scripts/reference_ros.sh --book``) and ours (written by
notebooks/T5_bki_3d.ipynb). The toy example's video stays in the course book."""
VIDEO_SUFFIXES = (".mp4", ".gif", ".webm", ".mkv", ".mov", ".avi")

README = """\
{name}_hw4: NA 568 Homework 4 (mapping with counting sensor models)

ogm_CSM.py               Task 1, discrete counting sensor model
ogm_continuous_CSM.py    Task 2, continuous counting sensor model
ogm_S_CSM.py             Task 3, semantic counting sensor model
ogm_continuous_S_CSM.py  Task 4, continuous semantic counting sensor model
ogm_continous_S_CSM.py   the same class under the name the course's run.py imports
hw4core/                 the shared implementation the four files import
videos/                  Task 5: the map growing scan by scan ({videos})

Put the course's run.py, utils.py and data/ next to these files and run
    python run.py --task_num N --plot
Needs numpy and scipy (tqdm only for progress bars). Import-checked when packaged with
Python {python}, numpy {numpy} and scipy {scipy}; the code uses only Python 3.8 syntax,
so Python 3.8 to 3.10 should work too but was not tested.
"""


# --------------------------------------------------------------------------- import analysis

def _module_file(module: str) -> Path | None:
    """Source file of a dotted ``hw4`` module name, or None when it is not a module of ``hw4``."""
    parts = module.split(".")
    if parts[0] != "hw4":
        return None
    base = PACKAGE_DIR.joinpath(*parts[1:])
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE_DIR).with_suffix("")
    parts = ["hw4", *rel.parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _package_of(module: str, path: Path) -> str:
    """The package a module's relative imports are resolved against."""
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _targets(node: ast.AST, module: str, path: Path) -> list[str]:
    """Absolute names of the ``hw4`` modules an import statement loads (possibly none)."""
    out = []
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name == "hw4" or alias.name.startswith("hw4."):
                out.append(alias.name)
    elif isinstance(node, ast.ImportFrom):
        if node.level:
            pkg = _package_of(module, path).split(".")
            if node.level - 1 >= len(pkg):
                raise InputError(f"{path} has a relative import beyond the hw4 package.")
            base = ".".join(pkg[: len(pkg) - (node.level - 1)])
            absolute = f"{base}.{node.module}" if node.module else base
        else:
            absolute = node.module or ""
        if absolute == "hw4" or absolute.startswith("hw4."):
            out.append(absolute)
            for alias in node.names:  # `from . import data` imports the submodule hw4.core.data
                if _module_file(f"{absolute}.{alias.name}") is not None:
                    out.append(f"{absolute}.{alias.name}")
    return out


def _parse(path: Path) -> ast.Module:
    try:
        return ast.parse(path.read_text(), filename=str(path))
    except (OSError, SyntaxError) as e:
        raise InputError(f"{path} cannot be read as Python source ({e}).") from None


def needed_modules() -> dict[str, Path]:
    """Every ``hw4`` module the five face files import, directly or through other modules.

    Returns ``{dotted name: source path}``, faces included; imports inside functions count too.
    Parent packages of a needed module are included (their ``__init__`` runs on import).
    """
    todo = []
    for face in FACES:
        path = PACKAGE_DIR / f"{face}.py"
        if not path.is_file():
            raise InputError(f"hw4/{face}.py is missing, so there is nothing to package for it.")
        todo.append((f"hw4.{face}", path))
    seen: dict[str, Path] = {}
    while todo:
        module, path = todo.pop()
        if module in seen:
            continue
        seen[module] = path
        for node in ast.walk(_parse(path)):
            for target in _targets(node, module, path):
                tpath = _module_file(target)
                if tpath is None:
                    if target != "hw4":
                        raise InputError(f"{path} imports {target}, which is not a module of hw4.")
                    continue
                todo.append((target, tpath))
                parent = target.rpartition(".")[0]
                while parent.count(".") >= 1:  # hw4.bki.x needs hw4/bki/__init__.py
                    ppath = _module_file(parent)
                    if ppath is not None:
                        todo.append((parent, ppath))
                    parent = parent.rpartition(".")[0]
    return seen


# --------------------------------------------------------------------------- rewriting

def _bundle_name(module: str) -> str:
    """Where a ``hw4`` module lives in the bundle: faces at top level, the rest under hw4core."""
    tail = module[len("hw4"):].lstrip(".")
    if tail in FACES:
        return tail
    return f"{CORE}.{tail}" if tail else CORE


def _rewrite(source: str, module: str, path: Path, is_face: bool) -> str:
    """Rewrite the import statements of one module for the bundle layout."""
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    offsets = [0]
    for line in lines:
        offsets.append(offsets[-1] + len(line))
    edits = []
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Import, ast.ImportFrom)) or not _targets(node, module, path):
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level and not is_face:
                absolute = _targets(node, module, path)[0]
                if not absolute[len("hw4"):].lstrip(".") in FACES:
                    continue  # relative import between core modules: unchanged layout
            absolute = _targets(node, module, path)[0]
            new = ast.ImportFrom(module=_bundle_name(absolute), names=node.names, level=0)
        else:
            new = ast.Import(names=[ast.alias(name=_bundle_name(a.name), asname=a.asname
                                              or (a.name if "." not in a.name else None))
                                    if a.name == "hw4" or a.name.startswith("hw4.") else a
                                    for a in node.names])
            if any("." in a.name and a.asname is None and a.name.startswith("hw4.")
                   for a in node.names):
                raise InputError(f"{path} uses `import {node.names[0].name}` without `as`; "
                                 "write `from hw4 import ...` so it can be packaged.")
        start = offsets[node.lineno - 1] + node.col_offset
        end = offsets[node.end_lineno - 1] + node.end_col_offset
        edits.append((start, end, ast.unparse(new)))
    for start, end, text in sorted(edits, reverse=True):
        source = source[:start] + text + source[end:]
    return source


def write_bundle(folder: Path) -> list[Path]:
    """Write the face files and ``hw4core/`` into ``folder``; return the files written."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for module, path in sorted(needed_modules().items()):
        is_face = module.rpartition(".")[2] in FACES and module.count(".") == 1
        target = _bundle_name(module).replace(".", "/")
        dest = folder / (f"{target}/__init__.py" if path.name == "__init__.py" else f"{target}.py")
        if module == "hw4":  # the package root: a fresh, import-free __init__ for hw4core
            text = '"""Shared core of the hw4 package, bundled with the homework files."""\n'
        else:
            text = _rewrite(path.read_text(), module, path, is_face)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(text)
        written.append(dest)
    core_init = folder / CORE / "__init__.py"
    if not core_init.exists():
        core_init.write_text('"""Shared core of the hw4 package, bundled with the homework files."""\n')
        written.append(core_init)
    for sub in (folder / CORE).rglob("*"):  # sub-packages need an __init__ to import
        if sub.is_dir() and not (sub / "__init__.py").exists():
            (sub / "__init__.py").write_text("")
            written.append(sub / "__init__.py")
    return written


CHECK = """\
import sys
sys.modules["hw4"] = None  # the bundle must not reach the repository's package
{imports}
print("ok")
"""


def check_bundle(folder: Path, timeout: float = 120) -> None:
    """Import the five face classes from ``folder`` in a fresh interpreter without ``hw4``."""
    imports = "\n".join(f"from {m} import {c}" for m, c in CLASSES.items())
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    res = subprocess.run([sys.executable, "-c", CHECK.format(imports=imports)], cwd=folder,
                         env=env, capture_output=True, text=True, timeout=timeout)
    if res.returncode != 0 or res.stdout.strip() != "ok":
        last = (res.stderr.strip().splitlines() or ["no error message"])[-1]
        raise InputError(f"the bundled homework files do not import on their own ({last}).")


# --------------------------------------------------------------------------- the package

def validate_uniqname(name: str) -> str:
    """Return ``name`` when it is a UMich uniqname (1-8 lowercase letters or digits)."""
    if not isinstance(name, str) or not UNIQNAME.fullmatch(name):
        raise InputError(f"uniqname {name!r} is not valid: use your UMich uniqname, 1 to 8 "
                         "lowercase letters or digits (for example 'jdoe').")
    return name


def find_pdf(pdf: str | Path | None = None) -> Path:
    """The written part: ``pdf`` when given, else the built report under ``_build/``."""
    if pdf is not None:
        path = Path(pdf)
        if path.is_dir():
            raise InputError(f"--pdf {path} is a folder, not a PDF file.")
        if not path.is_file():
            raise InputError(f"the PDF {path} does not exist: build the report with "
                             "`bash scripts/build_book.sh report` or give the path of your PDF.")
        try:
            with open(path, "rb") as f:
                head = f.read(5)
        except OSError as e:
            raise InputError(f"cannot read the PDF {path} ({e.strerror}).") from None
        if head != b"%PDF-":
            raise InputError(f"{path} is not a PDF file.")
        return path
    for rel in PDF_CANDIDATES:
        path = PROJECT_ROOT / rel
        if path.is_file() and path.stat().st_size > 0:
            return path
    raise InputError("the report PDF has not been built yet (no _build/hw4_report.pdf): run "
                     "`bash scripts/build_book.sh report` first, or pass --pdf PATH.")


def build_named_pdf(name: str, date: str | None = None) -> Path | None:
    """Build the report edition with ``name`` on its title page; return its path.

    Runs ``scripts/build_book.sh report`` with ``HW4_BOOK_AUTHOR=name`` (the report's author and
    the PDF's metadata author) and, with ``date``, ``HW4_REPORT_DATE=date`` (the title page's
    date; without it the handout's term, "Winter 2023"), which writes ``_build/hw4_report.pdf``. Returns None when this checkout has no build script
    (then the report already built is used).
    """
    script = PROJECT_ROOT / "scripts" / "build_book.sh"
    if not script.is_file():
        return None
    env = dict(os.environ, HW4_BOOK_AUTHOR=name)
    env.pop("HW4_REPORT_DATE", None)
    if date:
        env["HW4_REPORT_DATE"] = date
    pdf = PROJECT_ROOT / PDF_CANDIDATES[0]
    # the build removes the old PDF first: keep a copy to fall back on if it fails
    backup = None
    if pdf.is_file():
        backup = Path(tempfile.mkdtemp(prefix="hw4-pdf-")) / pdf.name
        shutil.copyfile(pdf, backup)
    print(f"package: building the report PDF with {name} on its title page", file=sys.stderr)
    try:
        res = subprocess.run(["bash", str(script), "report"], cwd=PROJECT_ROOT, env=env,
                             capture_output=True, text=True)
        if res.returncode == 0 and pdf.is_file():
            return pdf
        last = ((res.stderr.strip() or res.stdout.strip()).splitlines() or ["no message"])[-1]
        if backup is None:
            raise InputError(f"building the report PDF with your name failed ({last}); fix the "
                             "report build or pass --pdf PATH.")
        pdf.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(backup, pdf)
        print(f"package: note: building the report with your name failed ({last}); using the "
              "report built before, without your name on its title page.", file=sys.stderr)
        return pdf
    finally:
        if backup is not None:
            shutil.rmtree(backup.parent, ignore_errors=True)


def find_videos(videos=None) -> list[Path]:
    """The videos to submit: ``videos`` (paths) when given, else the chapter's :data:`VIDEOS`."""
    if videos:
        paths = [Path(v) for v in videos]
        for path in paths:
            if not path.is_file():
                raise InputError(f"--video {path} is not a file.")
            if path.suffix.lower() not in VIDEO_SUFFIXES:
                raise InputError(f"--video {path} is not a video ({', '.join(VIDEO_SUFFIXES)}).")
        names = [p.name for p in paths]
        if len(set(names)) != len(names):
            raise InputError("two --video files have the same name; rename one.")
        return paths
    paths = [PROJECT_ROOT / v for v in VIDEOS]
    missing = [p for p in paths if not p.is_file()]
    if missing:
        how = ("bash scripts/reference_ros.sh --book" if "rviz" in missing[0].name
               else "notebooks/T5_bki_3d.ipynb")
        raise InputError(f"the Task 5 video {missing[0]} is missing: run {how} "
                         "to write it, or pass --video PATH.")
    return paths


def _reset(info: tarfile.TarInfo) -> tarfile.TarInfo:
    info.uid = info.gid = 0
    info.uname = info.gname = ""
    info.mode = 0o755 if info.isdir() else 0o644
    return info


def build_package(uniqname: str, pdf: str | Path | None = None, out: str | Path = ".",
                  force: bool = False, videos=None, date: str | None = None) -> tuple[Path, Path]:
    """Write ``NAME_hw4.tgz`` and ``NAME_hw4.pdf`` into ``out``; return their paths.

    Parameters
    ----------
    uniqname : str
        UMich uniqname (1-8 lowercase letters or digits).
    pdf : path, optional
        The written part; default: the report edition, built with ``uniqname`` on its title
        page (:func:`build_named_pdf`), or ``_build/hw4_report.pdf`` in a checkout without the
        build script.
    out : path
        Output folder (created when missing).
    force : bool
        Overwrite an existing ``NAME_hw4.tgz`` / ``NAME_hw4.pdf``.
    videos : list of paths, optional
        Videos for ``NAME_hw4/videos/`` (default: :data:`VIDEOS`).
    date : str, optional
        The report's title-page date (default: the handout's term, "Winter 2023"); only used
        when the report is built here (no ``pdf``).
    """
    from .core.atomic import Outputs

    name = validate_uniqname(uniqname)
    if date is not None and (not date.strip() or len(date) > 40 or "\n" in date):
        raise InputError(f"--date {date!r} is not a date for the title page: give a short "
                         "line such as 'March 17, 2023'.")
    pdf_path = find_pdf(pdf if pdf is not None else build_named_pdf(name, date))
    video_paths = find_videos(videos)
    out = Path(out)
    tgz, pdf_out = out / f"{name}_hw4.tgz", out / f"{name}_hw4.pdf"
    same_pdf = pdf_out.exists() and pdf_path.resolve() == pdf_out.resolve()
    names = [tgz.name] + ([] if same_pdf else [pdf_out.name])
    with Outputs(out, names, force=force) as o, tempfile.TemporaryDirectory() as tmp:
        _write_package(name, pdf_path, Path(tmp), o, same_pdf, video_paths)
    return tgz, pdf_out


def _versions() -> dict:
    import numpy
    import scipy
    return {"python": ".".join(map(str, sys.version_info[:3])), "numpy": numpy.__version__,
            "scipy": scipy.__version__}


def _write_package(name: str, pdf_path: Path, tmp: Path, o, same_pdf: bool,
                   videos=()) -> None:
    """Bundle, check and write the two attachments through ``o`` (:class:`hw4.core.atomic.Outputs`)."""
    folder = tmp / f"{name}_hw4"
    write_bundle(folder)
    (folder / "README.txt").write_text(README.format(
        name=name, videos=", ".join(v.name for v in videos) or "none", **_versions()))
    check_bundle(folder)
    if videos:
        (folder / "videos").mkdir()
        for v in videos:
            try:
                shutil.copyfile(v, folder / "videos" / v.name)
            except OSError as e:
                raise InputError(f"cannot read the video {v} ({e.strerror}).") from None
    for cache in folder.rglob("__pycache__"):
        shutil.rmtree(cache)
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        tar.add(folder, arcname=folder.name, filter=_reset, recursive=False)
        for path in sorted(folder.rglob("*")):
            tar.add(path, arcname=f"{folder.name}/{path.relative_to(folder).as_posix()}",
                    filter=_reset, recursive=False)
    o[f"{name}_hw4.tgz"].write_bytes(buf.getvalue())
    if not same_pdf:
        try:
            shutil.copyfile(pdf_path, o[f"{name}_hw4.pdf"])
        except OSError as e:
            if e.filename and Path(e.filename) == pdf_path:
                raise InputError(f"cannot read the PDF {pdf_path} ({e.strerror}).") from None
            raise


# --------------------------------------------------------------------------- CLI

def _run(args: argparse.Namespace) -> int:
    tgz, pdf = build_package(args.uniqname, pdf=args.pdf, out=args.out, force=args.force,
                             videos=getattr(args, "video", None), date=getattr(args, "date", None))
    print(f"wrote {tgz} and {pdf}: upload both to Gradescope")
    return 0


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``package`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "package", help="make the homework submission NAME_hw4.tgz and NAME_hw4.pdf",
        description="Make the submission: NAME_hw4.tgz (directory NAME_hw4/ with the four "
                    "ogm_*.py files, runnable with the course's run.py and utils.py without "
                    "this repository) and the report PDF (the book's short edition, with your "
                    "name) as NAME_hw4.pdf.")
    p.add_argument("--uniqname", required=True, help="your UMich uniqname (1-8 lowercase letters/digits)")
    p.add_argument("--pdf", default=None,
                   help="PDF of the written part (default: the report edition, built with "
                        "your uniqname on its title page)")
    p.add_argument("--out", default=".", help="output folder (default: current folder)")
    p.add_argument("--video", action="append", default=None, metavar="PATH",
                   help="a Task 5 video for NAME_hw4/videos/ (repeat for more; default: the "
                        "two sequence 04 mapping videos the report names: RViz's and ours)")
    p.add_argument("--date", default=None,
                   help="the date on the report's title page (default: the handout's term, "
                        "'Winter 2023')")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=_run)
    return p
