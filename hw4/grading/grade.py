"""Grade one submission (or a folder of them): run each task sandboxed, score it, write the results.

:func:`grade` writes ``OUT/results.json`` (Gradescope's format) and ``OUT/report.md`` (with
figures in ``OUT/figures/``) and returns the results dict. Every failure of the submission ends
as a line in the report and 0 points for the task concerned, never as an exception.
"""
from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..core import data as _data
from ..core.errors import InputError
from . import archive, reference, sandbox
from .config import load as load_config

HERE = Path(__file__).parent
MAX_ARRAY_BYTES = 200 * 2**20


def _data_file(task: int) -> Path:
    return _data.ensure(_data.INTEL_SEMANTIC if task > 2 else _data.INTEL)


def _task_points(cfg: dict, grid_sizes: list) -> dict:
    """Points of each (task, grid size) test: a task's points split evenly over grid sizes."""
    return {(t, g): cfg["tasks"][t]["points"] / len(grid_sizes)
            for t in (1, 2, 3, 4) for g in grid_sizes}


def _load_npy(path: Path):
    if not path.is_file():
        return None, "the map arrays were not returned"
    if path.stat().st_size > MAX_ARRAY_BYTES:
        return None, "the returned map is larger than any valid map"
    try:
        return np.load(path, allow_pickle=False), None
    except (ValueError, OSError, EOFError) as e:
        return None, f"the returned map is not a plain array ({type(e).__name__})"


def _read_meta(path: Path) -> dict:
    try:
        meta = json.loads(path.read_text()[:10000])
        return meta if isinstance(meta, dict) else {}
    except (OSError, ValueError):
        return {}


def _prior_candidates(meta: dict) -> list:
    out = []
    for k in ("prior_alpha", "prior"):
        v = meta.get(k)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) and v > 0:
            out.append(float(v))
    out.append(1e-3)
    return out


class _Box:
    """The scratch folder of one child run: the submission's files (fresh copy each run), the
    grader's utils and wrapper, links to numpy/scipy/tqdm, the data, and an empty out/."""

    def __init__(self, base: Path, pristine: Path):
        self.base = base
        self.pristine = pristine

    def fresh(self, task: int) -> Path:
        box = self.base / "box"
        if box.exists():
            shutil.rmtree(box)
        box.mkdir()
        shutil.copytree(self.pristine, box / "sub")
        (box / "support").mkdir()
        shutil.copyfile(HERE / "support" / "utils.py", box / "support" / "utils.py")
        shutil.copyfile(HERE / "child.py", box / "child.py")
        sandbox.make_site(box / "site")  # links into the grader's site-packages, not into /tmp
        (box / "data").mkdir()
        src = _data_file(task)
        shutil.copyfile(src, box / "data" / src.name)  # a copy: never a link to the original
        (box / "out").mkdir()
        for d in (box, box / "support", box / "data"):
            d.chmod(0o755)
        return box


def _run_task(box: Path, task: int, g: float, cfg: dict, slot: int, hide: tuple, timeout=None,
              memory=None):
    limits = sandbox.Limits(timeout=timeout or cfg["timeout"], memory_mb=memory or cfg["memory"],
                            output_cap=cfg["output_cap"])
    user = sandbox.ensure_user(slot)
    py = sandbox.child_python(user is not None)
    data_rel = f"data/{_data_file(task).name}"
    argv = [py, "-I", "-S", "child.py", str(task), repr(g), data_rel, "site"]
    return sandbox.run(argv, box, limits, user=user, hide=hide, writable=("sub", "out"))


