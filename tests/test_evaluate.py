"""Held-out evaluation: metrics on hand-made cases with known answers, split, samples, coverage."""
from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from hw4 import book
from hw4.evaluation import evaluate as ev
from hw4.core.data import IntelData
from hw4.core.errors import InputError
from hw4.core.evidence import count_evidence
from hw4.core.grid import Grid


# ---------------------------------------------------------------- AUC and ROC, exact cases
def brute_auc(scores, positive):
    """P(positive scores higher) + P(tie) / 2 over all (positive, negative) pairs."""
    pos = [s for s, p in zip(scores, positive) if p]
    neg = [s for s, p in zip(scores, positive) if not p]
    total = sum(1.0 if a > b else 0.5 if a == b else 0.0 for a, b in itertools.product(pos, neg))
    return total / (len(pos) * len(neg))


def test_auc_perfectly_separated_is_one_and_reversed_is_zero():
    s = np.array([0.1, 0.2, 0.3, 0.7, 0.8, 0.9])
    y = np.array([0, 0, 0, 1, 1, 1], bool)
    assert ev.auc(s, y) == 1.0
    assert ev.auc(s, ~y) == 0.0
    assert ev.auc(-s, y) == 0.0


def test_auc_all_tied_is_one_half():
    assert ev.auc(np.full(7, 0.3), np.array([1, 0, 0, 1, 0, 1, 1], bool)) == 0.5
    fpr, tpr, thr = ev.roc_curve(np.full(4, 2.0), np.array([1, 0, 1, 0], bool))
    np.testing.assert_array_equal(fpr, [0, 1])
    np.testing.assert_array_equal(tpr, [0, 1])
    np.testing.assert_array_equal(thr, [2.0])


def test_auc_two_by_two_hand_cases():
    # positives 0.8, 0.4; negatives 0.6, 0.2: pairs won 0.8>0.6, 0.8>0.2, 0.4>0.2, lost 0.4<0.6
    assert ev.auc([0.8, 0.4, 0.6, 0.2], [1, 1, 0, 0]) == 0.75
    # positives 0.5, 0.9; negatives 0.5, 0.1: one tie (1/2) and three wins -> 3.5 / 4
    assert ev.auc([0.5, 0.9, 0.5, 0.1], [1, 1, 0, 0]) == 0.875


def test_roc_curve_of_a_hand_case():
    fpr, tpr, thr = ev.roc_curve([0.8, 0.4, 0.6, 0.2], [1, 1, 0, 0])
    np.testing.assert_array_equal(thr, [0.8, 0.6, 0.4, 0.2])
    np.testing.assert_array_equal(fpr, [0, 0, 0.5, 0.5, 1])
    np.testing.assert_array_equal(tpr, [0, 0.5, 0.5, 1, 1])
    assert ev.trapezoid_auc(fpr, tpr) == 0.75


def test_auc_equals_pair_count_and_roc_trapezoid_with_many_ties():
    rng = np.random.default_rng(5)
    for _ in range(20):
        n = int(rng.integers(2, 60))
        y = rng.random(n) < 0.4
        y[0], y[1] = True, False
        s = np.round(rng.normal(size=n) + y, 1)  # rounding makes ties
        a = ev.auc(s, y)
        assert a == pytest.approx(brute_auc(s, y), abs=1e-15)
        fpr, tpr, _ = ev.roc_curve(s, y)
        assert ev.trapezoid_auc(fpr, tpr) == pytest.approx(a, abs=1e-12)
        assert fpr[0] == tpr[0] == 0 and fpr[-1] == tpr[-1] == 1
        assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0)
        assert ev.auc(np.exp(3 * s), y) == a  # rank statistic: any increasing map


def test_auc_refuses_one_class_and_nan():
    with pytest.raises(InputError):
        ev.auc([0.1, 0.2], [1, 1])
    with pytest.raises(InputError):
        ev.auc([0.1, np.nan], [1, 0])
    with pytest.raises(InputError):
        ev.auc([0.1, 0.2, 0.3], [1, 0])


