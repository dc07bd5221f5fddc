"""Command line: ``python -m hw4 {run,data,bki,package,grade,check,autograder} ...`` (``--help`` on each)."""
from __future__ import annotations

import argparse
import sys

from .core.errors import InputError
from .core.parser import OneLineParser


def parser() -> argparse.ArgumentParser:
    from . import cli, package
    from .bki import cli as bki_cli
    from .grading import cli as grading_cli
    p = OneLineParser(
        prog="python -m hw4",
        description="Mapping with counting sensor models (NA 568 HW4): build the maps of tasks "
                    "1-4, run 3D semantic BKI (task 5), fetch data, package a submission.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    cli.register(sub)
    bki_cli.register(sub)
    package.register(sub)
    grading_cli.register(sub)
    return p


def _terminated(signum, frame):
    raise KeyboardInterrupt  # so that half-written outputs are cleaned up as on Ctrl-C


def main(argv=None) -> int:
    import signal
    import threading
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminated)
    args = parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
