"""Bad input gets one clear sentence, never a wrong map."""
import numpy as np
import pytest

from hw4.core.errors import InputError
from hw4.core.grid import Grid
from hw4.ogm_CSM import ogm_CSM
from hw4.ogm_S_CSM import ogm_S_CSM
from hw4.ogm_continuous_CSM import ogm_continuous_CSM
from hw4.ogm_continuous_S_CSM import ogm_continuous_S_CSM


def scene(n=3, labels=True):
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [2.0, 1.0, -0.5]])[:n]
    ang = np.linspace(-1.5, 1.5, 30)
    scans = []
    for t in range(n):
        xy = np.vstack([2 * np.cos(ang), 2 * np.sin(ang)])
        scans.append(np.vstack([xy, np.full(30, 1 + t)]) if labels else xy)
    return poses, scans


def build(cls, poses, scans, **kw):
    m = cls(grid_size=kw.pop("grid_size", 0.5), range_x=[-5, 5], range_y=[-5, 5], **kw)
    m.construct_map(poses, scans)
    m.build_ogm()
    return m


@pytest.mark.parametrize("g", [0, -0.1, float("nan"), float("inf"), "0.1"])
def test_bad_grid_size(g):
    with pytest.raises(InputError, match="grid_size"):
        Grid(g)


def test_grid_too_fine_is_refused_with_the_number():
    with pytest.raises(InputError, match=r"cells needing about [\d.]+ GiB"):
        Grid(0.0005)


@pytest.mark.parametrize("where", ["pose", "scan"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_or_inf(where, bad):
    poses, scans = scene(labels=False)
    if where == "pose":
        poses[1, 0] = bad
    else:
        scans[2][1, 4] = bad
    with pytest.raises(InputError, match="NaN or inf"):
        build(ogm_CSM, poses, scans)


def test_empty_scan():
    poses, scans = scene(labels=False)
    scans[1] = np.zeros((2, 0))
    with pytest.raises(InputError, match="scan 1 is empty"):
        build(ogm_continuous_CSM, poses, scans)


def test_pose_scan_count_mismatch():
    poses, scans = scene(labels=False)
    with pytest.raises(InputError, match="3 poses but 2 scans"):
        build(ogm_CSM, poses, scans[:2])


@pytest.mark.parametrize("label", [0, 7, 2.5, -1])
def test_labels_outside_1_to_6(label):
    poses, scans = scene()
    scans[0][2, 3] = label
    with pytest.raises(InputError, match="labels must be integers 1..6"):
        build(ogm_S_CSM, poses, scans)


@pytest.mark.parametrize("cls", [ogm_S_CSM, ogm_continuous_S_CSM])
def test_two_row_scan_to_semantic_model(cls):
    poses, scans = scene(labels=False)
    with pytest.raises(InputError, match="no label row"):
        build(cls, poses, scans)


def test_unknown_keyword():
    with pytest.raises(InputError, match="unknown parameter"):
        ogm_CSM(sigma=0.2)  # a continuous-model parameter given to the discrete one


@pytest.mark.parametrize("kw", [dict(beams="some"), dict(sample_step=0), dict(l=-1),
                                dict(nearest_poses=0), dict(nearest_poses=2.5)])
def test_bad_model_options(kw):
    poses, scans = scene(labels=False)
    with pytest.raises(InputError):
        build(ogm_continuous_CSM, poses, scans, **kw)


def test_build_before_construct():
    with pytest.raises(InputError, match="construct_map"):
        ogm_CSM().build_ogm()


def test_good_scene_builds_and_binary_model_ignores_labels():
    poses, scans = scene()
    a = build(ogm_CSM, poses, scans)
    b = build(ogm_CSM, poses, [s[:2] for s in scans])
    np.testing.assert_array_equal(a.map["alpha"], b.map["alpha"])
    assert a.counts.sum() > 0
