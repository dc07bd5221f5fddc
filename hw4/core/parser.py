"""The command-line parser every ``python -m hw4 ...`` entry point uses."""
from __future__ import annotations

import argparse


class OneLineParser(argparse.ArgumentParser):
    """argparse whose usage errors are one line, ``error: PROG: MESSAGE``, exit status 2."""

    def error(self, message):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help).\n")
