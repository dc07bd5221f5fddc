"""The book's helpers: glue names, rounding, and tables that reference exactly the glued names."""
from __future__ import annotations

import numpy as np
import pytest

from hw4 import book


def _collect():
    glued = {}
    return glued, (lambda n, v, display: glued.update({n: v}))


def test_put_unwraps_numpy_and_rounds_to_ten_digits():
    glued, glue = _collect()
    book.put("a", np.float64(0.1 + 0.2), glue)
    book.put("b", np.int64(7), glue)
    book.put("c", "text", glue)
    assert glued == {"a": 0.3, "b": 7, "c": "text"}
    assert type(glued["b"]) is int
    book.put_interval("d", 0.5, (0.25, 0.75), glue)
    assert (glued["d"], glued["d_lo"], glued["d_hi"]) == (0.5, 0.25, 0.75)


def test_grid_key_and_glue_key():
    assert [book.grid_key(g) for g in (0.135, 0.27, 0.5)] == ["0135", "027", "05"]
    assert book.glue_key({"task": 0, "grid_size": 0.27}, "auc", "p_") == "p_auc_t0_g027"


def test_glue_rows_and_myst_table_agree_on_names():
    rows = [{"model": "CSM", "task": 1, "grid_size": 0.27, "auc": 0.91, "coverage": 0.99,
             "occupied_recall": 0.8, "free_accuracy": 0.95, "accuracy": np.nan, "miou": np.nan}]
    glued, glue = _collect()
    names = book.glue_rows(rows, glue)
    assert glued == {"auc_t1_g027": 0.91, "coverage_t1_g027": 0.99,
                     "occupied_recall_t1_g027": 0.8, "free_accuracy_t1_g027": 0.95}
    assert names == list(glued)
    table = book.myst_table(rows)
    assert "{glue:text}`auc_t1_g027:.3f`" in table and table.endswith("| – | – |")
    assert all(f"`{n}:.3f`" in table for n in names)
    text = book.markdown_table(rows)
    assert "| CSM | 0.27 | 0.910 | 0.990 | 0.800 | 0.950 | – | – |" in text


def test_zoom_sets_the_named_window():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots()
    book.zoom(ax, "regions")
    assert ax.get_xlim() == (-12.0, 0.0) and ax.get_ylim() == (-22.0, -10.0)
    plt.close(fig)
    with pytest.raises(KeyError):
        book.zoom(ax, "nowhere")


def test_put_interval_signed_text_uses_a_minus_sign():
    got = {}
    book.put_interval("d", -0.2268, (-0.269, 0.0125), signed_digits=3,
                      glue=lambda name, value, display: got.__setitem__(name, value))
    assert got["d"] == -0.2268 and got["d_lo"] == -0.269
    assert [got[k] for k in ("d_s", "d_lo_s", "d_hi_s")] == ["\u22120.227", "\u22120.269", "+0.013"]
    assert "-" not in got["d_s"]
