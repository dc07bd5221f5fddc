"""Run untrusted code in a child process that cannot harm the grader, the machine or the grade.

Layers (each used where the machine allows it; :func:`isolation` says which are active):

* a clean environment, a scratch working directory, ``python -I -S`` with an explicit
  ``sys.path`` (the submission, the grader's ``utils``, a folder of links to numpy / scipy /
  tqdm only), so that this project's package is not on the path;
* rlimits: CPU time, address space, processes, file size, open files;
* as root: a private PID namespace (the task is process 1 of its own: it sees no other
  process, not the grader's command line; when it ends, every process it started ends with
  it), a private network namespace (no network: only a down loopback), a private mount
  namespace in which ``/tmp``, ``/var/tmp``, ``/dev/shm``, the grader's package, the output and
  the other submissions are empty read-only tmpfs, and an unprivileged user (one per parallel
  worker) so that file permissions and ``RLIMIT_NPROC`` apply;
* the memory and the number of processes of all the task's processes together: a cgroup v2
  of its own (``memory.max``, ``pids.max``) where the machine lets the grader make one with
  those controllers, else watchers polling four times a second (Pss of the user's processes;
  RLIMIT_NPROC). :func:`caps` says which ran, and the report repeats it;
* after each task every process of the submission is killed: its process group, every process
  of its user (as root), and any daemon re-parented to the grader (a child subreaper).

Output (stdout and stderr) goes to files the child cannot reopen and is read back capped.
"""
from __future__ import annotations

import contextlib
import ctypes
import fcntl
import os
import pwd
import resource
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

CLONE_NEWNS = 0x00020000
CLONE_NEWNET = 0x40000000
CLONE_NEWPID = 0x20000000
MS_NOEXEC = 8
MS_RDONLY, MS_NOSUID, MS_NODEV, MS_BIND, MS_REC, MS_PRIVATE = 1, 2, 4, 4096, 16384, 1 << 18
PR_SET_CHILD_SUBREAPER = 36
CHILD_PACKAGES = ("numpy", "numpy.libs", "scipy", "scipy.libs", "tqdm")
USER_PREFIX = "hw4grader"
ANCHOR = "/mnt"  # where the scratch folder appears inside the mount namespace

_libc = None


def _c():
    global _libc
    if _libc is None:
        _libc = ctypes.CDLL(None, use_errno=True)
    return _libc


def _check(rc: int, what: str) -> None:
    if rc != 0:
        e = ctypes.get_errno()
        raise OSError(e, f"{what}: {os.strerror(e)}")


@dataclass
class Limits:
    """Per-task limits: wall clock [s], memory (address space) [MB], output kept [bytes]."""
    timeout: float = 150.0
    memory_mb: int = 2048
    nproc: int = 64
    fsize_mb: int = 64
    nofile: int = 256
    output_cap: int = 8000
    disk_mb: int = 256      # all the files the task writes in its scratch folder
    disk_files: int = 5000  # and their number (folders included)


@dataclass
class Result:
    """What happened to one child run."""
    returncode: int | None
    timed_out: bool
    seconds: float
    stdout: str
    stderr: str
    leftovers_killed: int = 0
    notes: list = field(default_factory=list)
    disk_exceeded: str | None = None


def is_root() -> bool:
    return os.geteuid() == 0


def _world_executable(path: str) -> bool:
    """True when every directory on the way to ``path`` is o+x and the file o+rx."""
    p = Path(path).resolve()
    try:
        for d in list(p.parents)[::-1]:
            if not d.stat().st_mode & 0o001:
                return False
        return bool(p.stat().st_mode & 0o005 == 0o005)
    except OSError:
        return False


def child_python(as_other_user: bool) -> str:
    """The interpreter for the child: ours, or (when another user cannot reach ours) a system
    Python of the same minor version, which can load the same compiled numpy and scipy."""
    candidates = [sys.executable, os.path.realpath(sys.executable),
                  f"/usr/bin/python{sys.version_info[0]}.{sys.version_info[1]}",
                  f"/usr/local/bin/python{sys.version_info[0]}.{sys.version_info[1]}"]
    for c in candidates:
        if os.path.exists(c) and (not as_other_user or _world_executable(c)):
            return c
    return sys.executable