def grade(submission: Path, out: Path, *, config: Path | None = None, grid_sizes=None,
          timeout=None, memory=None, visible_only: bool = False, slot: int = 0,
          figures: bool = True, hide: tuple = ()) -> dict:
    """Grade ``submission`` into ``out``; return the results (also in ``out/results.json``).

    Raises :class:`InputError` only when no results can be written (``submission`` missing,
    ``out`` unwritable, bad configuration)."""
    t_start = time.monotonic()
    cfg = load_config(config)
    submission = Path(submission)
    if not submission.exists():
        raise InputError(f"{submission} does not exist")
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".hw4-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise InputError(f"cannot write to {out}: {e.strerror}")
    if grid_sizes:
        visible = [float(x) for x in grid_sizes]
        hidden = []
    else:
        visible, hidden = cfg["grid_sizes"], ([] if visible_only else cfg["hidden_grid_sizes"])
    sizes = visible + [g for g in hidden if g not in visible]
    points = _task_points(cfg, sizes)
    sandbox.set_subreaper()
    base = Path(tempfile.mkdtemp(prefix="hw4grade-"))
    base.chmod(0o711)
    notes: list[str] = []
    tests = []
    hide = tuple(hide) + (str(HERE.parent), str(out.resolve()),
                          str(submission.resolve().parent if submission.is_file() else submission.resolve()))
    hide = _safe_to_hide(hide)
    try:
        pristine = base / "pristine"
        found = None
        try:
            if archive.is_archive(submission):
                raw = base / "raw"
                notes += archive.extract(submission, raw)
                root = archive.find_root(raw)
            elif submission.is_dir():
                root = archive.find_root(submission)
            else:
                raise InputError(f"{submission.name} is neither a folder nor a .tgz/.tar.gz/.zip archive")
            found, more = archive.collect(root, pristine)
            notes += more
        except InputError as e:
            notes.append(f"The submission could not be read: {e}.")
        box_maker = _Box(base, pristine) if found else None
        for g in sizes:
            vis = cfg["visibility"] if g in visible else cfg["hidden_visibility"]
            for task in (1, 2, 3, 4):
                test = _grade_one(task, g, cfg, found, box_maker, slot, hide, timeout, memory,
                                  points[(task, g)], out, figures)
                test["visibility"] = vis
                tests.append(test)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    iso = list(dict.fromkeys(n for t in tests for n in t.get("_isolation", ())))
    total = round(sum(t["score"] for t in tests), 4)
    max_total = round(sum(t["max_score"] for t in tests), 4)
    results = {
        "score": total,
        "execution_time": round(time.monotonic() - t_start, 1),
        "output": _summary(total, max_total, sizes, notes),
        "output_format": "md",
        "tests": [{k: v for k, v in t.items() if not k.startswith("_")} for t in tests],
        "extra_data": {"grid_sizes": sizes, "hw4_grader": 1, "sandbox_limits": iso,
                       "grader_error": any(t.get("_grader_error") for t in tests)},
    }
    from .report import write_report
    write_report(out, results, tests, notes, sizes, cfg, iso)
    tmp = out / ".results.json.tmp"
    tmp.write_text(json.dumps(results, indent=1))
    tmp.replace(out / "results.json")
    return results


def _safe_to_hide(paths) -> tuple:
    """The folders to hide from the child, except those holding what it needs (its Python,
    numpy / scipy / tqdm) and the root folder."""
    import sysconfig
    need = [os.path.realpath(sysconfig.get_paths()["purelib"]), os.path.realpath(np.__file__),
            os.path.realpath(sandbox.child_python(sandbox.is_root()))]
    out = []
    for p in dict.fromkeys(os.path.realpath(p) for p in paths):
        if p != "/" and not any(n == p or n.startswith(p.rstrip("/") + "/") for n in need):
            out.append(p)
    return tuple(out)


def _summary(total, max_total, sizes, notes) -> str:
    lines = [f"Code score: {total:g} / {max_total:g} points (tasks 1-4, graded at "
             f"{', '.join(f'{g:g} m' for g in sizes)}; the written parts are graded by the TA)."]
    lines += [f"- {n}" for n in notes]
    return "\n".join(lines)


def _grade_one(task, g, cfg, found, box_maker, slot, hide, timeout, memory, pts, out, figures):
    name = f"Task {task} ({cfg['tasks'][task]['name']}) at grid size {g:g} m"
    test = {"name": name, "score": 0.0, "max_score": round(pts, 4), "status": "failed",
            "output": "", "_task": task, "_grid": g}
    if not found or found[task] is None:
        want = " or ".join(archive.TASK_FILES[task])
        test["output"] = f"0 points: {want} is missing from the submission."
        test["_reason"] = "file missing"
        return test
    box = box_maker.fresh(task)
    res = _run_task(box, task, g, cfg, slot, hide, timeout, memory)
    test["_seconds"] = round(res.seconds, 1)
    test["_isolation"] = res.notes
    logs = ""
    if res.stdout.strip():
        logs += f"\n\nstdout (capped):\n```\n{res.stdout.strip()[-2000:]}\n```"
    if res.stderr.strip():
        logs += f"\n\nstderr (capped):\n```\n{res.stderr.strip()[-2000:]}\n```"
    err = (box / "out" / "error.txt")
    reason = None
    if res.timed_out:
        reason = (f"timed out: the task did not finish within {timeout or cfg['timeout']:g} s "
                  "(a loop that never ends, or a solution far slower than the template)")
    elif err.is_file():
        reason = err.read_text(errors="replace")[:600].strip()
        if reason.startswith("grader setup:"):  # written by the wrapper before any student code
            test["_grader_error"] = True
            reason = ("the GRADER could not run this task, not the submission's fault (ask the "
                      "course staff to regrade): " + reason.split(":", 1)[1].strip())
    elif res.returncode != 0:
        sig = -res.returncode if res.returncode and res.returncode < 0 else None
        why = {9: "killed (CPU time or memory limit)", 24: "CPU time limit exceeded",
               25: "file size limit exceeded", 11: "crashed (segmentation fault)"}.get(sig, None)
        reason = why or f"the task's process ended with status {res.returncode}"
    mean = var = None
    if reason is None:
        mean, reason = _load_npy(box / "out" / "mean.npy")
    if reason is None:
        var, reason = _load_npy(box / "out" / "variance.npy")
    meta = _read_meta(box / "out" / "meta.json") if reason is None else {}
    semantic = task > 2
    grid, _ = reference.evidence(task, g)
    if reason is None:
        arrs = reference.student_arrays(mean, var, grid.n_cells, semantic)
        if isinstance(arrs, str):
            reason = arrs
        else:
            mean, var = arrs
    if res.leftovers_killed:
        test["output"] += f"{res.leftovers_killed} process(es) left running by the task were killed.\n"
    if reason is not None:
        test["output"] += f"0 points: {reason}.{logs}"
        test["_reason"] = reason.splitlines()[0][:200]
        return test
    best = reference.best_match(task, g, mean, var, _prior_candidates(meta), cfg["rtol"], cfg["atol"])
    frac = reference.credit(best, cfg["mean_weight"], cfg["zero_credit_share"],
                            cfg["full_credit_share"])
    test["score"] = round(pts * frac, 4)
    test["status"] = "passed" if frac == 1.0 else "failed"
    what = "most likely class" if semantic else "mean"
    lines = [f"{best.share:.1%} of the {best.compared:,} compared cells agree with the exact "
             f"reference ({best.label}, prior {best.prior:.3g}); the {what} agrees in "
             f"{best.mean_share:.1%}, the variance in {best.var_share:.1%}: "
             f"{test['score']:g} / {pts:g} points."]
    if best.share < 1.0:
        diag = reference.diagnose(task, g, mean, var, best.prior, cfg["rtol"], cfg["atol"],
                                  best.opts)
        if diag:
            lines.append(f"Most likely: {diag[0]} (explains {diag[1]:.0%} of the cells).")
        lines.append(_first_differences(grid, mean, var, best, semantic))
        if figures:
            test["_figure"] = _figure(out, task, g, grid, mean, best, semantic)
    test["output"] += "\n".join(lines) + logs
    test["_share"] = best.share
    test["_variant"] = best.label
    return test


