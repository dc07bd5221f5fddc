#!/usr/bin/env bash
# Build the book from the outputs stored in the notebooks (nothing is executed here), with
# Sphinx warnings as errors: HTML into _build/html, PDF into _build/latex and _build/hw4_book.pdf,
# and the report edition (the student's short PDF, hw4/book/report.py and report/) into
# _build/hw4_report.pdf.
#
#   bash scripts/build_book.sh          # HTML, PDF and report
#   bash scripts/build_book.sh html     # HTML only
#   bash scripts/build_book.sh pdf      # PDF only
#   bash scripts/build_book.sh report   # report only (HW4_BOOK_AUTHOR: the student's name)
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

if [ "$what" = all ] || [ "$what" = report ]; then
    if ! command -v xelatex >/dev/null 2>&1 || ! command -v latexmk >/dev/null 2>&1; then
        echo "book: the report needs TeX Live (xelatex, latexmk): run 'bash scripts/setup.sh' as root, or see its message." >&2
        exit 1
    fi
    echo "book: report"
    rm -f _build/hw4_report.pdf
    # the source folder _build/report_src: the chapters' glue cells and figures, report/taskN.md
    python -m hw4.book.report ${HW4_BOOK_AUTHOR:+--name "$HW4_BOOK_AUTHOR"}
    # the name is the report's author line already (not also the extension's extra line)
    env -u HW4_BOOK_AUTHOR jupyter-book build _build/report_src --builder pdflatex -W -n --keep-going
    if [ ! -s _build/report_src/_build/latex/hw4_report.pdf ]; then
        echo "book: LaTeX finished without writing the report; see _build/report_src/_build/latex/hw4_report.log." >&2
        exit 1
    fi
    cp _build/report_src/_build/latex/hw4_report.pdf _build/hw4_report.pdf
    echo "book: report at _build/hw4_report.pdf"
fi

# The HTML links the whole book's PDF (book/_ext/templates/hw4-pdf-link.html) next to index.html.
if [ -d _build/html ] && [ -s _build/hw4_book.pdf ]; then
    cp _build/hw4_book.pdf _build/html/hw4_book.pdf
fi