# ---------------------------------------------------------------- confusion and IoU
def test_confusion_matrix_and_iou_of_a_hand_case():
    truth = [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2]
    pred = [0, 0, 0, 0, 0, 1, 0, 0, 1, 1, 1, 2, 2, 2, 2, 2]
    cm = ev.confusion_matrix(truth, pred, 3)
    np.testing.assert_array_equal(cm, [[5, 1, 0], [2, 3, 1], [0, 0, 4]])
    # IoU = TP / (TP + FP + FN): 5 / (5 + 2 + 1), 3 / (3 + 1 + 3), 4 / (4 + 1 + 0)
    np.testing.assert_allclose(ev.iou_from_confusion(cm), [5 / 8, 3 / 7, 4 / 5], rtol=1e-15)
    np.testing.assert_allclose(ev.iou_from_confusion(cm, [2]), [4 / 5], rtol=1e-15)
    # a class neither present nor predicted has no IoU
    assert np.isnan(ev.iou_from_confusion(np.diag([3, 0]))[1])
    with pytest.raises(InputError):
        ev.confusion_matrix([0, 3], [0, 1], 3)


# ---------------------------------------------------------------- split and samples
def test_split_is_deterministic_and_partitions_the_scans():
    a_map, a_held = ev.split_scans(743)
    b_map, b_held = ev.split_scans(743)
    np.testing.assert_array_equal(a_held, b_held)
    np.testing.assert_array_equal(a_map, b_map)
    np.testing.assert_array_equal(a_held, np.arange(9, 743, 10))
    assert len(a_held) == 74 and len(a_map) == 669
    np.testing.assert_array_equal(np.sort(np.r_[a_map, a_held]), np.arange(743))
    _, h = ev.split_scans(20, every=5, offset=0)
    np.testing.assert_array_equal(h, [0, 5, 10, 15])
    for bad in (1, 0, 2.5, True):
        with pytest.raises(InputError):
            ev.split_scans(10, every=bad)
    with pytest.raises(InputError):
        ev.split_scans(10, every=5, offset=5)


def test_held_out_samples_of_one_beam():
    """Robot at (1, 2) facing +y; one beam 1 m straight ahead: end point (1, 3)."""
    data = IntelData(np.array([[1.0, 2.0, np.pi / 2]]), [np.array([[1.0], [0.0], [4.0]])])
    s = ev.held_out_samples(data, [0], step=0.25, margin=0.25)
    # occupied: the end point; free: s = 0.25, 0.5 (s < 1 - 0.25 strictly, so not 0.75)
    assert s.n_occupied == 1 and s.n_free == 2
    np.testing.assert_allclose(s.points[s.occupied], [[1.0, 3.0]], atol=1e-15)
    np.testing.assert_allclose(s.points[~s.occupied], [[1.0, 2.25], [1.0, 2.5]], atol=1e-15)
    np.testing.assert_array_equal(s.label, [4, 0, 0])
    np.testing.assert_array_equal(s.truth_class, [3, ev.N_LABELS, ev.N_LABELS])
    np.testing.assert_array_equal(s.scan, [0, 0, 0])


def test_held_out_samples_skip_max_range_end_points_and_short_beams():
    scan = np.array([[0.2, 30.0, 0.0], [0.0, 0.0, 2.0]])  # 0.2 m, max range, 2 m
    data = IntelData(np.array([[0.0, 0.0, 0.0]]), [scan])
    s = ev.held_out_samples(data, [0])
    # 0.2 m beam: end point, no free sample (0.1 is not < 0.2 - 0.25); 30 m beam: free samples
    # only; 2 m beam: end point and 0.1 .. 1.7 (17 samples)
    assert s.n_occupied == 2
    assert s.n_free == 297 + 17
    r = np.hypot(*s.points[~s.occupied].T)
    assert r.max() < 30 - 0.25 and r.min() == pytest.approx(0.1)


# ---------------------------------------------------------------- coverage and scoring
def _toy_map(observed, mean, semantic_alpha=None):
    grid = Grid(1.0, (0.0, 2.0), (0.0, 0.0 + 1.0))  # x 0, 1, 2; y 0, 1: 6 cells
    m = SimpleNamespace(grid=grid, observed=np.asarray(observed, bool),
                        map={"mean": np.asarray(mean, float).reshape(-1, 1)}, semantic=False)
    if semantic_alpha is not None:
        a = np.asarray(semantic_alpha, float)
        m.semantic = True
        m.map = {"alpha": a, "mean": a / a.sum(axis=1, keepdims=True)}
    return m


