"""The reference package's behaviours as options: each one's effect on a tiny hand-made case."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.bki import BKIConfig, VoxelMap
from hw4.bki import reference as ref
from hw4.bki import semantic_eval as se
from hw4.bki.kitti import SemanticKITTISequence
from hw4.bki.training import training_data
from hw4.core.errors import InputError


def rigid(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    T = np.eye(4)
    T[:3, :3] = q * np.sign(np.linalg.det(q))
    T[:3, 3] = rng.normal(size=3)
    return T


def test_world_frames_differ_by_one_fixed_transform():
    rng = np.random.default_rng(0)
    Tr = rigid(rng)
    P = np.stack([rigid(rng) for _ in range(3)])
    ours = ref.world_poses(P, Tr)
    theirs = ref.world_poses(P, Tr, "reference")
    assert np.allclose(ours, np.linalg.inv(Tr) @ P @ Tr)
    assert np.allclose(theirs, ref.frame_change(Tr) @ ours)
    # camera axes (x right, y down, z forward) -> (x, z, 1 - y): a point 2 m ahead, 1 m below
    p = ref.world_poses(np.eye(4)[None], np.eye(4), "reference")[0] @ [0.0, 1.0, 2.0, 1.0]
    assert np.allclose(p[:3], [0.0, 2.0, 0.0])
    with pytest.raises(InputError):
        ref.world_poses(P, Tr, "map")


def test_reference_origin_is_the_camera_translation():
    P = np.tile(np.eye(4), (2, 1, 1))
    P[1, :3, 3] = [0.1, -0.02, 1.3]       # 1.3 m forward in the camera frame
    Tr = np.eye(4)
    Tr[:3, 3] = [0.0, -0.08, -0.27]
    o_ref = ref.sensor_origins(P, Tr, "reference", "reference")
    assert np.allclose(o_ref[1], [0.1, -0.02, 1.3])    # taken as map coordinates: z = 1.3 m "up"
    o_true = ref.sensor_origins(P, Tr, "reference", "true")
    assert np.allclose(o_true[1], (ref.INIT_TRANS_TO_GROUND @ P[1] @ Tr)[:3, 3])
    assert o_true[1][2] == pytest.approx(1 + 0.08 + 0.02)  # 1 m up the ground transform, y down
    with pytest.raises(InputError):
        ref.sensor_origins(P, Tr, "velodyne", "reference")


def write_sequence(folder, pts, raw, poses, Tr):
    (folder / "velodyne").mkdir(parents=True)
    (folder / "labels").mkdir()
    for t, (p, r) in enumerate(zip(pts, raw)):
        np.column_stack([p, np.zeros(len(p))]).astype("<f4").tofile(folder / "velodyne" / f"{t:06d}.bin")
        np.asarray(r, "<u4").tofile(folder / "labels" / f"{t:06d}.label")
    (folder / "poses.txt").write_text("".join(" ".join(f"{v:.9f}" for v in P[:3].ravel()) + "\n"
                                              for P in poses))
    (folder / "calib.txt").write_text("Tr: " + " ".join(f"{v:.9f}" for v in Tr[:3].ravel()) + "\n")


@pytest.fixture
def tiny(tmp_path):
    """One scan: three road hits (raw 40) and two unlabeled hits (raw 0) in one 1 m voxel."""
    pts = [np.array([[5.1, 0.1, 0.1], [5.2, 0.2, 0.2], [5.3, 0.3, 0.3], [5.4, 0.4, 0.4], [5.5, 0.5, 0.5]])]
    raw = [np.array([40, 40, 0, 0, 0])]
    P = np.eye(4)
    P[:3, 3] = [0.0, 0.0, 1.3]
    write_sequence(tmp_path / "04", pts, raw, [P], np.eye(4))
    return tmp_path / "04"


CFG = BKIConfig(resolution=1.0, num_class=20, free_resolution=1000.0, ds_resolution=0.01, max_range=-1.0)


def test_reader_options(tiny):
    drop = SemanticKITTISequence(tiny).scan(0)
    keep = SemanticKITTISequence(tiny, unlabeled="insert").scan(0)
    assert len(drop.points) == 2 and keep.labels.tolist() == [9, 9, 0, 0, 0]
    theirs = SemanticKITTISequence(tiny, frame="reference", origin="reference").scan(0)
    assert np.allclose(theirs.origin, [0, 0, 1.3])
    assert np.allclose(theirs.points[0], [5.1, 1.3 + 0.1, 1 - 0.1])   # (x, z, 1 - y)
    relab = SemanticKITTISequence(tiny, relabel=lambda t, xyz, raw: np.where(raw == 40, 11, 0)).scan(0)
    assert relab.labels.tolist() == [11, 11]
    with pytest.raises(InputError):
        SemanticKITTISequence(tiny, unlabeled="keep")


def test_unlabeled_hits_turn_the_voxel_free(tiny):
    views = {}
    for opt in ("drop", "insert"):
        seq = SemanticKITTISequence(tiny, unlabeled=opt)
        r = se.run(seq, SemanticKITTISequence(tiny), lambda: VoxelMap(1.0, 20, "scsm"), CFG,
                   keep_views=(0,))
        views[opt] = (r.views[0], r.score)
    v, s = views["drop"]
    assert s.iou[9] == 1.0
    v, s = views["insert"]
    assert s.iou[9] == 0.0           # 3 free hits beat 2 road hits in the voxel
    hit = v.count == 5
    assert v.cls[hit].tolist() == [0]


def test_origin_moves_the_free_sample(tiny):
    # the camera drove 1.3 m forward: the reference's origin is 1.3 m up, the true one 1.3 m ahead
    for origin, o in (("reference", [0, 0, 1.3]), ("true", [0, 1.3, 1.0])):
        scan = SemanticKITTISequence(tiny, frame="reference", origin=origin).scan(0)
        td = training_data(scan, 0.01, 1000.0, -1.0, 20)
        assert td.n_free == 1 and np.allclose(td.points[-1], o)


def test_shifted_grid_puts_centres_on_multiples_of_the_resolution():
    g = ref.ShiftedGrid.reference_csm(0.5, 3)
    ours = VoxelMap(0.5, 3, "scsm")
    p = np.array([[0.3, 0.3, 0.3], [0.2, 0.2, 0.2]])
    g.update(p, np.array([1, 2]))
    ours.update(p, np.array([1, 2]))
    c = g.view().centres
    assert np.allclose(c[np.argsort(c[:, 0])], [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])
    assert len(ours.view()) == 1 and np.allclose(ours.view().centres, 0.25)
    look = se.Lookup(g.view(), g.offset)
    assert look(np.array([[0.26, 0.26, 0.26], [0.24, 0.24, 0.24]])).tolist() == [1, 2]


def test_missed_pairs_are_those_of_edge_and_corner_blocks():
    r, ell = 0.3, 0.3
    # blocks of 4 voxels centred on multiples of 1.2 m: faces at +-0.6 m
    corner = np.array([[0.62, 0.62, 0.0]])
    vox, cls, w, total = ref.missed_pairs(corner, np.array([5]), r, ell, 10.0)
    assert [1, 1, 0] in vox.tolist() and [1, 2, 0] not in vox.tolist()
    assert np.all(cls == 5) and np.all(w > 0) and w.sum() < total
    middle = np.array([[0.15, 0.15, 0.15]])
    assert len(ref.missed_pairs(middle, np.array([5]), r, ell, 10.0)[0]) == 0
    full = VoxelMap(r, 6, "sbki", ell=ell)
    emu = ref.FaceNeighbourMap(VoxelMap(r, 6, "sbki", ell=ell))
    full.update(corner, np.array([5]))
    emu.update(corner, np.array([5]))
    fv, ev = full.view(), emu.view()
    at = np.all(np.isclose(fv.centres, [0.45, 0.45, 0.15]), axis=1)
    assert fv.cls[at].tolist() == [5] and ev.cls[at].tolist() == [0]
    assert np.allclose(ev.alpha[at], full.prior)
    assert emu.n_missed == len(vox) and emu.missed_weight == pytest.approx(w.sum())


def test_points_on_block_faces():
    p = np.array([[0.6, 0.1, 0.1], [0.61, 0.1, 0.1], [0.1, -0.6, 0.1]], np.float32)
    assert ref.on_block_faces(p, 0.3) == 2
