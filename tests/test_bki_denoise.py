"""The map as a denoiser: scoring (hand-made cases with exact IoU) and the simulated segmenter."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.bki import BKIConfig, VoxelMap
from hw4.bki import semantic_eval as se
from hw4.bki.noise import CONFUSION, SimulatedSegmenter
from hw4.bki.scan import Scan
from hw4.core.errors import InputError


def test_confusion_and_iou_of_a_hand_made_case():
    gt = np.array([1, 1, 2, 2, 0, 0])
    pred = np.array([1, 2, 2, 2, 1, 3])
    s = se.score(se.confusion(gt, pred, 4))
    # class 1: TP 1, FN 1 -> 1/2; class 2: TP 2, FP 1 -> 2/3; gt 0 ignored; class 3 absent
    assert s.iou[1] == pytest.approx(1 / 2)
    assert s.iou[2] == pytest.approx(2 / 3)
    assert np.isnan(s.iou[0]) and np.isnan(s.iou[3])
    assert s.miou == pytest.approx((1 / 2 + 2 / 3) / 2)
    assert s.n_points == 4 and s.accuracy == pytest.approx(3 / 4)


def test_lookup_free_and_missing_voxels_count_as_class_0():
    m = VoxelMap(0.5, 3, "scsm")
    m.update(np.array([[0.1, 0.1, 0.1], [0.6, 0.1, 0.1], [1.1, 0.1, 0.1]]), np.array([1, 2, 0]))
    look = se.Lookup(m.view())
    q = np.array([[0.2, 0.3, 0.4], [0.9, 0.2, 0.2], [1.2, 0.4, 0.1], [3.0, 0.0, 0.0]])
    assert look(q).tolist() == [1, 2, 0, 0]


class ListSeq:
    """A sequence of ready-made scans."""

    def __init__(self, scans):
        self.scans = scans

    def __len__(self):
        return len(self.scans)

    def scan(self, t):
        return self.scans[t]


CFG = BKIConfig(resolution=1.0, num_class=3, free_resolution=1000.0, ds_resolution=-1.0,
                max_range=-1.0)
ORIGIN = np.array([50.5, 50.5, 50.5])  # the only free sample, far from everything


def _voxel_points(ix, n):
    return np.array([[ix + 0.1 + 0.2 * k, 0.5, 0.5] for k in range(n)])


def test_map_corrects_a_minority_of_wrong_labels_exactly():
    pts = np.vstack([_voxel_points(0, 3), _voxel_points(1, 3), _voxel_points(2, 1)])
    gt = np.array([1, 1, 1, 2, 2, 2, 2])
    noisy = np.array([1, 2, 1, 2, 1, 2, 2])
    truth = ListSeq([Scan(pts[:6], gt[:6], ORIGIN)])
    ins = ListSeq([Scan(pts[:6], noisy[:6], ORIGIN)])
    assert se.score(se.confusion(gt[:6], noisy[:6], 3)).miou == pytest.approx(0.5)
    r = se.run(ins, truth, lambda: VoxelMap(1.0, 3, "scsm"), CFG)
    assert r.score.miou == 1.0 and r.score.n_points == 6
    # a ground-truth point in a voxel the map never saw is wrong: class 2 has TP 3, FN 1
    truth2 = ListSeq([Scan(pts, gt, ORIGIN)])
    r2 = se.run(ins, truth2, lambda: VoxelMap(1.0, 3, "scsm"), CFG)
    assert r2.score.iou[2] == pytest.approx(3 / 4) and r2.score.iou[1] == 1.0


def test_schedules_look_up_the_scans_the_reference_looks_up():
    scans = [Scan(_voxel_points(i, 2), np.array([1, 1]), ORIGIN) for i in range(4)]
    seq = ListSeq(scans)
    every = se.run(seq, seq, lambda: VoxelMap(1.0, 3, "scsm"), CFG, window=1, schedule="every")
    assert every.score.n_points == 2 * (1 + 2 + 2 + 2)   # t=0: q0; t>=1: q=t-1, t
    ref = se.run(seq, seq, lambda: VoxelMap(1.0, 3, "scsm"), CFG, window=1)
    assert ref.score.n_points == 2 * 4                   # every scan once
    assert ref.score.miou == 1.0 and every.score.miou == 1.0
    with pytest.raises(InputError):
        se.run(seq, seq, lambda: VoxelMap(1.0, 3, "scsm"), CFG, schedule="sometimes")


def test_unlabeled_hits_inserted_are_free_evidence():
    pts = _voxel_points(0, 3)
    ins = ListSeq([Scan(pts, np.array([1, 0, 0]), ORIGIN)])
    truth = ListSeq([Scan(pts, np.array([1, 1, 1]), ORIGIN)])
    r = se.run(ins, truth, lambda: VoxelMap(1.0, 3, "scsm"), CFG)
    assert r.score.iou[1] == 0.0   # the voxel is free: 2 free hits beat 1 of class 1


# ---------------------------------------------------------------- the simulated segmenter
def fake_scan(seed=0, n=20000):
    """Points around a sensor with road (40), vegetation (70), building (50), cars (10 with
    instance ids 1..5) and unlabeled (0)."""
    rng = np.random.default_rng(seed)
    az = rng.uniform(-np.pi, np.pi, n)
    el = rng.uniform(np.radians(-24), np.radians(2), n)
    r = rng.uniform(3, 40, n)
    xyz = np.column_stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)])
    kind = rng.integers(0, 5, n)
    sem = np.array([40, 70, 50, 10, 0])[kind]
    inst = np.where(kind == 3, 1 + (np.floor((az + np.pi) / (2 * np.pi) * 5)).astype(int), 0)
    return xyz, (sem | (inst << 16)).astype(np.uint32)


def test_segmenter_is_deterministic_per_seed_and_keeps_unlabeled():
    xyz, raw = fake_scan()
    a = SimulatedSegmenter(rate=0.3, seed=7)(0, xyz, raw)
    b = SimulatedSegmenter(rate=0.3, seed=7)(0, xyz, raw)
    c = SimulatedSegmenter(rate=0.3, seed=8)(0, xyz, raw)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    gt = np.array([0, 1, 9, 13, 15])[np.searchsorted([0, 10, 40, 50, 70], raw & 0xFFFF)]
    assert np.array_equal(a == 0, gt == 0)
    wrong = a != gt
    assert wrong.any()
    for c_gt, c_pred in set(zip(gt[wrong].tolist(), a[wrong].tolist())):
        assert c_pred in CONFUSION[c_gt]


def test_rate_zero_is_the_ground_truth_and_errors_grow_nested_with_rate():
    xyz, raw = fake_scan(1)
    gt = SimulatedSegmenter(rate=0.0)(3, xyz, raw)
    assert np.array_equal(gt, SimulatedSegmenter(rate=0.0, scatter=0.0)(3, xyz, raw))
    from hw4.bki.kitti import learning_labels
    assert np.array_equal(gt, learning_labels(raw))
    prev = np.zeros(len(gt), bool)
    shares = []
    for rate in (0.1, 0.3, 0.6, 1.0):
        wrong = SimulatedSegmenter(rate=rate, seed=2)(3, xyz, raw) != gt
        assert np.all(wrong[prev])           # every error of a smaller rate stays
        shares.append(wrong[gt > 0].mean())
        prev = wrong
    assert np.all(np.diff(shares) > 0)
    assert shares[-1] == 1.0                 # rate 1: every labelled point is wrong
    assert 0.05 < shares[0] < 0.25
    with pytest.raises(InputError):
        SimulatedSegmenter(rate=1.5)


def test_errors_are_coherent_objects_and_patches():
    xyz, raw = fake_scan(2)
    seg = SimulatedSegmenter(rate=0.5, seed=3, scatter=0.0)
    a, b = seg(0, xyz, raw), seg(1, xyz, raw)
    inst = raw >> 16
    for i in range(1, 6):                     # an object is wrong as a whole, in every scan
        k = inst == i
        assert len(np.unique(a[k])) == 1 and np.array_equal(a[k], b[k])
    # stuff errors are drawn per scan: the two scans differ somewhere off the objects
    assert not np.array_equal(a[inst == 0], b[inst == 0])
