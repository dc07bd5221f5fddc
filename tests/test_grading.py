"""The grader (``python -m hw4 grade / check / autograder``): exact scoring, broken variants,
attacks contained, safe extraction, results.json against Gradescope's specification, the
autograder zip in a simulated /autograder tree.

Maps are graded at 1 m here (1,296 cells) to keep the tests short; the submissions are the
purpose-written ones in ``tests/grading_fixtures``.
"""
from __future__ import annotations

import io
import json
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import threading
import uuid
import zipfile
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from hw4.__main__ import main
from hw4.core.errors import InputError
from hw4.grading import archive, sandbox
from hw4.grading.grade import grade

FIX = Path(__file__).parent / "grading_fixtures"
G = [1.0]
SCHEMA = json.loads((Path(__file__).parents[1] / "hw4" / "grading" / "results_schema.json").read_text())
STRONG = sandbox.is_root() and sandbox.namespaces_available()


def _sub(tmp: Path, name: str, overlay: str | None = None, **fill) -> Path:
    d = tmp / name
    shutil.copytree(FIX / "exact", d, ignore=shutil.ignore_patterns("__pycache__"))
    if overlay:
        for f in (FIX / overlay).glob("*.py"):
            text = f.read_text()
            for k, v in fill.items():
                text = text.replace("{" + k + "}", str(v))
            (d / f.name).write_text(text)
    return d


def _tests(res):
    return {int(t["name"].split()[1]): t for t in res["tests"]}


def _valid(res):
    jsonschema.validate(res, SCHEMA)