def test_unobserved_cells_are_counted_but_not_scored():
    # cells: 0 (0,0) 1 (1,0) 2 (2,0) 3 (0,1) 4 (1,1) 5 (2,1); cell 5 unobserved
    m = _toy_map([1, 1, 1, 1, 1, 0], [0.9, 0.2, 0.8, 0.1, 0.3, 0.99])
    pts = np.array([[0, 0], [2, 0], [1, 0], [0, 1], [1.1, 1.2], [2, 1], [2.1, 0.9], [9, 9]])
    occ = np.array([1, 1, 0, 0, 0, 1, 0, 1], bool)
    s = ev.HeldOut(pts, occ, np.zeros(8, np.int64), np.zeros(8, np.int64))
    r = ev.score_map(m, s)
    # scored: the first five (cells 0, 2, 1, 3, 4); cell 5 (twice) and outside the map are not
    assert r["n_samples"] == 8 and r["n_scored"] == 5
    assert r["coverage"] == 5 / 8 and r["unobserved"] == 3 / 8
    assert r["coverage_occupied"] == 2 / 4 and r["coverage_free"] == 3 / 4
    # scored positives 0.9, 0.8 above every scored negative 0.2, 0.1, 0.3: AUC 1; the unobserved
    # cell's 0.99 on a free sample would have lowered it, had it been scored
    assert r["auc"] == 1.0
    np.testing.assert_array_equal(r["tpr"][[0, -1]], [0, 1])


def test_semantic_scores_of_a_hand_case():
    # 6 cells x 7 classes (labels 1..6, free last); predicted: cell 0 label 1, cell 1 label 2,
    # cell 2 free, cell 3 label 1, cell 4 free, cell 5 unobserved
    alpha = np.full((6, 7), 1e-3)
    alpha[0, 0] = alpha[1, 1] = alpha[2, 6] = alpha[3, 0] = alpha[4, 6] = 5.0
    m = _toy_map([1, 1, 1, 1, 1, 0], np.zeros(6), semantic_alpha=alpha)
    pts = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [1, 0], [1, 1]])
    occ = np.array([1, 1, 1, 1, 0, 1, 0, 0], bool)
    lab = np.array([1, 1, 2, 1, 0, 3, 0, 0])
    s = ev.HeldOut(pts, occ, lab, np.zeros(8, np.int64))
    r = ev.score_map(m, s)
    # scored end points: (true 1 -> 1), (true 1 -> 2), (true 2 -> free), (true 1 -> 1)
    assert r["accuracy"] == 2 / 4
    assert r["occupied_recall"] == 3 / 4 and r["label_accuracy"] == 2 / 3
    # scored free samples: cell 4 -> free, cell 1 -> label 2 (wrong), cell 4 -> free
    assert r["free_accuracy"] == 2 / 3
    cm = r["confusion"]
    assert cm[0, 0] == 2 and cm[0, 1] == 1 and cm[1, 6] == 1 and cm[6, 6] == 2 and cm[6, 1] == 1
    assert cm.sum() == 7
    # IoU from the end points only: label 1: 2 / (2 + 0 + 1); label 2: 0 / (0 + 1 + 1);
    # labels 3..6 absent and never predicted at end points: NaN, left out of the mean
    np.testing.assert_allclose(r["iou"][:2], [2 / 3, 0.0])
    assert np.all(np.isnan(r["iou"][2:]))
    assert r["miou"] == pytest.approx(1 / 3)


# ---------------------------------------------------------------- the Intel pipeline
def test_intel_split_samples_come_from_held_out_scans_only():
    sp = ev.intel_split()
    assert set(np.unique(sp.samples.scan)) == set(sp.held_out.tolist())
    assert not set(sp.mapping.tolist()) & set(sp.held_out.tolist())
    assert sp.samples.n_occupied > 10_000 and sp.samples.n_free > 20 * sp.samples.n_occupied
    assert np.all((sp.samples.label[sp.samples.occupied] >= 1)
                  & (sp.samples.label[sp.samples.occupied] <= 6))
    d = ev.mapping_data(1, sp)
    assert len(d.scans) == len(sp.mapping) and d.scans[0].shape[0] == 2


