"""Command line: ``python -m hw4 {run,data,bki,package,grade,check,autograder} ...`` (``--help`` on each)."""
from __future__ import annotations

import argparse
import sys

from .core.errors import InputError
from .core.parser import OneLineParser


FAST_COMMANDS = ("run", "data")  # registered alone when the command line starts with one


def parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand; for ``command`` 'run' or 'data' only those two (the same
    parser for them, without importing the other commands' modules: a faster start)."""
    from . import cli
    p = OneLineParser(
        prog="python -m hw4",
        description="Mapping with counting sensor models (NA 568 HW4): build the maps of tasks "
                    "1-4, run 3D semantic BKI (task 5), fetch data, package a submission.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    cli.register(sub)
    if command in FAST_COMMANDS:
        return p
    from . import package
    from .bki import cli as bki_cli
    from .grading import cli as grading_cli
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
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser(argv[0] if argv else None).parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    from . import cli
    cli.OWN_PROCESS = True
    status = main()
    cli.freeze_gc()  # the interpreter's last full collection at exit then skips what exit frees
    sys.exit(status)
