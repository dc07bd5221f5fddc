"""The sparse voxel map: kernel, exactness against the loop transcription, incrementality."""
from __future__ import annotations

import math

import numpy as np
import pytest
from bki_literal import literal_posterior, literal_update
from bki_literal import sparse_kernel as literal_kernel

from hw4.bki import VoxelMap
from hw4.bki.voxelmap import FREE, OCCUPIED, UNKNOWN, kernel_reach
from hw4.core.kernel import sparse_kernel
from hw4.core.kernel import sparse_kernel_inside as fast_kernel
from hw4.core.kernel import sparse_kernel_pieces

SF2, ELL = 10.0, 0.3


@pytest.mark.parametrize("kernel", [fast_kernel, sparse_kernel_pieces], ids=["closed-form", "pieces"])
def test_kernel_values_shape_and_support(kernel):
    d = np.linspace(0, ELL * (1 - 1e-12), 2001)
    k = kernel(d.copy(), SF2, ELL)
    np.testing.assert_allclose(k, sparse_kernel(d, sigma0=SF2, l=ELL).clip(0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(k, [literal_kernel(x, SF2, ELL) for x in d], rtol=0, atol=1e-12)
    assert k[0] == pytest.approx(SF2)
    assert np.all(np.diff(k) <= 1e-12)                  # non-increasing in d
    assert np.all(k >= 0) and k[-1] < 1e-9             # reaches 0 at ell, never negative
    assert literal_kernel(ELL, SF2, ELL) == 0.0
    # at half the length scale: sf2 * (2 + cos(pi)) * 0.5 / 3 = sf2 / 6
    assert kernel(np.array([ELL / 2]), SF2, ELL)[0] == pytest.approx(SF2 / 6)


@pytest.mark.parametrize("ell", [0.05, 0.3, 1.0, 7.0])
def test_kernel_pieces_agree_with_the_closed_form(ell):
    """The table of pieces against math.cos / math.sin: everywhere (random, piece boundaries and
    their neighbours, just below ell) within a few units in the last place of sigma0."""
    rng = np.random.default_rng(5)
    edges = np.arange(1024) / 1024 * ell
    d = np.concatenate([rng.random(20000) * ell, edges, np.nextafter(edges, ell),
                        np.nextafter(edges[1:], 0), [np.nextafter(ell, 0), 0.0]])
    d = d[d < ell]
    got = sparse_kernel_pieces(d, SF2, ell)
    want = np.array([literal_kernel(x, SF2, ell) for x in d])
    assert np.abs(got - want).max() <= 4e-15 * SF2
    assert np.all(got >= 0.0)
    d0 = d.copy()
    sparse_kernel_pieces(d, SF2, ell)
    assert np.array_equal(d, d0)                                    # input left as it was


@pytest.mark.parametrize("res, ell", [(0.1, 0.3), (0.3, 0.3), (0.2, 0.5), (0.25, 0.1)])
def test_kernel_reach_covers_every_voxel_within_ell(res, ell):
    rng = np.random.default_rng(1)
    R = kernel_reach(res, ell)
    for p in rng.uniform(-1, 1, (200, 3)):
        base = np.floor(p / res)
        rng_ = np.arange(-R - 3, R + 4)
        o = np.stack(np.meshgrid(rng_, rng_, rng_, indexing="ij"), -1).reshape(-1, 3)
        d = np.linalg.norm(p - (base + o + 0.5) * res, axis=1)
        assert np.all(np.abs(o[d < ell]) <= R)


def _random_training(n, seed, K=4, spread=1.0):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-spread, spread, (n, 3))
    pts[: n // 4] = np.round(pts[: n // 4], 1)  # some points exactly on voxel faces
    return pts, rng.integers(0, K, n)


@pytest.mark.parametrize("method", ["sbki", "scsm"])
def test_vectorised_update_equals_the_loop_transcription(method):
    K, res, prior, vt = 4, 0.1, 0.001, 0.09
    vmap = VoxelMap(res, K, method, SF2, ELL, prior, vt)
    ev, cnt = {}, {}
    for seed, n in ((0, 150), (1, 120), (2, 90)):  # three "scans", incrementally
        pts, lab = _random_training(n, seed)
        vmap.update(pts, lab)
        literal_update(ev, cnt, pts, lab, res, K, method, SF2, ELL)
    vox, e, count = vmap.evidence()
    assert len(vox) == len(ev)
    got = {tuple(v): (row, c) for v, row, c in zip(vox.tolist(), e, count)}
    assert set(got) == set(ev)
    err = max(np.abs(got[k][0] - np.array(ev[k])).max() for k in ev)
    assert err < 1e-9
    assert all(got[k][1] == cnt[k] for k in ev)
    view = vmap.view()
    names = {UNKNOWN: "unknown", FREE: "free", OCCUPIED: "occupied"}
    for v, probs, c, var, st in zip(np.floor(view.centres / res + 1e-9).astype(int).tolist(),
                                    view.probs, view.cls, view.variance, view.state):
        lp, lc, lv, ls = literal_posterior(ev[tuple(v)], prior, vt)
        assert np.abs(probs - lp).max() < 1e-9 and abs(var - lv) < 1e-9
        top2 = np.sort(ev[tuple(v)])[-2:]
        if top2[1] - top2[0] > 1e-9:  # classes tied to rounding (kernel ~1e-17 near ell) can differ
            assert (c, names[st]) == (lc, ls)


def test_every_point_within_ell_counts_even_across_block_corners():
    # a point at a corner shared by 8 blocks of 4^3 voxels: the C++ reference gathers training
    # points from a block and its six face neighbours only, so the diagonal blocks' voxels whose
    # centres are within ell would miss this point; here they must not
    res, ell = 0.1, 0.3
    p = np.array([[0.4 + 1e-6, 0.4 + 1e-6, 0.4 + 1e-6]])  # corner of blocks at 0.4 m
    vmap = VoxelMap(res, 2, "sbki", SF2, ell)
    vmap.update(p, np.array([1]))
    vox, e, _ = vmap.evidence()
    diag = (vox == [3, 3, 3]).all(axis=1)  # centre (0.35, 0.35, 0.35), block (0, 0, 0), d = 0.087
    assert diag.any()
    d = np.linalg.norm(p[0] - 0.35)
    assert e[diag, 1][0] == pytest.approx(literal_kernel(d, SF2, ell), abs=1e-12)
    blocks = {tuple(b) for b in (vox >> 2).tolist()}
    assert len(blocks) == 8


def test_incremental_equals_batch_and_order_does_not_matter():
    pts, lab = _random_training(400, 5, spread=2.0)
    a = VoxelMap(0.1, 4, "sbki")
    for chunk in np.array_split(np.arange(400), 5):
        a.update(pts[chunk], lab[chunk])
    b = VoxelMap(0.1, 4, "sbki")
    perm = np.random.default_rng(9).permutation(400)
    b.update(pts[perm], lab[perm])
    va, ea, ca = a.evidence()
    vb, eb, cb = b.evidence()
    np.testing.assert_array_equal(va, vb)
    np.testing.assert_array_equal(ca, cb)
    np.testing.assert_allclose(ea, eb, rtol=0, atol=1e-12)


def test_deterministic_bit_for_bit():
    pts, lab = _random_training(500, 11, spread=3.0)
    runs = []
    for _ in range(2):
        m = VoxelMap(0.1, 4, "sbki")
        m.update(pts[:250], lab[:250])
        m.update(pts[250:], lab[250:])
        runs.append(m.view())
    for f in ("centres", "alpha", "variance", "state"):
        assert np.array_equal(getattr(runs[0], f), getattr(runs[1], f))


def test_memory_grows_with_observed_volume_not_bounding_box():
    far = np.array([[0.0, 0.0, 0.0], [1000.0, -2000.0, 500.0]])  # 2.3 km apart
    m = VoxelMap(0.1, 4, "sbki")
    m.update(far, np.array([1, 2]))
    # each point touches at most 8 blocks of 4^3 voxels; a dense box would need ~10^13 voxels
    assert m.n_blocks <= 16
    assert m.nbytes < 5e6
    vox, e, _ = m.evidence()
    near0 = np.linalg.norm((vox + 0.5) * 0.1, axis=1) < 0.3
    assert near0.sum() + (~near0).sum() == len(vox) and near0.any() and (~near0).any()


def test_var_thresh_makes_weak_voxels_unknown_and_reference_view_keeps_them():
    m = VoxelMap(0.1, 4, "sbki", SF2, ELL, 0.001, 0.09)
    m.update(np.array([[0.05, 0.05, 0.05]]), np.array([2]))
    v = m.view()
    centre = np.all(np.isclose(v.centres, 0.05), axis=1)
    assert v.state[centre][0] == OCCUPIED and v.cls[centre][0] == 2
    # voxels just inside ell get a tiny kernel value: most likely class 2, but a large variance
    weak = v.alpha[:, 2] - 0.001 < 0.05
    assert weak.any()
    assert np.all(v.state[weak] == UNKNOWN)
    assert np.all(v.state_reference[weak] == OCCUPIED)
    assert np.all(v.variance[weak] > 0.09)


def test_scsm_counts_each_point_once_in_its_voxel():
    pts = np.array([[0.01, 0.01, 0.01], [0.09, 0.02, 0.03], [0.11, 0.0, 0.0], [-0.01, 0, 0]])
    m = VoxelMap(0.1, 3, "scsm")
    m.update(pts, np.array([1, 2, 2, 0]))
    vox, e, c = m.evidence()
    table = {tuple(v): tuple(r) for v, r in zip(vox.tolist(), e.tolist())}
    assert table == {(0, 0, 0): (0, 1, 1), (1, 0, 0): (0, 0, 1), (-1, 0, 0): (1, 0, 0)}
    assert math.isclose(m.view().alpha.sum(), 4 + 3 * 3 * 0.001)


@pytest.mark.parametrize("res, ell", [(0.15, 0.3), (0.3, 0.3), (0.25, 0.1), (0.2, 0.5), (0.7, 0.3)])
def test_offset_windows_miss_no_voxel_for_other_resolutions(res, ell):
    # the update tries per axis only the run of offsets within ell; any voxel size against ell
    pts, lab = _random_training(300, 3, spread=1.5)
    pts[:60] = np.round(pts[:60] / res) * res + ell * np.sign(pts[:60])  # on faces, ell off centres
    vmap = VoxelMap(res, 4, "sbki", SF2, ell)
    vmap.update(pts, lab)
    ev, cnt = {}, {}
    literal_update(ev, cnt, pts, lab, res, 4, "sbki", SF2, ell)
    vox, e, count = vmap.evidence()
    got = {tuple(v): (row, c) for v, row, c in zip(vox.tolist(), e, count)}
    assert set(got) == set(ev)
    assert max(np.abs(got[k][0] - np.array(ev[k])).max() for k in ev) < 1e-9
    assert all(got[k][1] == cnt[k] for k in ev)


def test_each_pair_weighs_what_sparse_kernel_pieces_gives():
    """One point alone: the voxels it reaches are exactly those whose centre lies within ell
    (numpy, all offsets), and each gets the piecewise kernel of its distance, bit for bit."""
    rng = np.random.default_rng(11)
    for res, ell in ((0.1, 0.3), (0.3, 0.3), (0.25, 0.1), (0.2, 0.55)):
        for p in rng.uniform(-3, 3, (25, 3)):
            c = int(rng.integers(0, 4))
            vmap = VoxelMap(res, 4, "sbki", SF2, ell)
            vmap.update(p[None], np.array([c]))
            vox, e, count = vmap.evidence()
            R = kernel_reach(res, ell) + 2
            o = np.stack(np.meshgrid(*[np.arange(-R, R + 1)] * 3, indexing="ij"), -1).reshape(-1, 3)
            cand = np.floor(p / res).astype(np.int64) + o
            diff = p - (cand + 0.5) * res
            sq = diff * diff
            d2 = (sq[:, 0] + sq[:, 1]) + sq[:, 2]
            inside = d2 < ell ** 2
            want = {tuple(v): w for v, w in zip(cand[inside].tolist(),
                                                sparse_kernel_pieces(np.sqrt(d2[inside]), SF2, ell))}
            assert {tuple(v) for v in vox.tolist()} == set(want)
            assert np.all(count == 1)
            assert np.all(e[:, np.arange(4) != c] == 0)
            for v, w in zip(vox.tolist(), e[:, c]):
                assert w == want[tuple(v)]


def test_same_map_bit_for_bit_when_built_again():
    pts, lab = _random_training(6000, 4, spread=2.0)
    runs = []
    for _ in range(2):
        m = VoxelMap(0.1, 4, "sbki")
        m.update(pts[:4000], lab[:4000])
        m.update(pts[4000:], lab[4000:])
        runs.append(m.evidence())
    for a, b in zip(*runs):
        assert np.array_equal(a, b)
