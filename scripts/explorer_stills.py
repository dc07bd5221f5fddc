"""Retake the book's stills of the live explorer (``notebooks/_static/t2_explorer.png``,
``t4_explorer.png``): the explorer of Tasks 2 and 4 running in Notebook 7, as a reader sees it.

What it does, per task: copies the chapter's explorer cell (cell id ``t2-explorer-code`` of
``notebooks/T2_continuous_csm.ipynb``, ``t4-explorer-code`` of
``notebooks/T4_continuous_semantic_csm.ipynb``; the chapters are only read) into a generated
notebook in a temporary folder, starts a Notebook 7 server there (jupyter-server on 127.0.0.1, a
free port, no token, its own config and runtime folders), opens the notebook in Debian's headless
Chromium through chromedriver (selenium; the same offline flags as ``tests_browser/conftest.py``,
at a device scale of 1.5), runs the cell with Ctrl+Enter, waits for the widgets, clicks the map
on the cell at ``--cell`` (default (-9, -18.5) m, world frame) through ipyevents, waits until the
evidence table shows that cell and the kernel is idle, and screenshots the cell (input and
output, ``.jp-Cell``). The screenshots are reduced to a 256-colour palette (as the book's PNGs
are) and written only when every task succeeded, each through a temporary file and a rename.

    source .venv/bin/activate
    python scripts/explorer_stills.py                  # both stills into notebooks/_static
    python scripts/explorer_stills.py --task 4 --out /tmp/stills

On any failure it prints one line (``explorer_stills: error: ...``), leaves the stills as they
were, stops Chromium and the server (its whole process group, kernels included) and exits 1.
The timings in the explorer's status line ("map 0 ms, cell and figure ... ms") are those of this
run: the map is cached by the click, the rest depends on the machine's load.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHAPTERS = {2: ("T2_continuous_csm.ipynb", "t2-explorer-code"),
            4: ("T4_continuous_semantic_csm.ipynb", "t4-explorer-code")}
CHROMIUM = ("chromium", "chromium-browser", "google-chrome")
SCALE = 1.5                 # device pixels per CSS pixel (the stills' scale)
WINDOW = (1165, 1700)       # [CSS px]: Notebook 7's cell 1145 px wide (1719 device px, the
                            # stills' framing; 1190 px at most in a wider window), tall enough
                            # that the whole cell (about 1175 px) shows without scrolling


class StillError(Exception):
    """A failure reported in one line."""


def chapter_cell(task: int) -> str:
    """The source of the chapter's explorer code cell (read-only)."""
    name, cell_id = CHAPTERS[task]
    path = ROOT / "notebooks" / name
    try:
        nb = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise StillError(f"cannot read {path}: {e}")
    for cell in nb.get("cells", []):
        if cell.get("id") == cell_id and cell.get("cell_type") == "code":
            src = cell["source"]
            return "".join(src) if isinstance(src, list) else src
    raise StillError(f"{path.name} has no code cell with id {cell_id!r}")


def write_notebook(folder: Path, task: int, source: str) -> str:
    """A one-cell notebook (nbformat 4) with ``source``, for the python3 kernel; its file name."""
    name = f"explorer_t{task}.ipynb"
    nb = {"cells": [{"cell_type": "code", "execution_count": None, "id": f"t{task}-explorer",
                     "metadata": {}, "outputs": [], "source": source}],
          "metadata": {"kernelspec": {"display_name": "Python 3 (ipykernel)", "language": "python",
                                      "name": "python3"},
                       "language_info": {"name": "python"}},
          "nbformat": 4, "nbformat_minor": 5}
    (folder / name).write_text(json.dumps(nb, indent=1), encoding="utf-8")
    return name


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def get_json(url: str, timeout: float = 5.0):
    with urllib.request.urlopen(url, timeout=timeout) as r:
        return json.loads(r.read().decode())


