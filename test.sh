#!/usr/bin/env bash
# The README's "test" command: set up, fetch the data, run the unit tests, re-execute every
# notebook with nbval (stored outputs must match what the code produces now), then build the
# book (HTML and PDF) with Sphinx warnings as errors, then open every HTML page in headless
# Chromium with no network (tests_browser). Exits non-zero on any failure.
set -eo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
bash scripts/setup.sh
# shellcheck disable=SC1091
source .venv/bin/activate
# Deterministic re-execution: one BLAS thread, fixed hash seed, no stdin.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 PYTHONHASHSEED=0

stage() { echo; echo "== $1 ($(date -u +%H:%M:%S))"; }

# pytest exit codes: 0 passed, 5 collected nothing (a failure here), anything else failed.
run_pytest() {
    local rc=0
    python -m pytest -p no:cacheprovider "$@" </dev/null || rc=$?
    if [ "$rc" -eq 5 ]; then
        echo "test: pytest collected no tests ($*); that is a failure." >&2
        exit 1
    elif [ "$rc" -ne 0 ]; then
        echo "test: pytest failed with exit code $rc ($1 ...)." >&2
        exit "$rc"
    fi
}

stage "data"
python -m hw4 data

stage "unit tests"
MPLBACKEND=Agg run_pytest tests

stage "reference C++/ROS package (Task 5: build, run the nodes headless, compare with ours)"
# Where ROS 1 can be installed (root on Debian 12 with apt, as in CI): scripts/reference_ros.sh
# installs it, builds BKISemanticMapping, runs its nodes on the toy and sequence 04 scans without
# RViz and records their maps; tests/test_bki_rosref_ros.py compares them with ours.
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 && grep -q '^VERSION_ID="12"' /etc/os-release 2>/dev/null; then
    bash scripts/reference_ros.sh --no-rviz --no-compare --out out/ros_ci
    HW4_ROS_OUT=out/ros_ci MPLBACKEND=Agg run_pytest tests/test_bki_rosref_ros.py
else
    echo "test: skipped (needs root on Debian 12 with apt to install ROS 1; run scripts/reference_ros.sh by hand elsewhere)"
fi

stage "notebooks (nbval re-executes each one and compares its stored outputs)"
notebooks=()
for nb in notebooks/*.ipynb book/*.ipynb; do [ -e "$nb" ] && notebooks+=("$nb"); done
# The kernels draw with matplotlib's inline backend, as Jupyter does, so that every figure the
# notebook stores is produced again (Agg would draw nothing and nbval would see outputs missing).
MPLBACKEND=module://matplotlib_inline.backend_inline run_pytest "${notebooks[@]}" \
    --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg \
    --nbval-cell-timeout 600

stage "book (HTML, PDF and the report edition, Sphinx warnings as errors)"
bash scripts/build_book.sh all

stage "browser (every HTML page in headless Chromium, no network: maths, drawers at 420 px, images, videos, console)"
run_pytest tests_browser

stage "done"
