"""The compiled S-BKI / S-CSM insertion (hw4.bki.compiled) against the numpy reference, bit for bit.

The numpy formulation (hw4.bki.training's downsample and free_samples, VoxelMap(engine="numpy"))
is the reference; the compiled engine must give the same training points and the same map (voxels,
evidence and pair counts) exactly, scan after scan, for both methods and for settings that reach
1 to 3 voxels per axis, points on leaf and voxel faces, rays of zero length and of exact multiples
of the free-sample step, and scans so spread out that the update splits them.
"""
from __future__ import annotations

import numpy as np
import pytest
from bki_literal import literal_update

from hw4.bki import Scan, VoxelMap, load_config, scan_source, training_data, validate_scan
from hw4.bki import compiled
from hw4.bki.training import downsample, free_samples
from hw4.core.errors import InputError


def _same_map(a: VoxelMap, b: VoxelMap) -> None:
    va, vb = a.evidence(), b.evidence()
    assert len(va[0]) == len(vb[0]) > 0
    for x, y in zip(va, vb):
        assert x.dtype == y.dtype and np.array_equal(x, y)  # bit for bit (no tolerance)
    assert a.n_voxels == b.n_voxels and a.n_blocks == b.n_blocks and a.n_scans == b.n_scans
    np.testing.assert_array_equal(a.keys, b.keys)


