"""The plain-array core every model, notebook, test and benchmark calls.

Data flows one way: :mod:`~hw4.core.data` (find, verify and load the Intel data into plain arrays)
-> :mod:`~hw4.core.sensor` (polar scans, perceptual field, nearest beam) and :mod:`~hw4.core.grid`
(cell centres in the template's order) -> :mod:`~hw4.core.kernel` (the sparse kernel) ->
:mod:`~hw4.core.evidence` (the counting of Algorithms 1 and 2 and their semantic versions) ->
:mod:`~hw4.core.posterior` (Beta / Dirichlet mean and variance) -> :mod:`~hw4.core.plotting`.
:mod:`~hw4.core.errors`, :mod:`~hw4.core.atomic` (outputs written all or nothing) and
:mod:`~hw4.core.parser` serve every command. Nothing in the core imports from outside it.
"""
