"""Hypothesis profiles of the fuzz suite (tests/test_fuzz_*.py) and the contract they all check.

Profiles, chosen with the environment variable ``HYPOTHESIS_PROFILE``:

* ``ci`` (default): derandomised (the same examples on every run, so CI is reproducible), no
  example database, a few hundred examples per reader: the whole suite runs in about a minute
  on two cores.
* ``long``: 20 times as many examples, random seeds, failures remembered in ``.hypothesis/``::

      HYPOTHESIS_PROFILE=long python -m pytest tests/test_fuzz_*.py

The contract (:func:`refused_or`): every call either returns a result that the test then checks
independently, or raises :class:`hw4.core.errors.InputError` with a one-line message. Any other
exception, any warning (pytest turns them into errors) or a NaN in a result fails the test.
"""
from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

from hw4.core.errors import InputError

_QUIET = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much,
          HealthCheck.data_too_large, HealthCheck.large_base_example]
settings.register_profile("ci", deadline=None, derandomize=True, database=None, print_blob=True,
                          suppress_health_check=_QUIET)
settings.register_profile("long", deadline=None, print_blob=True, suppress_health_check=_QUIET)
PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
settings.load_profile(PROFILE)
FACTOR = {"ci": 1, "long": 20}.get(PROFILE, 1)


def examples(n: int) -> int:
    """Examples for one property: ``n`` in the ci profile, 20 n in the long one."""
    return n * FACTOR


def refused_or(fn):
    """``fn()``, or None when it raised the project's one-line InputError (checked here)."""
    try:
        return fn()
    except InputError as e:
        msg = str(e)
        assert msg.strip() and "\n" not in msg, f"InputError message is not one line: {msg!r}"
        return None


def test_profile_is_known():
    assert PROFILE in ("ci", "long"), f"HYPOTHESIS_PROFILE={PROFILE!r}: use ci or long"
