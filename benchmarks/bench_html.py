"""What a reader's browser loads, page by page, for one or two builds of the HTML book.

    python benchmarks/bench_html.py                      # _build/html
    python benchmarks/bench_html.py OLD/_build/html _build/html   # side by side, with ratios

For every page, in headless Chromium (no network, no cache):

* bytes: everything the page loads served over 127.0.0.1 (the sum of Chromium's encoded data
  lengths: HTML, CSS, scripts, fonts, images, the 3D view's frame and its scripts);
* load from disk: the page opened as file:// until the DOM is ready and until its load event
  (every image, video and frame loaded), best of 5, the builds taking turns [s];
* figures at 420 px: each figure image's displayed width over its natural width (the scale at
  which a phone shows it; text drawn 25 px high shows at 25 x that), min / median / max; with
  the zoom viewer of book/_static/hw4-nav.js, the scale at which the viewer first shows it.

The numbers depend on the machine and its load (times) but not on it (bytes, scales).
"""
from __future__ import annotations

import functools
import http.server
import json
import shutil
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DISK_PAGES = ("notebooks/T5_bki_3d.html", "notebooks/T1_discrete_csm.html", "book/intro.html")

SCALES = """
const imgs = Array.from(document.querySelectorAll('.bd-article img'))
  .filter(i => i.naturalWidth > 300 && i.clientWidth > 0);
return imgs.map(i => i.clientWidth / i.naturalWidth);
"""

VIEWER = """
const done = arguments[arguments.length - 1];
const link = document.querySelector('.bd-article a.hw4-image-link');
// a build without the viewer would follow the link to the bare image
if (!link || !document.querySelector('.hw4-zoom-button')) { done(null); return; }
link.click();
setTimeout(() => {
  const d = document.querySelector('dialog.hw4-zoom');
  const img = d && d.querySelector('img');
  const out = d && d.open && img.naturalWidth ? img.clientWidth / img.naturalWidth : null;
  if (d && d.open) d.close();
  done(out);
}, 800);
"""


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _serve(directory: Path):
    handler = functools.partial(_Quiet, directory=str(directory))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def _driver():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary = next(shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome")
                  if shutil.which(b))
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    profile = tempfile.mkdtemp(prefix="hw4-bench-")
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--disable-background-networking", "--disable-extensions",
                 "--disable-dev-shm-usage", f"--user-data-dir={profile}",
                 "--allow-file-access-from-files",
                 "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--window-size=1400,1000"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"performance": "ALL"})
    drv = webdriver.Chrome(service=Service(executable_path=shutil.which("chromedriver")),
                           options=opts)
    drv.set_page_load_timeout(120)
    drv.set_script_timeout(60)
    drv.execute_cdp_cmd("Network.enable", {})
    drv.execute_cdp_cmd("Network.setCacheDisabled", {"cacheDisabled": True})
    return drv, profile


def _viewport(drv, width):
    drv.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                        {"width": width, "height": 1000, "deviceScaleFactor": 1,
                         "mobile": width < 992})


def _settle(drv):
    drv.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "(window.MathJax && MathJax.startup && MathJax.startup.promise"
        " ? MathJax.startup.promise : Promise.resolve()).then(() => setTimeout(done, 300));")


def _bytes(drv, url):
    drv.get_log("performance")
    drv.get(url)
    _settle(drv)
    total = 0
    for entry in drv.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg.get("method") == "Network.loadingFinished":
            total += msg["params"].get("encodedDataLength", 0)
    return total