def _first_differences(grid, mean, var, best, semantic, n=5) -> str:
    bad = np.flatnonzero(~best.agree)
    rows = ["First differing cells (x, y in m; student vs reference):", ""]
    rows.append("| cell | x | y | student | reference |")
    rows.append("|---|---|---|---|---|")
    for i in bad[:n]:
        x, y = grid.cells[i]
        if semantic:
            s = f"class {int(np.argmax(mean[i])) + 1}, var {var[i]:.4g}"
            r = f"class {int(best.ref_value[i]) + 1}, var {best.ref_var[i]:.4g}"
        else:
            s = f"mean {mean[i]:.6g}, var {var[i]:.4g}"
            r = f"mean {best.ref_value[i]:.6g}, var {best.ref_var[i]:.4g}"
        rows.append(f"| {i} | {x:.3f} | {y:.3f} | {s} | {r} |")
    rows.append(f"({len(bad):,} cells differ in all; class 7 is free space.)" if semantic
                else f"({len(bad):,} cells differ in all.)")
    return "\n".join(rows)


def _figure(out: Path, task, g, grid, mean, best, semantic) -> str | None:
    """Reference, student and difference maps side by side; the PNG's path relative to out."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    ny, nx = len(grid.y), len(grid.x)
    extent = (grid.x[0] - g / 2, grid.x[-1] + g / 2, grid.y[0] - g / 2, grid.y[-1] + g / 2)
    if semantic:  # classes 1-6 and free space (7); cells without evidence (uniform) blank
        observed = reference.evidence(task, g, **best.opts)[1].sum(axis=1) > 0
        ref = np.where(observed, best.ref_value, np.nan).reshape(ny, nx)
        uniform = np.ptp(mean, axis=1) < 1e-12
        stu = np.where(uniform, np.nan, np.argmax(mean, axis=1)).reshape(ny, nx)
        kw = dict(cmap="tab10", vmin=0, vmax=9)
    else:
        ref = best.ref_value.reshape(ny, nx)
        stu = mean.reshape(ny, nx)
        kw = dict(cmap="Greys", vmin=0, vmax=1)
    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.8), constrained_layout=True)
    for ax, img, title in ((axes[0], ref, "reference"), (axes[1], stu, "submission")):
        ax.imshow(img, origin="lower", extent=extent, **kw)
        ax.set_title(f"{title}: {'most likely class' if semantic else 'mean'}")
    axes[2].imshow((~best.agree).reshape(ny, nx), origin="lower", extent=extent, cmap="Reds",
                   vmin=0, vmax=1)
    axes[2].set_title("differing cells (red)")
    for ax in axes:
        ax.set_xlabel("x [m]")
    axes[0].set_ylabel("y [m]")
    (out / "figures").mkdir(exist_ok=True)
    rel = f"figures/task{task}_grid{g:g}.png"
    fig.savefig(out / rel, dpi=80)
    plt.close(fig)
    return rel
