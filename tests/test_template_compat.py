"""The four files are drop-in replacements for the course template's classes.

The course's ``run.py`` constructs each class with no arguments, calls
``construct_map(robotPose, laserScan)`` with the structures ``scipy.io.loadmat`` returns, then
``build_ogm()``, and its ``utils.py`` reads ``map['occMap'].data``, ``map['size']``,
``map['mean'][i]``, ``map['variance'].reshape(len(x), len(y))``, ``grid_size``, ``range_x``,
``range_y`` and ``num_classes`` (a cell whose mean equals cell 0's is drawn as unknown, index
``num_classes`` as free). These tests make exactly those accesses.
"""
import importlib

import numpy as np
import pytest
from scipy.io import loadmat

from hw4.core.data import INTEL, INTEL_SEMANTIC, ensure

FACES = [("ogm_CSM", "ogm_CSM", False), ("ogm_continuous_CSM", "ogm_continuous_CSM", False),
         ("ogm_S_CSM", "ogm_S_CSM", True), ("ogm_continous_S_CSM", "ogm_continous_S_CSM", True),
         ("ogm_continuous_S_CSM", "ogm_continuous_S_CSM", True)]


@pytest.fixture(scope="module")
def raw():
    return {False: loadmat(ensure(INTEL)), True: loadmat(ensure(INTEL_SEMANTIC))}


@pytest.mark.parametrize("module,cls,semantic", FACES, ids=[f[0] for f in FACES])
def test_template_workflow(raw, module, cls, semantic):
    Map = getattr(importlib.import_module(f"hw4.{module}"), cls)
    ogm = Map()
    assert ogm.grid_size == 0.135 and ogm.range_x == [-15, 20] and ogm.range_y == [-25, 10]
    assert ogm.z_max == 30 and ogm.n_beams == 133 and ogm.nn == 16
    ogm = Map(grid_size=0.5)
    ogm.construct_map(raw[semantic]["robotPose"], raw[semantic]["laserScan"])
    ogm.build_ogm()
    m = ogm.map
    x = np.arange(ogm.range_x[0], ogm.range_x[1] + ogm.grid_size, ogm.grid_size)
    y = np.arange(ogm.range_y[0], ogm.range_y[1] + ogm.grid_size, ogm.grid_size)
    assert m["size"] == len(x) * len(y) == m["occMap"].data.shape[0]
    X, Y = np.meshgrid(x, y)
    np.testing.assert_array_equal(m["occMap"].data, np.column_stack([X.ravel(), Y.ravel()]))
    m["variance"].reshape((len(x), len(y)))  # utils.plot_variance
    assert m["variance"].shape == (m["size"], 1)
    if semantic:
        assert ogm.num_classes == 6
        assert m["mean"].shape == (m["size"], 7) and m["alpha"].shape == (m["size"], 7)
        np.testing.assert_allclose(m["mean"].sum(axis=1), 1.0)
        # utils.plot_semantic: cell 0 (a map corner) is unobserved, so "equal to cell 0" = unknown
        unknown = np.array([np.array_equal(m["mean"][i], m["mean"][0]) for i in range(m["size"])])
        np.testing.assert_array_equal(unknown, ~ogm.observed)
        cls_idx = np.argmax(m["mean"], axis=1)
        assert (cls_idx[ogm.observed] == ogm.num_classes).any()  # free space drawn white
        assert (cls_idx[ogm.observed] < ogm.num_classes).any()
    else:
        assert m["mean"].shape == m["alpha"].shape == m["beta"].shape == (m["size"], 1)
        color = (1 - m["mean"][0]) * np.array([1, 1, 1])  # utils.plot_mean
        assert color.shape == (3,)
        np.testing.assert_allclose(m["mean"], m["alpha"] / (m["alpha"] + m["beta"]))


def test_misspelt_name_is_the_same_class():
    from hw4.ogm_continous_S_CSM import ogm_continous_S_CSM
    from hw4.ogm_continuous_S_CSM import ogm_continuous_S_CSM
    assert ogm_continous_S_CSM is ogm_continuous_S_CSM


def test_posterior_formulas_on_the_map(raw):
    from hw4.ogm_S_CSM import ogm_S_CSM
    ogm = ogm_S_CSM(grid_size=0.5)
    ogm.construct_map(raw[True]["robotPose"], raw[True]["laserScan"])
    ogm.build_ogm()
    a = ogm.map["alpha"]
    i = int(np.argmax(a.sum(axis=1)))  # the cell with the most evidence
    p = a[i].max() / a[i].sum()
    assert ogm.map["variance"][i, 0] == pytest.approx(p * (1 - p) / (a[i].sum() + 1), rel=1e-12)
    np.testing.assert_allclose(a - ogm.prior_alpha, ogm.counts)
