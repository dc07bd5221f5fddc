"""The one exception type the package raises for bad input.

Every check in ``hw4`` that rejects user input raises :class:`InputError` with a
single sentence that names the offending thing and says what to do. The CLI
prints that sentence alone (no traceback) and exits with status 2.
"""


class InputError(ValueError):
    """Bad input (data file, parameter, scan, pose): the message is one sentence."""
