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


def test_ratio_words_state_only_the_difference_the_times_show():
    assert book.ratio_words(1.76) == "1.8 times as long as"
    assert book.ratio_words(0.064 / 0.065) == "about as long as"
    assert book.ratio_words(1.15) == "about as long as"
    assert book.ratio_words(1.2) == "1.2 times as long as"
    assert book.ratio_words(0.5) == "0.5 times as long as"


def test_trend_words_follow_the_order_of_the_values():
    assert book.trend_words([0.219, 0.213, 0.179]) == "falls"
    assert book.trend_words([0.1, 0.2, 0.3]) == "rises"
    assert book.trend_words([0.2, 0.2, 0.1]) == "does not change monotonically"
    assert book.trend_words([0.2, 0.3, 0.1], neither="varies") == "varies"


def test_check_variance_scale_refuses_a_scale_that_would_clip_observed_cells():
    from hw4.core import plotting
    from hw4.tasks import build_map
    m = build_map(1, grid_size=0.5)
    low = book.check_variance_scale([m], plotting.VARIANCE_LOG_DISCRETE)
    assert low == float(m.map["variance"][m.observed, 0].min())
    with pytest.raises(ValueError, match="below the scale"):
        book.check_variance_scale([m], (2 * low, 0.25))


def test_map_and_variance_draws_both_panels_on_the_given_scale():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from hw4.tasks import build_map
    for task in (2, 4):   # binary and semantic
        m = build_map(task, grid_size=0.5)
        fig, axes = plt.subplots(1, 2)
        im = book.map_and_variance(m, axes, "0.5 m", (1e-4, 0.25))
        assert (im.norm.vmin, im.norm.vmax) == (1e-4, 0.25)
        assert axes[0].get_xlim() == book.WINDOWS["building"][0]
        assert axes[1].get_ylim() == book.WINDOWS["building"][1]
        plt.close(fig)


# --------------------------------------------------------------------------- the book's machinery

def _ext():
    import importlib.util
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "book" / "_ext" / "hw4_book.py"
    spec = importlib.util.spec_from_file_location("hw4_book_ext", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_task_n_is_chapter_n():
    """Numbered chapters in _toc.yml are the five tasks (T5_beyond a section of Task 5) and the
    beyond chapter, in order; the background is in an unnumbered part, with a prefix for its
    equations and figures in _config.yml."""
    from pathlib import Path
    import yaml
    root = Path(__file__).resolve().parents[1]
    toc = yaml.safe_load((root / "_toc.yml").read_text())
    numbered = [c["file"] for part in toc["parts"] if part.get("numbered")
                for c in part["chapters"]]
    assert numbered == ["notebooks/T1_discrete_csm", "notebooks/T2_continuous_csm",
                        "notebooks/T3_semantic_csm", "notebooks/T4_continuous_semantic_csm",
                        "notebooks/T5_bki_3d", "notebooks/T6_evaluation_studies"]
    config = yaml.safe_load((root / "_config.yml").read_text())["sphinx"]["config"]
    unnumbered = [c["file"] for part in toc["parts"] if not part.get("numbered")
                  for c in part["chapters"]]
    assert set(unnumbered) == set(config["hw4_unnumbered"])
    assert config["hw4_unnumbered"]["book/background"] == "B"


def test_unnumbered_chapters_get_their_prefix_once():
    from types import SimpleNamespace
    ext = _ext()
    env = SimpleNamespace(found_docs={"book/background", "notebooks/T1"}, toc_fignumbers={
        "book/background": {"figure": {"f1": (2,), "f2": (3,)}, "displaymath": {"e": (8,),
                                                                               "d": (1,)}},
        "notebooks/T1": {"figure": {"g": (1, 1)}}})
    app = SimpleNamespace(config=SimpleNamespace(hw4_unnumbered={"book/background": "B",
                                                                 "book/references": ""}))
    # the first call renumbers and asks for every page to be rewritten; a second changes nothing
    assert ext.prefix_unnumbered(app, env) == ["book/background", "notebooks/T1"]
    assert ext.prefix_unnumbered(app, env) == []
    assert env.toc_fignumbers["book/background"] == {
        "figure": {"f1": ("B", 1), "f2": ("B", 2)}, "displaymath": {"e": ("B", 2), "d": ("B", 1)}}
    assert env.toc_fignumbers["notebooks/T1"] == {"figure": {"g": (1, 1)}}


def test_superscripts_print_in_the_pdf():
    from sphinx.util import texescape
    _ext().superscripts_as_math(None)
    assert texescape.escape("10⁻⁶", "xelatex") == r"10\ensuremath{^{-}}\ensuremath{^{6}}"


def test_title_page_says_whose_book_it_is(monkeypatch):
    from types import SimpleNamespace
    ext = _ext()

    def author(name):
        if name:
            monkeypatch.setenv(ext.AUTHOR_ENV, name)
        else:
            monkeypatch.delenv(ext.AUTHOR_ENV, raising=False)
        config = SimpleNamespace(latex_engine="xelatex", hw4_course_author="The course book",
                                 latex_documents=[("intro", "b.tex", "T", "NA 568", "manual")])
        ext.override_author(None, config)
        return config.latex_documents[0][3]

    assert author(None) == r"NA 568\\The course book"
    assert author("Jane Doe") == r"Jane Doe\\NA 568"
