"""hw4.evaluation.stats and hw4.book.illustrate on small hand-made maps whose answers are known exactly."""
import numpy as np
import pytest

from hw4.book import illustrate
from hw4.evaluation import stats
from hw4.core.grid import Grid
from hw4.core.kernel import sparse_kernel


def small_grid(g=0.5):
    """3 x 3 cells: centres x, y in {0, 0.5, 1} [m] (g = 0.5), or 2 x 2 (g = 1)."""
    return Grid(g, (0.0, 1.0), (0.0, 1.0))


def binary_map():
    """3 x 3 binary map (rows are y): one occupied cell, a ring of free cells, unknown corners.

    Row-major cell order: i = iy * 3 + ix.
      iy = 2:  unknown   free(3)   unknown
      iy = 1:  free(1)   occ(4,1)  free(2)
      iy = 0:  unknown   free(1)   mixed(1,1)
    """
    c = np.zeros((9, 2))
    c[1] = (0, 1)      # (x 0.5, y 0): free
    c[2] = (1, 1)      # (x 1, y 0): alpha = beta: mean 0.5, not occupied
    c[3] = (0, 1)      # (x 0, y 0.5): free
    c[4] = (4, 1)      # centre: occupied
    c[5] = (0, 2)      # (x 1, y 0.5): free
    c[7] = (0, 3)      # (x 0.5, y 1): free
    return stats.from_counts(small_grid(), c, semantic=False, prior=1e-3)


def semantic_map():
    """3 x 3 semantic map with K = 3 (two classes, free last); cells 0 and 8 unknown."""
    c = np.zeros((9, 3))
    c[1] = (2, 0, 0)
    c[2] = (0, 2, 1)
    c[3] = (0, 0, 5)
    c[4] = (1, 1, 0)   # tie: first class wins
    c[5] = (0, 0, 1)
    c[6] = (0, 3, 0)
    c[7] = (0, 0, 2)
    return stats.from_counts(small_grid(), c, semantic=True, prior=1e-3)


def test_from_counts_posterior():
    m = binary_map()
    a, b = 1e-3 + 4, 1e-3 + 1
    assert m.map["mean"][4, 0] == pytest.approx(a / (a + b))
    assert m.map["variance"][4, 0] == pytest.approx(a * b / ((a + b) ** 2 * (a + b + 1)))
    assert m.map["variance"][0, 0] == pytest.approx(0.25 / (2e-3 + 1))  # prior only
    s = semantic_map()
    assert s.num_classes == 2
    assert s.map["mean"].shape == (9, 3)
    p = (5 + 1e-3) / (5 + 3e-3)
    assert s.map["variance"][3, 0] == pytest.approx(p * (1 - p) / (5 + 3e-3 + 1))


def test_coverage_and_areas():
    m = binary_map()
    assert stats.observed(m).sum() == 6
    assert stats.observed_share(m) == pytest.approx(6 / 9)
    assert stats.cell_area(m) == pytest.approx(0.25)
    assert stats.observed_area(m) == pytest.approx(6 * 0.25)
    assert stats.evidence_per_cell(m) == pytest.approx((1 + 2 + 1 + 5 + 2 + 3) / 6)


def test_mean_variance_observed_only():
    m = binary_map()
    var = m.map["variance"][:, 0]
    obs = [1, 2, 3, 4, 5, 7]
    assert stats.mean_variance(m) == pytest.approx(var[obs].mean())
    assert stats.mean_variance(m, observed_only=False) == pytest.approx(var.mean())


def test_binary_labels_and_counts():
    m = binary_map()
    lab = stats.cell_labels(m)
    np.testing.assert_array_equal(lab, [-1, 1, 1, 1, 0, 1, -1, 1, -1])  # mean 0.5 is not > 0.5
    assert stats.free_label(m) == 1
    np.testing.assert_array_equal(stats.label_counts(m), [1, 5])
    assert stats.occupied_cells(m) == 1
    assert stats.occupied_cells(m, threshold=0.4) == 2  # the alpha = beta cell joins
    assert stats.occupied_area(m) == pytest.approx(0.25)


