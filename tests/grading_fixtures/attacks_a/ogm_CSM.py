"""Attack: import the grader's own package past the wrapper's guard (sys.path, the editable
install's finder, the project folder) and hand back its exact map."""
import glob
import os
import sys

import numpy

site = os.path.dirname(os.path.dirname(os.path.realpath(numpy.__file__)))
sys.meta_path[:] = [m for m in sys.meta_path if type(m).__name__ != "_Blocked"]
sys.path.append(site)
for f in glob.glob(os.path.join(site, "__editable__*hw4*finder.py")):
    try:
        __import__(os.path.basename(f)[:-3]).install()
    except Exception:
        pass
p = site
for _ in range(6):  # the project folder (site-packages lives in PROJECT/.venv/lib/pythonX/)
    p = os.path.dirname(p)
    sys.path.append(p)
from hw4.ogm_CSM import ogm_CSM as _Exact  # noqa: E402


class ogm_CSM(_Exact):
    pass
