"""The instructor's grader: grade a submission of the four homework files exactly and safely.

``python -m hw4 grade SUBMISSION`` (a ``uniqname_hw4.tgz`` / ``.zip`` or a folder; ``--batch`` for a
folder of submissions), ``python -m hw4 check PATH`` (a student's own files, visible tests only)
and ``python -m hw4 autograder`` (the Gradescope zip). Each task of a submission runs in a
sandboxed child (:mod:`hw4.grading.sandbox`, driven by :mod:`hw4.grading.child`, which imports
nothing from this package); its map is compared cell by cell with the exact core's, built with
the legitimate variant the submission matches best (:mod:`hw4.grading.reference`). Settings live
in ``config.toml`` (:mod:`hw4.grading.config`). ``python -m hw4 similarity`` (and ``grade
--batch``) compares the submissions with each other and with known sources
(:mod:`hw4.grading.similarity`, copydetect): a prompt for a TA, never a grade; ``grade --batch
--previous OLD`` lists what a regrade changed and why (:func:`hw4.grading.batch.changes`).

This subpackage uses :mod:`hw4.core` and the task table; nothing outside it imports it except
the command line.
"""
