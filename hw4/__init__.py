"""Mapping with counting sensor models (NA 568 HW4) and 3D semantic BKI, in plain numpy.

Layout, by audience: :mod:`hw4.core` (the plain-array core), the homework faces at the top
(`ogm_CSM.py`, ... over :mod:`hw4.template`; :mod:`hw4.tasks` by task number), :mod:`hw4.bki`
(Task 5, 3D), :mod:`hw4.evaluation` (the studies of the beyond chapters), :mod:`hw4.book` (the
book's helpers) and the commands (:mod:`hw4.__main__`, :mod:`hw4.cli`, :mod:`hw4.package`).
Imports point down this list, never up to the commands.
"""
from .core.errors import InputError

__all__ = ["InputError"]
__version__ = "1.0.0"
