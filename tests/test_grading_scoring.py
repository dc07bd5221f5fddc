"""The grader's scoring, in the grader's process (no sandbox, no child): whole-mean semantic
comparison, right-shape garbage at 0, the 2024 template's ``else`` reading of Algorithm 2 (a
loop checks it, every placement scores full, its credit configurable), and diagnoses only where
a bug explains the differences. Maps at 1 m (1,296 cells); about 10 s in all.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from hw4.core.kernel import sparse_kernel
from hw4.core.sensor import polar, wrap_to_pi
from hw4.grading import reference
from hw4.grading.config import load as load_config
from hw4.tasks import load_task_data

G = 1.0
CFG = load_config()


def _map(task, prior=1e-3, **opts):
    grid, counts = reference.evidence(task, G, **opts)
    return reference.posterior(counts, prior, task > 2)


def _score(task, mean, var, cfg=CFG, priors=(1e-3,)):
    best = reference.best_match(task, G, mean, var, list(priors), cfg["rtol"], cfg["atol"], cfg)
    return best, reference.credit(best, cfg["mean_weight"], cfg["zero_credit_share"],
                                  cfg["full_credit_share"])


def test_defaults_weigh_map_and_variance_equally():
    assert CFG["mean_weight"] == 0.5 and CFG["else_credit"] == 1.0


@pytest.mark.parametrize("task", [3, 4])
def test_right_shape_garbage_scores_zero(task):
    """Every cell (0.4, 0.1, ..., 0.1): the most likely class ties to class 1 in every unobserved
    reference cell, but no cell is right: 0 points (the old argmax comparison gave 1.4 / 20)."""
    grid, counts = reference.evidence(task, G)
    mean = np.full((grid.n_cells, 7), 0.1)
    mean[:, 0] = 0.4
    var = np.full(grid.n_cells, 0.4 * 0.6 / 2)
    best, frac = _score(task, mean, var)
    assert frac == 0.0 and best.share == 0.0
    # the prior everywhere (an empty map of the right shape) scores 0 as well
    m0, v0 = reference.posterior(np.zeros_like(counts), 1e-3, True)
    assert _score(task, m0, v0)[1] == 0.0


def test_every_class_probability_is_compared():
    """A map whose most likely class and variance are right in every cell but whose other class
    probabilities are not (as a kernel twice as long gives) loses the means' half."""
    mean, var = _map(4)
    wrong = mean.copy()
    order = np.argsort(mean, axis=1)
    rows = np.arange(len(mean))
    top, second = mean[rows, order[:, -1]], mean[rows, order[:, -2]]
    observed = reference.evidence(4, G)[1].sum(axis=1) > 0
    clear = observed & (top > 1.2 * second)
    shift = np.where(clear, 0.1 * second, 0)  # a tenth of the second class to the least likely
    wrong[rows, order[:, -2]] -= shift
    wrong[rows, order[:, 0]] += shift
    assert clear.mean() > 0.5 * observed.mean()
    assert (np.argmax(wrong, axis=1) == np.argmax(mean, axis=1)).all()
    best, frac = _score(4, wrong, var)
    assert best.mean_share < 0.5 and frac == pytest.approx(0.5)


