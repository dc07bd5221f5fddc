"""Grade one submission (or a folder of them): run each task sandboxed, score it, write the results.

:func:`grade` writes ``OUT/results.json`` (Gradescope's format) and ``OUT/report.md`` (with
figures in ``OUT/figures/``) and returns the results dict. Every failure of the submission ends
as a line in the report and 0 points for the task concerned, never as an exception.
"""
from __future__ import annotations

import io
import json
import os
import re
import shutil
import stat
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
GRADER_VERSION = 2  # the scoring's version: 2 compares every class probability, mean_weight 0.5,
# the 2024 template's else reading, diagnoses that must explain the differences
TIMING_FIELDS = ("execution_time",)  # the only fields of results.json that vary between runs
MAX_ARRAY_BYTES = 200 * 2**20


def _data_file(task: int) -> Path:
    return _data.ensure(_data.INTEL_SEMANTIC if task > 2 else _data.INTEL)


def _task_points(cfg: dict, grid_sizes: list) -> dict:
    """Points of each (task, grid size) test: a task's points split evenly over grid sizes."""
    return {(t, g): cfg["tasks"][t]["points"] / len(grid_sizes)
            for t in (1, 2, 3, 4) for g in grid_sizes}


def _child_file(box: Path, name: str, cap: int):
    """The bytes of ``box/out/name`` as the child left it, or (None, why not).

    The child owns ``out/`` (and the scratch folder): it may have replaced a file, or ``out``
    itself, with a link to a file only the grader can read, a hard link, a FIFO or a device.
    Only a regular file with one link, reached without following any link, is read."""
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        dfd = os.open(box / "out", flags | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return None, "the task's out/ folder was replaced"
    try:
        fd = os.open(name, flags, dir_fd=dfd)
    except FileNotFoundError:
        return None, None
    except OSError:
        return None, f"out/{name} was replaced by a link or a special file"
    finally:
        os.close(dfd)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            return None, f"out/{name} was replaced by a link or a special file"
        if st.st_size > cap:
            return None, "the returned map is larger than any valid map"
        with os.fdopen(fd, "rb", closefd=False) as f:
            return f.read(cap + 1)[:cap], None
    finally:
        os.close(fd)


def _load_npy(box: Path, name: str):
    data, why = _child_file(box, name, MAX_ARRAY_BYTES)
    if data is None:
        return None, why or "the map arrays were not returned"
    fmt = np.lib.format
    try:  # the header's shape must match the bytes that follow (a claimed 40 GB would be
        # allocated before reading)
        bio = io.BytesIO(data)
        version = fmt.read_magic(bio)
        read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, _, dtype = read(bio)
        n = 1
        for k in shape:
            n *= int(k)
        if dtype.hasobject or n * dtype.itemsize != len(data) - bio.tell():
            return None, "the returned map is not a plain array (its header does not match its data)"
        return np.load(io.BytesIO(data), allow_pickle=False), None
    except (ValueError, OSError, EOFError, TypeError, MemoryError) as e:
        return None, f"the returned map is not a plain array ({type(e).__name__})"


def _read_meta(box: Path) -> dict:
    data, _ = _child_file(box, "meta.json", 10000)
    try:
        meta = json.loads(data.decode("utf-8", "replace")) if data else {}
        return meta if isinstance(meta, dict) else {}
    except ValueError:
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
        sandbox.remove_tree(box)
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
    with sandbox.exclusive_user(slot) as user:
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
    if out.exists() and not out.is_dir():
        raise InputError(f"cannot write to {out}: it is a file, not a folder")
    _refuse_foreign(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=".hw4-partial-", dir=out))
    except OSError as e:
        raise InputError(f"cannot write to {out}: {e.strerror}")
    try:
        return _grade(submission, out, stage, cfg, grid_sizes, timeout, memory, visible_only,
                      slot, figures, hide, t_start)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


