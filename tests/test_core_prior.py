"""construct_map's prior map: the first cell's mean and variance repeated (template._summarise
with prior=True) must be the arrays computed cell by cell, bit for bit, for any class count
(numpy sums 8 and more columns pairwise) and prior."""
from __future__ import annotations

import numpy as np
import pytest

from hw4.ogm_CSM import ogm_CSM
from hw4.ogm_S_CSM import ogm_S_CSM
from hw4.tasks import load_task_data


@pytest.mark.parametrize("prior", [1e-3, 0.7, 3.0, 1e-100, 1e50])
@pytest.mark.parametrize("classes", [None, 1, 6, 7, 8, 9, 15, 20])
def test_prior_summary_is_every_cell_s(prior, classes):
    m = ogm_CSM(prior_alpha=prior) if classes is None else ogm_S_CSM(prior_alpha=prior,
                                                                     num_classes=classes)
    n = 1000
    cols = 1 if classes is None else classes + 1
    m.map["alpha"] = np.full((n, cols), float(prior))
    if classes is None:
        m.map["beta"] = np.full((n, 1), float(prior))
    m._summarise(prior=True)
    fast = m.map["mean"].copy(), m.map["variance"].copy()
    m._summarise()
    np.testing.assert_array_equal(fast[0], m.map["mean"])
    np.testing.assert_array_equal(fast[1], m.map["variance"])
    assert fast[0].shape == (n, cols) if classes is not None else fast[0].shape == (n, 1)


@pytest.mark.parametrize("task", [1, 3])
def test_construct_map_prior_as_before(task):
    from hw4.core.posterior import beta_mean_variance, dirichlet_mean_variance
    data = load_task_data(task)
    m = (ogm_CSM if task == 1 else ogm_S_CSM)(grid_size=0.5)
    m.construct_map(data.poses, data.scans if task == 3 else [s[:2] for s in data.scans])
    ref = (dirichlet_mean_variance(m.map["alpha"]) if task == 3
           else beta_mean_variance(m.map["alpha"], m.map["beta"]))
    np.testing.assert_array_equal(m.map["mean"], ref[0])
    np.testing.assert_array_equal(m.map["variance"], ref[1])
    assert m.map["mean"].flags.writeable and m.map["mean"].shape[0] == m.map["size"]