def make_site(dest: Path) -> Path:
    """A folder of links to the few packages a submission may import (numpy, scipy, tqdm)."""
    dest.mkdir(parents=True, exist_ok=True)
    purelib = Path(sysconfig.get_paths()["purelib"])
    import numpy
    roots = {purelib, Path(numpy.__file__).resolve().parents[1]}
    for name in CHILD_PACKAGES:
        for root in roots:
            src = root / name
            if src.exists() and not (dest / name).exists():
                (dest / name).symlink_to(src.resolve())
    return dest


def ensure_user(slot: int = 0) -> tuple[int, int] | None:
    """(uid, gid) of the unprivileged grading user of this worker slot, created when missing
    (root only); None when not root or the user cannot be created."""
    if not is_root():
        return None
    name = f"{USER_PREFIX}{slot}" if slot else USER_PREFIX
    try:
        pw = pwd.getpwnam(name)
    except KeyError:
        useradd = shutil.which("useradd") or "/usr/sbin/useradd"
        subprocess.run([useradd, "--system", "--no-create-home", "--shell", "/usr/sbin/nologin",
                        name], check=False, capture_output=True)
        try:
            pw = pwd.getpwnam(name)
        except KeyError:
            return None
    return pw.pw_uid, pw.pw_gid


@contextlib.contextmanager
def exclusive_user(slot: int = 0):
    """(uid, gid) of a grading user no other grader on this machine uses meanwhile (None when
    not root). After each task every process of the user is killed: two graders sharing one
    user (two TAs, a check during a batch) would kill each other's tasks. A lock file per user
    (``flock``, released at exit even on a crash) makes the first free one from ``slot`` ours."""
    if not is_root():
        yield None
        return
    for k in range(slot, slot + 64):
        path = os.path.join(tempfile.gettempdir(), f".{USER_PREFIX}{k}.lock")
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue
        try:
            yield ensure_user(k)
        finally:
            os.close(fd)
        return
    yield ensure_user(slot)


_NS_OK = None
_PID_OK = None


def pid_namespace_available() -> bool:
    """Whether a private PID namespace can be made here (root, not blocked)."""
    global _PID_OK
    if _PID_OK is None:
        _PID_OK = False
        if namespaces_available():
            try:
                r = subprocess.run([sys.executable, "-I", "-S", "-c",
                                    "import ctypes,os,sys;l=ctypes.CDLL(None,use_errno=True);"
                                    f"l.unshare({CLONE_NEWNS | CLONE_NEWNET | CLONE_NEWPID}) and sys.exit(1);"
                                    "p=os.fork()\nif p==0: os._exit(0 if os.getpid()==1 else 3)\n"
                                    "sys.exit(os.waitstatus_to_exitcode(os.waitpid(p,0)[1]))"],
                                   capture_output=True, timeout=20)
                _PID_OK = r.returncode == 0
            except (OSError, subprocess.SubprocessError):
                _PID_OK = False
    return _PID_OK


def namespaces_available() -> bool:
    """Whether private network and mount namespaces can be made here (root, not blocked)."""
    global _NS_OK
    if _NS_OK is None:
        _NS_OK = False
        if is_root():
            try:
                r = subprocess.run([sys.executable, "-I", "-S", "-c",
                                    "import ctypes,sys;l=ctypes.CDLL(None,use_errno=True);"
                                    f"sys.exit(l.unshare({CLONE_NEWNS | CLONE_NEWNET}))"],
                                   capture_output=True, timeout=20)
                _NS_OK = r.returncode == 0
            except (OSError, subprocess.SubprocessError):
                _NS_OK = False
    return _NS_OK


def set_subreaper() -> bool:
    """Make this process adopt orphaned descendants, so that daemons can be found and killed."""
    try:
        return _c().prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (AttributeError, OSError):
        return False


