"""Find a submission's four files: in a folder, or in a ``.tgz`` / ``.tar.gz`` / ``.zip`` extracted
safely (regular files and folders only: no links, devices, absolute or ``..`` paths; caps on the
size and the number of files; odd names kept out of the copy)."""
from __future__ import annotations

import re
import shutil
import stat
import tarfile
import zipfile
from pathlib import Path, PurePosixPath

from ..core.errors import InputError

TASK_FILES = {1: ("ogm_CSM.py",), 2: ("ogm_continuous_CSM.py",), 3: ("ogm_S_CSM.py",),
              4: ("ogm_continuous_S_CSM.py", "ogm_continous_S_CSM.py")}
MAX_FILES = 200
MAX_BYTES = 20 * 2**20        # extracted size of the whole archive
MAX_FILE_BYTES = 5 * 2**20    # one file
MAX_DEPTH = 16                # folders in a member's path
SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$")
ARCHIVES = (".tgz", ".tar.gz", ".tar", ".zip")


def is_archive(path: Path) -> bool:
    return path.is_file() and path.name.lower().endswith(ARCHIVES)


def _member_parts(name: str) -> tuple:
    p = PurePosixPath(name.replace("\\", "/"))
    if p.is_absolute() or name.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:", name):
        raise InputError(f"the archive holds an absolute path ({name!r}): refused")
    if any(part == ".." for part in p.parts):
        raise InputError(f"the archive holds a path leaving its folder ({name!r}): refused")
    parts = tuple(x for x in p.parts if x not in ("", "."))
    if len(parts) > MAX_DEPTH:
        raise InputError(f"the archive holds a path {len(parts)} folders deep: refused")
    return parts


def extract(archive: Path, dest: Path) -> list[str]:
    """Extract ``archive`` into ``dest`` safely; return notes on what was skipped."""
    notes = []
    total = 0
    count = 0
    dest.mkdir(parents=True, exist_ok=True)

    def write(parts, reader, size):
        nonlocal total, count
        count += 1
        if count > MAX_FILES:
            raise InputError(f"the archive holds more than {MAX_FILES} files: refused")
        if size > MAX_FILE_BYTES:
            raise InputError(f"{'/'.join(parts)} is {size / 2**20:.1f} MB, more than the "
                             f"{MAX_FILE_BYTES / 2**20:.0f} MB a file may have: refused")
        total += size
        if total > MAX_BYTES:
            raise InputError(f"the archive unpacks to more than {MAX_BYTES / 2**20:.0f} MB: refused")
        if not all(SAFE_NAME.match(x) for x in parts):
            notes.append(f"skipped a file with an unusual name: {'/'.join(parts)!r}")
            return
        if parts[-1].startswith("._") or "__MACOSX" in parts:
            return
        target = dest.joinpath(*parts)
        target.parent.mkdir(parents=True, exist_ok=True)
        with reader() as src, open(target, "wb") as out:
            left = MAX_FILE_BYTES + 1
            while True:
                chunk = src.read(min(1 << 16, left))
                if not chunk:
                    break
                left -= len(chunk)
                if left <= 0:  # the header lied about the size
                    raise InputError(f"{'/'.join(parts)} is larger than its header says: refused")
                out.write(chunk)

    name = archive.name.lower()
    try:
        if name.endswith(".zip"):
            with zipfile.ZipFile(archive) as z:
                for info in z.infolist():
                    parts = _member_parts(info.filename)
                    mode = info.external_attr >> 16
                    if info.is_dir() or not parts:
                        continue
                    if stat.S_ISLNK(mode):
                        notes.append(f"skipped a link: {info.filename!r}")
                        continue
                    write(parts, lambda info=info: z.open(info), info.file_size)
        else:
            with tarfile.open(archive, "r:*") as t:
                for m in t:
                    parts = _member_parts(m.name)
                    if m.isdir() or not parts:
                        continue
                    if not m.isfile():
                        notes.append(f"skipped {'a link' if m.issym() or m.islnk() else 'a special file'}"
                                     f": {m.name!r}")
                        continue
                    write(parts, lambda m=m: t.extractfile(m), m.size)
    except (tarfile.TarError, zipfile.BadZipFile, EOFError, OSError, UnicodeDecodeError) as e:
        raise InputError(f"{archive.name} is not a readable archive ({type(e).__name__}: {e})")
    return notes