def test_semantic_labels_and_counts():
    s = semantic_map()
    np.testing.assert_array_equal(stats.cell_labels(s), [-1, 0, 1, 2, 0, 2, 1, 2, -1])
    assert stats.free_label(s) == 2
    np.testing.assert_array_equal(stats.label_counts(s), [2, 2, 3])
    assert stats.occupied_cells(s) == 4


def test_interior_gaps():
    c = np.zeros((9, 2))
    c[[1, 3, 5, 7], 1] = 1  # the centre is unobserved, its four neighbours observed
    assert stats.interior_gaps(stats.from_counts(small_grid(), c)) == 1
    c[7] = 0
    assert stats.interior_gaps(stats.from_counts(small_grid(), c)) == 0
    assert stats.interior_gaps(binary_map()) == 0


def test_labels_at_and_outside():
    m = binary_map()
    pts = [[0.5, 0.5], [0.6, 0.45], [1.0, 0.0], [0.0, 0.0], [5.0, 5.0]]
    np.testing.assert_array_equal(stats.labels_at(m, pts), [0, 0, 1, -1, -1])


def test_compare_labels_identical_and_self():
    m = binary_map()
    ch = stats.compare_labels(m, m)
    assert (ch.compared, ch.changed, ch.only_reference, ch.only_other) == (6, 0, 0, 0)
    assert ch.share_changed == 0.0


def test_compare_labels_coarser_map():
    fine = binary_map()
    # Coarse 2 x 2 grid, centres {0, 1} x {0, 1}; the fine centres 0, 0.5, 1 fall in coarse
    # cells 0, 0, 1 along each axis (np.rint rounds 0.5 half to even, to 0).
    coarse_grid = small_grid(1.0)
    c = np.zeros((4, 2))
    c[0] = (0, 1)  # (0, 0): free
    c[1] = (3, 0)  # (1, 0): occupied
    c[3] = (0, 4)  # (1, 1): free; (0, 1) unknown
    coarse = stats.from_counts(coarse_grid, c)
    idx = coarse_grid.nearest_cell(fine.grid.cells)
    np.testing.assert_array_equal(idx, [0, 0, 1, 0, 0, 1, 2, 2, 3])
    ch = stats.compare_labels(fine, coarse)
    # fine labels [-1, 1, 1, 1, 0, 1, -1, 1, -1]; coarse sampled [1, 1, 0, 1, 1, 0, -1, -1, 1]
    assert ch.compared == 5          # fine cells 1, 2, 3, 4, 5
    assert ch.changed == 3           # 2 (free -> occ), 4 (occ -> free), 5 (free -> occ)
    assert ch.to_free == 1 and ch.from_free == 2
    assert ch.only_reference == 1    # fine cell 7
    assert ch.only_other == 2        # fine cells 0 and 8
    assert ch.share_changed == pytest.approx(3 / 5)


def test_occupied_recall():
    fine = binary_map()                        # one occupied cell, at (0.5, 0.5)
    c = np.zeros((4, 2))
    c[1] = (3, 0)                              # coarse occupied cell at (1, 0)
    coarse = stats.from_counts(small_grid(1.0), c)
    d = np.hypot(0.5, 0.5)                     # distance between the two centres [m]
    assert stats.occupied_recall(fine, coarse, radius=d) == 1.0
    assert stats.occupied_recall(fine, coarse, radius=0.7) == 0.0
    assert stats.occupied_recall(coarse, fine, radius=0.5) == 0.0
    empty = stats.from_counts(small_grid(1.0), np.zeros((4, 2)))
    assert stats.occupied_recall(fine, empty, radius=1.0) == 0.0
    assert np.isnan(stats.occupied_recall(empty, fine, radius=1.0))
    # semantic: any region class counts as occupied
    s = semantic_map()                         # region cells 1, 2, 4, 6
    assert stats.occupied_recall(s, s, radius=0.0) == 1.0


def test_compare_labels_kinds_must_match():
    with pytest.raises(ValueError):
        stats.compare_labels(binary_map(), semantic_map())


def test_summary_plain_numbers():
    s = stats.summary(binary_map())
    assert s["cells"] == 9 and s["occupied_cells"] == 1 and s["interior_gaps"] == 0
    assert s["observed_area"] == pytest.approx(1.5)
    for v in s.values():
        assert type(v) in (int, float)