def _cgroup2_base() -> Path | None:
    """This process's cgroup v2 folder when it can hold children with the memory and pids
    controllers (root, cgroup2 mounted, the controllers enabled for its children or
    enableable), else None."""
    if not is_root():
        return None
    try:
        mount = None
        with open("/proc/self/mountinfo") as f:
            for line in f:
                left, _, right = line.partition(" - ")
                if right.split()[:1] == ["cgroup2"]:
                    mount = left.split()[4]
                    break
        if mount is None:
            return None
        rel = None
        with open("/proc/self/cgroup") as f:
            for line in f:
                if line.startswith("0::"):
                    rel = line[3:].strip()
        if rel is None:
            return None
        base = Path(mount) / rel.lstrip("/")
        if not {"memory", "pids"} <= set((base / "cgroup.controllers").read_text().split()):
            return None
        enabled = set((base / "cgroup.subtree_control").read_text().split())
        if not {"memory", "pids"} <= enabled:
            (base / "cgroup.subtree_control").write_text("+memory +pids")
        return base
    except OSError:
        return None


_CG_BASE = False


def caps() -> str:
    """How the memory and process count of a task's processes together are capped here."""
    global _CG_BASE
    if _CG_BASE is False:
        _CG_BASE = _cgroup2_base()
    if _CG_BASE is not None:
        return "cgroup v2 (memory.max, pids.max)"
    return ("watchers (memory polled four times a second, RLIMIT_NPROC: no writable cgroup v2 "
            "with the memory and pids controllers here)")


def _make_cgroup(limits: "Limits", nproc: int) -> Path | None:
    """A fresh cgroup v2 for one task with its memory and process caps, or None."""
    caps()
    if _CG_BASE is None:
        return None
    cg = _CG_BASE / f"hw4grade-{os.getpid()}-{time.monotonic_ns()}"
    try:
        cg.mkdir()
        (cg / "memory.max").write_text(str(int(limits.memory_mb) * 2**20))
        if (cg / "memory.swap.max").exists():
            (cg / "memory.swap.max").write_text("0")
        (cg / "pids.max").write_text(str(int(nproc)))
        return cg
    except OSError:
        _remove_cgroup(cg)
        return None


def _cgroup_events(cg: Path) -> str | None:
    """Why the cgroup's caps stopped the task (an OOM kill, a refused fork), or None."""
    try:
        mem = dict(ln.split() for ln in (cg / "memory.events").read_text().splitlines())
        if int(mem.get("oom_kill", 0)) or int(mem.get("max", 0)):
            return "used more than its memory (all its processes together, cgroup memory.max)"
        pids = dict(ln.split() for ln in (cg / "pids.events").read_text().splitlines())
        if int(pids.get("max", 0)):
            return None  # a refused fork is reported by the task itself ('forked ...')
    except (OSError, ValueError):
        pass
    return None


def _remove_cgroup(cg: Path) -> None:
    try:
        if (cg / "cgroup.kill").exists():
            (cg / "cgroup.kill").write_text("1")
        for _ in range(50):
            try:
                cg.rmdir()
                return
            except OSError:
                time.sleep(0.02)
    except OSError:
        pass