def find_root(folder: Path, notes: list | None = None) -> Path:
    """The folder holding the task files: ``folder`` itself or its one subfolder that has them
    (of several: the one with the most task files, said in ``notes``)."""
    def score(d):
        return sum(any((d / f).is_file() for f in names) for names in TASK_FILES.values())
    if score(folder):
        return folder
    dirs, level = [], [folder]
    for _ in range(6):  # breadth first, a few levels (a folder nested thousands deep is fine)
        level = [d for p in level for d in _subfolders(p)]
        dirs += level
    cands = [d for d in sorted(dirs) if score(d)]
    if not cands:
        raise InputError("no task file (ogm_CSM.py, ogm_continuous_CSM.py, ogm_S_CSM.py, "
                         "ogm_continuous_S_CSM.py) found in the submission")
    best = max(cands, key=lambda d: (score(d), -len(d.parts)))
    if len(cands) > 1 and notes is not None:
        others = ", ".join(str(d.relative_to(folder)) for d in cands if d != best)
        notes.append(f"task files are in several folders: graded {best.relative_to(folder)} "
                     f"(the one with the most), not {others}")
    return best


def _subfolders(p: Path) -> list:
    try:
        return [d for d in p.iterdir() if d.name != "__MACOSX" and not d.is_symlink()
                and d.is_dir()]
    except OSError:
        return []


def collect(root: Path, dest: Path) -> tuple[dict, list[str]]:
    """Copy the submission's Python files and helper packages (no links, no odd names) from
    ``root`` to ``dest``.

    Returns ({task: file name or None}, notes)."""
    dest.mkdir(parents=True, exist_ok=True)
    notes = []
    for f in sorted(root.iterdir()):
        if f.is_symlink():
            notes.append(f"skipped a link: {f.name!r}")
            continue
        if f.is_dir() and (f / "__init__.py").is_file() and SAFE_NAME.match(f.name) \
                and f.name != "hw4":  # a helper package of the submission
            _copy_package(f, dest / f.name, notes)
            continue
        if not f.is_file() or not f.name.endswith(".py"):
            continue
        if not SAFE_NAME.match(f.name):
            notes.append(f"skipped a file with an unusual name: {f.name!r}")
            continue
        if f.name == "utils.py":
            notes.append("the submission's utils.py is replaced by the template's")
            continue
        if f.stat().st_size > MAX_FILE_BYTES:
            notes.append(f"skipped {f.name}: larger than {MAX_FILE_BYTES / 2**20:.0f} MB")
            continue
        shutil.copyfile(f, dest / f.name)
    found = {}
    for task, names in TASK_FILES.items():
        found[task] = next((n for n in names if (dest / n).is_file()), None)
    return found, notes


def _copy_package(src: Path, dest: Path, notes: list, depth: int = 0) -> None:
    """Copy a helper package's .py files and subpackages (no links, safe names, 4 levels)."""
    if depth > 4:
        return
    dest.mkdir(parents=True, exist_ok=True)
    for f in sorted(src.iterdir()):
        if f.is_symlink() or not SAFE_NAME.match(f.name):
            notes.append(f"skipped {src.name}/{f.name!r} (a link or an unusual name)")
        elif f.is_dir() and (f / "__init__.py").is_file():
            _copy_package(f, dest / f.name, notes, depth + 1)
        elif f.is_file() and f.name.endswith(".py") and f.stat().st_size <= MAX_FILE_BYTES:
            shutil.copyfile(f, dest / f.name)
