"""Property-based tests of the SemanticKITTI reader: a generated sequence folder lands in the world
frame exactly; a mutated one (bins, labels, poses, calib, file names) is read into finite,
labelled scans or refused in one line."""
from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from test_fuzz_settings import examples, refused_or

from hw4.bki.kitti import LEARNING_MAP, SemanticKITTISequence
from hw4.bki.scan import validate_scan

RAW_IDS = sorted(LEARNING_MAP)
NASTY = ["nan", "inf", "1e308", "-1e308", "0", "1", "x", "", "1e-320", "\u00b2", "Tr:", ":"]
_ROOT = Path(tempfile.mkdtemp(prefix="fuzz-kitti-"))
atexit.register(shutil.rmtree, _ROOT, True)
_count = [0]


def rot(yaw, pitch):
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    return np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array(
        [[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])


@st.composite
def sequences(draw):
    """(seed, n_scans, Tr (4, 4), camera poses (T, 4, 4))."""
    n = draw(st.integers(1, 3))
    Tr = np.eye(4)
    Tr[:3, :3] = rot(draw(st.floats(-3, 3)), draw(st.floats(-1, 1)))
    Tr[:3, 3] = draw(st.lists(st.floats(-2, 2), min_size=3, max_size=3))
    P = np.tile(np.eye(4), (n, 1, 1))
    for t in range(n):
        P[t, :3, :3] = rot(draw(st.floats(-3, 3)), 0.0)
        P[t, :3, 3] = [draw(st.floats(-100, 100)) for _ in range(3)]
    return draw(st.integers(0, 2**31)), n, Tr, P


def write(seq, name="04"):
    seed, n, Tr, P = seq
    rng = np.random.default_rng(seed)
    _count[0] += 1
    folder = _ROOT / str(_count[0]) / name
    (folder / "velodyne").mkdir(parents=True)
    (folder / "labels").mkdir()
    truth = []
    for t in range(n):
        pts = rng.uniform(-20, 20, (25, 4)).astype("<f4")
        raw = rng.choice(RAW_IDS, 25).astype("<u4") | (rng.integers(0, 5, 25).astype("<u4") << 16)
        (folder / "velodyne" / f"{t:06d}.bin").write_bytes(pts.tobytes())
        (folder / "labels" / f"{t:06d}.label").write_bytes(raw.tobytes())
        truth.append((pts, raw))
    (folder / "poses.txt").write_text("".join(" ".join(repr(float(v)) for v in p[:3].reshape(-1)) + "\n"
                                              for p in P))
    (folder / "calib.txt").write_text("P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: "
                                      + " ".join(repr(float(v)) for v in Tr[:3].reshape(-1)) + "\n")
    return folder, truth


def read_all(folder):
    seq = SemanticKITTISequence(folder)
    return [validate_scan(seq.scan(t), 20) for t in range(len(seq))]


@settings(max_examples=examples(100))
@given(sequences())
def test_generated_sequence_lands_in_the_world_frame(seq):
    _, n, Tr, P = seq
    folder, truth = write(seq)
    scans = read_all(folder)
    assert len(scans) == n
    lut = np.full(1 << 16, 0)
    for k, v in LEARNING_MAP.items():
        lut[k] = v
    for t, (scan, (pts, raw)) in enumerate(zip(scans, truth)):
        W = np.linalg.solve(Tr, P[t] @ Tr)  # independent: inv(Tr) P_t Tr
        cls = lut[raw & 0xFFFF]
        keep = cls > 0
        want = pts[keep, :3].astype(float) @ W[:3, :3].T + W[:3, 3]
        np.testing.assert_allclose(scan.points, want, rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(scan.labels, cls[keep])
        np.testing.assert_allclose(scan.origin, W[:3, 3], atol=1e-9)


def _mutate_text(draw, text: str) -> bytes:
    lines = text.splitlines()
    op = draw(st.sampled_from(["token", "drop", "dup", "swap", "utf8", "colon", "scale", "extra"]))
    if op == "token" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        words = lines[i].split(" ")
        words[draw(st.integers(0, len(words) - 1))] = draw(st.sampled_from(NASTY))
        lines[i] = " ".join(words)
    elif op == "drop" and lines:
        del lines[draw(st.integers(0, len(lines) - 1))]
    elif op == "dup" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        lines.insert(i, lines[i].replace("1", "2") if draw(st.booleans()) else lines[i])
    elif op == "swap" and len(lines) > 1:
        lines.reverse()
    elif op == "utf8":
        return b"\xff" + text.encode()
    elif op == "colon":
        return text.replace("Tr:", draw(st.sampled_from(["Tr", "Tr :", "tr:", "Tr::"]))).encode()
    elif op == "scale" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        lines[i] = " ".join(repr(float(w) * 1.5) if w.replace(".", "").replace("-", "").replace(
            "e", "").isdigit() else w for w in lines[i].split(" "))
    elif op == "extra":
        lines.append(draw(st.sampled_from(["", "Tr:", "Tr: 1 0 0", "# comment", "1 2 3"])))
    return ("\n".join(lines) + "\n").encode()


@st.composite
def mutations(draw):
    seq = draw(sequences())
    ops = draw(st.lists(st.sampled_from(["bin_cut", "bin_add", "bin_nan", "label_cut", "label_raw",
                                         "label_missing", "poses", "calib", "calib_missing",
                                         "rename_digit", "bin_folder", "velodyne_file",
                                         "labels_file", "huge_pose"]), min_size=1, max_size=3))
    return seq, ops, draw(st.data())


@settings(max_examples=examples(200))
@given(mutations())
def test_mutated_sequence_is_read_finite_or_refused(case):
    seq, ops, data = case
    folder, _ = write(seq)
    bins = sorted((folder / "velodyne").glob("*.bin"))
    draw = data.draw
    for op in ops:
        bins = sorted(p for p in (folder / "velodyne").glob("*.bin") if p.is_file()) \
            if (folder / "velodyne").is_dir() else []
        b = bins[draw(st.integers(0, len(bins) - 1))] if bins else None
        lab = folder / "labels" / (b.stem + ".label") if b else None
        if op == "bin_cut" and b:
            b.write_bytes(b.read_bytes()[:-draw(st.integers(1, 20))])
        elif op == "bin_add" and b:
            b.write_bytes(b.read_bytes() + draw(st.binary(min_size=1, max_size=32)))
        elif op == "bin_nan" and b and b.stat().st_size % 4 == 0 and b.stat().st_size:
            a = np.frombuffer(b.read_bytes(), "<f4").copy()
            a[draw(st.integers(0, len(a) - 1))] = draw(st.sampled_from([np.nan, np.inf, 3e38]))
            b.write_bytes(a.tobytes())
        elif op == "label_cut" and lab and lab.exists():
            lab.write_bytes(lab.read_bytes()[:-4])
        elif op == "label_raw" and lab and lab.exists():
            a = np.frombuffer(lab.read_bytes(), "<u4").copy()
            a[draw(st.integers(0, len(a) - 1))] = draw(st.integers(0, 2**32 - 1))
            lab.write_bytes(a.tobytes())
        elif op == "label_missing" and lab and lab.exists():
            lab.unlink()
        elif op == "poses" and (folder / "poses.txt").is_file():
            (folder / "poses.txt").write_bytes(_mutate_text(draw, (folder / "poses.txt").read_text(
                errors="replace")))
        elif op == "calib" and (folder / "calib.txt").is_file():
            (folder / "calib.txt").write_bytes(_mutate_text(draw, (folder / "calib.txt").read_text(
                errors="replace")))
        elif op == "calib_missing":
            (folder / "calib.txt").unlink(missing_ok=True)
        elif op == "rename_digit" and b:
            new = draw(st.sampled_from(["\u00b2", "\u0664", "99999999999999999999", "a", "-1"]))
            b.rename(b.with_name(new + ".bin"))
            if lab and lab.exists():
                lab.rename(lab.with_name(new + ".label"))
        elif op == "bin_folder" and (folder / "velodyne").is_dir():
            (folder / "velodyne" / "zzz.bin").mkdir(exist_ok=True)
        elif op == "velodyne_file":
            shutil.rmtree(folder / "velodyne", ignore_errors=True)
            (folder / "velodyne").write_bytes(b"")
        elif op == "labels_file":
            shutil.rmtree(folder / "labels", ignore_errors=True)
            (folder / "labels").write_bytes(b"")
        elif op == "huge_pose" and (folder / "poses.txt").is_file():
            text = (folder / "poses.txt").read_text(errors="replace").split(" ")
            text[3] = "1e300"
            (folder / "poses.txt").write_text(" ".join(text))
    scans = refused_or(lambda: read_all(folder))
    if scans is not None:
        for s in scans:
            assert s.points.ndim == 2 and s.points.shape[1] == 3 and len(s.points) > 0
            assert np.all(np.isfinite(s.points)) and np.all(np.isfinite(s.origin))
            assert s.labels.min() >= 1 and s.labels.max() <= 19