# hw4.book.illustrate: the evidence one beam leaves along its line


def test_free_samples_strictly_short_of_end():
    np.testing.assert_allclose(illustrate.free_samples(0.5, 0.1), [0, 0.1, 0.2, 0.3, 0.4])
    np.testing.assert_allclose(illustrate.free_samples(0.45, 0.1), [0, 0.1, 0.2, 0.3, 0.4])
    np.testing.assert_allclose(illustrate.free_samples(0.5, 0.1, end_sample=True),
                               [0, 0.1, 0.2, 0.3, 0.4, 0.5])
    np.testing.assert_allclose(illustrate.free_samples(1.0, 0.5), [0, 0.5])


def test_beam_profile_known_values():
    # on the beam, step l/2 = 0.1: far from both ends a point on a sample gets k(0) + 2 k(l/2)
    # = sigma0 (1 + 2/6), and k(l/2) = sigma0 / 6 exactly
    assert sparse_kernel(0.1) == pytest.approx(0.1 / 6)
    a, b = illustrate.beam_profile(np.array([1.0, 2.0]), z=2.0, step=0.1)
    assert b[0] == pytest.approx(0.1 * 4 / 3)
    assert a[0] == 0.0 and a[1] == pytest.approx(0.1)
    assert b[1] == pytest.approx(0.1 / 6)  # only the sample at 1.9 is within l of the end point
    _, b_end = illustrate.beam_profile(np.array([2.0]), z=2.0, step=0.1, end_sample=True)
    assert b_end[0] == pytest.approx(0.1 + 0.1 / 6)
    _, b_one = illustrate.beam_profile(np.array([1.0, 1.05]), z=2.0, step=0.1, closest_only=True)
    np.testing.assert_allclose(b_one, [0.1, sparse_kernel(0.05)])
    # step 0.5 leaves points 0.25 m from both neighbouring samples without free evidence
    _, b_gap = illustrate.beam_profile(np.array([0.25, 0.75]), z=2.0, step=0.5)
    np.testing.assert_array_equal(b_gap, [0.0, 0.0])
    # a lateral offset of l or more receives nothing
    a, b = illustrate.beam_profile(np.array([1.0, 2.0]), z=2.0, offset=0.2)
    assert not a.any() and not b.any()


def test_uncovered_share():
    assert illustrate.uncovered_share(2.0, 0.1) == 0.0
    assert illustrate.uncovered_share(2.0, 0.27) == 0.0
    # step 0.5, l 0.2, samples at 0, 0.5, 1, 1.5: three bare stretches of 0.1 m between samples
    # and 0.3 m from 1.7 m to the end point (which the end point's own evidence covers)
    assert illustrate.uncovered_share(2.0, 0.5) == pytest.approx(0.3, abs=1e-3)


def test_seed_interval_is_students_t_interval_of_the_mean():
    from hw4.evaluation.stats import seed_interval
    from hw4.core.errors import InputError
    # five seeds: mean 3, sample sd sqrt(2.5); t(0.975, 4) = 2.7764451
    r = seed_interval([1.0, 2.0, 3.0, 4.0, 5.0])
    half = 2.7764451051977987 * np.sqrt(2.5) / np.sqrt(5)
    assert r["n"] == 5 and r["mean"] == 3.0 and r["sd"] == pytest.approx(np.sqrt(2.5))
    assert (r["lo"], r["hi"]) == (pytest.approx(3 - half), pytest.approx(3 + half))
    assert (r["min"], r["max"]) == (1.0, 5.0)
    # one interval per column; identical runs give a zero-width interval
    m = seed_interval(np.array([[1.0, 7.0], [2.0, 7.0], [3.0, 7.0], [4.0, 7.0], [5.0, 7.0]]))
    np.testing.assert_allclose(m["lo"], [3 - half, 7.0])
    np.testing.assert_allclose(m["hi"], [3 + half, 7.0])
    for bad in ([1.0], [1.0, np.nan]):
        with pytest.raises(InputError):
            seed_interval(bad)
    with pytest.raises(InputError):
        seed_interval([1.0, 2.0], level=1.0)
