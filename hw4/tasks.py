"""The homework's four tasks by number: which model, which data, what to call it.

``build_map(task, grid_size=...)`` is the one-line way for the CLI and the notebooks to get a
built map (a template face object with ``.map``, ``.grid``, ``.counts``).
"""
from __future__ import annotations

import time

from .core import data as _data
from .core.errors import InputError
from .ogm_CSM import ogm_CSM
from .ogm_continuous_CSM import ogm_continuous_CSM
from .ogm_S_CSM import ogm_S_CSM
from .ogm_continuous_S_CSM import ogm_continuous_S_CSM

TASKS = {
    1: (ogm_CSM, "CSM"),
    2: (ogm_continuous_CSM, "Continuous CSM"),
    3: (ogm_S_CSM, "S-CSM"),
    4: (ogm_continuous_S_CSM, "Continuous S-CSM"),
}
GRID_SIZES = (0.135, 0.27, 0.5)  # the homework's resolution study [m]

_cache: dict = {}


def model_class(task: int):
    """The template face class of task 1..4."""
    if task not in TASKS:
        raise InputError(f"task must be 1, 2, 3 or 4 (task 5 is `python -m hw4 bki`); got {task!r}.")
    return TASKS[task][0]


def task_name(task: int) -> str:
    """Short display name of the model of task 1..4."""
    model_class(task)
    return TASKS[task][1]


def load_task_data(task: int) -> _data.IntelData:
    """The Intel data a task uses (semantic copy for tasks 3 and 4), loaded once per process."""
    semantic = model_class(task).semantic
    if semantic not in _cache:
        _cache[semantic] = _data.load_intel(semantic=semantic)
    return _cache[semantic]


def build_map(task: int, grid_size: float = 0.135, data: _data.IntelData | None = None, **kw):
    """Build the map of task 1..4 and return the face object; ``.build_seconds`` holds the time.

    Parameters
    ----------
    task : int
        1 CSM, 2 continuous CSM, 3 S-CSM, 4 continuous S-CSM.
    grid_size : float [m]
        Cell size.
    data : IntelData, optional
        Poses and scans; default the task's Intel file. Binary models use rows x, y only.
    **kw
        Further parameters of the model (``nearest_poses``, ``beams``, ``sample_step``, ``l``,
        ``sigma``, ``progress``, ...).
    """
    cls = model_class(task)
    data = data if data is not None else load_task_data(task)
    scans = data.scans if cls.semantic else [s[:2] for s in data.scans]
    ogm = cls(grid_size=grid_size, **kw)
    ogm.construct_map(data.poses, scans)
    t = time.perf_counter()
    ogm.build_ogm()
    ogm.build_seconds = time.perf_counter() - t
    ogm.task = task
    ogm.name = task_name(task)
    return ogm
