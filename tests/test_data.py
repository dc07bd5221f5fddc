"""The data step: find, copy or refuse; always verify; never overwrite what the user has."""

import numpy as np
import pytest
from scipy.io import savemat

from hw4.core import data
from hw4.core.errors import InputError

NAME = data.INTEL


def test_manifest_lists_every_shared_file_with_checksum_and_url():
    rows = data.manifest()
    assert NAME in rows and data.INTEL_SEMANTIC in rows
    assert sum(p.startswith("bki_toy/") for p in rows) == 12
    for path, (sha, url) in rows.items():
        assert len(sha) == 64 and int(sha, 16) >= 0
        assert url == "-" or url.startswith("https://")


def test_copy_from_shared_then_verify(tmp_path):
    shared = data.SHARED_DIR
    got = data.ensure(NAME, data_dir=tmp_path, shared_dir=shared, download=False)
    assert got == tmp_path / NAME
    assert data.sha256(got) == data.manifest()[NAME][0]
    # second call finds it in place
    assert data.ensure(NAME, data_dir=tmp_path, shared_dir=tmp_path / "nowhere", download=False) == got


def test_corrupt_local_copy_is_reported_and_kept(tmp_path):
    target = tmp_path / NAME
    target.parent.mkdir(parents=True)
    target.write_bytes(b"not the dataset")
    with pytest.raises(InputError, match="does not match its SHA-256"):
        data.ensure(NAME, data_dir=tmp_path, shared_dir=data.SHARED_DIR, download=False)
    assert target.read_bytes() == b"not the dataset"  # the user's file is untouched


def test_corrupt_shared_copy_is_not_installed(tmp_path):
    shared = tmp_path / "shared"
    (shared / "intel").mkdir(parents=True)
    (shared / NAME).write_bytes(b"tampered")
    dest = tmp_path / "data"
    with pytest.raises(InputError, match="does not match"):
        data.ensure(NAME, data_dir=dest, shared_dir=shared, download=False)
    assert not (dest / NAME).exists()


def test_missing_everywhere_names_the_file(tmp_path):
    with pytest.raises(InputError, match="sample_Intel_dataset.mat is missing"):
        data.ensure(NAME, data_dir=tmp_path / "d", shared_dir=tmp_path / "s", download=False)


def test_unknown_name():
    with pytest.raises(InputError, match="not a dataset file"):
        data.ensure("intel/other.mat")


def test_load_intel_structure():
    d = data.load_intel()
    assert d.poses.shape == (743, 3) and len(d.scans) == 743
    assert all(s.shape[0] == 2 and 128 <= s.shape[1] <= 180 for s in d.scans)
    s = data.load_intel(semantic=True)
    labels = np.concatenate([x[2] for x in s.scans])
    assert set(np.unique(labels)) == {1, 2, 3, 4, 5, 6}
    np.testing.assert_array_equal(s.poses, d.poses)


def test_truncated_mat_gives_one_sentence(tmp_path):
    src = data.ensure(NAME)
    bad = tmp_path / "cut.mat"
    bad.write_bytes(src.read_bytes()[:5000])
    with pytest.raises(InputError, match="corrupt or truncated|not a readable") as e:
        data.load_intel(path=bad)
    assert "\n" not in str(e.value)


def test_garbage_mat(tmp_path):
    bad = tmp_path / "garbage.mat"
    bad.write_bytes(b"\x00" * 300)
    with pytest.raises(InputError):
        data.load_intel(path=bad)


def test_mat_of_wrong_structure(tmp_path):
    p = tmp_path / "other.mat"
    savemat(p, {"something": np.zeros(3)})
    with pytest.raises(InputError, match="no variable 'robotPose'"):
        data.load_intel(path=p)