def _scan(rng, n, K, spread=4.0, origin=(0.3, -0.2, 0.5)):
    pts = rng.normal(0, spread, (n, 3))
    pts[: n // 3] = np.round(pts[: n // 3], 1)          # on leaf and voxel faces (0.1 m grid)
    pts[n // 3: n // 2] = np.round(pts[n // 3: n // 2] / 0.3) * 0.3
    pts[-3:] = origin                                  # rays of length 0
    return Scan(pts, rng.integers(1, K, n), np.array(origin), "random")


@pytest.mark.parametrize("num_labels", [2, 4, 20])
@pytest.mark.parametrize("labelled", [True, False])
def test_downsample_equals_numpy(num_labels, labelled):
    rng = np.random.default_rng(num_labels)
    pts = rng.normal(0, 0.5, (20000, 3))
    pts[:5000] = np.round(pts[:5000], 1)
    pts[5000:6000] = pts[0]                            # many points in one leaf
    lab = rng.integers(0, num_labels, len(pts)) if labelled else None
    want = downsample(pts, lab, 0.1, num_labels if labelled else None)
    got = compiled.downsample(pts, lab, 0.1, num_labels if labelled else 0)
    assert not got[2]
    assert np.array_equal(got[0], want[0])
    if labelled:
        assert np.array_equal(got[1], want[1])
    else:
        assert got[1] is None


def test_downsample_ties_go_to_the_smallest_label():
    pts = np.zeros((6, 3)) + 0.05
    lab = np.array([3, 2, 3, 2, 1, 1])                 # a three-way tie, 2 votes each
    cen, maj, _ = compiled.downsample(pts, lab, 0.1, 4)
    assert maj.tolist() == [1] and np.array_equal(cen, downsample(pts, lab, 0.1, 4)[0])


def test_free_samples_equal_numpy():
    rng = np.random.default_rng(3)
    o = np.array([0.25, -1.0, 0.7])
    hits = o + rng.normal(0, 5, (3000, 3))
    hits[:10] = o                                      # L = 0
    hits[10:20] = o + np.array([1.0, 0, 0]) * np.arange(1, 11)[:, None] * 0.5  # L = j * step
    hits[20:30] = o + rng.normal(0, 0.2, (10, 3))      # L below the step
    for step in (0.5, 0.1, 100.0):
        want = free_samples(hits, o, step)
        got = compiled.free_samples(hits, o, compiled.lengths(hits, o), step)
        assert np.array_equal(got, want)
    assert np.array_equal(compiled.lengths(hits, o), np.linalg.norm(hits - o, axis=1))


@pytest.mark.parametrize("ds, fr, max_range", [(0.1, 0.5, 8.0), (0.1, 100.0, -1.0),
                                                (0.25, 0.3, 6.0), (0.05, 1.0, 0.0)])
def test_training_data_equals_numpy(ds, fr, max_range):
    rng = np.random.default_rng(int(ds * 100 + fr))
    for _ in range(3):
        s = validate_scan(_scan(rng, 4000, 5), 5)
        a = training_data(s, ds, fr, max_range, 5, engine="numpy")
        b = training_data(s, ds, fr, max_range, 5, engine="compiled")
        assert (a.n_hits, a.n_free) == (b.n_hits, b.n_free)
        assert np.array_equal(a.points, b.points) and np.array_equal(a.labels, b.labels)
        assert a.labels.dtype == b.labels.dtype and a.points.dtype == b.points.dtype


def test_training_data_of_the_toy_scans_equals_numpy():
    cfg = load_config("toy")
    for load in list(scan_source("toy"))[:4]:
        s = validate_scan(load(), cfg.num_class)
        args = (s, cfg.ds_resolution, cfg.free_resolution, cfg.max_range, cfg.num_class)
        a, b = training_data(*args, engine="numpy"), training_data(*args, engine="compiled")
        assert np.array_equal(a.points, b.points) and np.array_equal(a.labels, b.labels)


def test_far_points_and_free_resolution_give_the_same_errors():
    far = Scan(np.array([[1e6, 0.0, 0.0], [0.0, 0.0, 0.0]]), np.array([1, 1]), np.zeros(3))
    msgs = []
    for engine in ("numpy", "compiled"):
        with pytest.raises(InputError) as e:
            training_data(far, 0.1, 0.5, -1, 2, engine=engine)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1] and "farther than" in msgs[0]
    near = Scan(np.array([[1.0, 0.0, 0.0]]), np.array([1]), np.zeros(3))
    for engine in ("numpy", "compiled"):
        with pytest.raises(InputError, match="free_resolution must be positive"):
            training_data(near, 0.1, 0.0, -1, 2, engine=engine)
    with pytest.raises(InputError, match="unknown engine"):
        training_data(near, 0.1, 0.5, -1, 2, engine="fortran")
    with pytest.raises(InputError, match="unknown engine"):
        VoxelMap(0.1, 2, engine="fortran")


@pytest.mark.parametrize("method", ["sbki", "scsm"])
@pytest.mark.parametrize("res, ell, K", [(0.3, 0.3, 20), (0.1, 0.3, 4), (0.2, 0.5, 3),
                                         (0.25, 0.1, 2), (0.15, 0.3, 7)])
def test_update_equals_numpy_scan_after_scan(method, res, ell, K):
    rng = np.random.default_rng(int(res * 1000 + K))
    a = VoxelMap(res, K, method, 10.0, ell, engine="numpy")
    b = VoxelMap(res, K, method, 10.0, ell, engine="compiled")
    for n in (3000, 1, 2500, 4000):                   # incrementally, one lone point among them
        pts = rng.normal(0, 1.5, (n, 3))
        pts[: n // 3] = np.round(pts[: n // 3] / res) * res   # on voxel faces
        lab = rng.integers(0, K, n)
        a.update(pts, lab)
        b.update(pts, lab)
        _same_map(a, b)
    va, vb = a.view(), b.view()
    for x, y in ((va.probs, vb.probs), (va.variance, vb.variance), (va.state, vb.state)):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("method", ["sbki", "scsm"])
def test_update_equals_the_loop_transcription(method):
    K, res = 3, 0.1
    vmap = VoxelMap(res, K, method, 10.0, 0.3, engine="compiled")
    ev, cnt = {}, {}
    rng = np.random.default_rng(11)
    for n in (200, 150):
        pts, lab = rng.uniform(-1, 1, (n, 3)), rng.integers(0, K, n)
        vmap.update(pts, lab)
        literal_update(ev, cnt, pts, lab, res, K, method, 10.0, 0.3)
    vox, e, count = vmap.evidence()
    got = {tuple(v): (row, c) for v, row, c in zip(vox.tolist(), e, count)}
    assert set(got) == set(ev)
    assert max(np.abs(got[k][0] - np.array(ev[k])).max() for k in ev) < 1e-9
    assert all(got[k][1] == cnt[k] for k in ev)


def test_update_of_a_scan_split_for_its_box_equals_numpy():
    # two clusters 400 m apart in x and y: the scan's box of voxels exceeds _MAX_BOX, so the
    # update splits the points (in x order) and inserts the halves one after the other
    rng = np.random.default_rng(2)
    pts = np.vstack([rng.normal(0, 0.3, (500, 3)), rng.normal(400, 0.3, (500, 3))])
    lab = rng.integers(0, 3, len(pts))
    a = VoxelMap(0.1, 3, "sbki", engine="numpy")
    b = VoxelMap(0.1, 3, "sbki", engine="compiled")
    a.update(pts, lab)
    b.update(pts, lab)
    _same_map(a, b)
    assert b.n_scans == 1


def test_kitti_scans_give_the_same_map_on_both_engines():
    """Three scans of SemanticKITTI sequence 04 (0.3 m voxels, 20 classes): training points and
    maps of both methods identical."""
    cfg = load_config("semantickitti")
    loaders = list(scan_source("semantickitti", None, cfg))[:3]
    for method in ("sbki", "scsm"):
        maps = {e: VoxelMap(cfg.resolution, cfg.num_class, method, cfg.sf2, cfg.ell, cfg.prior,
                            cfg.var_thresh, engine=e) for e in ("numpy", "compiled")}
        for load in loaders:
            s = validate_scan(load(), cfg.num_class)
            tds = {e: training_data(s, cfg.ds_resolution, cfg.free_resolution, cfg.max_range,
                                    cfg.num_class, engine=e) for e in maps}
            assert np.array_equal(tds["numpy"].points, tds["compiled"].points)
            assert np.array_equal(tds["numpy"].labels, tds["compiled"].labels)
            for e, m in maps.items():
                m.update(tds[e].points, tds[e].labels)
            _same_map(maps["numpy"], maps["compiled"])


def test_stable_order_is_a_stable_argsort():
    rng = np.random.default_rng(0)
    keys = rng.integers(0, 50, 10000)
    order, sk = compiled.stable_order(keys, 49)
    assert np.array_equal(order, np.argsort(keys, kind="stable")) and np.array_equal(sk, keys[order])
    big = rng.integers(0, 1 << 60, 1000)               # too wide to pack with the index
    order, sk = compiled.stable_order(big, (1 << 60) - 1)
    assert np.array_equal(order, np.argsort(big, kind="stable"))


def test_cli_engines_write_the_same_files(tmp_path, capsys):
    from hw4.bki.cli import AUTO_NUMPY_SCANS, choose_engine, main
    assert choose_engine("auto", AUTO_NUMPY_SCANS) == "numpy"
    assert choose_engine("auto", AUTO_NUMPY_SCANS + 1) == "compiled"
    assert choose_engine("numpy", 1000) == "numpy"
    outs = {}
    for engine in ("numpy", "compiled"):
        out = tmp_path / engine
        assert main(["--dataset", "toy", "--scans", "3", "--no-figures", "--engine", engine,
                     "--out", str(out)]) == 0
        outs[engine] = out
    assert capsys.readouterr().out.count("3 scans:") == 2
    for name in ("voxels.csv", "voxels.ply"):
        assert (outs["numpy"] / name).read_bytes() == (outs["compiled"] / name).read_bytes()


@pytest.mark.parametrize("method, res, K", [("sbki", 0.1, 4), ("sbki", 0.3, 20), ("scsm", 0.1, 3)])
def test_the_map_is_the_same_on_any_number_of_threads(method, res, K):
    rng = np.random.default_rng(7)
    scans = [(rng.normal(0, 3, (4000, 3)), rng.integers(0, K, 4000)) for _ in range(3)]
    maps = []
    for threads in (1, 2, 3, 5):
        m = VoxelMap(res, K, method, threads=threads)
        for pts, lab in scans:
            m.update(pts, lab)
        maps.append(m)
    for m in maps[1:]:
        _same_map(maps[0], m)
        assert np.array_equal(m.ev[:m.n_voxels], maps[0].ev[:maps[0].n_voxels])  # pool too
        assert np.array_equal(m.table[:m.n_blocks], maps[0].table[:maps[0].n_blocks])
    parts = compiled.scan_evidence(scans[0][0], scans[0][1], *_box(scans[0][0], res), 1, res, 0.3,
                                   10.0, method == "scsm", n_threads=3)
    assert len(parts) == 3                             # the work was indeed split


def _box(pts, res):
    base, bmin, bmax = compiled.bases(np.ascontiguousarray(pts), res)
    return base, bmin - 1, bmax + 1 - (bmin - 1) + 1


def test_the_compiling_notice_only_on_a_terminal_and_only_when_not_cached(monkeypatch, capsys):
    import io
    import os

    class Tty(io.StringIO):
        def isatty(self):
            return True

    compiled.downsample(np.zeros((2, 3)), None, 0.1)             # every kernel is cached by now
    compiled.scan_evidence(np.zeros((1, 3)), np.zeros(1, np.int64), *_box(np.zeros((1, 3)), 0.1),
                           1, 0.1, 0.3, 10.0, False)
    for stale, want in ((False, ""), (True, "hw4: compiling the 3D mapping kernels")):
        err = Tty()
        monkeypatch.setattr("sys.stderr", err)
        monkeypatch.setattr(compiled, "_announced", False)
        if stale:   # the source newer than numba's cache index, as after an install or a change
            later = os.path.getmtime(compiled.__file__) + 3600
            monkeypatch.setattr(os.path, "getmtime",
                                lambda p, real=os.path.getmtime: later if p == compiled.__file__ else real(p))
        compiled.bases(np.zeros((1, 3)), 0.1)
        assert err.getvalue().startswith(want) and (want or err.getvalue() == "")
    monkeypatch.setattr(compiled, "_announced", False)
    monkeypatch.setattr("sys.stderr", io.StringIO())             # not a terminal: silent
    compiled.bases(np.zeros((1, 3)), 0.1)
    assert compiled._announced


@pytest.mark.parametrize("K, threads", [(4, 1), (20, 1), (4, 2)])
def test_the_sparse_path_for_a_reach_of_3_equals_numpy(K, threads):
    """A reach of 3 voxels (343 offsets, a window of 6 per axis) through the sparse path, called
    on its own: the same map as numpy."""
    rng = np.random.default_rng(K)
    a = VoxelMap(0.1, K, "sbki", engine="numpy")
    b = VoxelMap(0.1, K, "sbki", threads=threads)
    for n in (2000, 1500):
        pts = rng.normal(0, 0.6, (n, 3))
        lab = rng.integers(0, K, n)
        a.update(pts, lab)
        base, bmin, bmax = compiled.bases(pts, 0.1)
        R = 3
        b._update_compiled(pts, lab, base, bmin - R, bmax + R - (bmin - R) + 1, R)
    va, vb = a.evidence(), b.evidence()
    assert len(va[0]) == len(vb[0]) > 0
    assert all(np.array_equal(x, y) for x, y in zip(va, vb))