OURS = ("results.json", "report.md", "figures")


def _refuse_foreign(out: Path) -> None:
    """Refuse an output folder holding anything but an earlier run's results (never overwrite
    what the user had)."""
    if not out.is_dir():
        return
    try:
        names = [n for n in os.listdir(out) if not n.startswith(".hw4-partial-")]
    except OSError as e:
        raise InputError(f"cannot read {out}: {e.strerror}")
    if not names:
        return
    foreign = sorted(n for n in names if n not in OURS)
    try:
        earlier = json.loads((out / "results.json").read_text())["extra_data"]["hw4_grader"]
    except (OSError, ValueError, KeyError, TypeError):
        earlier = None
    if foreign or not earlier:
        what = foreign[0] if foreign else names[0]
        raise InputError(f"{out} already holds files the grader did not write (e.g. {what}): "
                         "choose an empty or new --out folder")


def _publish(stage: Path, out: Path) -> None:
    """Replace an earlier run's results with the staged ones, results.json last (so that a run
    stopped half-way leaves no results.json beside a newer report)."""
    (out / "results.json").unlink(missing_ok=True)
    if (out / "figures").is_dir() and not (out / "figures").is_symlink():
        shutil.rmtree(out / "figures")
    else:
        (out / "figures").unlink(missing_ok=True)
    if (stage / "figures").is_dir():
        (stage / "figures").replace(out / "figures")
    (stage / "report.md").replace(out / "report.md")
    (stage / "results.json").replace(out / "results.json")


def _grade(submission, out, stage, cfg, grid_sizes, timeout, memory, visible_only, slot,
           figures, hide, t_start) -> dict:
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
                root = archive.find_root(raw, notes)
            elif submission.is_dir():
                root = archive.find_root(submission, notes)
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
                                  points[(task, g)], stage, figures)
                test["visibility"] = vis
                tests.append(test)
    finally:
        sandbox.remove_tree(base)
    iso = list(dict.fromkeys(n for t in tests for n in t.get("_isolation", ())))
    total = round(sum(t["score"] for t in tests), 4)
    max_total = round(sum(t["max_score"] for t in tests), 4)
    results = {
        "score": total,
        "execution_time": round(time.monotonic() - t_start, 1),
        "output": _summary(total, max_total, sizes, notes),
        "output_format": "md",
        "test_output_format": "md",  # the tests' outputs hold tables and code fences
        "tests": [{k: v for k, v in t.items() if not k.startswith("_")} for t in tests],
        "extra_data": {"grid_sizes": sizes, "hw4_grader": 1, "sandbox_limits": iso,
                       "grader_error": any(t.get("_grader_error") for t in tests),
                       "grader": GRADER_VERSION, "config": _scoring_config(cfg),
                       "readings": {str(t["_task"]): t.get("_variant", "")
                                    for t in tests if t["_grid"] == sizes[0]}},
    }
    from .report import write_report
    write_report(stage, results, tests, notes, sizes, cfg, iso)
    (stage / "results.json").write_text(json.dumps(results, indent=1))
    _publish(stage, out)
    return results


def _scoring_config(cfg: dict) -> dict:
    """The configuration values a score depends on (for ``changes.csv``), flattened."""
    out = {k: v for k, v in cfg.items() if k not in ("tasks", "output_cap", "visibility",
                                                     "hidden_visibility")}
    for t, v in cfg["tasks"].items():
        out[f"tasks.{t}.points"] = v["points"]
    return out


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
    lines += [f"- {_md_escape(_plain(n))}" for n in notes]  # notes quote the submission's names
    return "\n".join(lines)


_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u200b-\u200f\u202a-\u202e\u2066-\u2069]")
_MD_SPECIAL = re.compile(r"([\\`*_\[\]<>|#!~&])")


def _plain(text: str) -> str:
    """``text`` without control characters (terminal escapes, carriage returns, bidi marks)."""
    return _CONTROL.sub("", text)


