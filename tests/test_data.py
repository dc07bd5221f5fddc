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


# --------------------------------------------------------------------- the data cache checks itself

@pytest.fixture
def data_dir(tmp_path, monkeypatch):
    """A data folder of its own (the verified .mat files linked in, an empty cache), so that the
    cache of the checkout, which other processes read, is never touched."""
    d = tmp_path / "data"
    (d / "intel").mkdir(parents=True)
    for name in (data.INTEL, data.INTEL_SEMANTIC):
        (d / name).symlink_to(data.ensure(name).resolve())
    monkeypatch.setattr(data, "DATA_DIR", d)
    return d


def loadmat_arrays(semantic: bool):
    """(poses, scans) straight from the .mat file (scipy.io.loadmat, no cache)."""
    name = data.INTEL_SEMANTIC if semantic else data.INTEL
    raw = data._loadmat(data.ensure(name))
    return data.poses_from_struct(raw["robotPose"]), data.scans_from_cell(raw["laserScan"])


def assert_same_arrays(got, poses, scans):
    assert got.poses.dtype == poses.dtype and got.poses.strides == poses.strides
    np.testing.assert_array_equal(got.poses, poses)
    assert len(got.scans) == len(scans)
    for a, b in zip(got.scans, scans):
        assert a.dtype == b.dtype and a.shape == b.shape and a.strides == b.strides
        np.testing.assert_array_equal(a, b)


def cache_of(name=NAME):
    return data._cache_file(name, data.manifest()[name][0])


def test_cache_is_written_with_its_checksum(data_dir):
    cache = cache_of()
    assert not cache.exists()
    data.load_intel()
    source = data.manifest()[NAME][0]
    with np.load(cache) as z:
        assert set(z.files) == {"poses", "scans", "counts", "source", "digest"}
        assert str(z["source"]) == source
        assert str(z["digest"]) == data._cache_digest(source, z["poses"], z["scans"], z["counts"])
    assert data._read_cache(cache, source) is not None
    assert data._read_cache(cache, "0" * 64) is None  # made from another file
    assert not list(cache.parent.glob("*.tmp"))  # no temporary file left behind


def _flip(raw: bytes, at: int) -> bytes:
    b = bytearray(raw)
    b[at] ^= 0x5A
    return bytes(b)


DAMAGE = {
    "empty": lambda raw: b"",
    "one byte": lambda raw: raw[:1],
    "cut in its header": lambda raw: raw[:300],
    "cut in half": lambda raw: raw[: len(raw) // 2],
    "last byte cut": lambda raw: raw[:-1],
    "byte flipped in the scans": lambda raw: _flip(raw, len(raw) // 2),
    "byte flipped in the poses": lambda raw: _flip(raw, 2000),
    "garbage": lambda raw: b"PK\x03\x04" + bytes(range(256)) * 40,
}


@pytest.mark.parametrize("semantic", [False, True], ids=["binary", "semantic"])
@pytest.mark.parametrize("damage", list(DAMAGE), ids=list(DAMAGE))
def test_damaged_cache_is_rebuilt_from_the_source(data_dir, capsys, damage, semantic):
    name = data.INTEL_SEMANTIC if semantic else NAME
    data.load_intel(semantic=semantic)
    cache = cache_of(name)
    raw = cache.read_bytes()
    cache.write_bytes(DAMAGE[damage](raw))
    assert data._read_cache(cache, data.manifest()[name][0]) is None
    capsys.readouterr()
    got = data.load_intel(semantic=semantic)  # no exception: the .mat file is read instead
    err = capsys.readouterr().err
    assert "note: the data cache" in err and "rebuilding it" in err and len(err.splitlines()) == 1
    assert_same_arrays(got, *loadmat_arrays(semantic))
    assert cache.read_bytes() == raw  # rebuilt, the same file as before
    assert_same_arrays(data.load_intel(semantic=semantic), *loadmat_arrays(semantic))
    assert capsys.readouterr().err == ""  # and read without a note from then on


def _rewrite(cache, **change):
    """Write ``cache`` again as a valid zip with some of its entries changed."""
    with np.load(cache) as z:
        entries = {k: z[k] for k in z.files}
    entries.update(change)
    with open(cache, "wb") as f:
        np.savez(f, **entries)
    return entries


@pytest.mark.parametrize("change", ["one beam moved", "digest", "source", "layout", "old layout"])
def test_cache_that_unzips_but_does_not_match_is_rebuilt(data_dir, capsys, change):
    """The zip's own CRCs pass here: only the cache's SHA-256, its source and its layout can
    catch these, and the map built from what is loaded is still the right one."""
    from hw4.tasks import build_map
    data.load_intel()
    cache = cache_of()
    with np.load(cache) as z:
        scans, digest = z["scans"].copy(), str(z["digest"])
    if change == "one beam moved":
        scans[0, 1000] += 0.25  # 25 cm: a plausible, wrong end point
        _rewrite(cache, scans=scans)
    elif change == "digest":
        _rewrite(cache, digest=np.array(digest[::-1]))
    elif change == "source":  # a cache made from another file, its digest consistent
        e = _rewrite(cache, source=np.array("1" * 64))
        _rewrite(cache, digest=np.array(data._cache_digest("1" * 64, e["poses"], e["scans"],
                                                            e["counts"])))
    elif change == "layout":
        _rewrite(cache, counts=np.zeros(743, dtype=np.int64))
    else:  # the v1 layout, without source or digest
        with np.load(cache) as z:
            old = {k: z[k] for k in ("poses", "scans", "counts")}
        with open(cache, "wb") as f:
            np.savez(f, **old)
    assert data._read_cache(cache, data.manifest()[NAME][0]) is None
    capsys.readouterr()
    got = data.load_intel()
    assert "rebuilding it" in capsys.readouterr().err
    poses, scans = loadmat_arrays(False)
    assert_same_arrays(got, poses, scans)
    ogm = build_map(1, 0.5, data=got)
    ref = build_map(1, 0.5, data=data.IntelData(poses, scans))
    np.testing.assert_array_equal(ogm.map["alpha"], ref.map["alpha"])
    np.testing.assert_array_equal(ogm.map["beta"], ref.map["beta"])


def test_cache_digest_sees_every_array():
    rng = np.random.default_rng(0)
    poses, flat = rng.normal(size=(4, 3)), rng.normal(size=(2, 10))
    counts = np.array([1, 2, 3, 4], dtype=np.int64)
    d = data._cache_digest("a" * 64, poses, flat, counts)
    assert d == data._cache_digest("a" * 64, poses.copy(order="F"), flat, counts)  # same values
    assert d != data._cache_digest("b" * 64, poses, flat, counts)
    for i, a in enumerate((poses, flat, counts)):
        changed = [poses, flat, counts]
        changed[i] = a.copy()
        changed[i].flat[-1] += 1
        assert d != data._cache_digest("a" * 64, *changed)
    assert d != data._cache_digest("a" * 64, poses.reshape(3, 4), flat, counts)  # same bytes


def test_unwritable_cache_folder_goes_without(data_dir):
    (data_dir / data.CACHE).write_text("a file where the cache folder goes")
    got = data.load_intel()
    assert_same_arrays(got, *loadmat_arrays(False))
    assert (data_dir / data.CACHE).read_text().startswith("a file")