def _children_of(pid: int) -> list[int]:
    out = []
    if not os.path.isdir("/proc"):  # not Linux: only the process group is killed
        return out
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat", "rb") as f:
                    stat = f.read().decode("latin-1")
                ppid = int(stat[stat.rindex(")") + 2:].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            if ppid == pid:
                out.append(int(d))
    return out


def _kill_user(uid: int, gid: int) -> None:
    """SIGKILL every process of ``uid`` (as that user, so nothing else can be hit)."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - child
        try:
            os.setgroups([])
            os.setgid(gid)
            os.setuid(uid)
            for _ in range(5):
                os.kill(-1, signal.SIGKILL)
        except OSError:
            pass
        os._exit(0)
    os.waitpid(pid, 0)


def _reap_orphans(known: set) -> int:
    """Kill and reap descendants re-parented to us (daemons that left the process group)."""
    killed = 0
    for _ in range(50):
        kids = [p for p in _children_of(os.getpid()) if p not in known]
        if not kids:
            break
        for p in kids:
            try:
                os.kill(p, signal.SIGKILL)
                killed += 1
            except ProcessLookupError:
                pass
        for p in kids:
            try:
                os.waitpid(p, 0)
            except ChildProcessError:
                pass
        time.sleep(0.02)
    return killed


def _read_capped(path: Path, cap: int) -> str:
    size = path.stat().st_size
    with open(path, "rb") as f:
        if size <= cap:
            data = f.read()
        else:
            head = f.read(cap // 2)
            f.seek(size - cap // 2)
            data = head + f"\n... [{size - cap} bytes cut] ...\n".encode() + f.read()
    return data.decode("utf-8", "replace")


def run(argv: list, scratch: Path, limits: Limits, *, user: tuple | None = None,
        hide: tuple = (), isolate_network: bool = True, writable: tuple = ()) -> Result:
    """Run ``argv`` (interpreter and arguments) in ``scratch`` under the limits.

    ``user`` (uid, gid): run as this unprivileged user (needs root), who owns ``scratch`` and
    the ``writable`` paths in it (everything else there stays the grader's, read-only);
    ``hide``: folders made empty and read-only inside the child's mount namespace.
    """
    scratch = Path(scratch).resolve()
    notes = []
    use_ns = isolate_network and namespaces_available()
    use_pid = use_ns and pid_namespace_available()
    if not use_ns:
        notes.append("network and mount namespaces unavailable: the network is not cut")
    elif not use_pid:
        notes.append("PID namespace unavailable: the task can see the machine's processes")
    if user is None:
        notes.append("not run as root: no separate user, file permissions are the grader's")
    hide = [os.path.realpath(h) for h in hide if h and os.path.isdir(h)]
    if user:
        os.lchown(scratch, *user)
        for w in writable:
            for root, dirs, files in os.walk(scratch / w):
                for n in [root, *[os.path.join(root, x) for x in dirs + files]]:
                    os.lchown(n, *user)
    env = {"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "HOME": ANCHOR if use_ns else str(scratch),
           "TMPDIR": ANCHOR if use_ns else str(scratch), "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "PYTHONHASHSEED": "0",
           "PYTHONDONTWRITEBYTECODE": "1", "TQDM_DISABLE": "1", "MPLBACKEND": "Agg"}
    nproc = limits.nproc
    if user is None and not is_root() and os.path.isdir("/proc"):  # NPROC counts all our uid's
        nproc += sum(1 for d in os.listdir("/proc") if d.isdigit()
                     and _owner(d) == os.getuid())
    site_links, top_hide = [], []
    if use_ns:
        argv = [os.path.realpath(argv[0]), *argv[1:]]
        if (scratch / "site").is_dir():
            site_links = [(e.name, os.path.realpath(e)) for e in sorted((scratch / "site").iterdir())
                          if e.is_symlink() and os.path.isdir(e)]
        top_hide = _tops_to_hide(argv[0])
    cpu = int(limits.timeout) + 5
    mem = int(limits.memory_mb) * 2**20
    cg = _make_cgroup(limits, nproc) if user else None
    notes.append("memory and process caps: " + ("cgroup v2 (memory.max, pids.max)" if cg else
                 caps() if user else "watchers (not root: per-process limits only)"))
    cg_procs = str(cg / "cgroup.procs").encode() if cg else None

    def preexec():  # pragma: no cover - runs in the forked child before exec
        if cg_procs:  # the task and all it forks count against the cgroup's caps
            fd = os.open(cg_procs, os.O_WRONLY)
            os.write(fd, str(os.getpid()).encode())
            os.close(fd)
        if use_ns:
            libc = _c()
            _check(libc.unshare(CLONE_NEWNS | CLONE_NEWNET | (CLONE_NEWPID if use_pid else 0)),
                   "unshare")
            _check(libc.mount(b"none", b"/", None, MS_REC | MS_PRIVATE, None), "mount private")
            if use_pid:
                _become_pid1()
                _check(libc.mount(b"proc", b"/proc", b"proc", MS_NOSUID | MS_NODEV | MS_NOEXEC,
                                  None), "mount /proc")
            _check(libc.mount(str(scratch).encode(), ANCHOR.encode(), None, MS_BIND | MS_REC,
                              None), "bind scratch")
            if site_links:  # the packages, reached through links that the hiding below cuts
                site = f"{ANCHOR}/site"
                libc.mount(b"tmpfs", site.encode(), b"tmpfs", MS_NOSUID | MS_NODEV, b"size=64k")
                for name, src in site_links:
                    os.mkdir(f"{site}/{name}")
                    _check(libc.mount(src.encode(), f"{site}/{name}".encode(), None,
                                      MS_BIND | MS_REC, None), f"bind {name}")
            for d in ("/tmp", "/var/tmp", "/dev/shm"):
                if os.path.isdir(d):
                    libc.mount(b"tmpfs", d.encode(), b"tmpfs", MS_NOSUID | MS_NODEV,
                               b"size=16m,mode=1777")
            for d in hide:
                if os.path.isdir(d):
                    libc.mount(b"tmpfs", d.encode(), b"tmpfs", MS_RDONLY | MS_NOSUID | MS_NODEV,
                               b"size=4k,mode=0555")
            for d in top_hide:  # everything but the system: other copies of the project, /run
                libc.mount(b"tmpfs", d.encode(), b"tmpfs", MS_RDONLY | MS_NOSUID | MS_NODEV,
                           b"size=4k,mode=0555")
            os.chdir(ANCHOR)
        else:
            os.chdir(scratch)
        os.umask(0o077)
        if user:
            os.setgroups([])
            os.setgid(user[1])
            os.setuid(user[0])
        for res, val in ((resource.RLIMIT_CPU, cpu), (resource.RLIMIT_AS, mem),
                         (resource.RLIMIT_NPROC, nproc),
                         (resource.RLIMIT_FSIZE, limits.fsize_mb * 2**20),
                         (resource.RLIMIT_NOFILE, limits.nofile), (resource.RLIMIT_CORE, 0)):
            try:
                resource.setrlimit(res, (val, val))
            except (ValueError, OSError):  # a limit this system does not support (macOS: AS)
                pass

    logs = Path(tempfile.mkdtemp(prefix="hw4grade-log-"))
    out_path, err_path = logs / "stdout", logs / "stderr"
    known = set(_children_of(os.getpid()))
    t0 = time.monotonic()
    timed_out = False
    with open(out_path, "wb") as fo, open(err_path, "wb") as fe:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=fo, stderr=fe, env=env,
                                preexec_fn=preexec, start_new_session=True, close_fds=True)
        disk = None
        while True:  # the wall clock, and the disk the scratch folder takes (checked 4 times a s)
            left = t0 + limits.timeout - time.monotonic()
            try:
                proc.wait(timeout=max(0.0, min(0.25, left)))
                break
            except subprocess.TimeoutExpired:
                if left <= 0.25:
                    timed_out = True
                    break
                disk = _disk_over(scratch, limits) or (user and not cg and _memory_over(user[0], limits))
                if disk:
                    break
    seconds = time.monotonic() - t0
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    if user:
        _kill_user(*user)
    proc.wait()
    killed = _reap_orphans(known | {proc.pid})
    if user:
        _kill_user(*user)
    if cg:
        disk = disk or _cgroup_events(cg)
        _remove_cgroup(cg)
    res = Result(None if timed_out else proc.returncode, timed_out, seconds,
                 _read_capped(out_path, limits.output_cap), _read_capped(err_path, limits.output_cap),
                 killed, notes, disk)
    shutil.rmtree(logs, ignore_errors=True)
    return res


def _become_pid1() -> None:  # pragma: no cover - runs in the forked child before exec
    """After unshare(CLONE_NEWPID): fork; the child goes on (process 1 of the new namespace) to
    exec the task, this process stays behind, closes every descriptor (so that the exec's
    status pipe closes when the child execs), waits and ends as the child ended."""
    pid = os.fork()
    if pid == 0:
        return
    os.closerange(3, 65536)
    while True:
        try:
            _, status = os.waitpid(pid, 0)
            break
        except InterruptedError:
            continue
        except ChildProcessError:
            os._exit(1)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
    os._exit(os.WEXITSTATUS(status) if os.WIFEXITED(status) else 1)


def _memory_over(uid: int, limits: Limits) -> str | None:
    """Why the processes of ``uid`` together exceed the task's memory, or None.

    RLIMIT_AS bounds one process; forks (up to RLIMIT_NPROC) would multiply it. Each process
    counts its proportional share of the pages it shares (Pss: forks share the parent's pages
    until they write them)."""
    page = os.sysconf("SC_PAGE_SIZE")
    total = 0
    for d in os.listdir("/proc"):
        if d.isdigit() and _owner(d) == uid:
            try:
                with open(f"/proc/{d}/smaps_rollup", "rb") as f:
                    for line in f:
                        if line.startswith(b"Pss:"):
                            total += int(line.split()[1]) * 1024
                            break
            except (OSError, ValueError, IndexError):
                try:  # kernels before 4.14: resident pages, shared ones counted in each
                    with open(f"/proc/{d}/statm", "rb") as f:
                        total += int(f.read().split()[1]) * page
                except (OSError, ValueError, IndexError):
                    continue
    if total > limits.memory_mb * 2**20:
        return f"used more than {limits.memory_mb} MB of memory (all its processes together)"
    return None


def _disk_over(scratch: Path, limits: Limits) -> str | None:
    """Why the files in ``scratch`` exceed the task's disk limits, or None."""
    used, count = 0, 0
    stack = [str(scratch)]
    while stack:
        try:
            it = os.scandir(stack.pop())
        except OSError:
            continue
        with it:
            for e in it:
                count += 1
                if count > limits.disk_files:
                    return f"wrote more than {limits.disk_files} files"
                try:
                    st = e.stat(follow_symlinks=False)
                except OSError:
                    continue
                used += st.st_blocks * 512
                if used > limits.disk_mb * 2**20:
                    return f"wrote more than {limits.disk_mb} MB of files"
                if e.is_dir(follow_symlinks=False):
                    stack.append(e.path)
    return None


SYSTEM_TOPS = ("usr", "lib", "lib32", "lib64", "libx32", "bin", "sbin", "etc", "proc", "dev",
               "sys", "tmp")


def _tops_to_hide(interpreter: str) -> list:
    """The top-level folders hidden from the child: all but the system's, the interpreter's
    (its standard library) and the scratch anchor. The child's packages are bound into its
    scratch folder, so no copy of this project (a checkout, a virtual environment, Gradescope's
    /autograder) and no host service socket (/run) stays readable."""
    keep = set(SYSTEM_TOPS) | {ANCHOR.strip("/").split("/")[0]}
    parts = Path(os.path.realpath(interpreter)).parts
    if len(parts) > 1:
        keep.add(parts[1])
    out = []
    for name in sorted(os.listdir("/")):
        path = "/" + name
        if name not in keep and os.path.isdir(path) and not os.path.islink(path):
            out.append(path)
    return out


def remove_tree(path) -> None:
    """Remove ``path`` (never following links), also a tree nested thousands of folders deep
    by a submission (``shutil.rmtree`` recurses and raises RecursionError there)."""
    try:
        shutil.rmtree(path)
    except FileNotFoundError:
        pass
    except (OSError, RecursionError):
        subprocess.run(["rm", "-rf", "--one-file-system", "--", str(path)], check=False,
                       stdin=subprocess.DEVNULL, capture_output=True)


def _owner(pid: str) -> int:
    try:
        return os.stat(f"/proc/{pid}").st_uid
    except OSError:
        return -1
