#!/usr/bin/env bash
# The README's "build" command: set up, fetch the data, build the maps of tasks 1-4 into
# out/maps, then the book (HTML and PDF) and its report edition from the notebooks' stored outputs.
set -eo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
bash scripts/setup.sh
# shellcheck disable=SC1091
source .venv/bin/activate
export MPLBACKEND=Agg
python -m hw4 data
for task in 1 2 3 4; do
    python -m hw4 run --task "$task" --out out/maps --force
done
bash scripts/build_book.sh all
echo "build: maps in out/maps, book in _build/html/index.html and _build/hw4_book.pdf, report in _build/hw4_report.pdf"