def test_evaluate_all_rows_at_the_coarse_grid():
    rows = ev.evaluate_all(grid_sizes=(0.5,), tasks=(1, 3))
    assert [r["model"] for r in rows] == ["log-odds", "CSM", "S-CSM"]
    for r in rows:
        assert 0.5 < r["auc"] <= 1 and 0.9 < r["coverage"] <= 1
        assert r["coverage"] + r["unobserved"] == pytest.approx(1)
    # the discrete CSM and S-CSM see the same hits and passes; their occupancy scores differ
    # only through the prior (one occupied pseudo-count vs six class pseudo-counts)
    assert rows[1]["auc"] == pytest.approx(rows[2]["auc"], abs=1e-3)
    assert np.isnan(rows[1]["miou"]) and 0 < rows[2]["miou"] < 1
    arr = ev.as_array(rows)
    assert arr["auc"][1] == rows[1]["auc"] and arr["model"][0] == "log-odds"
    table = book.markdown_table(rows)
    assert table.count("\n") == 4 and "| log-odds | 0.5 |" in table
    assert book.glue_key(rows[1], "auc") == "auc_t1_g05"
    assert ev.select(rows, task=3, grid_size=0.5) == [rows[2]]


def test_sigma_scaling_used_by_the_kernel_study_is_exact():
    from hw4.tasks import load_task_data
    d = load_task_data(2)
    scans = [s[:2] for s in d.scans[:60]]
    g = Grid(0.5)
    a = count_evidence(g, d.poses[:60], scans, model="continuous", sigma0=0.1)
    b = count_evidence(g, d.poses[:60], scans, model="continuous", sigma0=1.0)
    np.testing.assert_allclose(b, a * 10.0, rtol=1e-12, atol=0)


def test_growth_path_stands_apart_from_every_map_colour():
    """The robot's path is drawn over class maps: far from every class colour, free and unknown."""
    import matplotlib.colors as mc
    from hw4.evaluation import growth
    from hw4.core import plotting
    path = np.array(mc.to_rgb(growth.PATH_COLOR))
    colours = np.vstack([plotting.CLASS_COLORS, plotting.FREE_COLOR, plotting.UNKNOWN_COLOR])
    assert np.linalg.norm(colours - path, axis=1).min() > 0.5


def test_incremental_growth_is_the_batch_map():
    from hw4.evaluation.growth import incremental_counts
    from hw4.tasks import load_task_data
    d = load_task_data(4)
    d = IntelData(d.poses[:60], d.scans[:60])
    steps = [(n, c.copy()) for n, _, c in incremental_counts(d, every=25, grid_size=0.5)]
    assert [n for n, _ in steps] == [25, 50, 60]
    batch = count_evidence(Grid(0.5, n_classes=7), d.poses, d.scans, model="continuous",
                           semantic=True, nearest_poses=None, beams="all")
    np.testing.assert_allclose(steps[-1][1], batch, rtol=1e-12, atol=1e-12)
    with pytest.raises(InputError):
        next(incremental_counts(d, nearest_poses=16))


def _eight_samples():
    """Eight held-out samples over three scans: five in cells both toy maps observe, two in the
    cell only the fully observed map has seen, one outside the grid."""
    pts = np.array([[0, 0], [2, 0], [1, 0], [0, 1], [1.1, 1.2], [2, 1], [2.1, 0.9], [9, 9]])
    occ = np.array([1, 1, 0, 0, 0, 1, 0, 1], bool)
    return ev.HeldOut(pts, occ, np.zeros(8, np.int64), np.array([0, 1, 2, 0, 1, 2, 0, 1]))


def test_bootstrap_without_resampling_weights_is_the_plain_auc():
    m1 = _toy_map([1, 1, 1, 1, 1, 0], [0.9, 0.2, 0.8, 0.1, 0.3, 0.99])
    m2 = _toy_map([1, 1, 1, 1, 1, 1], [0.1, 0.2, 0.8, 0.1, 0.3, 0.99])
    s = _eight_samples()
    b = ev.bootstrap_auc([m1, m2], s, n_boot=30, seed=3)
    # common samples: the five in observed cells of m1 (m2 observes everything)
    assert b["n_common"] == 5
    assert b["auc"][0] == 1.0
    # m2 on those five: positives 0.1, 0.8 vs negatives 0.2, 0.1, 0.3 -> (0 + 0.5 + 0) + 3 = 3.5 / 6
    assert b["auc"][1] == pytest.approx(3.5 / 6)
    again = ev.bootstrap_auc([m1, m2], s, n_boot=30, seed=3)
    np.testing.assert_array_equal(b["replicates"], again["replicates"])