def _md_escape(text: str) -> str:
    """``text`` shown literally in Markdown (no emphasis, links, images, HTML or tables)."""
    return _MD_SPECIAL.sub(r"\\\1", text)


def _fenced(text: str) -> str:
    """``text`` as a Markdown code block whose fence no line of ``text`` can close."""
    longest = max((len(m) for m in re.findall(r"`+|~+", text)), default=0)
    fence = "`" * max(3, longest + 1)
    return f"{fence}\n{text}\n{fence}"


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
    for label, text in (("stdout", res.stdout), ("stderr", res.stderr)):
        if text.strip():
            logs += f"\n\n{label} (capped):\n{_fenced(_plain(text.strip()[-2000:]))}"
    err, err_why = _child_file(box, "error.txt", 2000)
    reason = None
    if res.timed_out:
        reason = (f"timed out: the task did not finish within {timeout or cfg['timeout']:g} s "
                  "(a loop that never ends, or a solution far slower than the template)")
    elif res.disk_exceeded:
        reason = (f"stopped: the task {res.disk_exceeded}" if "memory" in res.disk_exceeded else
                  f"stopped: the task {res.disk_exceeded} (the limit of its scratch folder)")
    elif err_why:
        reason = err_why
    elif err is not None:
        reason = _md_escape(_plain(err.decode("utf-8", "replace")[:600]).strip())
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
        mean, reason = _load_npy(box, "mean.npy")
    if reason is None:
        var, reason = _load_npy(box, "variance.npy")
    meta = _read_meta(box) if reason is None else {}
    semantic = task > 2
    grid, _ = reference.evidence(task, g)
    if reason is None:
        arrs = reference.student_arrays(mean, var, grid.n_cells, semantic)
        if isinstance(arrs, str):
            reason = arrs
        else:
            mean, var = arrs
    if res.leftovers_killed:  # after the result line ("0 points: ..." first, for grades.csv)
        logs = (f"\n\n{res.leftovers_killed} process(es) left running by the task were killed."
                + logs)
    if reason is not None:
        test["output"] += f"0 points: {reason}.{logs}"
        test["_reason"] = reason.splitlines()[0][:200]
        return test
    best = reference.best_match(task, g, mean, var, _prior_candidates(meta), cfg["rtol"],
                                cfg["atol"], cfg)
    frac = reference.credit(best, cfg["mean_weight"], cfg["zero_credit_share"],
                            cfg["full_credit_share"])
    test["score"] = round(pts * frac, 4)
    test["status"] = "passed" if test["score"] >= pts else "failed"
    what = "class probabilities (all K)" if semantic else "mean"
    lines = [f"{best.share:.1%} of the {best.compared:,} compared cells agree with the exact "
             f"reference ({best.label}, prior {best.prior:.3g}); the {what} agree{'' if semantic else 's'} in "
             f"{best.mean_share:.1%}, the variance in {best.var_share:.1%}: "
             f"{test['score']:g} / {pts:g} points."]
    if best.factor < 1.0:
        lines.append(f"This reading earns {best.factor:.0%} of the task's points "
                     "(else_credit of the grading configuration).")
    if best.share < 1.0:
        diag = reference.diagnose(task, g, mean, var, best, cfg["rtol"], cfg["atol"]) \
            if test["score"] < pts else None
        if diag:
            lines.append(f"Most likely: {diag[0]} (applied to the reference, this explains "
                         f"{diag[1]:.0%} of the differing cells; the map then agrees in "
                         f"{diag[2]:.1%} of the compared cells).")
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
            c, rc = int(np.argmax(mean[i])), int(best.ref_value[i])
            s = f"class {c + 1} (p {mean[i, c]:.4g}), var {var[i]:.4g}"
            r = f"class {rc + 1} (p {best.ref_mean[i, rc]:.4g}), var {best.ref_var[i]:.4g}"
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