@pytest.fixture(scope="module")
def exact_results(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("exact")
    d = _sub(tmp, "uniq_hw4")
    tgz = tmp / "uniq_hw4.tgz"
    with tarfile.open(tgz, "w:gz") as t:
        t.add(d, arcname="uniq_hw4")
    out = tmp / "out"
    return grade(tgz, out, grid_sizes=G), out


def test_exact_submission_full_marks(exact_results):
    res, out = exact_results
    _valid(res)
    assert res["score"] == 70
    for n, t in _tests(res).items():
        assert t["score"] == t["max_score"] == {1: 20, 2: 15, 3: 20, 4: 15}[n], t["output"]
        assert t["name"].startswith(f"Task {n}") and t["status"] == "passed"
    assert json.loads((out / "results.json").read_text()) == res
    assert "Task 4" in (out / "report.md").read_text()


def test_broken_variants_lose_only_their_task(tmp_path):
    res = grade(_sub(tmp_path, "broken", "broken"), tmp_path / "out", grid_sizes=G)
    _valid(res)
    t = _tests(res)
    # at most the variance share (50 %) is left, where a swap or a shift keeps the variances
    assert all(t[n]["score"] <= 0.5 * t[n]["max_score"] + 1e-9 for n in t), res
    assert "alpha and beta are swapped" in t[1]["output"]
    assert "free space is never updated" in t[2]["output"]
    assert "label k is stored as k+1" in t[3]["output"]
    assert "expected (1296, 7)" in t[4]["output"]
    assert (tmp_path / "out" / "figures" / "task1_grid1.png").is_file()
    assert "First differing cells" in t[2]["output"]
    # each broken file alone, beside three exact ones, costs only its task
    one = _sub(tmp_path, "one")
    shutil.copyfile(FIX / "broken" / "ogm_continuous_CSM.py", one / "ogm_continuous_CSM.py")
    res1 = grade(one, tmp_path / "out1", grid_sizes=G)
    assert [x["score"] for x in res1["tests"]] == [20, 0, 20, 15]


def _ps_with(token: str) -> list:
    hits = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                if token.encode() in Path(f"/proc/{d}/cmdline").read_bytes():
                    hits.append(int(d))
            except OSError:
                pass
    return hits


def test_attacks_import_network_writes_daemon_timeout(tmp_path):
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(5)
    server.settimeout(0.2)
    got = []

    def accept():
        while not stop.is_set():
            try:
                got.append(server.accept())
            except OSError:
                pass
    stop = threading.Event()
    th = threading.Thread(target=accept, daemon=True)
    th.start()
    token = uuid.uuid4().hex
    outside = tmp_path / "outside"
    outside.mkdir(mode=0o777)
    outside.chmod(0o777)
    sub = _sub(tmp_path, "attack", "attacks_a", PORT=server.getsockname()[1], TOKEN=token,
               OUTSIDE=outside)
    try:
        res = grade(sub, tmp_path / "out", grid_sizes=G, timeout=30, hide=(str(outside),))
    finally:
        stop.set()
        th.join()
        server.close()
    _valid(res)
    t = _tests(res)
    if STRONG:
        assert t[1]["score"] == 0 and "hw4" in t[1]["output"], t[1]["output"]
        assert not got, "the submission reached the network"
        assert "network blocked" in t[2]["output"]
        for p in (Path("/tmp"), Path("/var/tmp"), Path("/dev/shm"), outside, tmp_path):
            assert not (p / f"hw4-attack-{token}").exists()
    assert t[2]["score"] == 15 and t[3]["score"] == 20  # the attacks still mapped correctly
    assert t[4]["score"] == 0 and "timed out" in t[4]["output"]
    assert not _ps_with(f"hw4-daemon-{token}"), "a daemon of the submission is still alive"


def test_naive_import_of_the_grader_scores_zero(tmp_path):
    sub = _sub(tmp_path, "naive")
    for f in sub.glob("ogm_*.py"):
        f.unlink()
    (sub / "ogm_CSM.py").write_text("from hw4.ogm_CSM import ogm_CSM  # noqa: F401\n")
    res = grade(sub, tmp_path / "out", grid_sizes=G)
    t = _tests(res)
    assert t[1]["score"] == 0 and "No module named 'hw4" in t[1]["output"]
    assert "missing from the submission" in t[2]["output"]


def test_attacks_memory_forks_forgery_flood(tmp_path, capfd):
    res = grade(_sub(tmp_path, "attack_b", "attacks_b", KILL_PARENT=sandbox.is_root()),
                tmp_path / "out", grid_sizes=G, timeout=60)
    _valid(res)
    t = _tests(res)
    assert t[1]["score"] == 0 and "memory" in t[1]["output"], t[1]["output"]
    if sandbox.is_root():  # we are alive: the grader could not be killed
        assert "kill blocked" in t[1]["output"] and "KILLED THE PARENT" not in t[1]["output"]
    assert t[2]["score"] == 0 and "forked" in t[2]["output"]
    if sandbox.is_root():
        n = int(t[2]["output"].split("forked ")[1].split()[0])
        assert n < sandbox.Limits().nproc
        uid = sandbox.ensure_user(0)[0]
        alive = [d for d in os.listdir("/proc") if d.isdigit() and sandbox._owner(d) == uid]
        assert not alive, "processes of the sandbox user survived"
    assert t[3]["score"] == 0 and "not a plain array" in t[3]["output"]
    assert "PICKLE EXECUTED" not in capfd.readouterr().out
    assert res["score"] == 15  # the flood is capped, the map still graded
    assert len(t[4]["output"]) < 10000
    assert not (tmp_path / "out" / "out").exists()


def _tar(path: Path, members: list) -> Path:
    with tarfile.open(path, "w:gz") as t:
        for name, kind, data in members:
            info = tarfile.TarInfo(name)
            if kind == "sym":
                info.type, info.linkname = tarfile.SYMTYPE, data
                t.addfile(info)
            else:
                info.size = len(data)
                t.addfile(info, io.BytesIO(data))
    return path


@pytest.mark.parametrize("name,kind,data,expect", [
    ("../evil.py", "file", b"x", "leaving its folder"),
    ("/abs/evil.py", "file", b"x", "absolute path"),
    ("a/../../evil.py", "file", b"x", "leaving its folder"),
])
def test_unsafe_archive_paths_refused(tmp_path, name, kind, data, expect):
    arc = _tar(tmp_path / "s.tgz", [(name, kind, data)])
    with pytest.raises(InputError, match=expect):
        archive.extract(arc, tmp_path / "x")
    assert not (tmp_path / "evil.py").exists()


def test_archive_links_odd_names_and_caps(tmp_path):
    arc = _tar(tmp_path / "s.tgz", [("u_hw4/ogm_CSM.py", "sym", "/etc/passwd"),
                                   ("u_hw4/we ird\nname.py", "file", b"x"),
                                   ("u_hw4/ogm_S_CSM.py", "file", b"pass\n")])
    notes = archive.extract(arc, tmp_path / "x")
    assert any("link" in n for n in notes) and any("unusual name" in n for n in notes)
    assert not (tmp_path / "x" / "u_hw4" / "ogm_CSM.py").exists()
    assert (tmp_path / "x" / "u_hw4" / "ogm_S_CSM.py").read_text() == "pass\n"
    many = _tar(tmp_path / "many.tgz", [(f"f{i}.py", "file", b"") for i in range(archive.MAX_FILES + 1)])
    with pytest.raises(InputError, match="more than"):
        archive.extract(many, tmp_path / "y")
    big = tmp_path / "bomb.zip"
    with zipfile.ZipFile(big, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("u/ogm_CSM.py", b"0" * (archive.MAX_FILE_BYTES + 1))
    with pytest.raises(InputError, match="MB"):
        archive.extract(big, tmp_path / "z")


def test_helper_package_beside_the_task_files_imports(tmp_path):
    sub = _sub(tmp_path, "pkg")
    for f in sub.glob("ogm_*.py"):
        f.unlink()
    (sub / "helpers").mkdir()
    (sub / "helpers" / "__init__.py").write_text("")
    shutil.move(sub / "mapping_core.py", sub / "helpers" / "mapping_core.py")
    (sub / "ogm_CSM.py").write_text(
        (FIX / "exact" / "ogm_CSM.py").read_text().replace(
            "import mapping_core", "from helpers import mapping_core"))
    (sub / "hw4").mkdir()  # a folder named like the grader's package is not copied
    (sub / "hw4" / "__init__.py").write_text("")
    res = grade(sub, tmp_path / "out", grid_sizes=G)
    assert _tests(res)[1]["score"] == 20, _tests(res)[1]["output"]


def test_unreadable_submission_still_gets_results(tmp_path):
    bad = tmp_path / "u_hw4.tgz"
    bad.write_bytes(b"not an archive")
    assert main(["grade", str(bad), "--out", str(tmp_path / "o"), "--grid-size", "1"]) == 0
    res = json.loads((tmp_path / "o" / "results.json").read_text())
    _valid(res)
    assert res["score"] == 0 and "not a readable archive" in res["output"]


def test_grade_exit_status(tmp_path, capsys):
    assert main(["grade", str(tmp_path / "missing"), "--out", str(tmp_path / "o")]) == 2
    assert "does not exist" in capsys.readouterr().err
    f = tmp_path / "file"
    f.write_text("")
    assert main(["grade", str(FIX / "broken"), "--out", str(f / "o")]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_check_and_batch(tmp_path, capsys):
    one = tmp_path / "mine"
    one.mkdir()
    shutil.copyfile(FIX / "broken" / "ogm_CSM.py", one / "ogm_CSM.py")  # needs mapping_core
    assert main(["check", str(one), "--out", str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out
    assert "Task 1 (CSM)" in out and "mapping_core" in out
    assert (tmp_path / "c" / "report.md").is_file()
    subs = tmp_path / "subs"
    subs.mkdir()
    shutil.copytree(one, subs / "alice_hw4")
    with zipfile.ZipFile(subs / "bob_hw4.zip", "w") as z:
        z.writestr("bob_hw4/ogm_S_CSM.py", "raise SystemExit(3)\n")
    assert main(["grade", str(subs), "--batch", "--out", str(tmp_path / "b"), "--jobs", "2",
                 "--grid-size", "1"]) == 0
    rows = (tmp_path / "b" / "grades.csv").read_text().splitlines()
    assert rows[0].startswith("student,submission,task1,task2,task3,task4,total")
    assert [r.split(",")[0] for r in rows[1:]] == ["alice", "bob"]
    for who in ("alice", "bob"):
        _valid(json.loads((tmp_path / "b" / who / "results.json").read_text()))


def test_autograder_zip_in_simulated_tree(tmp_path):
    z = tmp_path / "autograder.zip"
    assert main(["autograder", "--out", str(z)]) == 0
    root = tmp_path / "autograder"
    with zipfile.ZipFile(z) as f:
        names = f.namelist()
        assert {"setup.sh", "run_autograder", "config.toml", "pyproject.toml"} <= set(names)
        assert "data/intel/sample_Intel_dataset.mat" in names
        f.extractall(root / "source")
    cfg = root / "source" / "config.toml"
    cfg.write_text(cfg.read_text().replace("grid_sizes = [0.5]", "grid_sizes = [1.0]"))
    shutil.copytree(FIX / "exact", root / "submission", ignore=shutil.ignore_patterns("__pycache__"))
    run = root / "source" / "run_autograder"
    r = subprocess.run(["bash", str(run)], env={**os.environ, "AUTOGRADER_ROOT": str(root),
                                                "HW4_PYTHON": sys.executable},
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    res = json.loads((root / "results" / "results.json").read_text())
    _valid(res)
    assert res["score"] == 70
    assert subprocess.run(["bash", "-n", str(root / "source" / "setup.sh")]).returncode == 0


@pytest.mark.parametrize("kind", ["strict", "through", "arange", "arange_world"])
def test_sample_count_readings_match_a_loop(kind):
    """count_evidence(sample_count=...) against a loop over cells, nearest poses and the free
    samples each reading places (Algorithm 2, nearest beam, 0.1 m steps), on 150 cells."""
    import numpy as np
    from hw4.core.evidence import count_evidence
    from hw4.core.grid import Grid
    from hw4.core.kernel import sparse_kernel
    from hw4.core.sensor import polar, wrap_to_pi
    from hw4.tasks import load_task_data
    from scipy.spatial import cKDTree
    data = load_task_data(2)
    scans = [s[:2] for s in data.scans]
    grid = Grid(0.5)
    counts = count_evidence(grid, data.poses, scans, model="continuous", sample_count=kind)
    if kind != "strict":  # each reading differs from the strict one somewhere
        assert (counts != count_evidence(grid, data.poses, scans, model="continuous")).any()
    tree = cKDTree(data.poses[:, :2])
    cells = np.random.default_rng(1).choice(grid.n_cells, 150, replace=False)
    for i in cells:
        m = grid.cells[i]
        free = 0.0
        for k in tree.query(m, 16)[1]:
            px, py, h = data.poses[k]
            r = np.hypot(m[0] - px, m[1] - py)
            phi = wrap_to_pi(np.arctan2(m[1] - py, m[0] - px) - h)
            if not (0 < r < 30 and -np.pi < phi < np.pi):
                continue
            z, b = polar(scans[k])
            j = int(np.nanargmin(np.abs(wrap_to_pi(b - phi))))
            c, s = np.cos(b[j] + h), np.sin(b[j] + h)
            ex, ey = px + z[j] * c, py + z[j] * s
            if kind == "strict":
                samples = [t * 0.1 for t in range(int(z[j] / 0.1) + 2) if t * 0.1 < z[j]]
            elif kind == "through":
                samples = [t * 0.1 for t in range(int(z[j] / 0.1) + 2) if t * 0.1 < z[j] + 1e-9]
            elif kind == "arange":
                samples = np.arange(0, z[j], 0.1)
            else:
                samples = np.arange(0, np.sqrt((px - ex) ** 2 + (py - ey) ** 2), 0.1)
            for t in samples:
                d = np.hypot(m[0] - (px + t * c), m[1] - (py + t * s))
                if d < 0.2:
                    free += float(sparse_kernel(np.array([d]))[0])
        assert counts[i, 1] == pytest.approx(free, rel=1e-9, abs=1e-12), (kind, i)


@pytest.mark.parametrize("argv,msg", [
    (["grade", "--help"], None), (["check", "--help"], None), (["autograder", "--help"], None),
    (["grade", "x", "--timeout", "-1"], "positive number"),
    (["grade", "x", "--grid-size", "abc"], "positive number"),
    (["check", "/nonexistent/files"], "does not exist"),
])
def test_commands_help_and_one_line_errors(argv, msg):
    r = subprocess.run([sys.executable, "-m", "hw4", *argv], capture_output=True, text=True,
                       timeout=120)
    if msg is None:
        assert r.returncode == 0 and "usage:" in r.stdout
    else:
        assert r.returncode == 2 and msg in r.stderr and "Traceback" not in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_bad_configuration_is_one_line(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[grading]\nfull_credit_share = 0.3\n[tasks.1]\n[tasks.2]\n[tasks.3]\n[tasks.4]\n")
    r = subprocess.run([sys.executable, "-m", "hw4", "grade", str(FIX / "exact"), "--config",
                        str(cfg), "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 2 and "credit_share" in r.stderr and "Traceback" not in r.stderr


def test_attacks_links_fifo_markdown_disk_other_copies(tmp_path, capsys):
    """Result files swapped for links / FIFOs after the wrapper wrote them, a copy of the
    project found on disk and imported past the guard, Markdown / HTML / fences / terminal
    escapes in the output, and a disk flood."""
    secret = tmp_path / "secret"
    token = uuid.uuid4().hex
    secret.write_text(f"SECRET-{token}\n")
    secret.chmod(0o600)
    sub = _sub(tmp_path, "attack_c", "attacks_c", SECRET=secret,
               PROJECT=Path(__file__).resolve().parents[1])
    out = tmp_path / "out"
    assert main(["grade", str(sub), "--out", str(out), "--grid-size", "1", "--timeout", "40"]) == 0
    printed = capsys.readouterr().out
    res = json.loads((out / "results.json").read_text())
    _valid(res)
    t = _tests(res)
    report = (out / "report.md").read_text()
    everything = json.dumps(res) + report + printed
    assert token not in everything, "a file only the grader can read reached the report"
    assert t[1]["score"] == 0 and "link or a special file" in t[1]["output"], t[1]["output"]
    assert t[4]["score"] == 0 and "link or a special file" in t[4]["output"], t[4]["output"]
    assert "\x1b" not in everything
    assert res["test_output_format"] == "md"  # Gradescope renders the escapes and fences
    assert "<img" not in report.replace("\\<img", "") and "**70" not in report.replace("\\*\\*70", "")
    fences = [ln for ln in report.splitlines() if ln.startswith("```")]
    assert any(len(f) > 8 for f in fences), "a line of the output can close the report's fence"
    if STRONG:
        assert "IMPORTED THE GRADER" not in t[2]["output"] and "import blocked" in t[2]["output"]
        assert t[3]["score"] == 0 and "wrote more than" in t[3]["output"], t[3]["output"]


def test_out_folder_never_overwrites_what_the_user_had(tmp_path, capsys, monkeypatch):
    sub = tmp_path / "s"
    sub.mkdir()
    (sub / "ogm_CSM.py").write_text("raise SystemExit(3)\n")
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.md").write_text("my own notes")
    assert main(["grade", str(sub), "--out", str(mine), "--grid-size", "1"]) == 2
    err = capsys.readouterr().err
    assert "did not write" in err and len(err.strip().splitlines()) == 1
    assert (mine / "report.md").read_text() == "my own notes" and len(list(mine.iterdir())) == 1
    out = tmp_path / "out"
    first = grade(sub, out, grid_sizes=G)
    (out / "figures").mkdir()
    (out / "figures" / "task9_grid1.png").write_bytes(b"stale")
    second = grade(sub, out, grid_sizes=G)  # an earlier run's results are replaced
    assert json.loads((out / "results.json").read_text()) == second != {}
    assert first["score"] == second["score"] == 0 and not (out / "figures").exists()
    from hw4.grading import report

    def broken(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(report, "write_report", broken)
    before = (out / "results.json").read_text()
    with pytest.raises(OSError):
        grade(sub, out, grid_sizes=G)
    assert sorted(p.name for p in out.iterdir()) == ["report.md", "results.json"]
    assert (out / "results.json").read_text() == before  # a failed run left no half results


def test_returned_files_are_read_only_when_plain(tmp_path):
    """What the child leaves in out/ is read without following links, never from a FIFO, a
    hard link or a header that claims more data than it holds (40 GB would be allocated)."""
    from hw4.grading.grade import _load_npy
    box = tmp_path / "box"
    (box / "out").mkdir(parents=True)
    o = box / "out"
    buf = io.BytesIO()
    np.save(buf, np.arange(6.0))
    (o / "good.npy").write_bytes(buf.getvalue())
    assert np.array_equal(_load_npy(box, "good.npy")[0], np.arange(6.0))
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                                "shape": (5 * 10**9,)})
    (o / "huge.npy").write_bytes(head.getvalue() + bytes(64))
    os.mkfifo(o / "fifo.npy")
    (o / "link.npy").symlink_to(o / "good.npy")
    os.link(o / "good.npy", o / "hard.npy")
    obj = io.BytesIO()
    np.save(obj, np.array([1, None], dtype=object), allow_pickle=True)
    (o / "obj.npy").write_bytes(obj.getvalue())
    for name in ("huge.npy", "fifo.npy", "link.npy", "hard.npy", "obj.npy", "missing.npy"):
        arr, why = _load_npy(box, name)
        assert arr is None and why, name
    shutil.rmtree(o)
    (box / "elsewhere").mkdir()
    (box / "elsewhere" / "good.npy").write_bytes(buf.getvalue())
    o.symlink_to(box / "elsewhere")  # out/ itself swapped for a link
    assert _load_npy(box, "good.npy")[0] is None


def test_notes_on_names_are_escaped_and_several_folders_said(tmp_path):
    sub = tmp_path / "two"
    for d, f in (("a", "ogm_CSM.py"), ("b", "ogm_S_CSM.py")):
        (sub / d).mkdir(parents=True)
        (sub / d / f).write_text("raise SystemExit(3)\n")
    res = grade(sub, tmp_path / "o", grid_sizes=G)
    assert "graded a" in res["output"] and "not b" in res["output"]
    arc = _tar(tmp_path / "u.tgz", [("u/**x** <b>y</b>.py", "file", b"x"),
                                   ("u/ogm_CSM.py", "file", b"raise SystemExit(3)\n")])
    res = grade(arc, tmp_path / "o2", grid_sizes=G)
    assert "unusual name" in res["output"] and "<b>" not in res["output"]
    assert "**x**" not in (tmp_path / "o2" / "report.md").read_text()


@pytest.mark.skipif(not sandbox.is_root(), reason="the total is counted per sandbox user")
def test_memory_spread_over_forks_is_stopped(tmp_path):
    sub = tmp_path / "mem"
    sub.mkdir()
    shutil.copyfile(FIX / "attacks_d" / "ogm_CSM.py", sub / "ogm_CSM.py")
    res = grade(sub, tmp_path / "out", grid_sizes=G, timeout=25, memory=400)
    out = _tests(res)[1]["output"]
    assert "more than 400 MB of memory" in out, out


def test_autograder_zip_never_overwrites_another_file(tmp_path, capsys):
    mine = tmp_path / "autograder.zip"
    mine.write_text("my notes")
    assert main(["autograder", "--out", str(mine)]) == 2
    assert "not an earlier autograder zip" in capsys.readouterr().err
    assert mine.read_text() == "my notes" and len(list(tmp_path.iterdir())) == 1


@pytest.mark.skipif(not sandbox.is_root(), reason="one grading user per grader needs root")
def test_two_graders_at_once_do_not_kill_each_others_tasks(tmp_path):
    slow = tmp_path / "slow"
    slow.mkdir()
    (slow / "ogm_CSM.py").write_text("import time\ntime.sleep(8)\nraise SystemExit(7)\n")
    quick = tmp_path / "quick"
    quick.mkdir()
    (quick / "ogm_CSM.py").write_text("raise SystemExit(3)\n")
    other = subprocess.Popen([sys.executable, "-m", "hw4", "grade", str(slow), "--out",
                              str(tmp_path / "o_slow"), "--grid-size", "1"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    import time
    time.sleep(4)
    for k in range(3):  # each run kills every process of its user when its task ends
        grade(quick, tmp_path / f"o_quick{k}", grid_sizes=G)
    out, err = other.communicate(timeout=300)
    res = json.loads((tmp_path / "o_slow" / "results.json").read_text())
    assert "SystemExit" in _tests(res)[1]["output"], _tests(res)[1]["output"]


def test_deep_trees_do_not_crash_the_grader(tmp_path, capsys):
    sub = tmp_path / "deep"
    sub.mkdir()
    shutil.copyfile(FIX / "attacks_d" / "ogm_S_CSM.py", sub / "ogm_S_CSM.py")
    fd = os.open(sub, os.O_RDONLY)
    for _ in range(1200):  # a submitted folder nested deeper than Python's recursion limit
        os.mkdir("d", dir_fd=fd)
        fd, old = os.open("d", os.O_RDONLY, dir_fd=fd), fd
        os.close(old)
    os.close(fd)
    try:
        assert main(["grade", str(sub), "--out", str(tmp_path / "o"), "--grid-size", "1"]) == 0
    finally:
        sandbox.remove_tree(sub)
    res = json.loads((tmp_path / "o" / "results.json").read_text())
    assert "SystemExit" in _tests(res)[3]["output"], _tests(res)[3]["output"]
    arc = _tar(tmp_path / "d.tgz", [("u/" + "a/" * 40 + "ogm_CSM.py", "file", b"x")])
    with pytest.raises(InputError, match="folders deep"):
        archive.extract(arc, tmp_path / "x")


@pytest.mark.skipif(not (STRONG and sandbox.pid_namespace_available()),
                    reason="a PID namespace needs root")
def test_task_sees_no_other_process_and_report_names_the_caps(tmp_path):
    """Each task is process 1 of its own PID namespace: /proc lists only its processes, not
    the grader's (whose command line is on this test's); the report says which caps ran."""
    sub = _sub(tmp_path, "pidns")
    core = (sub / "mapping_core.py").read_text()
    (sub / "mapping_core.py").write_text(
        "import os as _os\n"
        "_seen = sorted(int(p) for p in _os.listdir('/proc') if p.isdigit())\n"
        "_lines = [open(f'/proc/{p}/cmdline', 'rb').read() for p in _seen]\n"
        "print('PIDS', _seen, 'PID', _os.getpid(), 'PYTEST', any(b'pytest' in c for c in _lines))\n"
        + core)
    res = grade(sub, tmp_path / "out", grid_sizes=G)
    t = _tests(res)
    assert "PIDS [1] PID 1 PYTEST False" in t[1]["output"], t[1]["output"]
    assert t[1]["score"] == 20
    report = (tmp_path / "out" / "report.md").read_text()
    assert "memory and process caps: " + sandbox.caps() in report