def _else_loop(task, cells, step, closest):
    """The 2024 template's ``if d1 < l: alpha += k(d1)`` ``else: beta += k(...)``, a loop over
    cells, nearest poses and samples ``np.arange(0, z, step)`` (z from the end point's world
    coordinates, as the template's solutions write it): free evidence per cell."""
    data = load_task_data(task)
    scans = [s[:2] for s in data.scans]
    grid = reference.evidence(task, G)[0]
    tree = cKDTree(data.poses[:, :2])
    out = {}
    for i in cells:
        m = grid.cells[i]
        free = occ = 0.0
        for k in tree.query(m, 16)[1]:
            px, py, h = data.poses[k]
            r = np.hypot(m[0] - px, m[1] - py)
            phi = wrap_to_pi(np.arctan2(m[1] - py, m[0] - px) - h)
            if not (0 < r < 30 and -np.pi < phi < np.pi):
                continue
            z, b = polar(scans[k])
            j = int(np.nanargmin(np.abs(wrap_to_pi(b - phi))))
            c, s = np.cos(b[j] + h), np.sin(b[j] + h)
            ex, ey = px + z[j] * c, py + z[j] * s
            d1 = np.sqrt((m[0] - ex) ** 2 + (m[1] - ey) ** 2)
            if d1 < 0.2:
                occ += float(sparse_kernel(np.array([d1]))[0])
                continue
            ds = [np.sqrt((m[0] - (px + t * c)) ** 2 + (m[1] - (py + t * s)) ** 2)
                  for t in np.arange(0, np.sqrt((px - ex) ** 2 + (py - ey) ** 2), step)]
            for d in ([min(ds)] if closest and ds else ds):
                if d < 0.2:
                    free += float(sparse_kernel(np.array([d]))[0])
        out[i] = (occ, free)
    return out


@pytest.mark.parametrize("step,closest", [(0.2 * 2 / 3, True), (0.1, False)])
def test_else_reading_matches_a_loop(step, closest):
    opts = {"sample_step": step, "free_samples": "closest" if closest else "all",
            "free_where": "far"}
    _, counts = reference.evidence(2, G, **opts)
    _, both = reference.evidence(2, G, **{k: v for k, v in opts.items() if k != "free_where"})
    _, world = reference.evidence(2, G, **opts, sample_count="arange_world")
    assert (counts[:, 0] == both[:, 0]).all() and (counts[:, 1] < both[:, 1] - 1e-9).any()
    cells = np.random.default_rng(2).choice(len(counts), 120, replace=False)
    for i, (occ, free) in _else_loop(2, cells, step, closest).items():
        assert counts[i, 0] == pytest.approx(occ, rel=1e-9, abs=1e-12)
        assert world[i, 1] == pytest.approx(free, rel=1e-9, abs=1e-12), i


@pytest.mark.parametrize("task", [2, 4])
def test_every_reading_scores_full_and_is_named(task):
    for label, opts in reference.variants(task, G):
        mean, var = _map(task, **opts)
        best, frac = _score(task, mean, var)
        assert frac == 1.0 and best.share == 1.0, label
        if opts.get("free_where") == "far":
            assert "2024 template's reading" in best.label
            assert reference.diagnose(task, G, mean, var, best, CFG["rtol"], CFG["atol"]) is None


def test_else_credit_is_configurable():
    mean, var = _map(2, sample_step=0.2 * 2 / 3, free_samples="closest", free_where="far")
    cfg = {**CFG, "else_credit": 0.6}
    best, frac = _score(2, mean, var, cfg)
    assert frac == pytest.approx(0.6) and best.opts.get("free_where") == "far"


def test_no_diagnosis_for_a_few_stray_cells():
    """A map agreeing in 99.9 % of the cells (three cells off by a random amount) keeps full
    marks, and no bug is named for it even if asked."""
    mean, var = _map(4)
    observed = np.flatnonzero(reference.evidence(4, G)[1].sum(axis=1) > 0)
    bad = np.random.default_rng(0).choice(observed, 1, replace=False)
    mean, var = mean.copy(), var.copy()
    mean[bad] = np.roll(mean[bad], 1, axis=1)
    var[bad] *= 1.5
    best, frac = _score(4, mean, var)
    assert frac == 1.0 and best.share < 1.0
    assert reference.diagnose(4, G, mean, var, best, CFG["rtol"], CFG["atol"]) is None


def test_bad_else_credit_is_one_line(tmp_path):
    from hw4.core.errors import InputError
    p = tmp_path / "c.toml"
    from pathlib import Path
    text = Path(reference.__file__).with_name("config.toml").read_text()
    p.write_text(text.replace("else_credit = 1.0", "else_credit = 2"))
    with pytest.raises(InputError, match="else_credit"):
        load_config(p)
