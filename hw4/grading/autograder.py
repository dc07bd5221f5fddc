"""The Gradescope autograder zip: ``setup.sh``, ``run_autograder``, this package, data, config.

Gradescope unpacks the zip into ``/autograder/source`` and runs ``setup.sh`` once (as root, on its
Ubuntu 22.04 image), then ``/autograder/run_autograder`` for each submission, which must write
``/autograder/results/results.json``. Here ``setup.sh`` installs Python 3.11 (Ubuntu's package),
makes a virtual environment with this package, creates the unprivileged user the student code
runs as, and closes the package's folder to that user; ``run_autograder`` grades
``/autograder/submission``. ``AUTOGRADER_ROOT`` and ``HW4_PYTHON`` move both (for a test in a
temporary folder).
"""
from __future__ import annotations

import zipfile
from pathlib import Path

from ..core import data as _data
from ..core.errors import InputError
from .config import DEFAULT, load as load_config

PKG = Path(__file__).resolve().parents[1]

SETUP = """#!/usr/bin/env bash
# Gradescope runs this once, as root, when it builds the autograder image (Ubuntu 22.04).
set -euo pipefail
SRC=${AUTOGRADER_ROOT:-/autograder}/source
apt-get update -q
apt-get install -y -q python3.11 python3.11-venv   # Ubuntu 22.04's own Python is 3.10
python3.11 -m venv /autograder/venv
/autograder/venv/bin/pip install -q "$SRC"
# the unprivileged user that runs student code (one per parallel worker; run_autograder uses 1)
id hw4grader >/dev/null 2>&1 || useradd --system --no-create-home --shell /usr/sbin/nologin hw4grader
# the grader, its data and the reference code are closed to that user
chmod 700 "$SRC" /autograder/venv/lib/python3.11/site-packages/hw4
"""

RUN = """#!/usr/bin/env bash
# Gradescope runs this for each submission; it must write results/results.json.
ROOT=${AUTOGRADER_ROOT:-/autograder}
PY=${HW4_PYTHON:-/autograder/venv/bin/python}
cd "$ROOT"
mkdir -p "$ROOT/results"
export HW4_DATA_DIR="$ROOT/source/data"
"$PY" -m hw4 grade "$ROOT/submission" --out "$ROOT/results" --config "$ROOT/source/config.toml" \\
  || "$PY" - "$ROOT/results/results.json" <<'PYEOF'
import json, sys
json.dump({"score": 0, "output": "The autograder could not grade this submission; "
           "ask the course staff.", "tests": []}, open(sys.argv[1], "w"))
PYEOF
"""


def build_zip(out: Path, config: Path | None = None) -> Path:
    """Write the autograder zip to ``out``; return its path."""
    cfg_path = Path(config) if config else DEFAULT
    load_config(cfg_path)  # refuse a broken configuration now, not on Gradescope
    out = Path(out)
    if out.exists() or out.is_symlink():  # replace only an earlier autograder zip
        try:
            with zipfile.ZipFile(out) as z:
                ours = "run_autograder" in z.namelist() and not out.is_symlink()
        except (OSError, zipfile.BadZipFile):
            ours = False
        if not ours:
            raise InputError(f"{out} exists and is not an earlier autograder zip: choose another --out")
    tmp = out.with_name(out.name + ".tmp")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            def add_text(name, text, mode=0o755):
                info = zipfile.ZipInfo(name)
                info.external_attr = (0o100000 | mode) << 16
                info.compress_type = zipfile.ZIP_DEFLATED
                z.writestr(info, text)
            add_text("setup.sh", SETUP)
            add_text("run_autograder", RUN)
            z.write(cfg_path, "config.toml")
            root = PKG.parent
            for f in ("pyproject.toml", "README.md"):
                z.write(root / f, f)
            for f in sorted(PKG.rglob("*")):
                if f.is_file() and "__pycache__" not in f.parts and f.suffix != ".pyc":
                    z.write(f, str(f.relative_to(root)))
            for name in (_data.INTEL, _data.INTEL_SEMANTIC):
                z.write(_data.ensure(name), f"data/{name}")
        tmp.replace(out)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        raise InputError(f"cannot write {out}: {e.strerror}")
    return out
