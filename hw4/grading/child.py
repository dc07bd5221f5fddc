"""The trusted wrapper that runs ONE task of a submission inside the sandbox (a separate process).

Run as ``python -I -S child.py TASK GRID_SIZE DATA.mat SITE`` with the working directory the
scratch folder (the submission's files in ``sub/``, the grader's ``utils`` in ``support/``). It
imports nothing from ``hw4`` (the package is not importable here), drives the student's class the
way the course's ``run.py`` does and writes plain arrays only: ``out/mean.npy``,
``out/variance.npy`` (``allow_pickle=False``) and ``out/meta.json``; a failure is one line in
``out/error.txt``. The grader validates everything it reads back: nothing here is trusted.
"""
import importlib.abc
import inspect
import json
import os
import sys
import traceback

MODULES = {1: ("ogm_CSM",), 2: ("ogm_continuous_CSM",), 3: ("ogm_S_CSM",),
           4: ("ogm_continuous_S_CSM", "ogm_continous_S_CSM")}
DATA_KEYS = ("robotPose", "laserScan")


class _Blocked(importlib.abc.MetaPathFinder):
    """Refuse the grader's own package: a submission must not call the reference solution."""

    def find_spec(self, name, path=None, target=None):
        if name == "hw4" or name.startswith("hw4."):
            raise ImportError(f"No module named {name!r} (the grader's package is not available "
                              "to submissions)")
        return None


def _fail(msg: str) -> int:
    with open(os.path.join("out", "error.txt"), "w") as f:
        f.write(msg[:2000])
    return 1


def _student_frame(exc) -> str:
    """' (file.py, line N)' of the deepest frame in the submission's own files."""
    where = ""
    sub = os.path.abspath("sub")
    for fr in traceback.extract_tb(exc.__traceback__):
        if os.path.abspath(fr.filename).startswith(sub):
            where = f" ({os.path.relpath(fr.filename, sub)}, line {fr.lineno})"
    return where


def _load_class(task: int):
    import importlib
    last = None
    for mod_name in MODULES[task]:
        if not os.path.exists(os.path.join("sub", mod_name + ".py")):
            continue
        mod = importlib.import_module(mod_name)
        for cls_name in MODULES[task]:
            cls = getattr(mod, cls_name, None)
            if inspect.isclass(cls):
                return cls
        found = [c for _, c in inspect.getmembers(mod, inspect.isclass)
                 if c.__module__ == mod.__name__ and hasattr(c, "construct_map")
                 and hasattr(c, "build_ogm")]
        if len(found) == 1:
            return found[0]
        last = f"{mod_name}.py defines no class {MODULES[task][0]}"
    raise LookupError(last or f"{MODULES[task][0]}.py is missing from the submission")


def _accepts(fn, name: str) -> bool:
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def main(argv) -> int:
    task, grid_size, data_path, site = int(argv[1]), float(argv[2]), argv[3], argv[4]
    os.makedirs("out", exist_ok=True)
    sys.meta_path.insert(0, _Blocked())
    sys.path[:] = [os.path.abspath("sub"), os.path.abspath("support"), site] + [
        p for p in sys.path if p.startswith(sys.base_prefix) and "site-packages" not in p]
    os.environ["TQDM_DISABLE"] = "1"
    try:
        import numpy as np
        from scipy.io import loadmat
        raw = loadmat(data_path)
        pose, scan = (raw[k] for k in DATA_KEYS)
    except Exception as e:  # the grader's own data: a setup problem, not the student's
        return _fail(f"grader setup: cannot load the data ({type(e).__name__}: {e})")
    stage = "importing the submission"
    try:
        cls = _load_class(task)
        stage = "constructing the map object"
        passed = _accepts(cls.__init__, "grid_size")
        ogm = cls(grid_size=grid_size) if passed else cls()
        if not passed:  # as the course's run.py sets the resolution of a template object
            ogm.grid_size = grid_size
            if hasattr(ogm, "w_obstacle"):
                ogm.w_obstacle = 2 * grid_size
        stage = "construct_map"
        ogm.construct_map(pose, scan)
        stage = "build_ogm"
        if _accepts(ogm.build_ogm, "disable_print"):
            ogm.build_ogm(disable_print=True)
        else:
            ogm.build_ogm()
        stage = "reading map['mean'] and map['variance']"
        m = ogm.map
        mean = np.array(m["mean"], dtype=np.float64)
        variance = np.array(m["variance"], dtype=np.float64)
    except BaseException as e:  # noqa: BLE001 - everything a submission raises is its result
        if isinstance(e, MemoryError):
            return _fail(f"ran out of memory while {stage}")
        msg = str(e).splitlines()[0][:300] if str(e) else ""
        return _fail(f"{type(e).__name__} while {stage}{_student_frame(e)}: {msg}")
    meta = {"class": cls.__name__, "grid_size_in_constructor": passed}
    for name in ("prior_alpha", "prior"):
        try:
            v = getattr(ogm, name)
            meta[name] = float(v) if np.ndim(v) == 0 else None
        except Exception:  # noqa: BLE001
            meta[name] = None
    try:
        meta["student_grid_size"] = float(getattr(ogm, "grid_size"))
    except Exception:  # noqa: BLE001
        meta["student_grid_size"] = None
    np.save(os.path.join("out", "mean.npy"), mean, allow_pickle=False)
    np.save(os.path.join("out", "variance.npy"), variance, allow_pickle=False)
    with open(os.path.join("out", "meta.json"), "w") as f:
        json.dump(meta, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
