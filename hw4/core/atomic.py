"""Output files that appear complete or not at all.

Every command that writes files (``run``, ``bki``, ``package``) declares its outputs up front::

    with Outputs(folder, ["map.npz", "map.png"], force=args.force) as out:
        np.savez(out["map.npz"], ...)        # a temporary name in the same folder
        fig.savefig(out["map.png"])
    # here every written file has been renamed into place

Before anything is computed, :class:`Outputs` checks that ``folder`` is (or can be made) a
writable folder and that no output would overwrite a file without ``force`` or replace a folder.
Inside the ``with`` block each output is written to a hidden temporary name beside its target
(``.map.partial-1a2b3c.npz``, same suffix so writers that go by the extension still work). When
the block ends normally the temporary files are renamed into place (``os.replace``: each output
appears whole); when it ends with any exception, ``KeyboardInterrupt`` included, the temporary
files are removed, folders made for the run are removed again when empty, and no file the user
had is touched. A write error (full disk, quota, read-only file system, permission) becomes one
:class:`~hw4.core.errors.InputError` sentence.
"""
from __future__ import annotations

import errno
import os
from pathlib import Path

from .errors import InputError

def _reason(e: OSError) -> str:
    return e.strerror or type(e).__name__


def check_folder(folder: Path, option: str = "--out") -> list[Path]:
    """Make ``folder`` exist as a writable folder; return the folders created (outermost first).

    Raises :class:`InputError` when ``folder`` or one of its parents is a file, or when the folder
    cannot be created or written into (permission, read-only file system, ...).
    """
    folder = Path(folder)
    if str(folder) == "":
        raise InputError(f"{option} is empty: give a folder.")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{option} {folder} is a file, not a folder: choose another {option}.")
    missing = []
    p = folder
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    if p.exists() and not p.is_dir():
        raise InputError(f"{option} {folder} lies under {p}, which is a file, not a folder: "
                         f"choose another {option}.")
    made = []
    try:
        for q in reversed(missing):
            q.mkdir()
            made.append(q)
        fd, probe = _mkstemp(folder, ".write-test", "")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        remove_empty(made)
        raise InputError(f"cannot write into the output folder {folder} ({_reason(e)}): choose "
                         f"another {option}.") from None
    return made


def remove_empty(folders) -> None:
    """Remove the given folders, innermost first, where they are empty (best effort)."""
    for q in reversed(list(folders)):
        try:
            q.rmdir()
        except OSError:
            pass


def _mkstemp(folder: Path, stem: str, suffix: str):
    for _ in range(100):
        path = folder / f"{stem}.partial-{os.urandom(3).hex()}{suffix}"  # (secrets: slow import)
        try:
            return os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644), path
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(folder))


def temporary_name(target: Path) -> Path:
    """A fresh hidden name beside ``target`` with the same suffix (the file is created empty)."""
    target = Path(target)
    suffix = "".join(target.suffixes[-1:])
    stem = "." + (target.name[: -len(suffix)] if suffix else target.name)
    fd, path = _mkstemp(target.parent, stem, suffix)
    os.close(fd)
    return path


class Outputs:
    """A set of output files in one folder, written under temporary names and renamed on success.

    Parameters
    ----------
    folder : Path
        Output folder; created (with its parents) when missing, removed again if the run fails
        and it is still empty.
    names : iterable of str
        File names (in ``folder``) the run may write; only these can be asked for.
    force : bool
        Allow replacing existing files of these names (never folders).
    option : str
        How the user named ``folder`` (for messages), e.g. ``"--out"``.
    """

    def __init__(self, folder, names, force: bool = False, option: str = "--out"):
        self.folder = Path(folder)
        self.names = list(dict.fromkeys(names))
        self.option = option
        self._temps: dict[str, Path] = {}
        self._made: list[Path] = []
        self.written: list[Path] = []
        for n in self.names:
            t = self.folder / n
            if t.is_symlink() or t.exists():
                if t.is_dir():
                    raise InputError(f"{t} is a folder, not a file: move it away or choose another "
                                     f"{option}.")
                if not force:
                    raise InputError(f"{t} already exists: choose another {option} or pass --force.")
        self._made = check_folder(self.folder, option)

    def __enter__(self) -> "Outputs":
        return self

    def __getitem__(self, name: str) -> Path:
        """The temporary path to write output ``name`` to (the same path on every call)."""
        if name not in self.names:
            raise KeyError(f"{name} is not a declared output")
        if name not in self._temps:
            try:
                self._temps[name] = temporary_name(self.folder / name)
            except OSError as e:
                raise self._write_error(name, e) from None
        return self._temps[name]

    path = __getitem__

    def _write_error(self, name, e: OSError) -> InputError:
        return InputError(f"cannot write {self.folder / name} ({_reason(e)}); nothing was written: "
                          f"free some space or choose another {self.option}.")

    def discard(self) -> None:
        """Remove every temporary file (and the folders made for the run, when empty)."""
        for p in self._temps.values():
            try:
                p.unlink()
            except OSError:
                pass
        self._temps.clear()
        remove_empty(self._made)

    def commit(self) -> list[Path]:
        """Rename every written temporary file into place; return the final paths."""
        done = []
        try:
            for name in self.names:
                tmp = self._temps.get(name)
                if tmp is None:
                    continue
                target = self.folder / name
                os.replace(tmp, target)
                del self._temps[name]
                done.append(target)
        except OSError as e:
            self.discard()
            raise self._write_error(name, e) from None
        self.written = done
        return done

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.commit()
            return False
        name, space = None, False
        if isinstance(exc, OSError):
            temps = {str(p): n for n, p in self._temps.items()}
            name = temps.get(str(getattr(exc, "filename", None)))
            space = exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
        self.discard()
        if name is not None:
            raise self._write_error(name, exc) from None
        if space:
            raise InputError(f"cannot write the outputs in {self.folder} ({_reason(exc)}); nothing "
                             f"was written: free some space or choose another "
                             f"{self.option}.") from None
        return False