class Server:
    """Notebook 7 on 127.0.0.1 in ``folder`` (token off), in its own process group."""

    def __init__(self, folder: Path, timeout: float):
        self.folder, self.port = folder, free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        conf = folder / ".jupyter"
        (conf / "labconfig").mkdir(parents=True)
        # no "official Jupyter news?" toast over the notebook
        (conf / "labconfig" / "page_config.json").write_text(json.dumps(
            {"disabledExtensions": {"@jupyterlab/apputils-extension:announcements": True}}))
        env = dict(os.environ, JUPYTER_CONFIG_DIR=str(conf),
                   JUPYTER_RUNTIME_DIR=str(folder / ".runtime"),
                   IPYTHONDIR=str(folder / ".ipython"), PYTHONPATH=str(ROOT))
        self.log_path = folder / ".server.log"
        self.log = open(self.log_path, "wb")
        cmd = [sys.executable, "-m", "notebook", "--no-browser", "--ServerApp.ip=127.0.0.1",
               f"--ServerApp.port={self.port}", "--ServerApp.port_retries=0",
               "--IdentityProvider.token=", "--ServerApp.password=",
               f"--ServerApp.root_dir={folder}", "--ServerApp.open_browser=False"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:   # containers: Jupyter refuses root without it
            cmd.append("--allow-root")
        self.proc = subprocess.Popen(cmd, cwd=folder, env=env, stdin=subprocess.DEVNULL,
                                     stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        end = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                raise StillError(f"the Jupyter server exited ({self.proc.returncode}): "
                                 f"{self.last_log_line()}")
            try:
                get_json(self.url + "api/status")
                return
            except OSError:
                if time.monotonic() > end:
                    raise StillError(f"the Jupyter server did not answer on {self.url} "
                                     f"within {timeout:g} s")
                time.sleep(0.3)

    def last_log_line(self) -> str:
        try:
            lines = [ln for ln in self.log_path.read_text(errors="replace").splitlines() if ln.strip()]
        except OSError:
            return "(no log)"
        return lines[-1].strip() if lines else "(empty log)"

    def kernel_idle(self, notebook: str) -> bool:
        """True when the server has a session of ``notebook`` whose kernel is idle."""
        for s in get_json(self.url + "api/sessions"):
            if s.get("path", "").endswith(notebook) and s.get("kernel"):
                return s["kernel"].get("execution_state") == "idle"
        return False

    def stop(self):
        """Stop the server and its kernels (the whole process group)."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout=10)
            except ProcessLookupError:
                pass
        try:   # kernels left in the group after the server's exit
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.log.close()


def chromium(profile: Path):
    """Headless Chromium at device scale :data:`SCALE`, no network but 127.0.0.1."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    binary = next((shutil.which(b) for b in CHROMIUM if shutil.which(b)), None)
    chromedriver = shutil.which("chromedriver")
    if binary is None or chromedriver is None:
        raise StillError("Chromium and chromedriver are needed (apt-get install chromium "
                         "chromium-driver, as scripts/setup.sh does)")
    os.environ["SE_OFFLINE"] = "true"   # selenium manager must never download a browser
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--disable-default-apps", "--disable-extensions",
                 "--disable-dev-shm-usage", "--hide-scrollbars", f"--user-data-dir={profile}",
                 f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--force-device-scale-factor={SCALE}",
                 "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=127.0.0.1"):
        opts.add_argument(flag)
    drv = webdriver.Chrome(service=Service(executable_path=chromedriver), options=opts)
    drv.set_page_load_timeout(60)
    drv.set_script_timeout(60)
    return drv


def wait_for(what: str, test, timeout: float, step: float = 0.25):
    """Poll ``test()`` until it returns something true; its value, or StillError naming ``what``."""
    end = time.monotonic() + timeout
    while True:
        value = test()
        if value:
            return value
        if time.monotonic() > end:
            raise StillError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(step)


# the output's parts, found in the page (Notebook 7 / JupyterLab 4 class names)
JS_STATE = """
const cell = document.querySelector('.jp-Notebook .jp-CodeCell');
if (!cell) return null;
const out = cell.querySelector('.jp-OutputArea');
const img = out && out.querySelector('.widget-image');
const html = out ? Array.from(out.querySelectorAll('.widget-html-content')).map(e => e.innerText) : [];
const err = out && out.querySelector('[data-mime-type="application/vnd.jupyter.stderr"], .jp-RenderedText[data-mime-type="application/vnd.jupyter.error"]');
let box = null;
if (img && img.complete && img.naturalWidth > 0) {
  const r = img.getBoundingClientRect();
  box = [r.left, r.top, r.width, r.height, img.naturalWidth, img.naturalHeight];
}
return {img: box, src: img ? img.src : null, html: html, error: err ? err.innerText : null};
"""


def click_point(task: int, x: float, y: float):
    """The pixel (from the top left, the figure's own pixels) of the world point (x, y) [m] on
    the explorer's map panel (:data:`hw4.book.explorer.PANELS`, the map's extent)."""
    from hw4.book import explorer as ex
    from hw4.core.grid import RANGE_X, RANGE_Y
    x0, y0, w, h = ex.PANELS[0]
    px = x0 + (x - RANGE_X[0]) / (RANGE_X[1] - RANGE_X[0]) * w
    py = y0 + (y - RANGE_Y[0]) / (RANGE_Y[1] - RANGE_Y[0]) * h
    return px, ex.FIG_PX[1] - py


def take_still(drv, server: Server, notebook: str, task: int, cell: tuple, timeout: float) -> bytes:
    """Open ``notebook``, run its cell, click the map at ``cell`` [m], screenshot the cell."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    drv.get(server.url + "notebooks/" + notebook)
    wait_for("the kernel to start", lambda: server.kernel_idle(notebook), timeout, 0.5)
    time.sleep(1.0)   # the page's kernel connection settles
    editor = wait_for("the notebook's code cell", lambda: drv.find_elements(
        By.CSS_SELECTOR, ".jp-Notebook .jp-CodeCell .cm-content"), 60)[0]
    editor.click()
    ActionChains(drv).key_down(Keys.CONTROL).send_keys(Keys.ENTER).key_up(Keys.CONTROL).perform()

    def state():
        s = drv.execute_script(JS_STATE)
        if s and s.get("error"):
            raise StillError(f"the cell failed: {s['error'].strip().splitlines()[-1]}")
        return s

    first = wait_for("the explorer's figure and table", lambda: (
        (s := state()) and s["img"] and any(t.startswith("Cell ") for t in s["html"]) and s),
        timeout, 0.5)
    wait_for("the kernel to finish the cell", lambda: server.kernel_idle(notebook), timeout, 0.5)
    # a click on the map, where the reader clicks: the image's own pixels -> page pixels
    left, top, width, height, nat_w, nat_h = first["img"]
    px, py = click_point(task, *cell)
    vx, vy = left + px * width / nat_w, top + py * height / nat_h
    actions = ActionChains(drv)
    actions.w3c_actions.pointer_action.move_to_location(round(vx), round(vy))
    actions.w3c_actions.pointer_action.click()
    actions.perform()
    # the table names the picked cell by its centre: the click's cell, not a neighbour
    want = f"at ({cell[0]:.3f}, {cell[1]:.3f}) m"
    try:
        wait_for(f"the table of the cell {want}", lambda: (
            (s := state()) and s["src"] != first["src"]
            and any(want in t for t in s["html"]) and s), 60, 0.25)
    except StillError:
        s = state() or {}
        shown = next((t.split(":")[0] for t in s.get("html", []) if t.startswith("Cell ")), "none")
        raise StillError(f"the click at page pixel ({vx:.1f}, {vy:.1f}) did not pick the cell "
                         f"{want}; the table shows {shown!r}")
    wait_for("the kernel to finish the click", lambda: server.kernel_idle(notebook), 60, 0.25)

    def settled():   # the output unchanged for a second, its image loaded
        a = state()
        time.sleep(1.0)
        b = state()
        return a == b and b["img"] is not None
    wait_for("the output to settle", settled, 30, 0)
    target = drv.find_element(By.CSS_SELECTOR, ".jp-Notebook .jp-CodeCell")
    rect = drv.execute_script("const r = arguments[0].getBoundingClientRect();"
                              "return [r.top, r.bottom, window.innerHeight];", target)
    if rect[0] < 0 or rect[1] > rect[2]:
        raise StillError(f"the cell ({rect[1] - rect[0]:.0f} px high) does not fit the "
                         f"{WINDOW[1]} px window: raise WINDOW")
    return target.screenshot_as_png


def palette_png(png: bytes) -> bytes:
    """The screenshot as a 256-colour palette PNG (the book's stills are such PNGs)."""
    import io
    from PIL import Image
    im = Image.open(io.BytesIO(png)).convert("RGB")
    q = im.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    buf = io.BytesIO()
    q.save(buf, format="png", optimize=True)
    return buf.getvalue()


def run(tasks, out: Path, cell, timeout: float) -> list[Path]:
    sources = {t: chapter_cell(t) for t in tasks}
    if not out.is_dir():
        raise StillError(f"the output folder {out} does not exist")
    tmp = Path(tempfile.mkdtemp(prefix="hw4-stills-"))
    server = drv = None
    shots = {}
    try:
        names = {t: write_notebook(tmp, t, sources[t]) for t in tasks}
        server = Server(tmp, 60)
        drv = chromium(tmp / ".chromium")
        for t in tasks:
            shots[t] = palette_png(take_still(drv, server, names[t], t, cell, timeout))
    finally:
        if drv is not None:
            try:
                drv.quit()
            except Exception:   # the browser may be gone already; the server must still stop
                pass
        if server is not None:
            server.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    written = []
    for t in tasks:   # every still taken: now replace the old ones, each atomically
        path = out / f"t{t}_explorer.png"
        part = path.with_name(f".{path.name}.part")
        part.write_bytes(shots[t])
        os.replace(part, path)
        written.append(path)
    return written


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="scripts/explorer_stills.py",
                                description="Retake the book's stills of the live explorer (T2, T4).")
    p.add_argument("--task", type=int, nargs="+", choices=(2, 4), default=[2, 4])
    p.add_argument("--out", type=Path, default=ROOT / "notebooks" / "_static",
                   help="folder for t2_explorer.png / t4_explorer.png (default notebooks/_static)")
    p.add_argument("--cell", type=float, nargs=2, default=(-9.0, -18.5), metavar=("X", "Y"),
                   help="world point [m] to click on the map (default -9 -18.5)")
    p.add_argument("--timeout", type=float, default=240.0,
                   help="seconds to wait for the kernel and the first redraw (default 240)")
    a = p.parse_args(argv)
    from hw4.core.grid import RANGE_X, RANGE_Y
    x, y = a.cell
    if not (RANGE_X[0] <= x <= RANGE_X[1] and RANGE_Y[0] <= y <= RANGE_Y[1]):
        print(f"explorer_stills: error: --cell ({x:g}, {y:g}) m lies outside the map "
              f"x {RANGE_X}, y {RANGE_Y}", file=sys.stderr)
        return 1
    try:
        for path in run(sorted(set(a.task)), a.out, tuple(a.cell), a.timeout):
            from PIL import Image
            with Image.open(path) as im:
                print(f"wrote {path} ({im.width}x{im.height} px, {path.stat().st_size:,} bytes)")
    except StillError as e:
        print(f"explorer_stills: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("explorer_stills: error: interrupted", file=sys.stderr)
        return 1
    except Exception as e:   # selenium, OS: one line, never a traceback
        msg = (str(e).strip().splitlines() or [""])[0] or type(e).__name__
        print(f"explorer_stills: error: {type(e).__name__}: {msg}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
