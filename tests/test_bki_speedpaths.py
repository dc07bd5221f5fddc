"""The compiled engine's fast paths against the numpy reference, bit for bit (issue 23)."""
import numpy as np
import pytest

from hw4.bki import compiled, training


@pytest.mark.parametrize("spread, labelled", [(3.0, True), (3.0, False), (2.0 ** 17, True)])
def test_downsample_equals_numpy(spread, labelled):
    """Leaf keys packed with the point index and sorted once, then streamed sums; a box of leaves
    too wide to pack (spread 2^17 leaves per axis) ranks the keys first: the same centroids and
    majorities as :func:`hw4.bki.training.downsample`."""
    rng = np.random.default_rng(3)
    pts = rng.normal(0, spread * 0.1, (5000, 3))
    pts = np.vstack([pts, pts[:1000] + 1e-3])          # shared leaves, mixed labels
    lab = rng.integers(0, 5, len(pts)) if labelled else None
    cen, maj = training.downsample(pts, lab, 0.1, 5 if labelled else None)
    got, gmaj, far = compiled.downsample(pts, lab, 0.1, 5 if labelled else 0)
    assert not far and np.array_equal(got, cen)
    assert (gmaj is None and maj is None) or np.array_equal(gmaj, maj)
