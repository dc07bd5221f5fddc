"""Training data: downsampling, free-space samples along rays, and the toy data's counts."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.bki import Scan, load_config, scan_source, training_data, validate_scan
from hw4.bki.training import downsample, free_samples
from hw4.core.errors import InputError


def test_toy_training_counts_are_12363_hits_and_22294_free():
    cfg = load_config("toy")
    tds = [training_data(validate_scan(load(), cfg.num_class), cfg.ds_resolution,
                         cfg.free_resolution, cfg.max_range, cfg.num_class)
           for load in scan_source("toy")]
    hits, free = sum(t.n_hits for t in tds), sum(t.n_free for t in tds)
    print(f"toy training data: {hits} hits, {free} free points")
    assert (len(tds), hits, free) == (12, 12_363, 22_294)
    for t in tds:
        assert np.all(t.labels[:t.n_hits] > 0) and np.all(t.labels[t.n_hits:] == 0)


def test_downsample_centroid_majority_and_ties_to_smallest_label():
    pts = np.array([[0.01, 0.01, 0.01], [0.03, 0.05, 0.07], [0.09, 0.02, 0.04],   # leaf (0,0,0)
                    [0.15, 0.0, 0.0], [0.16, 0.0, 0.0],                          # leaf (1,0,0)
                    [-0.01, 0.0, 0.0]])                                          # leaf (-1,0,0)
    lab = np.array([2, 3, 3, 3, 1, 2])
    cen, maj = downsample(pts, lab, 0.1, 4)
    # order of increasing leaf key: (-1,0,0), (0,0,0), (1,0,0)
    np.testing.assert_allclose(cen, [[-0.01, 0, 0], pts[:3].mean(0), [0.155, 0, 0]])
    np.testing.assert_array_equal(maj, [2, 3, 1])  # (1,0,0) is a 3-vs-1 tie: smallest label wins


def test_downsample_leaf_is_floor_of_x_over_resolution():
    # 0.0999 and 0.0001 share leaf 0; 0.1 is in leaf 1; -0.0001 in leaf -1 (floor, not truncation)
    pts = np.array([[0.0999, 0, 0], [0.1, 0, 0], [-0.0001, 0, 0], [0.0001, 0, 0]])
    cen, _ = downsample(pts, None, 0.1)
    np.testing.assert_allclose(cen[:, 0], [-0.0001, 0.05, 0.1])


def test_free_samples_along_a_ray():
    o = np.array([1.0, 2.0, 3.0])
    d = np.array([0.6, 0.0, 0.8])
    hits = o + np.outer([1.2, 0.5, 0.3, 0.0, 2.0], d)
    pts = free_samples(hits, o, 0.5)
    dist = np.linalg.norm(pts - o, axis=1)
    # L = 1.2: origin, 0.5, 1.0, then L - 0.5 = 0.7
    # L = 0.5: origin only (0.5 is not < 0.5, and L is not > 0.5)
    # L = 0.3: origin only; L = 0: origin only
    # L = 2.0: origin, 0.5, 1.0, 1.5, then 1.5 again
    expect = [0, 0.5, 1.0, 0.7, 0, 0, 0, 0, 0.5, 1.0, 1.5, 1.5]
    np.testing.assert_allclose(dist, expect, atol=1e-12)
    # every sample lies on its ray
    on_ray = pts[dist > 0] - o
    np.testing.assert_allclose(on_ray / np.linalg.norm(on_ray, axis=1)[:, None], np.tile(d, (len(on_ray), 1)))
    with pytest.raises(InputError):
        free_samples(hits, o, 0.0)


def test_max_range_drops_far_hits_and_their_rays():
    o = np.zeros(3)
    pts = np.array([[3.05, 0.05, 0.05], [9.05, 0.05, 0.05]])
    scan = validate_scan(Scan(pts, np.array([1, 2]), o), 4)
    near = training_data(scan, 0.1, 0.5, 8.0, 4)
    everything = training_data(scan, 0.1, 0.5, -1, 4)
    assert (near.n_hits, everything.n_hits) == (1, 2)
    assert near.n_free < everything.n_free
    assert np.all(np.linalg.norm(near.points, axis=1) < 3.1)
    # the free points of the near ray: origin and 0.5 .. 3.0 and L - 0.5, each in its own leaf
    assert near.n_free == 1 + 6 + 1


def test_free_points_are_downsampled_across_rays():
    o = np.array([0.05, 0.05, 0.05])
    # two hits in different leaves but almost the same direction: their free samples share leaves
    pts = np.array([[4.05, 0.05, 0.05], [4.05, 0.0501, 0.05]]) + [[0, 0, 0], [0.1, 0, 0]]
    td = training_data(validate_scan(Scan(pts, np.array([1, 1]), o), 4), 0.1, 0.5, -1, 4)
    assert td.n_hits == 2
    assert td.n_free == len(np.unique(np.floor(td.points[td.n_hits:] / 0.1), axis=0))
    assert td.n_free < 2 * 9


@pytest.mark.parametrize("num_labels, spread", [(3, 0.3), (20, 1.0), (20, 0.2)])
def test_downsample_matches_a_loop_over_leaves(num_labels, spread):
    # many leaves and labels (the vote runs only in leaves with mixed labels) and few (every leaf
    # votes): centroid and majority (ties to the smallest label) of each leaf as a plain loop
    rng = np.random.default_rng(num_labels)
    pts = np.round(rng.uniform(-spread, spread, (3000, 3)), 2)
    lab = np.where(rng.random(3000) < 0.7, 5 % num_labels, rng.integers(0, num_labels, 3000))
    cen, maj = downsample(pts, lab, 0.1, num_labels)
    leaves = {}
    for p, c in zip(pts, lab):
        leaves.setdefault(tuple(np.floor(p / 0.1).astype(int)), []).append((p, c))
    assert len(cen) == len(leaves)
    for (leaf, members), c, m in zip(sorted(leaves.items()), cen, maj):
        np.testing.assert_allclose(c, np.mean([p for p, _ in members], axis=0), rtol=0, atol=1e-12)
        votes = np.bincount([lab_ for _, lab_ in members], minlength=num_labels)
        assert m == int(np.flatnonzero(votes == votes.max())[0])