def test_bootstrap_on_each_maps_own_samples_matches_score_map():
    m1 = _toy_map([1, 1, 1, 1, 1, 0], [0.9, 0.2, 0.8, 0.1, 0.3, 0.99])
    m2 = _toy_map([1, 1, 1, 1, 1, 1], [0.1, 0.2, 0.8, 0.1, 0.3, 0.5])
    s = _eight_samples()
    own = ev.bootstrap_scores([m1, m2], s, n_boot=30, seed=3, common=False)
    shared = ev.bootstrap_scores([m1, m2], s, n_boot=30, seed=3)
    assert own["n_common"] == shared["n_common"] == 5
    for i, m in enumerate((m1, m2)):
        r = ev.score_map(m, s, keep_roc=False)
        assert own["auc"][i] == pytest.approx(r["auc"], abs=1e-12)
        assert own["occupied_recall"][i] == pytest.approx(r["occupied_recall"], abs=1e-12)
    # m2 also scores the sixth and seventh samples (in the cell m1 has not observed): 8/12, not 7/12
    assert own["auc"][1] == pytest.approx(8 / 12) and shared["auc"][1] == pytest.approx(7 / 12)
    assert own["auc"][0] == shared["auc"][0]
    d = ev.paired_difference(own, 0, 1)
    assert d["diff"] == pytest.approx(own["auc"][0] - own["auc"][1])
    assert d["lo"] <= d["hi"]


def test_binary_maps_read_at_one_half():
    m = _toy_map([1, 1, 1, 1, 1, 0], [0.9, 0.2, 0.5, 0.1, 0.6, 0.99])
    pts = np.array([[0, 0], [2, 0], [1, 0], [0, 1], [1, 1], [2, 1]])
    occ = np.array([1, 1, 0, 0, 0, 1], bool)
    r = ev.score_map(m, ev.HeldOut(pts, occ, np.zeros(6, np.int64), np.zeros(6, np.int64)))
    # scored end points 0.9 (called occupied) and 0.5 (not: > 0.5 is occupied); free 0.2, 0.1, 0.6
    assert r["occupied_recall"] == 0.5 and r["free_accuracy"] == 2 / 3


def test_bootstrap_scores_match_score_map_without_resampling_and_pair_the_draws():
    rng = np.random.default_rng(11)
    alpha = rng.uniform(0.1, 3.0, (6, 7))
    sem = _toy_map([1] * 6, np.zeros(6), semantic_alpha=alpha)
    binary = _toy_map([1] * 6, rng.uniform(0, 1, 6))
    pts = rng.uniform(-0.4, 2.4, (60, 2)) * [1, 0.5]
    occ = rng.uniform(size=60) < 0.4
    label = np.where(occ, rng.integers(1, 7, 60), 0)
    s = ev.HeldOut(pts, occ, label, rng.integers(0, 9, 60))
    b = ev.bootstrap_scores([sem, binary], s, n_boot=40, seed=1)
    assert b["n_common"] == 60
    for i, m in enumerate((sem, binary)):
        r = ev.score_map(m, s, keep_roc=False)
        assert b["auc"][i] == pytest.approx(r["auc"], abs=1e-12)
        assert b["occupied_recall"][i] == pytest.approx(r["occupied_recall"], abs=1e-12)
    r = ev.score_map(sem, s, keep_roc=False)
    assert b["accuracy"][0] == pytest.approx(r["accuracy"]) and b["miou"][0] == pytest.approx(r["miou"])
    assert np.isnan(b["miou"][1])
    # a map against itself: every paired replicate difference is exactly zero
    same = ev.bootstrap_scores([binary, binary], s, n_boot=40, seed=1)
    d = ev.paired_difference(same, 0, 1)
    assert (d["diff"], d["lo"], d["hi"], d["p_le0"]) == (0.0, 0.0, 0.0, 1.0)
    # replicates differ from the estimate (the draws do resample) and are reproducible
    assert np.ptp(b["auc_replicates"][:, 1]) > 0
    np.testing.assert_array_equal(b["auc_replicates"],
                                  ev.bootstrap_scores([sem, binary], s, 40, 1)["auc_replicates"])
    with pytest.raises(InputError):
        ev.paired_difference(b, 0, 1, level=1.0)


