#!/usr/bin/env bash
# Idempotent setup for a fresh machine: the virtual environment with the package and its
# book/test extras, and Debian's TeX Live for the PDF (installed when missing and run as root;
# otherwise the exact command is printed and the PDF step will fail with a clear message).
#
#   bash scripts/setup.sh          # from anywhere; works on the repository this file is in
set -eo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ] || ! .venv/bin/python -m pip --version >/dev/null 2>&1; then
    rm -rf .venv
    echo "setup: creating .venv with $($PYTHON --version 2>&1)"
    if ! "$PYTHON" -m venv .venv; then
        # Debian/Ubuntu ship venv (ensurepip) separately
        if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
            rm -rf .venv
            apt-get update -q
            DEBIAN_FRONTEND=noninteractive apt-get install -y -q python3-venv
            "$PYTHON" -m venv .venv
        else
            rm -rf .venv  # a half-made venv would make the next run skip this step
            echo "setup: '$PYTHON -m venv' failed; install it with: sudo apt-get install -y python3-venv" >&2
            exit 1
        fi
    fi
fi
# shellcheck disable=SC1091
source .venv/bin/activate

# pip is quick when everything is already installed; the stamp skips it entirely when
# pyproject.toml has not changed since the last successful install.
stamp=.venv/.hw4-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || ! python -c "import hw4, nbval, jupyter_book" 2>/dev/null; then
    python -m pip install --quiet --disable-pip-version-check --upgrade pip
    python -m pip install --quiet --disable-pip-version-check -e '.[dev]'
    touch "$stamp"
fi

TEX_PACKAGES="texlive-latex-recommended texlive-fonts-recommended texlive-latex-extra texlive-xetex \
texlive-pictures texlive-plain-generic tex-gyre fonts-texgyre fonts-lmodern latexmk cm-super poppler-utils"
missing=""
for tool in xelatex pdflatex latexmk pdftoppm kpsewhich; do
    command -v "$tool" >/dev/null 2>&1 || missing="$missing $tool"
done
if command -v kpsewhich >/dev/null 2>&1; then
    # the LaTeX packages and fonts the book's PDF uses (see _config.yml)
    for file in ucharclasses.sty unicode-math.sty pgfplots.sty changepage.sty mathrsfs.sty \
                texgyretermes-regular.otf texgyreheros-regular.otf lmmono10-regular.otf latinmodern-math.otf; do
        [ -n "$(kpsewhich "$file")" ] || missing="$missing $file"
    done
fi
if [ -n "$missing" ]; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing TeX Live (missing:$missing)"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -q
        # shellcheck disable=SC2086
        apt-get install -y -q $TEX_PACKAGES
    else
        echo "setup: the PDF book needs TeX Live (missing:$missing); install it with:"
        echo "  sudo apt-get update && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y $TEX_PACKAGES"
    fi
fi
# The HTML book's MathJax, shipped with the build so that maths renders offline: MathJax 3 from
# the npm registry into the git-ignored .vendor/ (npm is Debian's when missing and root), then the
# parts the book uses (TeX input and its extensions, CommonHTML output and fonts, menu, a11y)
# into .vendor/static/mathjax, which _config.yml adds to html_static_path.
MATHJAX_VERSION=3.2.2
mathjax=.vendor/static/mathjax
if [ ! -f "$mathjax/tex-chtml.js" ] || [ "$(cat "$mathjax/VERSION" 2>/dev/null)" != "$MATHJAX_VERSION" ]; then
    if ! command -v npm >/dev/null 2>&1 && [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing npm (for MathJax)"
        apt-get update -q
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q npm
    fi
    if command -v npm >/dev/null 2>&1; then
        echo "setup: MathJax $MATHJAX_VERSION from npm into $mathjax"
        npm install --silent --no-audit --no-fund --no-save --prefix .vendor/npm "mathjax@$MATHJAX_VERSION"
        es5=.vendor/npm/node_modules/mathjax/es5
        rm -rf "$mathjax.tmp" && mkdir -p "$mathjax.tmp"
        cp -r "$es5/tex-chtml.js" "$es5/input" "$es5/output" "$es5/ui" "$es5/a11y" "$es5/sre" \
              "$es5/adaptors" "$mathjax.tmp/"
        rm -rf "$mathjax.tmp/output/svg" "$mathjax.tmp/output/svg.js" "$mathjax.tmp/input/mml"* \
               "$mathjax.tmp/input/asciimath"*
        echo "$MATHJAX_VERSION" > "$mathjax.tmp/VERSION"
        rm -rf "$mathjax" && mv "$mathjax.tmp" "$mathjax"
    else
        echo "setup: the HTML book needs MathJax from npm; install npm (sudo apt-get install -y npm) and run this again." >&2
    fi
fi

# The browser test (tests_browser/, run by test.sh after the book build): Debian's Chromium and
# its WebDriver, installed when missing and run as root (selenium itself comes from PyPI).
if ! command -v chromium >/dev/null 2>&1 || ! command -v chromedriver >/dev/null 2>&1; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing Chromium and chromium-driver (browser test)"
        apt-get update -q
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium chromium-driver
    else
        echo "setup: the browser test needs Chromium; install it with:"
        echo "  sudo apt-get update && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y chromium chromium-driver"
    fi
fi
echo "setup: ready ($(python --version), $(python -c 'import hw4; print("hw4", hw4.__version__)'))"
