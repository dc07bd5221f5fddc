"""The grading configuration (``config.toml`` beside this module, or a file the staff name)."""
from __future__ import annotations

import tomllib
from pathlib import Path

from ..core.errors import InputError

DEFAULT = Path(__file__).with_name("config.toml")
VISIBILITY = ("hidden", "after_due_date", "after_published", "visible")


def load(path: Path | None = None) -> dict:
    """The configuration as a dict, checked; ``path`` None reads the packaged default."""
    path = Path(path) if path else DEFAULT
    try:
        cfg = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"grading configuration {path} does not exist")
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"grading configuration {path} is not valid TOML: {e}")
    g = cfg.get("grading", {})
    tasks = cfg.get("tasks", {})
    try:
        out = {
            "grid_sizes": [float(x) for x in g.get("grid_sizes", [0.5])],
            "hidden_grid_sizes": [float(x) for x in g.get("hidden_grid_sizes", [])],
            "timeout": float(g.get("timeout", 130)),
            "memory": int(g.get("memory", 2048)),
            "rtol": float(g.get("rtol", 1e-6)),
            "atol": float(g.get("atol", 1e-9)),
            "full_credit_share": float(g.get("full_credit_share", 0.99)),
            "zero_credit_share": float(g.get("zero_credit_share", 0.5)),
            "mean_weight": float(g.get("mean_weight", 0.5)),
            "else_credit": float(g.get("else_credit", 1.0)),
            "output_cap": int(g.get("output_cap", 8000)),
            "visibility": str(g.get("visibility", "visible")),
            "hidden_visibility": str(g.get("hidden_visibility", "after_published")),
            "tasks": {int(k): {"name": str(v.get("name", f"task {k}")),
                               "points": float(v.get("points", 0))} for k, v in tasks.items()},
        }
    except (TypeError, ValueError, AttributeError) as e:
        raise InputError(f"grading configuration {path}: {e}")
    if sorted(out["tasks"]) != [1, 2, 3, 4]:
        raise InputError(f"grading configuration {path} must have [tasks.1] .. [tasks.4]")
    for v in (out["visibility"], out["hidden_visibility"]):
        if v not in VISIBILITY:
            raise InputError(f"visibility must be one of {', '.join(VISIBILITY)}; got {v!r}")
    if not 0 <= out["mean_weight"] <= 1:
        raise InputError("mean_weight must lie between 0 and 1")
    if not 0 <= out["else_credit"] <= 1:
        raise InputError("else_credit must lie between 0 and 1")
    if not 0 <= out["zero_credit_share"] < out["full_credit_share"] <= 1:
        raise InputError("need 0 <= zero_credit_share < full_credit_share <= 1")
    if not out["grid_sizes"] or any(not 0.05 <= x <= 5 for x in
                                    out["grid_sizes"] + out["hidden_grid_sizes"]):
        raise InputError("grid sizes must lie between 0.05 and 5 m (and at least one be given)")
    return out