def test_closest_free_sample_matches_the_one_beam_profile():
    from hw4.book.illustrate import beam_profile
    g = 0.05
    grid = Grid(g, (-0.5, 3.0), (-0.5, 0.5))
    z = 2.0
    poses = np.zeros((1, 3))
    scans = [np.array([[z], [0.0]])]
    on_line = np.isclose(grid.cells[:, 1], 0.0, atol=1e-9) & (grid.cells[:, 0] > 0)
    x = grid.cells[on_line, 0]
    for mode, closest in (("all", False), ("closest", True)):
        c = count_evidence(grid, poses, scans, model="continuous", nearest_poses=1,
                           free_samples=mode)
        alpha, beta = beam_profile(x, z, closest_only=closest)
        np.testing.assert_allclose(c[on_line, 1], beta, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(c[on_line, 0], alpha, rtol=1e-9, atol=1e-12)
    allc = count_evidence(grid, poses, scans, model="continuous", nearest_poses=1)
    close = count_evidence(grid, poses, scans, model="continuous", nearest_poses=1,
                           free_samples="closest")
    assert np.all(close[:, 1] <= allc[:, 1] + 1e-15) and close[:, 1].sum() < allc[:, 1].sum()
    with pytest.raises(InputError):
        count_evidence(grid, poses, scans, model="continuous", beams="all", free_samples="closest")
    with pytest.raises(InputError):
        count_evidence(grid, poses, scans, model="continuous", free_samples="nearest")


def test_free_sample_study_scales_only_the_free_column():
    from hw4.evaluation import studies
    sp = ev.intel_split()
    variants = (studies.FREE_VARIANTS[0], studies.FREE_VARIANTS[3])   # package, free x 0.5
    rows, maps, boot = studies.free_sample_study(grid_size=0.5, variants=variants, n_boot=5)
    a, b = maps["package"], maps["free_half"]
    np.testing.assert_array_equal(b.counts[:, :-1], a.counts[:, :-1])
    np.testing.assert_allclose(b.counts[:, -1], 0.5 * a.counts[:, -1])
    # less free weight: more end points called some region
    assert rows[1]["occupied_recall"] > rows[0]["occupied_recall"]
    assert boot["auc_replicates"].shape == (5, 2)
    ref = ev.build_eval_map(4, 0.5, sp)   # the face class gives the package's variant
    np.testing.assert_allclose(a.counts, ref.counts, rtol=1e-12, atol=1e-12)


def test_label_changes_between_frames_by_hand():
    from hw4.evaluation.growth import label_changes
    # 4 cells, 3 classes (2 regions + free): cell 0 keeps region 0, cell 1 swaps 0 -> 1 with
    # both labels seen, cell 2 turns free, cell 3 unobserved then region 1
    a = np.array([[2, 0, 0], [1, 0, 0], [1, 0, 0], [0, 0, 0]], float)
    b = np.array([[3, 0, 1], [1, 2, 0], [1, 0, 5], [0, 1, 0]], float)
    (r,) = label_changes({10: (None, a), 20: (None, b)})
    assert (r["n_from"], r["n_to"], r["region_both"]) == (10, 20, 2)
    assert r["swapped"] == 0.5 and r["to_free"] == pytest.approx(1 / 3) and r["mixed_swapped"] == 1.0


def test_table_difference_is_that_of_the_printed_scores_and_threshold_scores_read_the_map():
    rng = np.random.default_rng(5)
    a = _toy_map([1] * 6, rng.uniform(0, 1, 6))
    b = _toy_map([1] * 6, rng.uniform(0, 1, 6))
    pts = rng.uniform(-0.4, 2.4, (80, 2)) * [1, 0.5]
    occ = rng.uniform(size=80) < 0.4
    s = ev.HeldOut(pts, occ, np.zeros(80, int), rng.integers(0, 9, 80))
    boot = ev.bootstrap_scores([a, b], s, n_boot=40, seed=1, common=False)
    d = ev.table_difference(boot, 0, 1, "auc", digits=3)
    assert d["diff"] == round(round(boot["auc"][0], 3) - round(boot["auc"][1], 3), 3)
    assert d["inside"] == (round(d["lo"], 3) <= d["diff"] <= round(d["hi"], 3))
    assert (d["lo"], d["hi"]) == tuple(ev.paired_difference(boot, 0, 1)[k] for k in ("lo", "hi"))
    # read at 0.5, threshold_scores gives score_map's occupied recall and free accuracy
    r, t = ev.score_map(a, s, keep_roc=False), ev.threshold_scores(a, s, 0.5)
    assert t["occupied_recall"] == pytest.approx(r["occupied_recall"])
    assert t["free_accuracy"] == pytest.approx(r["free_accuracy"])
    assert ev.threshold_scores(a, s, -1.0)["occupied_recall"] == 1.0


# ---------------------------------------------------------------- bootstrap: per-scan sums, BCa
def _random_case(seed, n=90, n_scans=7):
    """A semantic and a binary toy map with partly unobserved cells, and samples from a few scans."""
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(0.1, 3.0, (6, 7))
    observed = [1, 1, 1, 1, 0, 1]
    sem = _toy_map(observed, np.zeros(6), semantic_alpha=alpha)
    sem.observed = np.asarray(observed, bool)
    binary = _toy_map([1, 1, 0, 1, 1, 1], rng.choice([0.2, 0.5, 0.7, 0.9], 6))  # ties
    pts = rng.uniform(-0.4, 2.4, (n, 2)) * [1, 0.5]
    occ = rng.uniform(size=n) < 0.4
    label = np.where(occ, rng.integers(1, 7, n), 0)
    return sem, binary, ev.HeldOut(pts, occ, label, rng.integers(0, n_scans, n) * 10)


def _repeated(samples, scans, weights):
    """The samples with every sample of scan ``scans[i]`` repeated ``weights[i]`` times."""
    times = np.zeros(len(samples.scan), np.int64)
    for sc, w in zip(scans, weights):
        times[samples.scan == sc] = w
    keep = np.repeat(np.arange(len(times)), times)
    return ev.HeldOut(samples.points[keep], samples.occupied[keep], samples.label[keep],
                      samples.scan[keep])


@pytest.mark.parametrize("common", [True, False])
def test_bootstrap_replicates_and_jackknife_equal_scoring_the_resampled_samples(common):
    # the per-scan sums give exactly the scores of the samples repeated as often as their scan
    # was drawn (score_map on the repeated samples is the independent reference)
    sem, binary, s = _random_case(3)
    b = ev.bootstrap_scores([sem, binary], s, n_boot=12, seed=4, common=common)
    _, ok_sem = ev.scored_cells(sem, s)
    _, ok_bin = ev.scored_cells(binary, s)
    use = (ok_sem & ok_bin) if common else (ok_sem | ok_bin)
    scans = np.unique(s.scan[use])
    assert b["scan_weights"].shape == (12, len(scans)) and b["n_scans"] == len(scans)
    assert np.all(b["scan_weights"].sum(axis=1) == len(scans))
    assert np.ptp(b["scan_weights"]) > 0
    cases = [(b["scan_weights"][r], b, "replicates", r) for r in range(12)]
    cases += [(1 - np.eye(len(scans), dtype=int)[j], b, "jackknife", j) for j in range(len(scans))]
    for i, m in enumerate((sem, binary)):
        ok = (ok_sem & ok_bin) if common else (ok_sem, ok_bin)[i]
        for w, boot, kind, r in cases:
            rep = _repeated(ev.HeldOut(s.points[ok], s.occupied[ok], s.label[ok], s.scan[ok]),
                            scans, w)
            ref = ev.score_map(m, rep, keep_roc=False)
            assert boot[f"auc_{kind}"][r, i] == pytest.approx(ref["auc"], abs=1e-12)
            assert boot[f"occupied_recall_{kind}"][r, i] == pytest.approx(ref["occupied_recall"],
                                                                         abs=1e-12)
            if m is sem:
                assert boot[f"accuracy_{kind}"][r, i] == pytest.approx(ref["accuracy"], abs=1e-12)
                assert boot[f"miou_{kind}"][r, i] == pytest.approx(ref["miou"], abs=1e-12)
            else:
                assert np.isnan(boot[f"miou_{kind}"][r, i])


def test_bca_interval_by_hand():
    from scipy.stats import norm
    r = np.arange(1000) / 999.0          # replicates uniform on [0, 1]
    # symmetric jackknife (no acceleration) and the estimate at the median (no bias): percentile
    pct = ev.bootstrap_interval(r, 0.5, method="percentile")
    bca = ev.bootstrap_interval(r, 0.5, method="bca", jackknife=[0.0, 1.0, 0.5])
    assert bca == pytest.approx(pct, abs=1e-12)
    assert pct == pytest.approx(np.quantile(r, [0.025, 0.975]), abs=1e-12)
    # a skewed jackknife [0, 0, 0, 1]: d = mean - j = (1/4, 1/4, 1/4, -3/4), sum d^2 = 3/4,
    # sum d^3 = -3/8, a = -3/8 / (6 (3/4)^1.5); z0 = 0; the quantiles move to Phi(z / (1 - a z))
    a = -0.375 / (6 * 0.75 ** 1.5)
    z = norm.ppf([0.025, 0.975])
    expect = np.quantile(r, norm.cdf(z / (1 - a * z)))
    got = ev.bootstrap_interval(r, 0.5, method="bca", jackknife=[0, 0, 0, 1])
    assert got == pytest.approx(tuple(expect), abs=1e-12)
    assert got[0] < pct[0] and got[1] < pct[1]       # negative skew: the interval moves down
    # an estimate below most replicates (bias): z0 = Phi^-1(0.2) moves both ends down
    z0 = norm.ppf(200 / 1000)
    est = (r[199] + r[200]) / 2                       # 200 replicates below it
    got = ev.bootstrap_interval(r, est, method="bca", jackknife=[0.0, 1.0, 0.5])
    assert got == pytest.approx(tuple(np.quantile(r, norm.cdf(2 * z0 + z))), abs=1e-12)
    with pytest.raises(InputError):
        ev.bootstrap_interval(r, 0.5, method="bca")
    with pytest.raises(InputError):
        ev.bootstrap_interval(r, 0.5, method="student")
    with pytest.raises(InputError):
        ev.bootstrap_interval([np.nan], 0.5)


def test_paired_bca_difference_and_score_interval_use_the_paired_jackknife():
    sem, binary, s = _random_case(8, n=200, n_scans=12)
    b = ev.bootstrap_scores([sem, binary], s, n_boot=300, seed=2)
    d = ev.paired_difference(b, 0, 1, method="bca")
    direct = ev.bootstrap_interval(b["auc_replicates"][:, 0] - b["auc_replicates"][:, 1],
                                   b["auc"][0] - b["auc"][1], method="bca",
                                   jackknife=b["auc_jackknife"][:, 0] - b["auc_jackknife"][:, 1])
    assert (d["lo"], d["hi"]) == direct and d["lo"] <= d["diff"] <= d["hi"]
    one = ev.score_interval(b, 1, "auc", method="bca")
    assert one["est"] == b["auc"][1] and one["lo"] < one["est"] < one["hi"]
    # a map against itself: the difference and both ends are exactly zero, BCa as percentile
    same = ev.bootstrap_scores([binary, binary], s, n_boot=50, seed=2)
    d = ev.paired_difference(same, 0, 1, method="bca")
    assert (d["diff"], d["lo"], d["hi"]) == (0.0, 0.0, 0.0)
    with pytest.raises(InputError):
        ev.bootstrap_scores([binary], s, n_boot=0)


def test_paired_comparison_is_the_books_one_convention():
    """Every chapter's paired difference: common points, PAIRED_BOOT draws, BCa, printed digits."""
    sem, binary, s = _random_case(8, n=200, n_scans=12)
    d = ev.paired_comparison(sem, binary, s, "auc", digits=4)
    b = ev.bootstrap_scores([sem, binary], s, n_boot=ev.PAIRED_BOOT, seed=0, common=True)
    want = ev.table_difference(b, 0, 1, "auc", digits=4, method="bca")
    assert {k: d[k] for k in want} == want
    assert (d["a"], d["b"]) == (round(float(b["auc"][0]), 4), round(float(b["auc"][1]), 4))
    assert d["diff"] == round(d["a"] - d["b"], 4) and d["n"] == b["n_common"]
    assert d["n_boot"] == ev.PAIRED_BOOT == 2000 and ev.PAIRED_METHOD == "bca"
    # the same comparison the other way round: the same interval, mirrored
    r = ev.paired_comparison(binary, sem, s, "auc", digits=4)
    assert r["diff"] == -d["diff"]
    assert r["lo"] == pytest.approx(-d["hi"], abs=1e-9) and r["hi"] == pytest.approx(-d["lo"], abs=1e-9)
