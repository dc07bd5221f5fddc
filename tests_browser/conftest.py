"""Fixtures for the browser test of the built HTML book (run by test.sh after the book build).

The book in ``_build/html`` is served on 127.0.0.1 by a thread of this process and opened in
Debian's headless Chromium through its chromedriver (selenium). Chromium runs with a new, empty
profile, without background networking, and with every host name except 127.0.0.1 resolving to
nothing, so a page that needed the network would show it here; every request a page makes is
recorded (DevTools performance log) and checked to be local.
"""
from __future__ import annotations

import functools
import http.server
import os
import shutil
import tempfile
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# the build to test: _build/html, or another build (HW4_BOOK_HTML=/path/to/html)
HTML = Path(os.environ.get("HW4_BOOK_HTML") or ROOT / "_build" / "html")
SHOTS = ROOT / "_build" / "browser"
CHROMIUM = ("chromium", "chromium-browser", "google-chrome")


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # the test reports what matters; no access log on stderr
        pass


@pytest.fixture(scope="session")
def book_url():
    """Base URL of ``_build/html`` served on 127.0.0.1 (an ephemeral port)."""
    if not (HTML / "index.html").is_file():
        pytest.fail("the HTML book is not built: run `bash scripts/build_book.sh all` first.")
    handler = functools.partial(_Quiet, directory=str(HTML))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


@pytest.fixture(scope="session")
def driver():
    """Headless Chromium with no network but 127.0.0.1, console and network logs on."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary = next((shutil.which(b) for b in CHROMIUM if shutil.which(b)), None)
    chromedriver = shutil.which("chromedriver")
    if binary is None or chromedriver is None:
        pytest.fail("Chromium and chromedriver are needed: run `bash scripts/setup.sh` as root "
                    "(apt-get install chromium chromium-driver).")
    os.environ["SE_OFFLINE"] = "true"  # selenium manager must never download a browser or driver
    profile = tempfile.mkdtemp(prefix="hw4-chromium-")
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--disable-default-apps", "--disable-extensions",
                 "--disable-dev-shm-usage", "--autoplay-policy=no-user-gesture-required",
                 f"--user-data-dir={profile}", "--window-size=1400,1000",
                 # no DNS for anything but the local server: a CDN request fails here
                 "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=127.0.0.1"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    drv = webdriver.Chrome(service=Service(executable_path=chromedriver), options=opts)
    drv.set_page_load_timeout(60)
    drv.set_script_timeout(60)
    yield drv
    drv.quit()
    shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="session")
def shots():
    """Folder for the screenshots (``_build/browser``), emptied once per session."""
    shutil.rmtree(SHOTS, ignore_errors=True)
    SHOTS.mkdir(parents=True)
    return SHOTS
