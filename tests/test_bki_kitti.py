"""SemanticKITTI layout: a synthetic sequence written in the dataset's format, read, mapped, CLI."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from hw4.bki import build_map, load_config, scan_source
from hw4.bki.cli import register
from hw4.core.data import ensure_all
from hw4.bki.kitti import COLORS, LEARNING_MAP, SemanticKITTISequence, learning_labels, read_bin, read_label
from hw4.core.errors import InputError

# velodyne -> camera of KITTI odometry sequences 04-10 (as published with the dataset)
TR = np.array([[-1.857739385241e-03, -9.999659513510e-01, -8.039975204516e-03, -4.784029760483e-03],
               [-6.481465826011e-03, 8.051860151134e-03, -9.999466081774e-01, -7.337429464231e-02],
               [9.999773098287e-01, -1.805528627661e-03, -6.496203536139e-03, -3.339968064433e-01],
               [0, 0, 0, 1]])


def velodyne_pose(t: int) -> np.ndarray:
    """Ground truth of the synthetic drive: 1.5 m forward and 0.1 rad of yaw per scan."""
    th = 0.1 * t
    T = np.eye(4)
    T[:3, :3] = [[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]]
    T[:3, 3] = [1.5 * t * np.cos(th / 2), 1.5 * t * np.sin(th / 2), 0.0]
    return T


def world_scene(rng, n=3000):
    """Labelled world points [m]: road (raw 40), a building wall (50), a car (10, some moving:
    252 with an instance id), unlabeled clutter (0)."""
    road = np.column_stack([rng.uniform(-5, 15, n), rng.uniform(-4, 4, n), np.full(n, -1.73)])
    wall = np.column_stack([rng.uniform(-5, 15, n // 2), np.full(n // 2, 6.0), rng.uniform(-1.7, 3, n // 2)])
    car = np.column_stack([rng.uniform(4, 8, n // 4), rng.uniform(-3, -1.5, n // 4), rng.uniform(-1.7, -0.3, n // 4)])
    junk = rng.uniform(-5, 15, (50, 3))
    pts = np.vstack([road, wall, car, junk])
    raw = np.concatenate([np.full(n, 40), np.full(n // 2, 50),
                          np.where(np.arange(n // 4) % 2, 10, 252 | (7 << 16)), np.zeros(50, int)])
    return pts, raw.astype(np.uint32)


def write_sequence(folder, n_scans=4, seed=0, pose_hook=None):
    """Write a SemanticKITTI sequence folder: velodyne/*.bin, labels/*.label, poses.txt, calib.txt."""
    rng = np.random.default_rng(seed)
    (folder / "velodyne").mkdir(parents=True)
    (folder / "labels").mkdir()
    truth = []
    lines = []
    for t in range(n_scans):
        V = velodyne_pose(t)
        pts, raw = world_scene(rng)
        local = (pts - V[:3, 3]) @ V[:3, :3]  # world -> velodyne frame of scan t
        rec = np.column_stack([local, rng.uniform(0, 1, len(local))]).astype("<f4")
        (folder / "velodyne" / f"{t:06d}.bin").write_bytes(rec.tobytes())
        (folder / "labels" / f"{t:06d}.label").write_bytes(raw.astype("<u4").tobytes())
        P = TR @ V @ np.linalg.inv(TR)  # camera pose: SemanticKITTI's poses.txt convention
        if pose_hook:
            P = pose_hook(t, P)
        lines.append(" ".join(f"{v:.12e}" for v in P[:3].reshape(-1)))
        truth.append((V, rec[:, :3].astype(float) @ V[:3, :3].T + V[:3, 3], raw))
    (folder / "poses.txt").write_text("\n".join(lines) + "\n")
    tr = " ".join(f"{v:.12e}" for v in TR[:3].reshape(-1))
    (folder / "calib.txt").write_text(f"P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: {tr}\n")
    return truth


def test_learning_map_and_colours():
    raw = np.array([0, 1, 10, 40, 44, 48, 50, 52, 60, 70, 81, 99, 252, 259], np.uint32)
    raw[2] |= 5 << 16  # instance ids live in the high 16 bits
    np.testing.assert_array_equal(learning_labels(raw), [0, 0, 1, 9, 10, 11, 13, 0, 9, 15, 19, 0, 1, 5])
    assert sorted(set(LEARNING_MAP.values())) == list(range(20))
    assert COLORS.shape == (20, 3)
    assert tuple(COLORS[1]) == (100, 150, 245)  # car: yaml BGR (245, 150, 100) as RGB
    assert tuple(COLORS[9]) == (255, 0, 255)    # road
    with pytest.raises(InputError, match="semantic id 7"):
        learning_labels(np.array([7]))


def test_reader_puts_points_in_the_world_frame(tmp_path):
    seq_dir = tmp_path / "sequences" / "04"
    truth = write_sequence(seq_dir)
    seq = SemanticKITTISequence(seq_dir)
    assert len(seq) == 4
    for t, (V, world, raw) in enumerate(truth):
        s = seq.scan(t)
        keep = (raw & 0xFFFF) != 0
        np.testing.assert_allclose(s.origin, V[:3, 3], atol=1e-6)
        np.testing.assert_allclose(s.points, world[keep], atol=1e-5)
        np.testing.assert_array_equal(s.labels, learning_labels(raw[keep]))
        assert set(np.unique(s.labels)) == {1, 9, 13}


def test_real_sample_frame_reads(tmp_path):
    cfg = load_config("semantickitti")
    files = {p.name: p for p in ensure_all("semantickitti_sample/")}
    loaders = scan_source("semantickitti", files["calib.txt"].parent, cfg)
    assert loaders.note == ""  # its calib.txt has the Tr line
    s = loaders[0]()
    xyz = read_bin(files["000000.bin"])[:, :3].astype(float)
    raw = read_label(files["000000.label"])
    assert len(xyz) == 50 and set(np.unique(raw & 0xFFFF)) == {0, 50, 52, 70, 71, 80}
    keep = learning_labels(raw) > 0
    assert len(s.points) == keep.sum()
    assert set(np.unique(s.labels)) <= {13, 15, 16, 18}
    # pose 0 is the identity, so inv(Tr) @ I @ Tr = I: world = velodyne coordinates
    np.testing.assert_allclose(s.points, xyz[keep], atol=1e-9)
    np.testing.assert_allclose(s.origin, 0, atol=1e-12)


def _run_cli(argv):
    parser = argparse.ArgumentParser(prog="hw4")
    register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return args.func(args)


def test_pipeline_and_cli_on_a_synthetic_sequence(tmp_path, capsys):
    seq_dir = tmp_path / "sequences" / "04"
    write_sequence(seq_dir, n_scans=3)
    cfg = load_config("semantickitti")
    vmap, hits, free = build_map(scan_source("semantickitti", seq_dir, cfg), cfg, "sbki")
    view = vmap.view()
    assert hits > 0 and free >= 3  # at least the origin of each scan
    occ = view.occupied
    # the wall (y = 6) is building (13), the road (z = -1.73, |y| < 4) is road (9)
    wall = occ & (np.abs(view.centres[:, 1] - 6.0) < 0.2) & (view.centres[:, 2] > 0)
    road = occ & (view.centres[:, 2] < -1.5) & (np.abs(view.centres[:, 1]) < 1.0)
    assert wall.sum() > 50 and np.mean(view.cls[wall] == 13) > 0.95
    assert road.sum() > 50 and np.mean(view.cls[road] == 9) > 0.95

    out = tmp_path / "out"
    rc = _run_cli(["bki", "--dataset", "semantickitti", str(seq_dir), "--out", str(out), "--scans", "3"])
    assert rc == 0
    text = capsys.readouterr().out
    assert f"{hits:,} training hits" in text and f"{len(view):,} voxels with evidence" in text
    rows = (out / "voxels.csv").read_text().splitlines()
    assert rows[0].split(",")[:6] == ["x", "y", "z", "state", "class", "variance"]
    assert len(rows[0].split(",")) == 6 + 20 and len(rows) == 1 + len(view)
    probs = np.array([r.split(",")[6:] for r in rows[1:]], float)
    np.testing.assert_allclose(probs.sum(axis=1), 1, atol=1e-4)
    ply = (out / "voxels.ply").read_text().splitlines()
    assert ply[0] == "ply" and f"element vertex {int(occ.sum())}" in ply
    assert len(ply) == ply.index("end_header") + 1 + int(occ.sum())
    for name in ("map3d_class.png", "map3d_class_no_var_thresh.png", "topdown_variance.png"):
        assert (out / name).stat().st_size > 1000


def test_cli_toy_video_and_help(tmp_path, capsys):
    out = tmp_path / "toy"
    assert _run_cli(["bki", "--dataset", "toy", "--method", "scsm", "--scans", "2", "--out", str(out),
                     "--video", "--no-figures"]) == 0
    assert "2 scans:" in capsys.readouterr().out
    assert (out / "mapping.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert (out / "mapping.mp4").read_bytes()[4:8] == b"ftyp"
    assert (out / "mapping_poster.jpg").read_bytes()[:2] == b"\xff\xd8"   # JPEG, final name
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]  # no temporary left
    with pytest.raises(SystemExit):
        _run_cli(["bki", "--help"])
    assert "voxels.csv" in capsys.readouterr().out


def test_default_semantickitti_is_sequence_04_with_the_published_tr():
    cfg = load_config("semantickitti")
    loaders = scan_source("semantickitti", None, cfg)
    assert len(loaders) == 10
    assert "published" in loaders.note and "sequence 04" in loaders.note
    s0, s9 = loaders[0](), loaders[9]()
    assert len(s0.points) > 100_000 and s0.labels.min() >= 1 and s0.labels.max() <= 19
    # the car drives forward (+x of the velodyne frame of scan 0) about 11.8 m over the ten scans
    assert 11.0 < s9.origin[0] < 12.6 and abs(s9.origin[1]) < 1.0 and abs(s9.origin[2]) < 1.0
    np.testing.assert_allclose(s0.origin, 0, atol=1e-6)


def _static_match(a, b):
    """Median distance from the points of ``a`` to their nearest neighbour in ``b`` [m]."""
    from scipy.spatial import cKDTree
    return float(np.median(cKDTree(b).query(a[::50])[0]))


def test_published_tr_registers_scans_0_and_9():
    """With the published extrinsic, static structure of scans 0 and 9 coincides; with the
    identity in place of Tr it does not (checks that the fallback is the right matrix)."""
    from hw4.bki.kitti import PUBLISHED_TR, SemanticKITTISequence, read_poses, velodyne_poses
    folder = ensure_all("semantickitti_04/sequences/04/poses.txt")[0].parent
    seq = SemanticKITTISequence(folder)
    Tr = np.eye(4)
    Tr[:3] = np.reshape(PUBLISHED_TR[4], (3, 4))
    np.testing.assert_array_equal(seq.Tr, Tr)
    a, b = seq.scan(0), seq.scan(9)
    static = lambda s: s.points[np.isin(s.labels, (13, 14, 15, 16, 18, 19))]  # building .. sign
    good = _static_match(static(a), static(b))
    assert good < 0.3
    wrong = velodyne_poses(read_poses(folder / "poses.txt"), np.eye(4))
    xyz = read_bin(seq.bins[9])[:, :3].astype(float)
    cls = learning_labels(read_label(seq.label_dir / "000009.label"))
    keep = np.isin(cls, (13, 14, 15, 16, 18, 19))
    moved = xyz[keep] @ wrong[9][:3, :3].T + wrong[9][:3, 3]
    assert _static_match(static(a), moved) > 5 * good


def test_calib_tr_wins_and_calib_option_overrides(tmp_path):
    from hw4.bki.kitti import SemanticKITTISequence
    seq_dir = tmp_path / "sequences" / "04"
    write_sequence(seq_dir, n_scans=2)
    seq = SemanticKITTISequence(seq_dir)
    assert seq.calib_note.startswith("Tr from")  # the file's own Tr, not the published value
    own = seq.Tr.copy()
    other = tmp_path / "other_calib.txt"
    T = np.eye(4)[:3]
    other.write_text("Tr: " + " ".join(f"{v:.12e}" for v in T.ravel()) + "\n")
    seq2 = SemanticKITTISequence(seq_dir, calib=other)
    np.testing.assert_array_equal(seq2.Tr, np.eye(4))
    assert not np.array_equal(own, np.eye(4))


def test_missing_tr_fallback_and_refusal(tmp_path):
    from hw4.bki.kitti import PUBLISHED_TR, SemanticKITTISequence
    for name, ok in (("04", True), ("00", True), ("03", True), ("10", True), ("11", False),
                     ("²", False), ("my_drive", False)):
        seq_dir = tmp_path / name / "sequences" / name
        write_sequence(seq_dir, n_scans=1)
        calib = seq_dir / "calib.txt"
        calib.write_text("P0: " + " ".join(["0"] * 12) + "\n")
        if ok:
            seq = SemanticKITTISequence(seq_dir)
            np.testing.assert_array_equal(seq.Tr[:3].ravel(), PUBLISHED_TR[int(name)])
            assert f"sequence {int(name):02d}" in seq.calib_note
        else:
            with pytest.raises(InputError, match="no 'Tr:' line.*--calib FILE"):
                SemanticKITTISequence(seq_dir)


def test_calib_refusals(tmp_path):
    from hw4.bki.kitti import read_calib
    row = " ".join(f"{v:.6e}" for v in np.eye(4)[:3].ravel())
    p = tmp_path / "calib.txt"
    p.write_text(f"Tr: {row}\nTr: {row}\n")
    np.testing.assert_array_equal(read_calib(p), np.eye(4))  # the same line twice is harmless
    shifted = " ".join(f"{v:.6e}" for v in (np.eye(4)[:3] + [[0, 0, 0, 1], [0] * 4, [0] * 4]).ravel())
    p.write_text(f"Tr: {row}\nTr: {shifted}\n")
    with pytest.raises(InputError, match="2 different 'Tr:' lines"):
        read_calib(p)
    p.write_text(f"Tr {row}\n")
    with pytest.raises(InputError, match="no colon"):
        read_calib(p)
    p.write_bytes(b"Tr: \xff\xfe\n")
    with pytest.raises(InputError, match="not a UTF-8"):
        read_calib(p)


def test_cli_says_how_many_scans_exist(tmp_path, capsys):
    seq_dir = tmp_path / "sequences" / "04"
    write_sequence(seq_dir, n_scans=2)
    rc = _run_cli(["bki", "--dataset", "semantickitti", str(seq_dir), "--out", str(tmp_path / "o"),
                   "--scans", "50", "--no-figures"])
    assert rc == 0
    err = capsys.readouterr().err
    assert "50 scans asked for, 2 exist: mapping all 2" in err
