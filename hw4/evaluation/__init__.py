"""The evaluation and studies behind the book's beyond-the-homework chapter.

:mod:`~hw4.evaluation.evaluate` (held-out split and scores), :mod:`~hw4.evaluation.stats`
(map statistics quoted in the chapters), :mod:`~hw4.evaluation.studies` (parameter and option
studies), :mod:`~hw4.evaluation.logodds` (the classical baseline), :mod:`~hw4.evaluation.growth`
(the growing map) and :mod:`~hw4.evaluation.evalplots` (their figures). They build maps through
the homework's tasks (:mod:`hw4.tasks`) and the core (:mod:`hw4.core`).
"""
