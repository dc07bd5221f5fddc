"""``python -m hw4.bki``: the ``bki`` command on its own (the same as ``python -m hw4 bki``)."""
import sys

from .cli import main

sys.exit(main())