def load_times(drv, paths: list[Path], repeat=5) -> list[tuple[float, float]]:
    """[s] (DOM ready, load event) of each file:// page, the best of `repeat` runs, the pages
    taking turns so that a change in the machine's load affects them alike."""
    best = [[float("inf"), float("inf")] for _ in paths]
    for _ in range(repeat):
        for k, path in enumerate(paths):
            drv.get("about:blank")
            drv.get(path.as_uri())
            t = drv.execute_script(
                "const n = performance.getEntriesByType('navigation')[0];"
                "return [n.domContentLoadedEventEnd - n.startTime, n.loadEventEnd - n.startTime];")
            best[k] = [min(b, x / 1000) for b, x in zip(best[k], t)]
    return [tuple(b) for b in best]


def measure(html: Path, drv) -> dict:
    pages = sorted(p.relative_to(html).as_posix() for p in html.rglob("*.html")
                   if not {"_static", "_sources", ".ros_ws"} & set(p.parts)
                   and p.name != "index.html")
    server = _serve(html)
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    out = {}
    try:
        for page in pages:
            _viewport(drv, 1400)
            row = {"bytes": _bytes(drv, base + page)}
            _viewport(drv, 420)
            drv.get(base + page)
            _settle(drv)
            row["scales"] = drv.execute_script(SCALES)
            row["viewer"] = drv.execute_async_script(VIEWER) if row["scales"] else None
            out[page] = row
    finally:
        server.shutdown()
        server.server_close()
    return out


def _mb(n):
    return f"{n / 1e6:7.2f} MB"


def _scales(s):
    if not s:
        return "-"
    return f"{min(s):.2f}/{statistics.median(s):.2f}/{max(s):.2f} (n={len(s)})"


def main(argv: list[str]) -> int:
    dirs = [Path(a) for a in argv] or [ROOT / "_build" / "html"]
    for d in dirs:
        if not (d / "index.html").is_file():
            print(f"bench_html: no built book in {d} (run `bash scripts/build_book.sh html`).",
                  file=sys.stderr)
            return 1
    drv, profile = _driver()
    try:
        results = [measure(d, drv) for d in dirs]
        _viewport(drv, 1400)
        disk = {page: load_times(drv, [d / page for d in dirs]) for page in DISK_PAGES}
    finally:
        drv.quit()
        shutil.rmtree(profile, ignore_errors=True)
    pages = sorted(set().union(*results))
    print("bytes loaded per page (served, no cache)" +
          ("" if len(dirs) == 1 else f": {dirs[0]}  vs  {dirs[1]}"))
    for page in pages:
        rows = [r.get(page) for r in results]
        cells = [_mb(r["bytes"]) if r else "      -   " for r in rows]
        ratio = (f"  x{rows[1]['bytes'] / rows[0]['bytes']:.2f}"
                 if len(rows) == 2 and all(rows) else "")
        print(f"  {page:40s} " + "  ".join(cells) + ratio)
    totals = [sum(r[p]["bytes"] for p in r) / len(r) for r in results]
    print(f"  {'mean over pages':40s} " + "  ".join(_mb(t) for t in totals) +
          (f"  x{totals[1] / totals[0]:.2f}" if len(totals) == 2 else ""))
    print("load from disk (file://, 1400 px, best of 5 taking turns): DOM ready / load event")
    for page in DISK_PAGES:
        times = disk[page]
        print(f"  {page:40s} " + "  ".join(f"{a:5.2f} / {b:5.2f} s" for a, b in times) +
              (f"  x{times[1][0] / times[0][0]:.2f} / x{times[1][1] / times[0][1]:.2f}"
               if len(times) == 2 else ""))
    print("figures at 420 px: displayed / natural width, min/median/max; viewer's first scale")
    for page in pages:
        rows = [r.get(page) for r in results]
        if not any(r and r["scales"] for r in rows):
            continue
        print(f"  {page:40s} " + "   ".join(
            (_scales(r["scales"]) + (f", viewer {r['viewer']:.2f}" if r and r["viewer"] else ""))
            if r else "-" for r in rows))
    allscales = [[s for p in r for s in r[p]["scales"]] for r in results]
    print(f"  {'all figures':40s} " + "   ".join(_scales(s) for s in allscales))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
