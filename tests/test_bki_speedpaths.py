"""The compiled engine's fast paths against the numpy reference, bit for bit (issue 23)."""
import numpy as np
import pytest

from hw4.bki import compiled, training


@pytest.mark.parametrize("spread, labelled", [(3.0, True), (3.0, False), (2.0 ** 17, True)])
def test_downsample_equals_numpy(spread, labelled):
    """Leaf keys in runs of consecutive points, one value per run packed with the run and sorted
    once, then streamed sums; a box of leaves too wide to pack (spread 2^17 leaves per axis)
    ranks the keys first: the same centroids and majorities as
    :func:`hw4.bki.training.downsample`."""
    rng = np.random.default_rng(3)
    pts = rng.normal(0, spread * 0.1, (5000, 3))
    pts = np.vstack([pts, pts[:1000] + 1e-3])          # shared leaves, mixed labels
    lab = rng.integers(0, 5, len(pts)) if labelled else None
    cen, maj = training.downsample(pts, lab, 0.1, 5 if labelled else None)
    got, gmaj, far = compiled.downsample(pts, lab, 0.1, 5 if labelled else 0)
    assert not far and np.array_equal(got, cen)
    assert (gmaj is None and maj is None) or np.array_equal(gmaj, maj)


@pytest.mark.parametrize("labelled", [True, False])
def test_downsample_runs_equal_numpy(labelled):
    """Runs of consecutive points in one leaf (as a lidar's neighbouring beams make them), a
    leaf reached by several runs far apart, single-point runs and mixed labels within a run:
    the same centroids and majorities as :func:`hw4.bki.training.downsample`."""
    rng = np.random.default_rng(8)
    seeds = rng.normal(0, 0.4, (300, 3))
    reps = rng.integers(1, 9, len(seeds))
    pts = np.repeat(seeds, reps, axis=0) + rng.uniform(0, 0.02, (reps.sum(), 3))
    pts = np.vstack([pts, pts[::-7], pts[:50]])          # the same leaves again, later
    lab = rng.integers(0, 4, len(pts)) if labelled else None
    cen, maj = training.downsample(pts, lab, 0.1, 4 if labelled else None)
    got, gmaj, far = compiled.downsample(pts, lab, 0.1, 4 if labelled else 0)
    keys = training.leaf_keys(pts, 0.1)
    assert np.count_nonzero(np.diff(keys)) + 1 < 0.6 * len(pts)   # long runs indeed
    assert not far and np.array_equal(got, cen)
    assert (gmaj is None and maj is None) or np.array_equal(gmaj, maj)


@pytest.mark.parametrize("method, res, ell, K", [("sbki", 0.3, 0.3, 20), ("sbki", 0.1, 0.3, 4),
                                                 ("sbki", 0.2, 0.5, 6), ("scsm", 0.1, 0.3, 3),
                                                 ("scsm", 0.3, 0.3, 20)])
@pytest.mark.parametrize("span", [None, 1])
def test_point_windows_equal_numpy(monkeypatch, method, res, ell, K, span):
    """The kernel sums point by point over each axis's window of reachable offsets; with a
    window of 1 (every point then has more offsets within ell: the whole neighbourhood) the same
    map as with the natural window and as the numpy engine. S-CSM (its counts in input order,
    no voxel order) with few classes (dense sums) and many (the sparse list)."""
    from hw4.bki import VoxelMap
    if span is not None:
        monkeypatch.setattr(compiled, "window_span", lambda R, r, e: span)
    rng = np.random.default_rng(11)
    a = VoxelMap(res, K, method, ell=ell, engine="numpy")
    b = VoxelMap(res, K, method, ell=ell, threads=1)
    for n in (3000, 2000):
        pts = rng.normal(0, 1.5, (n, 3))
        lab = rng.integers(0, K, n)
        a.update(pts, lab)
        b.update(pts, lab)
    va, vb = a.evidence(), b.evidence()
    assert len(va[0]) == len(vb[0]) > 0
    assert all(np.array_equal(x, y) for x, y in zip(va, vb))


