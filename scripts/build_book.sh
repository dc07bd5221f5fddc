#!/usr/bin/env bash
# Build the book from the outputs stored in the notebooks (nothing is executed here), with
# Sphinx warnings as errors: HTML into _build/html, PDF into _build/latex and _build/hw4_book.pdf.
#
#   bash scripts/build_book.sh          # HTML and PDF
#   bash scripts/build_book.sh html     # HTML only
#   bash scripts/build_book.sh pdf      # PDF only
set -eo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if [ -z "$VIRTUAL_ENV" ] && [ -f .venv/bin/activate ]; then
    # shellcheck disable=SC1091
    source .venv/bin/activate
fi
what=${1:-all}

if [ "$what" = all ] || [ "$what" = html ]; then
    echo "book: HTML"
    # plotly.js for Task 5's interactive map, from the installed package (never a CDN)
    python -c "from hw4.bki.interactive import vendor_plotly; vendor_plotly('notebooks/_static/interactive')"
    jupyter-book build . -W -n --keep-going
fi

if [ "$what" = all ] || [ "$what" = pdf ]; then
    if ! command -v xelatex >/dev/null 2>&1 || ! command -v latexmk >/dev/null 2>&1; then
        echo "book: the PDF needs TeX Live (xelatex, latexmk): run 'bash scripts/setup.sh' as root, or see its message." >&2
        exit 1
    fi
    echo "book: PDF"
    rm -f _build/latex/hw4_book.pdf _build/hw4_book.pdf
    jupyter-book build . --builder pdflatex -W -n --keep-going
    if [ ! -s _build/latex/hw4_book.pdf ]; then
        echo "book: LaTeX finished without writing _build/latex/hw4_book.pdf; see _build/latex/hw4_book.log." >&2
        exit 1
    fi
    cp _build/latex/hw4_book.pdf _build/hw4_book.pdf
    echo "book: PDF at _build/hw4_book.pdf"
fi

# The HTML links the whole book's PDF (book/_ext/templates/hw4-pdf-link.html) next to index.html.
if [ -d _build/html ] && [ -s _build/hw4_book.pdf ]; then
    cp _build/hw4_book.pdf _build/html/hw4_book.pdf
fi