def test_pool_grows_in_place_or_by_a_copy_when_viewed():
    """The pool grows in place (resize) while small unless something views it; the map is the same."""
    from hw4.bki import VoxelMap
    rng = np.random.default_rng(5)
    scans = [(rng.normal(0, s, (5000, 3)), rng.integers(0, 8, 5000)) for s in (2, 5, 9)]
    a, b = VoxelMap(0.3, 8), VoxelMap(0.3, 8)
    views = []
    for pts, lab in scans:
        a.update(pts, lab)
        views.append(b.ev[:3])      # held: b's pool must be copied, not reallocated
        b.update(pts, lab)
    assert all(np.array_equal(x, y) for x, y in zip(a.evidence(), b.evidence()))
    assert len(b.count) > 1024 and all(v.shape == (3, 8) for v in views)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_scsm_counts_in_input_order_on_threads(threads):
    """S-CSM's counts (input order, per thread an x range) give the numpy map and the same pool."""
    from hw4.bki import VoxelMap
    rng = np.random.default_rng(2)
    a = VoxelMap(0.2, 20, "scsm", engine="numpy")
    b = VoxelMap(0.2, 20, "scsm", threads=threads)
    c = VoxelMap(0.2, 20, "scsm", threads=1)
    for n in (4000, 3000):
        pts = rng.normal(0, 2.0, (n, 3))
        lab = rng.integers(0, 3, n) * 7          # few classes per voxel, some mixed
        for m in (a, b, c):
            m.update(pts, lab)
    assert all(np.array_equal(x, y) for x, y in zip(a.evidence(), b.evidence()))
    assert np.array_equal(b.ev[:b.n_voxels], c.ev[:c.n_voxels])


def test_voxel_order_is_stable_and_falls_back_to_argsort():
    """The sorted ``code << nb | index`` gives the stable argsort of the voxel codes; a box whose
    codes leave no room for the index takes the argsort itself."""
    rng = np.random.default_rng(4)
    base = rng.integers(-20, 20, (5000, 3))
    lo, dims = base.min(axis=0), np.ptp(base, axis=0) + 1
    codes = ((base - lo) * np.array([dims[1] * dims[2], dims[2], 1])).sum(axis=1)
    okeys, omask, nb = compiled.voxel_order(base, lo, dims)
    assert nb > 0 and np.array_equal(okeys & omask, np.argsort(codes, kind="stable"))
    wide = np.array([1 << 20, 1 << 20, 1 << 21])      # 2^61 voxels: no room for the index
    okeys, omask, nb = compiled.voxel_order(base, lo, wide)
    wcodes = ((base - lo) * np.array([wide[1] * wide[2], wide[2], 1])).sum(axis=1)
    assert nb == 0 and np.array_equal(okeys & omask, np.argsort(wcodes, kind="stable"))


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", ["scsm", "sbki"])
def test_a_failed_update_leaves_the_map_as_it_was(monkeypatch, engine, method):
    """Whatever can fail in an update (the pool's growth: MemoryError; an interrupt) comes before
    the map changes: after a failed scan the map is the one before it, and the next scans give
    the map of a run that never saw the failed one (no phantom voxels, no shared slots)."""
    from hw4.bki.voxelmap import VoxelMap
    rng = np.random.default_rng(7)
    scans = [(rng.normal(c, 2, (300, 3)), rng.integers(0, 3, 300)) for c in (0.0, 5.0, -5.0)]
    ref = VoxelMap(0.5, 3, method, engine=engine)
    ref.update(*scans[0])
    ref.update(*scans[2])
    m = VoxelMap(0.5, 3, method, engine=engine)
    m.update(*scans[0])
    before = [a.copy() for a in m.evidence()]

    def boom(self, n):
        raise MemoryError("simulated")
    monkeypatch.setattr(VoxelMap, "_reserve", boom)
    with pytest.raises(MemoryError):
        m.update(*scans[1])
    monkeypatch.undo()
    assert all(np.array_equal(a, b) for a, b in zip(m.evidence(), before))
    m.update(*scans[2])
    assert all(np.array_equal(a, b) for a, b in zip(m.evidence(), ref.evidence()))
    used = m.table[m.slots].ravel()
    used = used[used >= 0]
    assert len(used) == len(np.unique(used)) == m.n_voxels
